"""Read the US EPA Test Car List (certification chassis-dynamometer results, one row a test).

The list is published per model year as CSV (``16tstcar.csv``, ``17tstcar.csv``...):
latin-1 text, CR or CRLF line endings, and in some years a reduced column set (no test
number, originator or displacement). :func:`read_test_car_list` reads any of them into
:class:`EpaTest` records with the road-load coefficients, test weight and rated power in SI;
fuel economy stays in the list's unit (``FE_UNIT``, miles per US gallon for gasoline).
"""

from __future__ import annotations

import csv
import math
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
}
#: the model-year column is named differently across years
YEAR_COLUMNS = ("Model Year", "Year")

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


def _open(path: Path):
    """Open a list for streaming (latin-1 maps every byte; CR, LF, CRLF are all line ends)."""
    check_input_file(path, "test car list (CSV)")
    try:
        size = path.stat().st_size
        if size > MAX_LIST_BYTES:
            raise InputFileError(
                f"{path}: {size / 1e6:.0f} MB is larger than the {MAX_LIST_BYTES / 1e6:.0f} MB "
                "budget for an EPA Test Car List (a model year's list is 1-3 MB): give the "
                "yearly list files (e.g. 19tstcar.csv) rather than one concatenated file")
        return path.open("r", encoding="latin-1", newline=None)
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


def _read(path: Path, rows) -> list[EpaTest]:
    try:
        header = [h.strip() for h in next(rows)[1]]
    except StopIteration:
        raise InputFileError(f"{path}: empty file: expected an EPA Test Car List CSV with a "
                             "header row") from None
    index = {name: k for k, name in enumerate(header)}
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
    tests: list[EpaTest] = []
    for lineno, row in rows:
        if not any(cell.strip() for cell in row):
            continue
        if len(row) > len(header) and any(cell.strip() for cell in row[len(header):]):
            raise InputFileError(f"{path}: line {lineno}: {len(row)} fields, the header has "
                                 f"{len(header)}: fix or remove the line")
        if any("\x00" in cell for cell in row):
            raise InputFileError(f"{path}: line {lineno}: a NUL byte in a field (binary data "
                                 "in a text list: a damaged file): fix or remove the line")
        row = row + [""] * (len(header) - len(row))

        f = {field: _cell(row, index, col) for col, field in {**REQUIRED, **OPTIONAL}.items()}
        year = _num(_cell(row, index, year_col))
        code = _num(f["procedure_code"])
        tests.append(EpaTest(
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
            gears=int(_num(f["gears"])) if not math.isnan(_num(f["gears"])) else 0,
            transmission=f["transmission"].upper(),
        ))
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


def read_lists(paths: Sequence[str | Path]) -> list[EpaTest]:
    """Read every list file in ``paths`` (files or directories) into one list of tests.

    A test that appears in several years' lists (same test number, or the same vehicle,
    procedure and results when the list has no test numbers) is kept once, from the
    earliest list read that gives its test number, with every year that lists it
    (``EpaTest.years``: a selection by year finds it under each).
    """
    seen: dict[tuple, int] = {}
    out: list[EpaTest] = []
    for f in find_list_files(paths):
        for t in read_test_car_list(f):
            key = ((t.make.upper(), t.vehicle_id, t.procedure_code, round(t.fe, 3),
                    tuple(round(b, 3) if not math.isnan(b) else None for b in t.bags),
                    round(t.target_a_n, 3)))
            if key in seen:
                kept = out[seen[key]]
                years = tuple(sorted({*kept.listed_years, t.year}))
                if t.test_number and not kept.test_number:
                    kept = t                # the numbered row says which test it is
                out[seen[key]] = replace(kept, years=years)
                continue
            seen[key] = len(out)
            out.append(t)
    return out
