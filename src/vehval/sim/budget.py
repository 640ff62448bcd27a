"""Memory budget: refuse an allocation that cannot fit before making it.

A time grid of a simulation or a set of Monte Carlo draws is sized by options (``--dt``,
``--monte-carlo``) and by the input (a cycle's duration). Before such arrays are made, their
size is estimated (``samples x columns x 8`` bytes) and compared with the budget

    min(available memory / 2, MEMORY_CAP_BYTES)

where the available memory is the smallest of the system's available memory
(``MemAvailable``), the room left under the process's address-space limit (``RLIMIT_AS``)
and the room left in its cgroup (``memory.max``). The cap is 8 GiB; the environment variable
``VEHVAL_MEMORY_CAP_MB`` sets another. A run over the budget is refused with the memory it
would need, before anything is allocated.
"""

from __future__ import annotations

import os
import resource
from pathlib import Path

from vehval.errors import VehvalError

MEMORY_CAP_BYTES = 8 * 2**30
CAP_ENV = "VEHVAL_MEMORY_CAP_MB"
GIB = 2**30


class MemoryBudgetError(VehvalError):
    """A run would need more memory than the budget allows."""


def _meminfo_available() -> int | None:
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemAvailable:"):
                return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return None


def _address_space_left() -> int | None:
    soft, _ = resource.getrlimit(resource.RLIMIT_AS)
    if soft == resource.RLIM_INFINITY:
        return None
    used = 0
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("VmSize:"):
                used = int(line.split()[1]) * 1024
                break
    except (OSError, ValueError, IndexError):
        pass
    return max(soft - used, 0)


def _cgroup_left() -> int | None:
    try:
        limit = Path("/sys/fs/cgroup/memory.max").read_text().strip()
        if limit == "max":
            return None
        used = int(Path("/sys/fs/cgroup/memory.current").read_text().strip())
        return max(int(limit) - used, 0)
    except (OSError, ValueError):
        return None


def available_bytes() -> int | None:
    """Memory this process can still obtain [bytes] (``None``: unknown)."""
    known = [x for x in (_meminfo_available(), _address_space_left(), _cgroup_left())
             if x is not None]
    return min(known) if known else None


def cap_bytes() -> int:
    """The cap of the budget [bytes]: ``VEHVAL_MEMORY_CAP_MB`` or 8 GiB."""
    raw = os.environ.get(CAP_ENV, "").strip()
    if not raw:
        return MEMORY_CAP_BYTES
    try:
        mb = float(raw)
    except ValueError:
        raise VehvalError(f"{CAP_ENV}={raw!r}: give the memory cap in MB, e.g. 4096") from None
    if not (mb > 0 and mb < 2**43):
        raise VehvalError(f"{CAP_ENV}={raw!r}: give a positive memory cap in MB, e.g. 4096")
    return int(mb * 2**20)


def budget_bytes() -> int:
    """``min(available memory / 2, cap)`` [bytes]."""
    avail = available_bytes()
    cap = cap_bytes()
    return cap if avail is None else min(avail // 2, cap)


def _size(n: float) -> str:
    return f"{n / GIB:.1f} GiB" if n >= GIB / 10 else f"{n / 2**20:.0f} MiB"


def check_memory(need_bytes: float, what: str, hint: str) -> None:
    """Refuse (:class:`MemoryBudgetError`) when ``need_bytes`` exceeds :func:`budget_bytes`.

    Parameters
    ----------
    need_bytes : float
        Estimated memory of the arrays about to be made [bytes].
    what : str
        What needs it, for the message (e.g. ``simulation of 'udds' at dt = 1e-05 s``).
    hint : str
        What to do, e.g. ``use a larger --dt``.
    """
    budget = budget_bytes()
    if need_bytes > budget:
        avail = available_bytes()
        where = (f"half the {_size(avail)} available, at most {_size(cap_bytes())}"
                 if avail is not None and avail // 2 < cap_bytes()
                 else f"the cap; {CAP_ENV} sets another")
        raise MemoryBudgetError(f"{what} would need about {_size(need_bytes)} of memory, over "
                                f"the budget of {_size(budget)} ({where}): {hint}")


def check_samples(samples: float, columns: int, what: str, hint: str) -> None:
    """:func:`check_memory` for ``samples x columns`` float64 values."""
    check_memory(float(samples) * columns * 8.0, f"{what} ({samples:.3g} samples x {columns} "
                 "values)", hint)
