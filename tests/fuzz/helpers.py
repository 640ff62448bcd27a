"""Settings, hang guard, outcome classes and input generators of the hardening (fuzz) tests.

Every property here is the same contract: a reader or loader given hostile input returns a
correct result or raises a :class:`vehval.errors.VehvalError` -- never another exception
type and never a hang. A hang is turned into a failure by :func:`no_hang` (SIGALRM), which
is far above the normal time of one call (milliseconds) so it cannot fire spuriously.

Imported by the tests of this folder (and its conftest); fixtures stay in conftest.py.
"""

from __future__ import annotations

import contextlib
import io
import signal
import threading

import numpy as np
from hypothesis import HealthCheck, settings

from vehval.errors import VehvalError

#: Per-example deadline [ms]: generous for the first (cold-import) call on a loaded 2-core box.
DEADLINE_MS = 3000


#: Hard wall per call [s]: a call this slow is a hang, not a slow path.
HANG_S = 20


FUZZ = settings(max_examples=25, deadline=DEADLINE_MS, derandomize=True,
                suppress_health_check=[HealthCheck.function_scoped_fixture,
                                       HealthCheck.too_slow, HealthCheck.data_too_large])


#: For loaders that are slow per call (the vehicle file validates whole efficiency maps).
FUZZ_SLOW = settings(FUZZ, max_examples=10)


class Hang(Exception):
    pass


@contextlib.contextmanager
def no_hang(seconds: int = HANG_S):
    """Fail (raise :class:`Hang`) when the block runs longer than ``seconds`` [s]."""
    if threading.current_thread() is not threading.main_thread():  # pragma: no cover
        yield
        return

    def _alarm(signum, frame):
        raise Hang(f"call did not return within {seconds} s")

    old = signal.signal(signal.SIGALRM, _alarm)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)


def outcome(fn, *args, **kw):
    """Call ``fn``; return its result, or the VehvalError it raised. Any other error propagates."""
    with no_hang():
        try:
            return fn(*args, **kw)
        except VehvalError as exc:
            assert str(exc).strip(), "a VehvalError must carry a message"
            return exc


def check_table(table) -> None:
    """Invariants of a RawTable that was returned (not raised)."""
    assert len(table.names) == len(set(table.names)), "channel names must be unique"
    assert len(table.names) == len(table.units)
    assert set(table.data) <= set(table.names) | ({table.time_name} if table.time_name else set())
    for name, arr in table.data.items():
        arr = np.asarray(arr)
        assert arr.ndim == 1 and arr.dtype.kind == "f", f"{name}: {arr.dtype} {arr.shape}"
    if table.time_name is not None and not getattr(table, "times", None):
        n = {np.asarray(a).size for a in table.data.values()}
        assert len(n) == 1, f"columns of one table differ in length: {n}"


D3_HEADERS = ["Time[s]", "Dyno_Speed[mph]", "Engine_Speed[rpm]", "Bty_Curr[A]", "Cell_Temp[°C]"]


def d3_text(n: int = 30, delim: str = "\t", eol: str = "\r\n", values=None) -> str:
    """A D3-style table: time first, ``Name[unit]`` headers."""
    t = np.round(np.arange(n) * 0.1 - 0.5, 3)
    cols = [t, 20 + 5 * np.sin(t), 1000 + 10 * t, -3 + 0 * t, 25 + 0 * t] if values is None else values
    lines = [delim.join(D3_HEADERS)]
    for i in range(n):
        lines.append(delim.join(f"{c[i]:.6g}" if isinstance(c[i], (float, np.floating)) else str(c[i])
                                for c in cols))
    return eol.join(lines) + eol


def csv_text(n: int = 20, delim: str = ",") -> str:
    """A generic CSV with a unit row."""
    lines = [delim.join(["time", "speed", "current"]), delim.join(["s", "km/h", "A"])]
    for i in range(n):
        lines.append(delim.join([f"{i * 0.5:g}", f"{i * 1.5:g}", f"{-i:g}"]))
    return "\n".join(lines) + "\n"


def parquet_bytes(columns: dict[str, np.ndarray] | None = None) -> bytes:
    import pyarrow as pa
    import pyarrow.parquet as pq

    if columns is None:
        t = np.arange(20) * 0.1
        columns = {"time": t, "veh_speed": 3.0 * t, "eng_speed": 100 + t}
    buf = io.BytesIO()
    pq.write_table(pa.table({k: pa.array(v) for k, v in columns.items()}), buf)
    return buf.getvalue()
