"""Warm-up fuel of a cold start, identified from a cold-start and a hot-start test.

The same car driving the same cycle from a cold and from a hot start burns more fuel cold;
the excess fades as the engine, its oil and the after-treatment warm up. The model
(:mod:`vehval.sim`, ``cold_start=True``) multiplies every fuel rate by
``1 + f exp(-t / tau)``, t the time since the start: ``engine.warmup_fuel_fraction`` f and
``engine.warmup_time_constant_s`` tau.

Both are identified from measurements only, the hot test's fuel rate standing for the warm
engine on the same trace, so the fit does not inherit the fuel model's own errors: the
measured cumulative excess ``E(t) = int (c - h) ds`` (c, h the cold and hot fuel rates) is
fitted by ``f int h exp(-s / tau) ds`` (least squares on a 1 s grid; f linear for each tau of
a logarithmic grid from 20 s to 3000 s). The fit quality is R² of E(t); the measured and
fitted excess per phase is kept as evidence.

Which test starts cold is decided by the one rule of :func:`vehval.conditions.cold_start`
(:func:`cold_start_state` applies it to a trace): the engine coolant at the start at most
10 K above the cell (a soaked engine is at the cell temperature, a hot start after a
10-minute soak near its working temperature).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from vehval.conditions import COLD_START_BAND_K, COLD_START_CELL_C, cold_start
from vehval.identify.traces import IdentificationError, Trace

#: [°C] the coolant start above which a test is warm whatever its cell (the one rule,
#: :func:`vehval.conditions.cold_start`, without a measured cell: cell + band)
COLD_COOLANT_C = COLD_START_CELL_C + COLD_START_BAND_K
#: [s] time constants tried (logarithmic grid)
TAU_GRID_S = np.geomspace(20.0, 3000.0, 121)
_GRID_S = 1.0  # [s] resolution of the cumulative curves


def cold_start_state(trace: Trace) -> tuple[bool | None, str]:
    """Whether ``trace`` starts with a cold engine (None: unknown, no coolant temperature)
    and why."""
    return cold_start(trace.coolant_start_c, trace.amb_temp_c)


def start_label(pred: dict) -> str:
    """How a test of :func:`vehval.identify.predict.predict_trace` started and how the
    model ran it."""
    if pred.get("cold_start"):
        return "cold start"
    if pred.get("starts_cold"):
        return "cold start, run warm"
    return "warm start" if pred.get("starts_cold") is False else "start unknown"


@dataclass
class WarmupFit:
    """Identified warm-up fuel: fraction [-] and time constant [s] with their evidence."""

    fraction: float
    time_constant_s: float
    cold_test: str
    hot_test: str
    r2: float  # of the cumulative excess fuel curve
    excess_g: float  # measured whole-test excess of the cold test [g]
    hot_fuel_g: float  # measured fuel of the hot test [g]
    phases: list[dict] = field(default_factory=list)
    note: str = ""

    def to_dict(self) -> dict:
        return {"warmup_fuel_fraction": self.fraction,
                "warmup_time_constant_s": self.time_constant_s, "cold_test": self.cold_test,
                "hot_test": self.hot_test, "r2": self.r2, "excess_g": self.excess_g,
                "hot_fuel_g": self.hot_fuel_g, "phases": self.phases, "note": self.note}

    def provenance(self) -> str:
        return (f"identified from the cold-start test {self.cold_test} against the hot-start "
                f"test {self.hot_test} of the same cycle (measured fuel of both; excess "
                f"{self.excess_g:.1f} g = {100 * self.excess_g / self.hot_fuel_g:.1f} % of "
                f"the hot test; cumulative-excess fit R² {self.r2:.3f})")


def _on_grid(tr: Trace, t_end: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Fuel rate [kg/s] and phase on a 1 s grid from 0 to ``t_end`` (means per second)."""
    m = (tr.t >= 0.0) & (tr.t < t_end)
    k = np.floor(tr.t[m] / _GRID_S).astype(int)
    n = int(np.ceil(t_end / _GRID_S))
    cnt = np.bincount(k, minlength=n)[:n]
    fuel = np.bincount(k, weights=np.clip(tr.fuel[m], 0.0, None), minlength=n)[:n]
    phase = np.zeros(n)
    phase[k] = tr.phase[m]
    return fuel / np.maximum(cnt, 1), phase, (np.arange(n) + 0.5) * _GRID_S


def fit_warmup(cold: Trace, hot: Trace) -> WarmupFit:
    """Warm-up fraction and time constant from ``cold`` against ``hot`` (same car, cycle).

    Raises
    ------
    IdentificationError
        The tests are of different cycles, the cold one does not start cold or the hot one
        does (by their coolant temperature), or the cold test burns no more than the hot one.
    """
    if cold.cycle and hot.cycle and cold.cycle != hot.cycle:
        raise IdentificationError(
            f"{cold.file}: cycle {cold.cycle}, its hot reference {hot.file} is a {hot.cycle}: "
            "the warm-up is identified against a hot start on the same cycle")
    for tr, want in ((cold, True), (hot, False)):
        state, why = cold_start_state(tr)
        if state is not None and state != want:
            raise IdentificationError(
                f"{tr.file}: {why}: it is not a {'cold' if want else 'hot'} start; give a "
                f"{'cold-start' if want else 'hot-start'} test")
    t_end = min(cold.t[-1], hot.t[-1])
    c, phase, t = _on_grid(cold, t_end)
    h, _, _ = _on_grid(hot, t_end)
    sel = phase > 0 if np.any(phase > 0) else np.ones(phase.size, dtype=bool)
    c, h, t, phase = c[sel], h[sel], t[sel], phase[sel]
    excess = np.cumsum(c - h) * _GRID_S
    if excess[-1] <= 0.0:
        raise IdentificationError(
            f"{cold.file}: it burns no more fuel ({1e3 * c.sum():.1f} g) than the hot start "
            f"{hot.file} ({1e3 * h.sum():.1f} g): no warm-up to identify")
    best = (np.inf, 0.0, TAU_GRID_S[0])
    for tau in TAU_GRID_S:
        g = np.cumsum(h * np.exp(-t / tau)) * _GRID_S  # t from the start, as in the model
        f = max(float(excess @ g / (g @ g)), 0.0)
        sse = float(np.sum((excess - f * g) ** 2))
        if sse < best[0]:
            best = (sse, f, float(tau))
    sse, f, tau = best
    r2 = 1.0 - sse / float(np.sum((excess - excess.mean()) ** 2))
    fitted = h * f * np.exp(-t / tau)
    phases = [{"phase": int(p), "hot_g": 1e3 * float(h[phase == p].sum() * _GRID_S),
               "cold_g": 1e3 * float(c[phase == p].sum() * _GRID_S),
               "fitted_excess_g": 1e3 * float(fitted[phase == p].sum() * _GRID_S)}
              for p in np.unique(phase) if p > 0]
    edge = tau >= TAU_GRID_S[-1] * 0.999 or tau <= TAU_GRID_S[0] * 1.001
    note = ("the time constant is at the end of the searched range: the test is too short "
            "to tell it" if edge else "")
    return WarmupFit(fraction=f, time_constant_s=tau, cold_test=cold.test_id,
                     hot_test=hot.test_id, r2=r2, excess_g=1e3 * float(excess[-1]),
                     hot_fuel_g=1e3 * float(h.sum() * _GRID_S), phases=phases, note=note)


def hot_partner(cold: Trace, traces: list[Trace]) -> Trace:
    """The identification test to compare a cold start with: same cycle, not a cold start."""
    same = [tr for tr in traces if tr.cycle and tr.cycle == cold.cycle
            and cold_start_state(tr)[0] is not True]
    if not same:
        cycles = ", ".join(sorted({tr.cycle or "?" for tr in traces}))
        raise IdentificationError(
            f"{cold.file}: no hot-start identification test on its cycle "
            f"({cold.cycle or 'unknown'}; the identification tests are on {cycles}): give a "
            "hot start of the same cycle among the identification tests")
    return same[0]
