"""Error metrics between a measured and a simulated signal, and engine on/off events.

Pure functions of numpy arrays on a common time grid; NaN samples in either input are
ignored pairwise. Conventions (the test is the reference everywhere):

* difference ``d = sim - test``; mean absolute difference ``MAD = mean(|d|)``;
  ``RMSE = sqrt(mean(d^2))``; bias ``mean(d)``;
* ``R^2 = 1 - sum(d^2) / sum((test - mean(test))^2)`` (coefficient of determination of the
  simulation as a predictor of the test; it can be negative; NaN if the test is constant);
* relative error ``(sim - test) / |test|`` (NaN when ``test == 0``);
* energies by the trapezoidal rule of ``max(P, 0)`` and ``min(P, 0)`` separately, so that
  motoring and regenerating energies do not cancel.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from vehval.integrals import integral


def _pair(test: np.ndarray, sim: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    a = np.asarray(test, dtype=float).ravel()
    b = np.asarray(sim, dtype=float).ravel()
    if a.shape != b.shape:
        raise ValueError(f"test and simulation must have the same length ({a.size} != {b.size})")
    ok = np.isfinite(a) & np.isfinite(b)
    return a[ok], b[ok]


def mean_abs_diff(test: np.ndarray, sim: np.ndarray) -> float:
    """Mean absolute difference ``mean(|sim - test|)`` [unit of the signal]."""
    a, b = _pair(test, sim)
    return float(np.mean(np.abs(b - a))) if a.size else float("nan")


def bias(test: np.ndarray, sim: np.ndarray) -> float:
    """Mean difference ``mean(sim - test)`` [unit of the signal]."""
    a, b = _pair(test, sim)
    return float(np.mean(b - a)) if a.size else float("nan")


def rmse(test: np.ndarray, sim: np.ndarray) -> float:
    """Root-mean-square difference ``sqrt(mean((sim - test)^2))`` [unit of the signal]."""
    a, b = _pair(test, sim)
    return float(np.sqrt(np.mean((b - a) ** 2))) if a.size else float("nan")


def r_squared(test: np.ndarray, sim: np.ndarray) -> float:
    """Coefficient of determination of ``sim`` against the reference ``test`` [-].

    ``1 - SS_res / SS_tot`` with ``SS_res = sum((test - sim)^2)`` and
    ``SS_tot = sum((test - mean(test))^2)``. 1 is a perfect match, 0 is no better than the
    test's mean, negative is worse. NaN when the test is constant or empty.
    """
    a, b = _pair(test, sim)
    if a.size < 2:
        return float("nan")
    ss_tot = float(np.sum((a - a.mean()) ** 2))
    if ss_tot <= 0.0:
        return float("nan")
    return 1.0 - float(np.sum((a - b) ** 2)) / ss_tot


def relative_error(test: float, sim: float) -> float:
    """``(sim - test) / |test|`` [-]; NaN when ``test`` is zero or not finite."""
    if not (np.isfinite(test) and np.isfinite(sim)) or test == 0.0:
        return float("nan")
    return (float(sim) - float(test)) / abs(float(test))


def integrate(time_s: np.ndarray, values: np.ndarray) -> float:
    """Trapezoidal integral of ``values`` over ``time_s`` [unit·s] by the one rule of
    :func:`vehval.integrals.integral` (gaps bridged); 0 when fewer than two finite samples
    (a comparison figure is never NaN for want of samples)."""
    x = integral(time_s, values)
    return x if np.isfinite(x) else 0.0


def energies(time_s: np.ndarray, power_w: np.ndarray) -> tuple[float, float]:
    """Positive and negative energy of a power signal [J].

    Returns ``(E+, E-)`` with ``E+ = ∫ max(P, 0) dt >= 0`` and ``E- = ∫ min(P, 0) dt <= 0``
    (trapezoidal rule on the clipped samples).
    """
    p = np.asarray(power_w, dtype=float)
    return integrate(time_s, np.maximum(p, 0.0)), integrate(time_s, np.minimum(p, 0.0))


def signal_metrics(test: np.ndarray, sim: np.ndarray) -> dict[str, float]:
    """All pointwise metrics of one signal pair.

    Returns
    -------
    dict
        ``n`` (valid pairs), ``mean_test``, ``mean_sim``, ``mad``, ``rmse``, ``bias``,
        ``r2`` and ``nrmse`` = RMSE / (standard deviation of the test) [-] (NaN when the
        test is constant), all in the signal's unit except the dimensionless ones.
    """
    a, b = _pair(test, sim)
    if not a.size:
        nan = float("nan")
        return {"n": 0, "mean_test": nan, "mean_sim": nan, "mad": nan, "rmse": nan,
                "bias": nan, "r2": nan, "nrmse": nan}
    e = rmse(a, b)
    sd = float(np.std(a))
    return {"n": int(a.size), "mean_test": float(a.mean()), "mean_sim": float(b.mean()),
            "mad": mean_abs_diff(a, b), "rmse": e, "bias": bias(a, b), "r2": r_squared(a, b),
            "nrmse": e / sd if sd > 0 else float("nan")}


# ----------------------------------------------------------------------------- on/off events
def on_off_events(time_s: np.ndarray, on: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Times [s] of engine starts (off -> on) and stops (on -> off).

    An event is placed at the first sample of the new state. NaN samples hold the previous
    state. A signal that starts on has no start event at its first sample.
    """
    t = np.asarray(time_s, dtype=float)
    x = np.asarray(on, dtype=float)
    if not x.size:
        return np.empty(0), np.empty(0)
    fin = np.isfinite(x)
    # forward-fill NaN: index of the last finite sample at or before each position
    idx = np.maximum.accumulate(np.where(fin, np.arange(x.size), -1))
    state = np.where(idx >= 0, x[np.maximum(idx, 0)] > 0.5, False)
    d = np.diff(state.astype(np.int8))
    return t[1:][d > 0], t[1:][d < 0]


@dataclass
class EventMatch:
    """Events of the test matched one-to-one to events of the simulation.

    Attributes
    ----------
    pairs : list of (float, float)
        Matched (test time, simulation time) [s].
    missed : list of float
        Test events with no simulation event within the window [s].
    extra : list of float
        Simulation events with no test event within the window [s].
    window_s : float
        Tolerance window [s].
    """

    pairs: list[tuple[float, float]] = field(default_factory=list)
    missed: list[float] = field(default_factory=list)
    extra: list[float] = field(default_factory=list)
    window_s: float = 2.0

    @property
    def n_test(self) -> int:
        return len(self.pairs) + len(self.missed)

    @property
    def n_sim(self) -> int:
        return len(self.pairs) + len(self.extra)

    @property
    def matched_share(self) -> float:
        """Matched pairs / max(test events, simulation events) [-] (1 if neither has any)."""
        n = max(self.n_test, self.n_sim)
        return len(self.pairs) / n if n else 1.0

    @property
    def mean_lag_s(self) -> float:
        """Mean of (simulation - test) time over the matched pairs [s] (NaN if none)."""
        if not self.pairs:
            return float("nan")
        return float(np.mean([s - t for t, s in self.pairs]))

    def to_dict(self) -> dict:
        return {"window_s": self.window_s, "n_test": self.n_test, "n_sim": self.n_sim,
                "matched": len(self.pairs), "missed": len(self.missed), "extra": len(self.extra),
                "matched_share": self.matched_share, "mean_lag_s": self.mean_lag_s,
                "pairs": [list(p) for p in self.pairs], "missed_times_s": list(self.missed),
                "extra_times_s": list(self.extra)}


def match_events(t_test: np.ndarray, t_sim: np.ndarray, window_s: float = 2.0) -> EventMatch:
    """Match test events to simulation events one-to-one within ``±window_s`` [s].

    Greedy by increasing time distance: the closest remaining pair within the window is
    matched first, ties going to the earlier test event. Each event is used at most once.
    """
    if window_s < 0:
        raise ValueError("window_s must be >= 0")
    a = np.sort(np.asarray(t_test, dtype=float).ravel())
    b = np.sort(np.asarray(t_sim, dtype=float).ravel())
    cand = []
    for i, ta in enumerate(a):
        lo, hi = np.searchsorted(b, ta - window_s - 1e-9), np.searchsorted(b, ta + window_s + 1e-9)
        for j in range(lo, hi):
            cand.append((abs(b[j] - ta), i, j))
    cand.sort()
    used_a: set[int] = set()
    used_b: set[int] = set()
    pairs = []
    for _, i, j in cand:
        if i in used_a or j in used_b:
            continue
        used_a.add(i)
        used_b.add(j)
        pairs.append((float(a[i]), float(b[j])))
    pairs.sort()
    return EventMatch(pairs=pairs,
                      missed=[float(a[i]) for i in range(a.size) if i not in used_a],
                      extra=[float(b[j]) for j in range(b.size) if j not in used_b],
                      window_s=float(window_s))


def on_agreement(on_test: np.ndarray, on_sim: np.ndarray) -> float:
    """Share of time steps where test and simulation agree on the engine state [-].

    Both inputs are on/off flags (> 0.5 is on) on the same uniform grid; pairs with a NaN
    are ignored.
    """
    a, b = _pair(on_test, on_sim)
    if not a.size:
        return float("nan")
    return float(np.mean((a > 0.5) == (b > 0.5)))
