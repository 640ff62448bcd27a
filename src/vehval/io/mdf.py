"""ASAM MDF4 files through asammdf; every channel keeps its own timestamps."""

from __future__ import annotations

import contextlib
import gc
import io
import logging
import sys
from pathlib import Path
from typing import Any

import numpy as np

from vehval.errors import InputFileError
from vehval.io.budget import check_decoded
from vehval.io.delimited import check_exists
from vehval.io.mdf_links import check_links
from vehval.io.raw import RawTable


@contextlib.contextmanager
def _quiet():
    """Silence asammdf's logging and the block dumps it prints on corrupted files."""
    log = logging.getLogger("asammdf")
    level = log.level
    log.setLevel(logging.CRITICAL + 1)
    old_hook = sys.unraisablehook

    def hook(unraisable) -> None:  # asammdf's __del__ fails on half-built objects: ignore it
        mod = str(getattr(unraisable.object, "__module__", "") or "")
        if not mod.startswith("asammdf"):
            old_hook(unraisable)

    sys.unraisablehook = hook
    failed = False
    try:
        with contextlib.redirect_stdout(io.StringIO()):
            yield
    except BaseException:
        failed = True
        raise
    finally:
        if failed:
            gc.collect(0)
        sys.unraisablehook = old_hook
        log.setLevel(level)


def read_mdf(path: str | Path, **_opts) -> RawTable:
    """Read every numeric channel of an MDF (3 or 4) file (see :func:`_read_mdf`)."""
    path = Path(path)
    check_exists(path)
    check_links(path)  # before asammdf follows them: a loop would never end
    with _quiet():
        return _read_mdf(path)


def _read_mdf(path: Path) -> RawTable:
    """Read every numeric channel of an MDF (3 or 4) file.

    Channels of different rates keep their own time arrays in ``RawTable.times`` (the file
    has no single shared time column, so ``time_name`` is ``None``). Master (time) channels
    are not returned as channels. Non-numeric channels are skipped with a note.

    Raises
    ------
    InputFileError
        Missing/empty/unreadable file, no numeric channel, or one channel name in two groups.
    """
    try:
        from asammdf import MDF
    except ImportError as exc:  # pragma: no cover - asammdf is a dependency
        raise InputFileError(f"{path}: reading MDF needs the 'asammdf' package") from exc
    problem = None
    try:
        mdf = MDF(path)
    except Exception as exc:  # noqa: BLE001 - asammdf raises many types on bad files
        problem = f"{type(exc).__name__}: {exc}"
    if problem is not None:  # raised outside the except block: no context keeps the half-built
        gc.collect(0)        # MDF object (and its failing __del__) alive after we return
        raise InputFileError(f"{path}: not a readable MDF file ({problem})")
    names: list[str] = []
    units: list[str | None] = []
    data: dict[str, np.ndarray] = {}
    times: dict[str, np.ndarray] = {}
    notes: list[str] = []
    where: dict[str, int] = {}
    size = path.stat().st_size
    group: Any  # asammdf's Group (typed as object in its annotations)
    try:
        declared = 0.0
        for gi, group in enumerate(mdf.groups):
            declared += _check_group(path, group, gi, size)
            for ch in group.channels:
                _check_layout(path, group, ch, gi)
        check_decoded(path, "MDF4 file", declared, advice="split the recording into tests of a "
                      "few hours, or read it on a machine with more memory")
        for gi, group in enumerate(mdf.groups):
            master = mdf.masters_db.get(gi)
            for ci, ch in enumerate(group.channels):
                if ci == master:
                    continue
                try:
                    sig = mdf.get(group=gi, index=ci)
                except Exception as exc:  # noqa: BLE001 - corrupted blocks raise many types
                    raise InputFileError(f"{path}: channel '{ch.name}' (group {gi}) cannot be read "
                                         f"({type(exc).__name__}: {exc}): the file is corrupted") from None
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
    except InputFileError:
        raise
    except Exception as exc:  # noqa: BLE001 - corrupted blocks raise many types
        raise InputFileError(f"{path}: corrupted MDF file ({type(exc).__name__}: {exc})") from None
    finally:
        with contextlib.suppress(Exception):
            mdf.close()
    if not names:
        raise InputFileError(f"{path}: no numeric channel in the MDF file")
    headers = [f"{n}[{u}]" if u else n for n, u in zip(names, units)]
    return RawTable(path=path, fmt="mdf4", headers=headers, names=names, units=units, data=data,
                    time_name=None, notes=notes, times=times, time_unit="s", first_data_line=0)


def _check_layout(path: Path, group, ch, gi: int) -> None:
    """Reject a channel whose bytes lie outside its record (a corrupted file).

    asammdf's C extraction trusts these offsets; a corrupted offset would read outside the
    data buffer and crash the interpreter instead of raising.
    """
    cg = group.channel_group
    record = int(getattr(cg, "samples_byte_nr", 0)) + int(getattr(cg, "invalidation_bytes_nr", 0))
    nbytes = (int(getattr(ch, "bit_offset", 0)) + int(getattr(ch, "bit_count", 0)) + 7) // 8
    start = int(getattr(ch, "byte_offset", 0))
    if int(getattr(ch, "channel_type", 0)) not in (0, 2, 3):  # VLSD/virtual: no fixed bytes
        return
    if record <= 0 or start < 0 or nbytes <= 0 or start + nbytes > record:
        raise InputFileError(
            f"{path}: channel '{ch.name}' (group {gi}) lies outside its record (bytes "
            f"{start}..{start + nbytes} of {record}): the file is corrupted")


def _check_group(path: Path, group, gi: int, size: int) -> float:
    """Reject a channel group whose data blocks lie outside the file or hold too few records;
    return the bytes it decodes to (records, then a float64 value and time per channel)."""
    cg = group.channel_group
    record = int(getattr(cg, "samples_byte_nr", 0)) + int(getattr(cg, "invalidation_bytes_nr", 0))
    cycles = int(getattr(cg, "cycles_nr", 0))
    total = 0
    for blk in getattr(group, "data_blocks", []) or []:
        addr = int(getattr(blk, "address", 0))
        csize = int(getattr(blk, "compressed_size", 0))
        if addr < 0 or csize < 0 or addr + csize > size:
            raise InputFileError(f"{path}: data block of group {gi} lies beyond the end of the file "
                                 "(truncated or corrupted file)")
        total += int(getattr(blk, "original_size", 0))
    if cycles < 0 or (cycles and record <= 0) or total < cycles * record:
        raise InputFileError(f"{path}: group {gi} declares {cycles} records of {record} bytes but holds "
                             f"{total} bytes: the file is truncated or corrupted")
    return float(total) + 16.0 * cycles * len(getattr(group, "channels", []) or [])
