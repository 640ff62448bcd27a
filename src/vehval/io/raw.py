"""The :class:`RawTable`: channels as read from a file, before renaming and SI conversion."""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from vehval.errors import InputFileError
from vehval.nomenclature import normalise_raw, registry
from vehval.units import dimension, split_header

#: Normalised raw names recognised as a time column (besides the registry's ``time`` aliases).
TIME_NAMES = frozenset({"time", "t", "timestamp", "elapsed time", "time s", "time sec", "zeit",
                        "time stamp", "relative time", "elapsed"})


def is_time_header(name: str, unit: str | None) -> bool:
    """True when a raw channel name (without unit) and its unit look like a time column."""
    norm = normalise_raw(name)
    if norm not in TIME_NAMES and registry().match_alias(name) != "time":
        return False
    if unit is None:
        return True
    try:
        return dimension(unit) == dimension("s")
    except Exception:  # noqa: BLE001 - an unparsable unit simply is not a time unit
        return False


@dataclass
class RawTable:
    """Channels of one raw file, in raw units.

    Attributes
    ----------
    path : pathlib.Path
        File read.
    fmt : str
        Format actually used: ``d3``, ``csv``, ``mdf4`` or ``parquet``.
    headers : list of str
        Column headers as written in the file (e.g. ``Dyno_Speed[mph]``).
    names : list of str
        Channel names without the unit suffix (e.g. ``Dyno_Speed``); unique.
    units : list of str or None
        Unit of each channel from the header (``None`` when the file gives none).
    data : dict of str to numpy.ndarray
        Samples per channel name (float64, NaN for empty cells), raw units.
    time_name : str or None
        Name of the shared time column, if the file has one (it is also in ``data``).
    notes : list of str
        Repairs and observations made while reading (stray bytes stripped, truncated last
        line dropped...). Never empty when something was changed.
    times : dict of str to numpy.ndarray
        Per-channel time arrays [raw time unit] for formats where channels have their own
        time base (MDF4, our Test parquet); empty for tables with one shared time column.
    time_unit : str or None
        Unit of the time column(s).
    first_data_line : int
        1-based line number of the first data row in the file (text formats), used to name
        the line in error messages; 0 for binary formats.
    """

    path: Path
    fmt: str
    headers: list[str]
    names: list[str]
    units: list[str | None]
    data: dict[str, np.ndarray]
    time_name: str | None = None
    notes: list[str] = field(default_factory=list)
    times: dict[str, np.ndarray] = field(default_factory=dict)
    time_unit: str | None = "s"
    first_data_line: int = 0
    meta: dict = field(default_factory=dict)

    @property
    def n_rows(self) -> int:
        """Number of rows of the shared table (longest channel for per-channel times)."""
        return max((v.size for v in self.data.values()), default=0)

    @property
    def channels(self) -> list[str]:
        """Channel names other than the shared time column."""
        return [n for n in self.names if n != self.time_name]

    def unit_of(self, name: str) -> str | None:
        """Header unit of a channel (``None`` when absent)."""
        return self.units[self.names.index(name)]

    def time_of(self, name: str) -> np.ndarray | None:
        """Time array of a channel in the file's time unit (``None`` when the file has none)."""
        if name in self.times:
            return self.times[name]
        if self.time_name is not None:
            return self.data[self.time_name]
        return None

    def line_of(self, row: int) -> int | None:
        """1-based file line of data row ``row`` (``None`` for binary formats)."""
        return self.first_data_line + row if self.first_data_line else None


def split_headers(headers: list[str], path: Path) -> tuple[list[str], list[str | None]]:
    """Split ``Name[unit]`` headers into names and units; duplicate names are an error."""
    names: list[str] = []
    units: list[str | None] = []
    seen: dict[str, int] = {}
    for i, h in enumerate(headers):
        name, unit = split_header(h)
        if not name:
            name = f"column_{i + 1}"
        if name in seen:
            raise InputFileError(
                f"{path}: duplicate channel name '{name}' in columns {seen[name] + 1} and {i + 1}"
                " of the header: rename one of them in the file")
        seen[name] = i
        names.append(name)
        units.append(unit if unit else None)
    return names, units


def find_time_column(names: list[str], units: list[str | None]) -> str | None:
    """First column whose name and unit look like time, or ``None``."""
    for n, u in zip(names, units):
        if is_time_header(n, u):
            return n
    return None


_PRINTABLE = re.compile(r"^[\x20-\x7e\u00a0-\uffff]*$")


def is_printable(text: str) -> bool:
    """True when ``text`` has no control characters."""
    return bool(_PRINTABLE.match(text))
