"""ASAM MDF4 files through asammdf; every channel keeps its own timestamps."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from vehval.errors import InputFileError
from vehval.io.delimited import check_exists
from vehval.io.raw import RawTable


def read_mdf(path: str | Path, **_opts) -> RawTable:
    """Read every numeric channel of an MDF (3 or 4) file.

    Channels of different rates keep their own time arrays in ``RawTable.times`` (the file
    has no single shared time column, so ``time_name`` is ``None``). Master (time) channels
    are not returned as channels. Non-numeric channels are skipped with a note.

    Raises
    ------
    InputFileError
        Missing/empty/unreadable file, no numeric channel, or one channel name in two groups.
    """
    path = Path(path)
    check_exists(path)
    try:
        from asammdf import MDF
    except ImportError as exc:  # pragma: no cover - asammdf is a dependency
        raise InputFileError(f"{path}: reading MDF needs the 'asammdf' package") from exc
    try:
        mdf = MDF(path)
    except Exception as exc:  # noqa: BLE001 - asammdf raises many types on bad files
        raise InputFileError(f"{path}: not a readable MDF file ({type(exc).__name__}: {exc})") from None
    names: list[str] = []
    units: list[str | None] = []
    data: dict[str, np.ndarray] = {}
    times: dict[str, np.ndarray] = {}
    notes: list[str] = []
    where: dict[str, int] = {}
    try:
        for gi, group in enumerate(mdf.groups):
            master = mdf.masters_db.get(gi)
            for ci, ch in enumerate(group.channels):
                if ci == master:
                    continue
                sig = mdf.get(group=gi, index=ci)
                samples = np.asarray(sig.samples)
                if samples.dtype.kind not in "biuf" or samples.ndim != 1:
                    notes.append(f"channel '{sig.name}' (group {gi}) is not numeric: skipped")
                    continue
                name = sig.name
                if name in where:
                    raise InputFileError(
                        f"{path}: duplicate channel name '{name}' in groups {where[name]} and {gi}: "
                        "rename one of them when exporting the file")
                where[name] = gi
                names.append(name)
                units.append(sig.unit or None)
                data[name] = samples.astype(float)
                times[name] = np.asarray(sig.timestamps, dtype=float)
    finally:
        mdf.close()
    if not names:
        raise InputFileError(f"{path}: no numeric channel in the MDF file")
    headers = [f"{n}[{u}]" if u else n for n, u in zip(names, units)]
    return RawTable(path=path, fmt="mdf4", headers=headers, names=names, units=units, data=data,
                    time_name=None, notes=notes, times=times, time_unit="s", first_data_line=0)
