"""Read the US EPA Test Car List (certification chassis-dynamometer results, one row a test).

The list is published per model year as CSV (``16tstcar.csv``, ``17tstcar.csv``...):
latin-1 or UTF-8 text (recent years with a UTF-8 byte-order mark), CR, LF or CRLF line
endings, and in some years a reduced column set (no test number, originator or
displacement). :func:`read_test_car_list` reads any of them into :class:`EpaTest` records
with the road-load coefficients, test weight and rated power in SI; fuel economy stays in
the list's unit (``FE_UNIT``, miles per US gallon for gasoline).

Every test number is kept. Rows of one list sharing a test number and differing at most in
columns not read or in the dyno set coefficients are one test listed again (once per
aftertreatment device, or a repeated row): the first row is kept and the others are named
in ``EpaTest.duplicate_rows`` with what differs (``duplicate_note``); rows of one number
that differ in anything else are kept apart, each naming the other.
"""

from __future__ import annotations

import codecs
import csv
import math
from collections import Counter
from collections.abc import Sequence
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any

from vehval.constants import LB_KG, LBF_N, MILE_M, MPH_M_PER_S
from vehval.errors import InputFileError
from vehval.io.paths import check_input_file

#: One mechanical horsepower [W] (550 ft·lbf/s).
HP_W = 745.69987158227022

#: list column -> record field, for the columns every year of the list has.
REQUIRED = {
    "Represented Test Veh Make": "make",
    "Represented Test Veh Model": "model",
    "Test Vehicle ID": "vehicle_id",
    "Equivalent Test Weight (lbs.)": "weight_lb",
    "Axle Ratio": "axle_ratio",
    "N/V Ratio": "n_v_ratio",
    "Test Procedure Cd": "procedure_code",
    "Test Procedure Description": "procedure",
    "Test Fuel Type Cd": "fuel_code",
    "RND_ADJ_FE": "fe",
    "FE_UNIT": "fe_unit",
    "FE Bag 1": "bag1", "FE Bag 2": "bag2", "FE Bag 3": "bag3", "FE Bag 4": "bag4",
    "Target Coef A (lbf)": "target_a", "Target Coef B (lbf/mph)": "target_b",
    "Target Coef C (lbf/mph**2)": "target_c",
    "Set Coef A (lbf)": "set_a", "Set Coef B (lbf/mph)": "set_b",
    "Set Coef C (lbf/mph**2)": "set_c",
}
#: columns some years lack (the record then holds '' or NaN)
OPTIONAL = {
    "Test Number": "test_number",
    "Test Originator": "originator",
    "Test Veh Configuration #": "config",
    "Test Veh Displacement (L)": "displacement_l",
    "Rated Horsepower": "rated_hp",
    "Vehicle Manufacturer Name": "manufacturer",
    "CO2 (g/mi)": "co2_g_per_mi",
    "Test Fuel Type Description": "fuel",
    "# of Gears": "gears",
    "Tested Transmission Type Code": "transmission",
    "# of Cylinders and Rotors": "cylinders",
}
#: the model-year column is named differently across years
YEAR_COLUMNS = ("Model Year", "Year")
#: columns found by their name without case, spaces and punctuation (record field <- the
#: normalised names): the lists of 2016 and 2019 name the first 'Analytically Derived FE?'
#: (Yes/No), the reduced 2017 list lacks both
LOOSE = {"adfe": ("analyticallyderivedfe", "analyticallyderived", "analyticallyderivedfueleconomy"),
         "adfe_test_number": ("adfetestnumber",)}

_LBF_PER_MPH = LBF_N / MPH_M_PER_S  # lbf/mph -> N/(m/s)
_LBF_PER_MPH2 = LBF_N / MPH_M_PER_S**2  # lbf/mph^2 -> N/(m/s)^2


@dataclass(frozen=True)
class EpaTest:
    """One certification test of the EPA Test Car List, in SI.

    Attributes
    ----------
    year : int
        Model year.
    make, model : str
        Represented test vehicle make and model (as the list spells them).
    vehicle_id : str
        Test vehicle ID (one physical car; several configurations may share it).
    config : str
        Test vehicle configuration number ('' when the list lacks the column).
    test_number : str
        Test number ('' when absent).
    originator : str
        ``EPA`` or ``MFR`` (manufacturer); '' when the list lacks the column.
    procedure_code : int
        EPA test procedure code (21 FTP-75 2-day, 3 HWFET, 90 US06, 95 SC03, 11 cold CO...).
    procedure : str
        Procedure description as listed.
    fuel_code : str
        Test fuel code (61 Tier 2 certification gasoline, 26 cold CO fuel...).
    mass_kg : float
        Equivalent test weight (inertia class) [kg].
    axle_ratio, n_v_ratio : float
        Axle ratio [-] and engine-speed to vehicle-speed ratio [rpm/mph] as listed.
    target_a_n, target_b_n_per_mps, target_c_n_per_mps2 : float
        Road-load target coefficients F = A + B v + C v^2 [N, N/(m/s), N/(m/s)^2].
    set_a_n, set_b_n_per_mps, set_c_n_per_mps2 : float
        Dynamometer set coefficients (same units).
    fe : float
        Whole-test lab fuel economy ``RND_ADJ_FE`` in ``fe_unit`` (not label-adjusted).
    fe_unit : str
        Unit of ``fe`` and ``bags`` (``MPG`` for gasoline).
    bags : tuple of float
        ``FE Bag 1..4`` (NaN when empty or 0, the lists' placeholder; likewise ``fe``). FTP:
        bags 1-3 (or 4 for a 4-bag hybrid test);
        US06: bag 1 city part, bag 2 highway part.
    co2_g_per_km : float
        CO2 [g/km] (NaN when absent).
    displacement_l : float
        Engine displacement [L] (NaN when absent).
    rated_power_w : float
        Rated engine power [W] (NaN when absent).
    source : str
        ``file:line`` of the row.
    gears : int
        ``# of Gears`` (0 when absent; 1 for a CVT).
    transmission : str
        ``Tested Transmission Type Code`` (``A``, ``SA``, ``M``, ``AM``, ``CVT``...; '' when
        absent).
    years : tuple of int
        Every model year whose list holds this test (a carried-over certification is listed
        again the next years; :func:`read_lists` keeps it once); ``(year,)`` for one list.
    analytically_derived : bool or None
        The list's ``Analytically Derived FE?``: True when the figures are computed from
        another test (``adfe_test_number``), not measured; None when the list lacks the
        column (the reduced 2017 list).
    adfe_test_number : str
        ``ADFE Test Number``: the test an analytically derived row is computed from.
    duplicate_rows : tuple of str
        ``file:line`` of the other rows of the same list with this test number (the row
        kept is ``source``); empty for a test listed once.
    cylinders : int
        ``# of Cylinders and Rotors`` (0 when absent).
    duplicate_note : str
        What those rows are: identical, differing only in columns not read (e.g. one row per
        aftertreatment device) or in the dyno set coefficients (the first row's are used).
        Also set, with ``duplicate_rows`` empty, on a row whose test number another row of
        other values carries (both kept) and on a row without a number identical in every
        column to another (kept: nothing tells a repeated row from another test).
    """

    year: int
    make: str
    model: str
    vehicle_id: str
    config: str
    test_number: str
    originator: str
    procedure_code: int
    procedure: str
    fuel_code: str
    fuel: str
    mass_kg: float
    axle_ratio: float
    n_v_ratio: float
    target_a_n: float
    target_b_n_per_mps: float
    target_c_n_per_mps2: float
    set_a_n: float
    set_b_n_per_mps: float
    set_c_n_per_mps2: float
    fe: float
    fe_unit: str
    bags: tuple[float, ...]
    co2_g_per_km: float
    displacement_l: float
    rated_power_w: float
    manufacturer: str
    source: str
    gears: int = 0  # number of gears (0 when absent; 1 for a CVT)
    transmission: str = ""  # tested transmission type code (A, SA, M, AM, CVT...; '' absent)
    years: tuple[int, ...] = ()  # model years whose lists hold this test (read_lists)
    analytically_derived: bool | None = None  # 'Analytically Derived FE?' (None: not stated)
    adfe_test_number: str = ""  # 'ADFE Test Number' ('' when absent)
    duplicate_rows: tuple[str, ...] = ()  # file:line of the other rows of this test number
    duplicate_note: str = ""  # what those rows repeat or differ in
    cylinders: int = 0  # '# of Cylinders and Rotors' (0 when absent)

    @property
    def listed_years(self) -> tuple[int, ...]:
        """The model years whose lists hold this test (at least its own)."""
        return self.years or (self.year,)

    @property
    def label(self) -> str:
        """Short identification: test number, or vehicle id + procedure code + line."""
        return self.test_number or f"{self.vehicle_id}/{self.procedure_code}@{self.source}"

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict (NaN -> None)."""
        out = asdict(self)
        out["bags"] = [None if math.isnan(b) else b for b in self.bags]
        out["years"] = list(self.listed_years)
        out["duplicate_rows"] = list(self.duplicate_rows)
        return {k: (None if isinstance(v, float) and math.isnan(v) else v)
                for k, v in out.items()}


def _result(text: str) -> float:
    """A listed fuel economy: empty or 0 (the lists' placeholder for a result not stated,
    e.g. bag 4 of a 3-bag FTP or a charge-depleting test) is NaN."""
    v = _num(text)
    return math.nan if v == 0.0 else v


def _num(text: str) -> float:
    text = (text or "").strip()
    if not text:
        return math.nan
    try:
        return float(text)
    except ValueError:
        return math.nan


def _cell(row: list[str], index: dict[str, int], col: str | None) -> str:
    k = index.get(col) if col is not None else None
    return row[k].strip() if k is not None else ""


#: Largest Test Car List read [bytes]: a model year's list is 1-3 MB (about 5,000 tests);
#: 64 MB holds every year since 1978 together and keeps the records under ~0.5 GB.
MAX_LIST_BYTES = 64_000_000
#: Longest field of a row [characters] (the csv module's limit; real fields are < 100).
MAX_FIELD = 131_072


def _encoding(path: Path) -> str:
    """The text encoding of a list: ``utf-8-sig`` after a UTF-8 byte-order mark, ``utf-8``
    for valid UTF-8 holding non-ASCII text, else ``latin-1`` (which maps every byte).

    Raises InputFileError for UTF-16 (a byte-order mark FF FE / FE FF) and for a file
    that starts with the UTF-8 mark but is not UTF-8 (naming the line)."""
    with path.open("rb") as fh:
        head = fh.read(4)
        if head[:2] in (codecs.BOM_UTF16_LE, codecs.BOM_UTF16_BE):
            raise InputFileError(f"{path}: UTF-16 text (Excel's 'Unicode text'): save the list "
                                 "as CSV (UTF-8 or latin-1)")
        bom = head.startswith(codecs.BOM_UTF8)
        fh.seek(0)
        dec, ascii_only, lines = codecs.getincrementaldecoder("utf-8")(), True, 0
        try:
            for chunk in iter(lambda: fh.read(1 << 20), b""):
                ascii_only = ascii_only and chunk.isascii()
                dec.decode(chunk)
                lines += chunk.count(b"\n") or chunk.count(b"\r")
            dec.decode(b"", final=True)
        except UnicodeDecodeError as exc:
            if bom:
                line = lines + (chunk[:exc.start].count(b"\n") or chunk[:exc.start].count(b"\r")) + 1
                raise InputFileError(f"{path}: line {line}: byte 0x{chunk[exc.start]:02X} is not "
                                     "UTF-8 although the file starts with a UTF-8 byte-order "
                                     "mark (a damaged or re-encoded file): save it again as "
                                     "UTF-8") from None
            return "latin-1"
    return "utf-8-sig" if bom else ("latin-1" if ascii_only else "utf-8")


def _open(path: Path):
    """Open a list for streaming (CR, LF, CRLF are all line ends; :func:`_encoding`)."""
    check_input_file(path, "test car list (CSV)")
    try:
        size = path.stat().st_size
        if size > MAX_LIST_BYTES:
            raise InputFileError(
                f"{path}: {size / 1e6:.0f} MB is larger than the {MAX_LIST_BYTES / 1e6:.0f} MB "
                "budget for an EPA Test Car List (a model year's list is 1-3 MB): give the "
                "yearly list files (e.g. 19tstcar.csv) rather than one concatenated file")
        return path.open("r", encoding=_encoding(path), newline=None)
    except OSError as exc:
        raise InputFileError(f"{path}: cannot read the test car list ({exc.strerror})") from None


def _rows(path: Path, fh):
    """Rows of the list with their line number; quoting faults are an InputFileError."""
    reader = csv.reader(fh, strict=True)
    prev = 0
    while True:
        try:
            row = next(reader)
        except StopIteration:
            return
        except csv.Error as exc:
            what = (f"a field longer than {MAX_FIELD:,} characters" if "field limit" in str(exc)
                    else f"bad CSV quoting ({exc})")
            raise InputFileError(f"{path}: line {prev + 1}: {what}: an unclosed or stray quote "
                                 "(\") or a damaged row; fix or remove that row") from None
        if reader.line_num - prev > 1:      # a quoted field ran over a line end
            raise InputFileError(f"{path}: line {prev + 1}: a quoted field is not closed on its "
                                 f"line (it runs to line {reader.line_num}): close the quote "
                                 "(\") or remove it")
        prev = reader.line_num
        yield prev, row


def read_test_car_list(path: str | Path) -> list[EpaTest]:
    """Read one EPA Test Car List CSV file.

    Parameters
    ----------
    path : str or Path
        A ``*tstcar.csv`` file (latin-1; CR, LF or CRLF line endings).

    Returns
    -------
    list of EpaTest
        One record per row, in file order.

    Raises
    ------
    InputFileError
        Unreadable file, no header, a required column missing (the message names the
        file and the columns), a file over :data:`MAX_LIST_BYTES`, an unclosed quote or a
        field over :data:`MAX_FIELD` characters (naming the line). The file is read as a
        stream: memory grows with the records, not with the text.
    """
    path = Path(path)
    with _open(path) as fh:
        return _read(path, _rows(path, fh))


def _norm(name: str) -> str:
    """A column name without case, spaces and punctuation."""
    return "".join(ch for ch in name.lower() if ch.isalnum())


def _header(path: Path, rows) -> tuple[list[str], dict[str, int], str | None]:
    """The header, its column index (including the :data:`LOOSE` fields) and the year
    column; a missing required column is an InputFileError naming them."""
    try:
        header = [h.strip().lstrip("\ufeff") for h in next(rows)[1]]
    except StopIteration:
        raise InputFileError(f"{path}: empty file: expected an EPA Test Car List CSV with a "
                             "header row") from None
    index = {name: k for k, name in enumerate(header)}
    for field, names in LOOSE.items():
        k = next((i for i, h in enumerate(header) if _norm(h) in names), None)
        if k is not None:
            index[field] = k
    year_col = next((c for c in YEAR_COLUMNS if c in index), None)
    missing = [c for c in REQUIRED if c not in index]
    if year_col is None:
        missing.insert(0, " or ".join(f"'{c}'" for c in YEAR_COLUMNS))
    if missing:
        shown = ", ".join(m if m.startswith("'") else f"'{m}'" for m in missing[:6])
        more = f" (+{len(missing) - 6} more)" if len(missing) > 6 else ""
        raise InputFileError(f"{path}: line 1: missing column(s) {shown}{more}: not an EPA "
                             "Test Car List file, or a column was renamed; the list needs "
                             "make, model, test weight, procedure, results and road-load "
                             "coefficients")
    return header, index, year_col


def _flag(text: str) -> bool | None:
    """A Yes/No cell: True, False, or None when empty or neither."""
    t = text.strip().upper()
    return True if t in ("YES", "Y", "TRUE", "1") else False if t in ("NO", "N", "FALSE", "0") \
        else None


#: record fields read as numbers (a text there is refused, not read as an empty cell)
NUMERIC = frozenset({"weight_lb", "axle_ratio", "n_v_ratio", "procedure_code", "fe", "bag1",
                     "bag2", "bag3", "bag4", "target_a", "target_b", "target_c", "set_a", "set_b",
                     "set_c", "displacement_l", "rated_hp", "co2_g_per_mi", "gears", "cylinders"})


def _check_numbers(path: Path, lineno: int, cells: dict[str, str]) -> None:
    """Refuse a text in a numeric column (column -> cell), naming line, column and text."""
    for col, text in cells.items():
        try:
            float(text or "0")
        except ValueError:
            raise InputFileError(f"{path}: line {lineno}: '{text}' in column '{col}' is not a "
                                 "number: correct the cell, or leave it empty where the list "
                                 "gives no value") from None


def _record(path: Path, lineno: int, row: list[str], index: dict[str, int],
            year_col: str | None) -> EpaTest:
    """One row as an EpaTest (SI units)."""
    cols = {**REQUIRED, **OPTIONAL}
    f = {field: _cell(row, index, col) for col, field in cols.items()}
    _check_numbers(path, lineno, {str(year_col): _cell(row, index, year_col),
                                  **{c: f[k] for c, k in cols.items() if k in NUMERIC}})
    year = _num(_cell(row, index, year_col))
    code = _num(f["procedure_code"])
    gears = _num(f["gears"])
    cylinders = _num(f["cylinders"])
    return EpaTest(
        year=int(year) if not math.isnan(year) else 0,
        make=f["make"], model=f["model"], vehicle_id=f["vehicle_id"], config=f["config"],
        test_number=f["test_number"], originator=f["originator"].upper(),
        procedure_code=int(code) if not math.isnan(code) else -1,
        procedure=f["procedure"], fuel_code=f["fuel_code"], fuel=f["fuel"],
        mass_kg=_num(f["weight_lb"]) * LB_KG,
        axle_ratio=_num(f["axle_ratio"]), n_v_ratio=_num(f["n_v_ratio"]),
        target_a_n=_num(f["target_a"]) * LBF_N,
        target_b_n_per_mps=_num(f["target_b"]) * _LBF_PER_MPH,
        target_c_n_per_mps2=_num(f["target_c"]) * _LBF_PER_MPH2,
        set_a_n=_num(f["set_a"]) * LBF_N,
        set_b_n_per_mps=_num(f["set_b"]) * _LBF_PER_MPH,
        set_c_n_per_mps2=_num(f["set_c"]) * _LBF_PER_MPH2,
        fe=_result(f["fe"]), fe_unit=f["fe_unit"].upper(),
        bags=tuple(_result(f[f"bag{k}"]) for k in range(1, 5)),
        co2_g_per_km=_num(f["co2_g_per_mi"]) / (MILE_M / 1000.0),
        displacement_l=_num(f["displacement_l"]),
        rated_power_w=_num(f["rated_hp"]) * HP_W,
        manufacturer=f["manufacturer"],
        source=f"{path.name}:{lineno}",
        gears=int(gears) if not math.isnan(gears) else 0,
        transmission=f["transmission"].upper(),
        cylinders=int(cylinders) if math.isfinite(cylinders) else 0,
        analytically_derived=_flag(_cell(row, index, "adfe")) if "adfe" in index else None,
        adfe_test_number=_cell(row, index, "adfe_test_number"),
    )


#: columns a test listed again may differ in and still be one test: the dyno set
#: coefficients (the 2016 and 2019 lists give some GM tests twice, once per set of
#: coefficients; the simulation uses the target coefficients)
MAY_DIFFER = frozenset({"Set Coef A (lbf)", "Set Coef B (lbf/mph)", "Set Coef C (lbf/mph**2)"})


def _repeat_note(lines: list[int], differ: list[str], read: set[str]) -> str:
    """What the rows ``lines`` of one test number are, given the columns that differ
    between them (``read``: the columns the reader reads)."""
    where = f"listed {len(lines)} times (lines {', '.join(map(str, lines))})"
    if not differ:
        return f"{where} with identical values: a duplicate row, kept once"
    shown = ", ".join(f"'{c}'" for c in differ[:4]) + (" ..." if len(differ) > 4 else "")
    if not any(c in read for c in differ):
        return f"{where} differing only in {shown} (columns not read): one test, kept once"
    return (f"{where} with different {shown}: one test, kept once with the values of line "
            f"{lines[0]}")


def _conflict_note(number: str, others: list[int], differ: set[str], header: list[str]) -> str:
    cols = [h for h in header if h in differ]
    shown = ", ".join(f"'{c}'" for c in cols[:4]) + (" ..." if len(cols) > 4 else "")
    return (f"test number {number} is also given to line(s) {', '.join(map(str, others))} "
            f"with another {shown}: kept as separate rows (a typing error in the list?)")


def _read(path: Path, rows) -> list[EpaTest]:
    header, index, year_col = _header(path, rows)
    read = {*REQUIRED, *OPTIONAL, *(header[index[k]] for k in LOOSE if k in index)}
    if year_col:
        read.add(year_col)
    tests: list[EpaTest] = []
    first: dict[str, list[tuple[int, list[str]]]] = {}  # test number -> (position, row) each
    repeats: dict[int, tuple[list[int], set[str]]] = {}  # position -> (lines, columns differing)
    conflicts: dict[int, tuple[list[int], set[str]]] = {}  # position -> (other lines, columns)
    unnumbered: dict[tuple[str, ...], int] = {}  # a row without a test number -> its line
    line_of: dict[int, int] = {}  # position -> line
    for lineno, row in rows:
        if not any(cell.strip() for cell in row):
            continue
        extra = len(row) > len(header) and any(cell.strip() for cell in row[len(header):])
        if extra or len(row) < len(header):
            cut = "" if extra else ": the row is cut short (a truncated file?)"
            raise InputFileError(f"{path}: line {lineno}: {len(row)} fields, the header has "
                                 f"{len(header)}{cut}: fix or remove the line")
        if any("\x00" in cell for cell in row):
            raise InputFileError(f"{path}: line {lineno}: a NUL byte in a field (binary data "
                                 "in a text list: a damaged file): fix or remove the line")
        row = [c.strip() for c in row[:len(header)]] + [""] * (len(header) - len(row))
        number = _cell(row, index, "Test Number")
        earlier = [(pos, {h for h, a, b in zip(header, row0, row) if a != b})
                   for pos, row0 in (first.get(number, []) if number else [])]
        same = next(((pos, d) for pos, d in earlier if not (d & read) - MAY_DIFFER), None)
        if same is not None:        # the same test listed again
            lines, seen = repeats.setdefault(same[0], ([line_of[same[0]]], set()))
            lines.append(lineno)
            seen.update(same[1])
            continue
        for pos, differ in earlier:     # the same number, another test: both kept, named
            for p_, other in ((pos, lineno), (len(tests), line_of[pos])):
                conflicts.setdefault(p_, ([], set()))[0].append(other)
                conflicts[p_][1].update(differ & read)
        if number:
            first.setdefault(number, []).append((len(tests), row))
        rec = _record(path, lineno, row, index, year_col)
        if not number:      # no number to tell a repeated row from another test
            seen_at = unnumbered.setdefault(tuple(row), lineno)
            if seen_at != lineno:
                rec = replace(rec, duplicate_note=(
                    f"identical in every column to line {seen_at}, and the list gives no test "
                    "number to tell a repeated row from another test: kept as a test"))
        line_of[len(tests)] = lineno
        tests.append(rec)
    for pos, (lines, differ) in repeats.items():
        tests[pos] = replace(tests[pos], duplicate_rows=tuple(f"{path.name}:{n}" for n in lines[1:]),
                             duplicate_note=_repeat_note(
                                 lines, [h for h in header if h in differ], read))
    for pos, (others, differ) in conflicts.items():
        note = _conflict_note(tests[pos].test_number, others, differ, header)
        old = tests[pos].duplicate_note
        tests[pos] = replace(tests[pos], duplicate_note=f"{old}; {note}" if old else note)
    return tests


def find_list_files(paths: Sequence[str | Path]) -> list[Path]:
    """Expand files and directories (``*tstcar*.csv`` inside) into list files, sorted."""
    files: list[Path] = []
    for p in map(Path, paths):
        if p.is_dir():
            found = sorted(q for q in p.iterdir()
                           if q.suffix.lower() == ".csv" and "tstcar" in q.name.lower())
            if not found:
                raise InputFileError(f"{p}: no EPA Test Car List file (*tstcar*.csv) in this "
                                     "directory; give the file itself or its directory")
            files.extend(found)
        elif p.exists():
            files.append(p)
        else:
            raise InputFileError(f"{p}: no such file or directory (give an EPA Test Car List "
                                 "CSV, e.g. 16tstcar.csv, or the directory holding it)")
    return files


def _value_key(t: EpaTest) -> tuple:
    """What identifies a test of a list without test numbers: make, vehicle, procedure,
    figures and road load."""
    return (t.make.upper(), t.vehicle_id, t.procedure_code, round(t.fe, 3),
            tuple(round(b, 3) if not math.isnan(b) else None for b in t.bags),
            round(t.target_a_n, 3))


def _rows_of(t: EpaTest) -> int:
    """How many rows of its own list a test stands for."""
    return 1 + len(t.duplicate_rows)


def read_lists(paths: Sequence[str | Path]) -> list[EpaTest]:
    """Read every list file in ``paths`` (files or directories) into one list of tests.

    Every test number is kept: rows with different test numbers are different tests, even
    when all their values are equal. A test that appears in several years' lists (a
    carried-over certification: the same test number, or, for a list without test numbers,
    the same make, vehicle, procedure, figures and road load) is kept once, with every year
    that lists it (``EpaTest.years``: a selection by year finds it under each); the
    numbered row is kept over one without a number. A row without a number matches at most
    as many rows of another list as that list holds for the test (one, or the
    ``duplicate_rows`` of a test listed again), and never another row of its own list.
    """
    out: list[EpaTest | None] = []
    taken: list[Counter] = []  # per record: rows it holds from each file
    by_number: dict[str, int] = {}
    by_key: dict[tuple, list[int]] = {}
    for f in find_list_files(paths):
        name = str(f)
        for t in read_test_car_list(f):
            if t.test_number and t.test_number in by_number \
                    and name not in taken[by_number[t.test_number]]:
                i = by_number[t.test_number]
                kept = out[i]
                assert kept is not None
                out[i] = replace(kept, years=tuple(sorted({*kept.listed_years, t.year})))
                taken[i][name] += _rows_of(t)
                continue
            key = _value_key(t)
            same = [i for i in by_key.get(key, []) if out[i] is not None]
            if t.test_number:   # takes over rows without a number, of other files
                match = [i for i in same if not out[i].test_number  # type: ignore[union-attr]
                         and name not in taken[i]][:_rows_of(t)]
            else:               # joins a test holding fewer rows of this file than it stands for
                match = [i for i in same if taken[i][name] < _rows_of(out[i])][:1]  # type: ignore[arg-type]
            if match:
                i = match[0]
                years = {t.year, *(y for j in match for y in out[j].listed_years)}  # type: ignore[union-attr]
                base = t if t.test_number else out[i]
                assert base is not None
                out[i] = replace(base, years=tuple(sorted(years)))
                for j in match[1:]:
                    taken[i].update(taken[j])
                    out[j] = None
                taken[i][name] += 1 if not t.test_number else _rows_of(t)
                if t.test_number:
                    by_number[t.test_number] = i
                continue
            if t.test_number:
                by_number[t.test_number] = len(out)
            by_key.setdefault(key, []).append(len(out))
            taken.append(Counter({name: _rows_of(t)}))
            out.append(t)
    return [t for t in out if t is not None]
