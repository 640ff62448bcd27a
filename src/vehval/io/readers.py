"""Read any supported raw file into a :class:`~vehval.io.raw.RawTable`.

Formats: Argonne D3 text (``d3``), generic delimited text (``csv``), ASAM MDF4 (``mdf4``)
and Parquet (``parquet``). ``fmt="auto"`` picks by extension, then by content.
"""

from __future__ import annotations

from pathlib import Path

from vehval.errors import InputFileError
from vehval.io.paths import check_input_file
from vehval.io.raw import RawTable

__all__ = ["RawTable", "read_raw", "detect_format", "FORMATS"]

FORMATS = ("auto", "d3", "csv", "mdf4", "parquet")
_MDF_EXT = {".mf4", ".mdf", ".mf3", ".dat"}
_PARQUET_EXT = {".parquet", ".pq"}


def detect_format(path: str | Path) -> str:
    """Guess the format of a file from its extension and first bytes.

    Returns
    -------
    str
        ``mdf4``, ``parquet``, ``d3`` or ``csv``.
    """
    path = Path(path)
    ext = path.suffix.lower()
    if ext in _MDF_EXT:
        return "mdf4"
    if ext in _PARQUET_EXT:
        return "parquet"
    try:
        with open(path, "rb") as fh:
            head = fh.read(4096)
    except OSError:
        return "csv"
    if head.startswith(b"MDF "):
        return "mdf4"
    if head.startswith(b"PAR1"):
        return "parquet"
    from vehval.io.d3 import looks_like_d3
    from vehval.io.delimited import _tokens, decode_bytes, repair_first_header, sniff_delimiter
    try:
        text = decode_bytes(head, path, None, []).decode("utf-8", errors="replace")
        lines = [ln.rstrip("\r") for ln in text.split("\n") if ln.strip()][:6]
        if not lines:
            return "csv"
        delim = sniff_delimiter(lines)
        headers = _tokens(lines[0], delim)
        headers[0] = repair_first_header(headers[0], path, [])
    except InputFileError:
        return "csv"
    return "d3" if looks_like_d3(headers) else "csv"


def read_raw(path: str | Path, fmt: str = "auto", **opts) -> RawTable:
    """Read a raw data file.

    Parameters
    ----------
    path : str or Path
        File to read.
    fmt : {'auto', 'd3', 'csv', 'mdf4', 'parquet'}
        Format; ``auto`` detects it.
    **opts
        Reader options: ``delimiter``, ``decimal``, ``encoding`` for text formats.

    Returns
    -------
    RawTable
        Channels in raw units with notes on every repair made while reading.

    Raises
    ------
    InputFileError
        When the file is missing, empty or malformed (message names file and line).
    """
    path = Path(path)
    if fmt not in FORMATS:
        raise InputFileError(f"{path}: unknown format '{fmt}': use one of {', '.join(FORMATS)}")
    check_input_file(path)
    if fmt == "auto":
        fmt = detect_format(path)
    opts = {k: v for k, v in opts.items() if v is not None}
    if fmt == "mdf4":
        from vehval.io.mdf import read_mdf
        return read_mdf(path, **opts)
    if fmt == "parquet":
        from vehval.io.parquet import read_parquet_raw
        return read_parquet_raw(path, **opts)
    if fmt == "d3":
        from vehval.io.d3 import read_d3
        return read_d3(path, **opts)
    from vehval.io.delimited import read_delimited
    return read_delimited(path, fmt="csv", **opts)
