"""Delimited text (CSV, TSV, semicolon; decimal point or comma) with one header row.

The byte-level checks (encoding, NUL bytes, stray bytes before the header, truncated last
line) are done here in Python on the raw bytes; the numeric parsing is done by
``pyarrow.csv`` so that a large file costs little more than pyarrow alone.
"""

from __future__ import annotations

import codecs
import csv
import re
from pathlib import Path

from vehval.errors import InputFileError
from vehval.io.arrow import arrow_owned, float_values
from vehval.io.budget import MAX_TEXT_BYTES, address_space_limited, check_file_size
from vehval.io.raw import RawTable, find_time_column, is_printable, is_time_header, split_headers
from vehval.units import split_header

_DELIMS = ("\t", ";", ",")
_DECIMAL_COMMA = re.compile(rb"(?:^|[;\t ])-?\d+,\d+(?:[;\t\r\n]|$)")
_LONE_CR = re.compile(rb"\r(?!\n)")
_NUMBER = re.compile(r"^\s*[-+]?(\d+([.,]\d*)?|[.,]\d+)([eE][-+]?\d+)?\s*$")


#: Most columns a data file may have (dyno and CAN logs have hundreds): refused before any
#: per-column allocation.
MAX_COLUMNS = 20_000


#: Columns every EPA Test Car List has (its reader: :mod:`vehval.epa.reader`): a file with
#: them is a list of certification tests, not a time series.
_EPA_LIST_HEADERS = frozenset({"Test Vehicle ID", "Represented Test Veh Make"})


def check_exists(path: Path) -> None:
    """Raise :class:`InputFileError` when ``path`` is missing, a directory or empty."""
    if not path.exists():
        raise InputFileError(f"{path}: file not found: check the path")
    if path.is_dir():
        raise InputFileError(f"{path}: is a directory, expected a data file")
    if path.stat().st_size == 0:
        raise InputFileError(f"{path}: file is empty (0 bytes)")


def decode_bytes(raw: bytes, path: Path, encoding: str | None, notes: list[str]) -> bytes:
    """Return UTF-8 (or ASCII-compatible) bytes, decoding UTF-16 and explicit encodings."""
    if encoding:
        try:
            codec = codecs.lookup(encoding).name
        except LookupError:
            raise InputFileError(f"{path}: unknown text encoding '{encoding}': use e.g. utf-8, "
                                 "cp1252, latin-1 or utf-16") from None
    if encoding and codec not in ("utf-8", "ascii"):
        try:
            text = raw.decode(encoding)
        except UnicodeDecodeError as exc:
            raise InputFileError(f"{path}: cannot decode as {encoding}: {exc}") from None
        notes.append(f"decoded from {encoding}")
        return text.lstrip("\ufeff").encode("utf-8")
    if raw.startswith(codecs.BOM_UTF8):
        return raw[3:]
    utf16 = None
    if raw.startswith(codecs.BOM_UTF32_LE) or raw.startswith(codecs.BOM_UTF32_BE):
        try:
            text = raw.decode("utf-32")
        except UnicodeDecodeError as exc:
            raise InputFileError(f"{path}: looks like UTF-32 but cannot be decoded: {exc}") from None
        notes.append("decoded from UTF-32")
        return text.lstrip("\ufeff").encode("utf-8")
    if raw.startswith(codecs.BOM_UTF16_LE) or raw.startswith(codecs.BOM_UTF16_BE):
        utf16 = "utf-16"
    else:
        head = raw[:400]
        if len(head) >= 8:
            even_nul = head[0::2].count(0) / len(head[0::2])
            odd_nul = head[1::2].count(0) / len(head[1::2])
            if odd_nul > 0.4 and even_nul < 0.05:
                utf16 = "utf-16-le"
            elif even_nul > 0.4 and odd_nul < 0.05:
                utf16 = "utf-16-be"
    if utf16:
        body = raw.rstrip(b"\0")
        if len(body) % 2:
            body = body + b"\0"
        try:
            text = body.decode(utf16)
        except UnicodeDecodeError as exc:
            raise InputFileError(f"{path}: looks like UTF-16 but cannot be decoded: {exc}") from None
        notes.append("decoded from UTF-16")
        return text.lstrip("\ufeff").encode("utf-8")
    return raw


def _strip_nuls(raw: bytes, path: Path, notes: list[str]) -> bytes:
    body = raw.rstrip(b"\0")
    if len(body) != len(raw):
        notes.append(f"stripped {len(raw) - len(body)} NUL bytes of padding at the end of the file")
    i = body.find(b"\0")
    if i >= 0:
        line = body.count(b"\n", 0, i) + 1
        raise InputFileError(
            f"{path} line {line}: NUL byte inside the data (byte offset {i}): the file is "
            "corrupted; cut the damaged lines or re-export the file")
    return body


def _drop_blank_tail(body: bytes) -> bytes:
    """Remove trailing line ends and whitespace-only lines, keeping empty last cells."""
    body = body.rstrip(b"\r\n")
    while body:
        start = body.rfind(b"\n") + 1
        if body[start:].strip():
            break
        body = body[:start].rstrip(b"\r\n")
    return body


def _decode_line(line: bytes, path: Path, notes: list[str]) -> str:
    try:
        return line.decode("utf-8")
    except UnicodeDecodeError:
        notes.append("header decoded as cp1252 (not valid UTF-8)")
        return line.decode("cp1252", errors="replace")


def sniff_delimiter(lines: list[str]) -> str:
    """Pick tab, semicolon or comma: present in the header and equally often in data lines."""
    header, data = lines[0], [ln for ln in lines[1:] if ln.strip()]
    for d in _DELIMS:
        n = header.count(d)
        if n == 0:
            continue
        if not data or all(ln.count(d) == n for ln in data[:-1] or data):
            return d
    counts = {d: header.count(d) for d in _DELIMS}
    best = max(counts, key=lambda d: counts[d])
    return best if counts[best] else ","


def _tokens(line: str, delimiter: str) -> list[str]:
    try:
        row = next(csv.reader([line], delimiter=delimiter, skipinitialspace=True), [])
    except csv.Error as exc:
        raise InputFileError(f"cannot split the line {line[:60]!r}: {exc}") from None
    return [t.strip().strip('"').strip() for t in row]


def repair_first_header(token: str, path: Path, notes: list[str]) -> str:
    """Strip stray bytes before a recognisable time header (``fpTime[sec]`` -> ``Time[sec]``).

    Raises
    ------
    InputFileError
        When the first header has control bytes and no recognisable time header follows.
    """
    name, unit = split_header(token)
    if is_time_header(name, unit) and is_printable(token):
        return token
    for k in range(1, min(9, len(token))):
        rest = token[k:]
        n2, u2 = split_header(rest)
        if len(n2) >= 4 and is_time_header(n2, u2) and (u2 is not None or not is_printable(token[:k])):
            notes.append(f"line 1: stripped {k} stray byte(s) {token[:k]!r} before the time header "
                         f"'{rest}'")
            return rest
    if not is_printable(token):
        raise InputFileError(
            f"{path} line 1: stray control byte(s) in the first header {token!r}: remove them "
            "from the file (the header is not a recognisable time column)")
    return token


def _skip_blank_lines(raw: bytes) -> tuple[int, int]:
    """Byte offset of the first non-blank line and the number of blank lines before it."""
    start, skipped = 0, 0
    while True:
        nl = raw.find(b"\n", start)
        line = raw[start:nl if nl >= 0 else len(raw)]
        if line.strip() or nl < 0:
            return start, skipped
        start, skipped = nl + 1, skipped + 1


def _sample_lines(raw: bytes, start: int, path: Path, notes: list[str]) -> list[str]:
    """The first few non-empty lines from ``start`` (the header first), decoded, for sniffing."""
    sample_end = start
    for _ in range(8):
        nl = raw.find(b"\n", sample_end)
        if nl < 0:
            sample_end = len(raw)
            break
        sample_end = nl + 1
    sample = [_decode_line(ln.rstrip(b"\r"), path, notes) for ln in raw[start:sample_end].split(b"\n")]
    return [s for s in sample if s != ""] or [""]


def _line_ends(raw: bytes, notes: list[str]) -> bytes:
    """``raw`` with LF line ends: old Mac CR-only files, and mixed CR, CR LF and LF (files
    appended by several tools), each said in ``notes``."""
    if b"\n" not in raw and b"\r" in raw:
        notes.append("old Mac line ends (CR only) read as line ends")
        return raw.replace(b"\r", b"\n")
    if _LONE_CR.search(raw):
        notes.append("mixed line ends (CR, CR LF and LF) read as line ends")
        return raw.replace(b"\r\n", b"\n").replace(b"\r", b"\n")
    return raw


def read_delimited(path: str | Path, *, fmt: str = "csv", delimiter: str | None = None,
                   decimal: str | None = None, encoding: str | None = None) -> RawTable:
    """Read a delimited text file with one header row (optionally a unit row below it).

    Parameters
    ----------
    path : str or Path
        File to read.
    fmt : str
        Format tag stored in the result (``csv`` or ``d3``).
    delimiter : str, optional
        Field separator; sniffed among tab, ``;`` and ``,`` when omitted.
    decimal : str, optional
        Decimal mark ``.`` or ``,``; detected when omitted (comma only with ``;`` or tab).
    encoding : str, optional
        Text encoding; UTF-8 (with or without BOM) and UTF-16 (BOM or NUL pattern) are
        detected when omitted.

    Returns
    -------
    RawTable
        Channels as float64 arrays (empty cells are NaN), with repair notes.

    Raises
    ------
    InputFileError
        Missing or empty file, NUL bytes inside the data, duplicate channel names, non-numeric
        cells, rows with a wrong number of fields (each naming file and line).
    """
    path = Path(path)
    check_exists(path)
    # parsed in memory (2-3 times the file): refused before reading past the budget
    check_file_size(path, "text data file", MAX_TEXT_BYTES,
                    advice="split the file into tests of a few hours, or convert it to Parquet")
    notes: list[str] = []
    raw = decode_bytes(path.read_bytes(), path, encoding, notes)
    raw = _strip_nuls(raw, path, notes)
    raw = _line_ends(raw, notes)
    start, skipped = _skip_blank_lines(raw)
    if not raw[start:].strip():
        raise InputFileError(f"{path}: file is empty (no header line)")
    sample = _sample_lines(raw, start, path, notes)
    header_line = sample[0]
    delim = delimiter or sniff_delimiter(sample)
    ncols = header_line.count(delim) + 1
    if ncols > MAX_COLUMNS:
        raise InputFileError(f"{path} line {skipped + 1}: {ncols} columns, more than the "
                             f"{MAX_COLUMNS} a test file may have: not a test's data file")
    try:
        headers = _tokens(header_line, delim)
    except InputFileError as exc:
        raise InputFileError(f"{path} line {skipped + 1}: {exc}") from None
    if {h.strip() for h in headers} >= _EPA_LIST_HEADERS:
        raise InputFileError(f"{path}: is an EPA Test Car List (one row per certification "
                             "test), not a time series: read it with `vehval epa list`, `epa "
                             "tests`, `epa validate` or `epa fleet`")
    headers[0] = repair_first_header(headers[0], path, notes)
    for i, h in enumerate(headers[1:], start=2):
        if not is_printable(h):
            raise InputFileError(f"{path} line {skipped + 1}: control byte(s) in header column {i} "
                                 f"{h!r}: fix the header")
    names, units = split_headers(headers, path)
    header_end = raw.find(b"\n", start)
    data_start = len(raw) if header_end < 0 else header_end + 1
    first_line = skipped + 2
    # optional unit row: no [unit] in the header and a fully non-numeric second line
    if len(sample) > 1 and all(u is None for u in units):
        try:
            cells = _tokens(sample[1], delim)
        except InputFileError:
            cells = []
        if len(cells) == len(names) and any(cells) and not any(_NUMBER.match(c) for c in cells if c):
            units = [c or None for c in cells]
            headers = [f"{n}[{u}]" if u else n for n, u in zip(names, units)]
            nl = raw.find(b"\n", data_start)
            data_start = len(raw) if nl < 0 else nl + 1
            first_line += 1
            notes.append("line 2 read as the unit row")
    body = _drop_blank_tail(raw[data_start:])
    if not body:
        raise InputFileError(f"{path}: header found but no data rows")
    ncol = len(names)
    bdelim = delim.encode()
    # truncated last line -> drop with a note
    last_start = body.rfind(b"\n") + 1
    last = body[last_start:]
    n_last = last.count(bdelim) + 1
    if n_last < ncol and b'"' not in last:
        lineno = first_line + body.count(b"\n")
        if last_start == 0:
            raise InputFileError(f"{path} line {lineno}: the only data row has {n_last} of {ncol} "
                                 "fields (truncated file)")
        notes.append(f"line {lineno}: truncated last line ({n_last} of {ncol} fields) dropped")
        body = body[:last_start].rstrip(b"\r\n")
    if decimal is None:
        decimal = "," if delim != "," and _DECIMAL_COMMA.search(body[:4000]) else "."
    col_ids = [f"c{i}" for i in range(ncol)]
    import pyarrow as pa  # imported here: the byte checks above do not need it
    import pyarrow.csv as pacsv

    try:
        table = pacsv.read_csv(
            pa.BufferReader(arrow_owned(body)),     # never a Python object: see arrow_owned
            # on this thread under an address-space limit: Arrow's worker threads each map
            # a stack and an allocator arena, and one that cannot start fails or hangs the read
            read_options=pacsv.ReadOptions(column_names=col_ids,
                                           use_threads=not address_space_limited()),
            parse_options=pacsv.ParseOptions(delimiter=delim),
            convert_options=pacsv.ConvertOptions(
                column_types={c: pa.float64() for c in col_ids}, decimal_point=decimal))
    except pa.ArrowInvalid as exc:
        raise _locate_error(exc, body, delim, decimal, names, first_line, path) from None
    data = {n: float_values(table.column(i)) for i, n in enumerate(names)}
    time_name = find_time_column(names, units)
    return RawTable(path=path, fmt=fmt, headers=headers, names=names, units=units, data=data,
                    time_name=time_name, notes=notes,
                    time_unit=(units[names.index(time_name)] or "s") if time_name else None,
                    first_data_line=first_line, meta={"delimiter": delim, "decimal": decimal})


def _locate_error(exc: Exception, body: bytes, delim: str, decimal: str, names: list[str],
                  first_line: int, path: Path) -> InputFileError:
    """Turn a pyarrow parse error into a message naming the line (and channel)."""
    import pyarrow.csv as pacsv

    # pyarrow's default null spellings (kept default: a custom list slows parsing by half)
    nulls = set(pacsv.ConvertOptions().null_values)
    msg = str(exc)
    text = body.decode("utf-8", errors="replace").split("\n")
    m = re.search(r"column #(\d+)", msg)
    col = int(m.group(1)) if m else None
    for i, line in enumerate(text):
        line = line.rstrip("\r")
        try:
            cells = _tokens(line, delim) if '"' in line else line.split(delim)
        except InputFileError as err:
            return InputFileError(f"{path} line {first_line + i}: {err}")
        if len(cells) != len(names):
            return InputFileError(f"{path} line {first_line + i}: {len(cells)} fields, the header "
                                  f"has {len(names)}: fix or remove the line")
        if col is not None:
            cell = cells[col].strip().strip('"')
            if cell in nulls:
                continue
            try:
                float(cell.replace(",", ".") if decimal == "," else cell)
            except ValueError:
                return InputFileError(
                    f"{path} line {first_line + i}: non-numeric value {cell!r} in channel "
                    f"'{names[col]}': fix the cell or leave it empty")
    return InputFileError(f"{path}: cannot parse the data: {msg}")

