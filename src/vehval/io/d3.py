"""Argonne D3 text files: ``Name[unit]`` headers, a time column first, tab (or comma) separated.

The 10 Hz originals are tab separated with CRLF line ends and a time that starts before 0 s
(pre-test padding); reduced copies exist with commas and ``Time[s]``. Some files carry stray
bytes before the first header (``fpTime[sec]``): they are stripped with a note.
"""

from __future__ import annotations

from pathlib import Path

from vehval.io.delimited import read_delimited
from vehval.io.raw import RawTable, is_time_header
from vehval.units import split_header


def looks_like_d3(headers: list[str]) -> bool:
    """True when the first header is a time column with a unit and most headers carry one."""
    if len(headers) < 2:
        return False
    name, unit = split_header(headers[0])
    with_unit = sum(1 for h in headers if split_header(h)[1] is not None)
    return unit is not None and is_time_header(name, unit) and with_unit >= 0.5 * len(headers)


def read_d3(path: str | Path, **opts) -> RawTable:
    """Read an Argonne D3 text file (see :func:`vehval.io.delimited.read_delimited`).

    The time column, when present, is named in ``RawTable.time_name``; a D3 file without one
    is read as is and the template must then give ``time.rate_hz``.
    """
    return read_delimited(path, fmt="d3", **opts)
