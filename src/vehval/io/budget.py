"""Memory and size budgets checked before a file is read.

A 3.6 MB Parquet file can decode to 7.4 GB, an MDF4 file can declare terabytes of records
and a text file is parsed in memory: each reader compares what the file declares (footer
metadata, block headers, its size on disk) with a budget here and refuses with one line
naming the file, its declared size, the budget and what to do, before allocating anything.

The budget is the smaller of a fixed cap per kind of data and a share of the memory the
process may still use (the address-space limit, ``ulimit -v``, when one is set, else the
memory the system reports available).
"""

from __future__ import annotations

import os
import resource
from pathlib import Path

from vehval.errors import InputFileError

#: Largest decoded table a reader builds [bytes]: 10 h at 10 Hz of 100 float64 channels is
#: 0.3 GB; 2 GB is a week at 10 Hz.
MAX_DECODED_BYTES = 2_000_000_000
#: Largest text (CSV/TSV/D3) data file parsed [bytes]; parsing takes 2-3 times the file.
MAX_TEXT_BYTES = 1_000_000_000
#: Share of the memory still available that one read may decode into.
AVAILABLE_SHARE = 0.5


def _vm_size() -> int | None:
    """Virtual memory the process uses now [bytes] (Linux), or None."""
    try:
        with open("/proc/self/status", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("VmSize:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError):
        return None
    return None


def _mem_available() -> int | None:
    """Memory the system reports available [bytes] (Linux), or None."""
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError):
        return None
    return None


def address_space_limited() -> bool:
    """True when this process runs under an address-space limit (``ulimit -v``)."""
    soft, _ = resource.getrlimit(resource.RLIMIT_AS)
    return soft != resource.RLIM_INFINITY and soft > 0


def system_allocator_under_limit() -> None:
    """Under an address-space limit, make the system allocator Arrow's default (call before
    Arrow's first allocation; a pool the caller chose, ``ARROW_DEFAULT_MEMORY_POOL``, is
    kept). Arrow's own allocator (mimalloc) reserves an arena on first use, 1 GiB of address
    space under a 1.5 GB limit and 128 MB under 1 GB: a 1.5 GB process would be refused what
    a 1 GB one runs."""
    if address_space_limited():
        os.environ.setdefault("ARROW_DEFAULT_MEMORY_POOL", "system")


def available_memory() -> tuple[int | None, str]:
    """Memory this process may still allocate [bytes] and where the figure comes from.

    Returns
    -------
    bytes : int or None
        The address-space limit less what the process maps now, when a limit is set;
        else the memory the system reports available; None when neither is known.
    origin : str
        ``"address-space limit X GB"`` or ``"available memory"`` (for messages).
    """
    soft, _ = resource.getrlimit(resource.RLIMIT_AS)
    if address_space_limited():
        used = _vm_size() or 0
        return max(soft - used, 0), f"address-space limit {_gb(soft)}"
    avail = _mem_available()
    if avail is None and hasattr(os, "sysconf"):
        try:
            avail = os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
        except (ValueError, OSError):
            avail = None
    return avail, "available memory"


def _gb(n: float) -> str:
    """A byte count for a message: kB, MB or GB."""
    if n < 1e6:
        return f"{n / 1e3:.0f} kB"
    if n < 1e9:
        return f"{n / 1e6:.0f} MB"
    return f"{n / 1e9:.2f} GB" if n < 1e10 else f"{n / 1e9:.0f} GB"


def decode_budget(cap: int | None = None) -> tuple[int, str]:
    """Bytes one read may decode into (at most ``cap``, default :data:`MAX_DECODED_BYTES`),
    and a phrase saying why (for messages)."""
    cap = MAX_DECODED_BYTES if cap is None else cap
    avail, origin = available_memory()
    if avail is not None and avail * AVAILABLE_SHARE < cap:
        return int(avail * AVAILABLE_SHARE), f"half of the {_gb(avail)} left under the {origin}"
    return cap, "vehval's cap for one file"


def check_decoded(path: Path, kind: str, declared: float, *, advice: str) -> None:
    """Refuse a file whose declared decoded size exceeds the budget.

    Parameters
    ----------
    path : Path
        The file (named in the message).
    kind : str
        What the file is, e.g. ``"Parquet file"``.
    declared : float
        Bytes the file declares once decoded (rows x columns x width) [bytes].
    advice : str
        What to do, ending the message.

    Raises
    ------
    InputFileError
        When ``declared`` exceeds :func:`decode_budget`.
    """
    budget, why = decode_budget()
    if declared <= budget:
        return
    try:
        disk = path.stat().st_size
    except OSError:
        disk = 0
    ratio = f" from {_gb(disk)} on disk ({declared / max(disk, 1):,.0f} x)" if disk else ""
    raise InputFileError(f"{path}: the {kind} declares {_gb(declared)} of data once decoded"
                         f"{ratio}, more than the budget of {_gb(budget)} ({why}): {advice}")


def check_memory(need: float, what: str, *, advice: str) -> None:
    """Refuse up front a step that needs more memory than the process may still allocate.

    Parameters
    ----------
    need : float
        Estimated peak memory of the step [bytes].
    what : str
        The step and its data, e.g. ``"QA of 'T' (370,000 samples x 25 signals)"``.
    advice : str
        What to do, ending the message.
    """
    avail, origin = available_memory()
    if avail is None or need <= avail:
        return
    raise InputFileError(f"{what} needs about {_gb(need)} of memory, {_gb(avail)} is left "
                         f"({origin}): {advice}")


def check_file_size(path: Path, kind: str, limit: int, *, advice: str) -> int:
    """Refuse a file larger than ``limit`` [bytes] or than the memory budget; its size."""
    try:
        size = path.stat().st_size
    except OSError as exc:
        raise InputFileError(f"{path}: cannot read ({exc.strerror})") from None
    budget, why = decode_budget(limit)
    if size > budget:
        raise InputFileError(f"{path}: the {kind} is {_gb(size)}, more than the budget of "
                             f"{_gb(budget)} ({why}): {advice}")
    return size


#: Peak memory of QA per stored sample [bytes]: measured 6.2 x 8 B of traced arrays on a
#: 10 h 10 Hz test (alignment grids, level 1 windows, calculated signals, the validated
#: copy), plus allocator and fragmentation overhead seen under an address-space limit.
QA_BYTES_PER_SAMPLE = 8 * 16


def check_qa_memory(test) -> None:
    """Refuse QA of ``test`` up front when its estimated peak exceeds the memory left.

    The estimate is :data:`QA_BYTES_PER_SAMPLE` x the samples of all signals; a 10 h test
    at 10 Hz with 22 channels needs about 0.7 GB.
    """
    samples = sum(int(s.time.size) for s in test)
    check_memory(samples * QA_BYTES_PER_SAMPLE,
                 f"QA of '{test.meta.test_id or 'the test'}' ({samples:,} samples in "
                 f"{len(test)} signals)",
                 advice="run it with more memory (raise `ulimit -v`), or split the test into "
                        "shorter files")
