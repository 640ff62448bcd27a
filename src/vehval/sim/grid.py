"""A drive cycle on the simulation's uniform time grid, with its EPA tolerance band.

One :class:`Grid` is what a compiled loop runs over: the target speed on a uniform grid of
step ``dt``, the band the trace check judges against, and whether the run starts with a
cold engine. The front door (:mod:`vehval.sim.simulate`) builds one per cycle or per run
of a test plan.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from vehval.cycles import Cycle
from vehval.errors import ConfigError
from vehval.sim.budget import check_samples
from vehval.sim.driver import MPH, tolerance_band
from vehval.sim.layout import SIGNALS


@dataclass(frozen=True)
class Grid:
    """One run's time grid.

    Attributes
    ----------
    t : ndarray
        Time [s], uniform with step ``dt``.
    vt : ndarray
        Target speed [m/s] on ``t``.
    lo, hi : ndarray
        EPA tolerance band of the target [m/s] on ``t``.
    dt : float
        Step [s].
    cold_start : bool
        The run starts with a cold engine (the vehicle's cold-start model applies).
    """

    t: np.ndarray
    vt: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    dt: float
    cold_start: bool = False


def check_dt(dt: Any) -> float:
    """The step [s] as a float in (0, 1]; a ConfigError naming the value otherwise."""
    try:
        dt = float(dt)
    except (TypeError, ValueError):
        raise ConfigError(f"dt must be a number of seconds, got {dt!r}") from None
    if not (0.0 < dt <= 1.0):
        raise ConfigError(f"dt = {dt:g} s is outside (0, 1] s; use e.g. 0.1 or 1.0")
    return dt


#: float64 values per time step of a recorded run: grid, target, tolerance band, the
#: recorded signals and their copies in the result (measured peak: about 37 at dt 0.01 s)
GRID_COLUMNS = 8 + 2 * len(SIGNALS)


def time_grid(cycle: Cycle, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Uniform grid [s] over the cycle and the target speed [m/s] on it (linear); refused
    (:class:`vehval.sim.budget.MemoryBudgetError`) when a recorded run on it would not fit
    the memory budget."""
    t0 = float(cycle.time_s[0])
    span = float(cycle.time_s[-1]) - t0
    check_samples(np.floor(span / dt + 1e-9) + 1, GRID_COLUMNS,
                  f"a simulation of '{cycle.name}' ({span:g} s) at dt = {dt:g} s",
                  "use a larger --dt")
    n = int(np.floor(span / dt + 1e-9)) + 1
    t = t0 + dt * np.arange(n)
    return t, np.interp(t, cycle.time_s, cycle.speed_mps)


def make_grid(veh: Any, t: np.ndarray, vt: np.ndarray, dt: float,
              cold_start: bool = False) -> Grid:
    """Grid of target ``vt`` [m/s] on ``t`` [s] with the band of ``veh``'s driver block."""
    lo, hi = tolerance_band(t, vt, veh.driver.tolerance_speed_mph * MPH,
                            veh.driver.tolerance_time_s)
    return Grid(t, vt, lo, hi, float(dt), bool(cold_start))


def cycle_grid(veh: Any, cycle: Cycle, dt: float, cold_start: bool = False) -> Grid:
    """:func:`make_grid` over the whole of ``cycle`` at step ``dt`` [s]."""
    t, vt = time_grid(cycle, dt)
    return make_grid(veh, t, vt, dt, cold_start)
