"""Estimate the engine on/off rule from an observed engine state.

Estimator: the rule is the simulator's state machine (:mod:`vehval.analysis.replay`);
its thresholds are chosen to maximise the share of time steps where the replayed state
(fed with the demand rebuilt from measured signals, :mod:`vehval.analysis.demand`) agrees
with the observed engine state, with the starts and stops delayed separately (searched
around the spin-up / spin-down measured from the engine speed). The objective is piecewise
constant, so the search is a coordinate ascent over grids: a joint coarse scan of the two
on-thresholds, whose best few distinct points each start rounds of (start / stop delays),
joint (on, off) grids for the power and for the speed thresholds, the joint
off-conditions and the minimum times, then a fine refinement (100 W, 0.1 m/s, one step);
the best end point wins (a power threshold can mimic a speed threshold on gentle
accelerations: one local optimum is not enough).

Identifiability: every estimated parameter is finally scanned over its whole plausible
range with the others fixed. The values whose agreement lies within ``tol`` (default 0.2 %
of the steps) of the best form its interval. A parameter is *identified* only when that
interval lies strictly inside the range; when it reaches an end of the range, changing the
parameter up to that end does not change the replay, so the data only **bound** it (e.g.
an on-power threshold above every demand driven, an off-power threshold that never decided
a stop, a minimum time no run was held by): it goes to ``bounds``, never to ``estimated``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from vehval.analysis.modes import run_lengths
from vehval.analysis.replay import IDX, agreement, replay, rule_vector, score_rule

ESTIMATED = ("engine_on_power_w", "engine_off_power_w", "engine_on_speed_mps",
             "engine_off_speed_mps", "min_on_time_s", "min_off_time_s")


@dataclass
class RuleFit:
    """Result of the rule estimation.

    Attributes
    ----------
    params : dict
        Full rule parameter set used for the replay (estimated + fixed).
    estimated : dict
        Only the parameters the data identified (vehicle-file controller keys).
    bounds : dict
        Parameters the data bounded but did not pin down: key -> {"low", "high", "why"}
        (``None`` for an open side).
    uncertainty : dict
        Key -> {"low", "high", "method", ...} (and bootstrap figures for the minimum times).
    agreement : float
        Share of valid time steps where the replayed rule matches the observed state.
    lag_s : dict
        ``{"start": s, "stop": s}``: delay of the observed engine starts / stops behind the
        replayed command [s].
    replayed : ndarray of bool
        Replayed (lagged) engine state.
    """

    params: dict
    estimated: dict
    bounds: dict
    uncertainty: dict
    agreement: float
    lag_s: dict
    replayed: np.ndarray
    runs: dict = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    ranges: dict = field(default_factory=dict)


def run_durations(state: np.ndarray, dt: float, valid: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """Durations [s] of complete on and off runs (the first and last runs are censored and
    left out, as are runs touching invalid samples)."""
    starts, lengths, vals = run_lengths(np.asarray(state, bool))
    on: list[float] = []
    off: list[float] = []
    for k, (st, ln, val) in enumerate(zip(starts, lengths, vals)):
        if k == 0 or k == len(starts) - 1:
            continue
        if valid is not None and not np.all(valid[st:st + ln]):
            continue
        (on if val else off).append(ln * dt)
    return {"on": np.asarray(on), "off": np.asarray(off)}


def bootstrap_quantile(x: np.ndarray, q: float = 0.05, n_boot: int = 400, seed: int = 0) -> dict:
    """Lower quantile of ``x`` with a bootstrap 95 % interval and standard error."""
    if x.size == 0:
        return {}
    rng = np.random.default_rng(seed)
    est = float(np.quantile(x, q))
    boot = np.quantile(rng.choice(x, size=(n_boot, x.size), replace=True), q, axis=1)
    return {"quantile": q, "estimate": est, "low": float(np.quantile(boot, 0.025)),
            "high": float(np.quantile(boot, 0.975)), "std": float(np.std(boot)), "n": int(x.size)}


class _Problem:
    """The replay objective over one test."""

    def __init__(self, obs, valid, p_wh, v, soc, dt, base, aux_w, pdis_av):
        def f(x):
            return np.ascontiguousarray(x, dtype=np.float64)

        self.obs, self.valid = np.ascontiguousarray(obs, bool), np.ascontiguousarray(valid, bool)
        self.p_wh, self.v, self.soc, self.dt = f(p_wh), f(v), f(soc), float(dt)
        self.aux_w = float(aux_w)
        self.pdis_av = f(np.full(len(p_wh), np.inf) if pdis_av is None
                         else np.where(np.isfinite(pdis_av), pdis_av, np.inf))
        self.vec = rule_vector(base)
        self.state0 = bool(obs[np.argmax(valid)]) if valid.any() else False
        self.lag = (0, 0)
        self.calls = 0

    def score(self, vec: np.ndarray, lag: tuple[int, int] | None = None) -> float:
        self.calls += 1
        la, lb = self.lag if lag is None else lag
        return score_rule(self.p_wh, self.v, self.soc, self.pdis_av, self.aux_w, self.dt,
                          np.asarray(vec, np.float64), self.state0, self.obs, self.valid, la, lb)

    def replayed(self) -> np.ndarray:
        return replay(self.p_wh, self.v, self.soc, self.dt, self.vec, aux_w=self.aux_w,
                      pdis_av_w=self.pdis_av, state0=self.state0, lag_steps=self.lag)


def _plateau(values: np.ndarray, scores: np.ndarray, i_ref: int, tol: float) -> tuple[int, int]:
    """Index range [lo, hi] of the contiguous run around ``i_ref`` scoring >= best - tol."""
    ok = scores >= np.max(scores) - tol
    lo = hi = i_ref
    while lo > 0 and ok[lo - 1]:
        lo -= 1
    while hi < values.size - 1 and ok[hi + 1]:
        hi += 1
    return lo, hi


def _pick(values: np.ndarray, scores: np.ndarray) -> float:
    """Best value of a 1-D scan: the middle of the longest plateau of exactly best score."""
    best = np.max(scores)
    idx = np.nonzero(scores >= best - 1e-12)[0]
    groups = np.split(idx, np.nonzero(np.diff(idx) > 1)[0] + 1)
    g = max(groups, key=len)
    return float(values[g[len(g) // 2]])


def _scan(prob: _Problem, key: str, values: np.ndarray) -> np.ndarray:
    """Agreement for each value of ``key``, the other parameters fixed."""
    out = np.empty(values.size)
    for i, x in enumerate(values):
        vec = prob.vec.copy()
        vec[IDX[key]] = x
        out[i] = prob.score(vec)
    return out


def _scan_pair(prob: _Problem, on_key: str, off_key: str, on_vals: np.ndarray,
               gaps: np.ndarray) -> None:
    """Joint grid over (on threshold, off threshold = on - gap); sets the best in place."""
    best, arg = prob.score(prob.vec), None
    for on in on_vals:
        for gap in gaps:
            vec = prob.vec.copy()
            vec[IDX[on_key]] = on
            vec[IDX[off_key]] = on - gap
            s = prob.score(vec)
            if s > best + 1e-12:
                best, arg = s, (on, on - gap)
    if arg is not None:
        prob.vec[IDX[on_key]], prob.vec[IDX[off_key]] = arg


def _scan_off(prob: _Problem, p_vals: np.ndarray, v_vals: np.ndarray) -> None:
    """Joint grid over the two engine-off conditions (power and speed), set in place."""
    best, arg = prob.score(prob.vec), None
    for p in p_vals:
        for v in v_vals:
            vec = prob.vec.copy()
            vec[IDX["engine_off_power_w"]] = p
            vec[IDX["engine_off_speed_mps"]] = v
            s = prob.score(vec)
            if s > best + 1e-12:
                best, arg = s, (p, v)
    if arg is not None:
        prob.vec[IDX["engine_off_power_w"]], prob.vec[IDX["engine_off_speed_mps"]] = arg


def _scan_lags(prob: _Problem, lags: tuple[np.ndarray, np.ndarray]) -> None:
    """Joint grid over the start and stop delays [steps], set in place."""
    best, arg = -1.0, prob.lag
    for a in lags[0]:
        for b in lags[1]:
            s = prob.score(prob.vec, lag=(int(a), int(b)))
            if s > best + 1e-12:
                best, arg = s, (int(a), int(b))
    prob.lag = arg


def _refine(prob: _Problem, key: str, lo: float, hi: float, step: float) -> None:
    values = np.arange(lo, hi + step / 2, step)
    if values.size:
        prob.vec[IDX[key]] = _pick(values, _scan(prob, key, values))


def _ranges(prob: _Problem, p_hi: float, v_max: float, p_step: float, v_step: float,
            t_step: float) -> dict[str, np.ndarray]:
    """Plausible range of each estimated parameter, as a scan grid (given the others)."""
    on_p = prob.vec[IDX["engine_on_power_w"]]
    on_v = prob.vec[IDX["engine_on_speed_mps"]]
    return {
        "engine_on_power_w": np.arange(0.0, p_hi + p_step / 2, p_step),
        "engine_off_power_w": np.arange(-10000.0, on_p + p_step / 2, p_step),
        "engine_on_speed_mps": np.arange(0.0, v_max + 2.0 + v_step / 2, v_step),
        "engine_off_speed_mps": np.arange(0.0, on_v + v_step / 2, v_step),
        "min_on_time_s": np.arange(0.0, 30.0 + t_step / 2, t_step),
        "min_off_time_s": np.arange(0.0, 30.0 + t_step / 2, t_step),
    }


_WHY = {
    "engine_on_power_w": "the power condition never decided an engine start",
    "engine_off_power_w": "the power condition never decided an engine stop",
    "engine_on_speed_mps": "the speed condition never decided an engine start",
    "engine_off_speed_mps": "the speed condition never decided an engine stop",
    "min_on_time_s": "no on run was held by the minimum on time",
    "min_off_time_s": "no off run was held by the minimum off time",
}


def identifiability(prob: _Problem, grids: dict[str, np.ndarray], tol: float
                    ) -> tuple[dict, dict, dict]:
    """Classify each parameter as identified or bounded from a full-range scan.

    Returns
    -------
    (estimated, bounds, uncertainty) : dicts keyed by parameter name.
    """
    estimated: dict[str, float] = {}
    bounds: dict[str, dict[str, Any]] = {}
    unc: dict[str, dict[str, Any]] = {}
    for key in ESTIMATED:
        values = grids[key]
        x = float(prob.vec[IDX[key]])
        if values.size < 2:
            bounds[key] = {"low": None, "high": None, "why": "empty plausible range"}
            continue
        scores = _scan(prob, key, values)
        i_ref = int(np.argmin(np.abs(values - x)))
        lo, hi = _plateau(values, scores, i_ref, tol)
        at_lo, at_hi = lo == 0, hi == values.size - 1
        unit = key.rsplit("_", 1)[-1]
        rng = [round(float(values[0]), 4), round(float(values[-1]), 4)]
        unc[key] = {"low": round(float(values[lo]), 4), "high": round(float(values[hi]), 4),
                    "method": f"classification margin: agreement within {tol:.1%} of the best "
                              "with the other parameters fixed, scanned over the plausible "
                              f"range {rng} [{unit}]",
                    "agreement_drop_over_range": round(float(np.max(scores) - np.min(scores)), 5)}
        if at_lo and at_hi:
            bounds[key] = {"low": None, "high": None,
                           "why": f"{_WHY[key]}: any value in the plausible range {rng} "
                                  "reproduces the test (not identifiable)"}
        elif at_hi:
            bounds[key] = {"low": round(float(values[lo]), 4), "high": None,
                           "why": f"{_WHY[key]}: any value above {values[lo]:g} reproduces "
                                  "the test up to the end of the plausible range"}
        elif at_lo:
            bounds[key] = {"low": None, "high": round(float(values[hi]), 4),
                           "why": f"{_WHY[key]}: any value below {values[hi]:g} reproduces "
                                  "the test down to the start of the plausible range"}
        else:
            estimated[key] = round(x, 4)
    return estimated, bounds, unc


def _fine(prob: _Problem, lags: tuple[np.ndarray, np.ndarray], p_hi: float, v_max: float,
          dt: float) -> None:
    """Fine refinement (100 W, 0.1 m/s, one step) within +-1.5 coarse cells, twice."""
    x = prob.vec
    for _ in range(2):
        _scan_lags(prob, lags)
        on = x[IDX["engine_on_power_w"]]
        _refine(prob, "engine_on_power_w", max(on - 1500.0, x[IDX["engine_off_power_w"]]),
                min(on + 1500.0, p_hi), 100.0)
        off = x[IDX["engine_off_power_w"]]
        _refine(prob, "engine_off_power_w", off - 1500.0,
                min(off + 1500.0, x[IDX["engine_on_power_w"]]), 100.0)
        vs = x[IDX["engine_on_speed_mps"]]
        _refine(prob, "engine_on_speed_mps", max(vs - 1.5, x[IDX["engine_off_speed_mps"]]),
                min(vs + 1.5, v_max + 2.0), 0.1)
        vo = x[IDX["engine_off_speed_mps"]]
        _refine(prob, "engine_off_speed_mps", max(vo - 1.5, 0.0),
                min(vo + 1.5, x[IDX["engine_on_speed_mps"]]), 0.1)
        mo = x[IDX["min_on_time_s"]]
        _refine(prob, "min_on_time_s", max(mo - 2.0, 0.0), mo + 2.0, dt)
        mf = x[IDX["min_off_time_s"]]
        _refine(prob, "min_off_time_s", max(mf - 2.0, 0.0), mf + 2.0, dt)


def lag_grids(dt: float, lag_range_s: tuple[float, float] = (-0.3, 1.0),
              lag_center_s: tuple[float | None, float | None] = (None, None),
              lag_halfwidth_s: float = 0.3) -> tuple[np.ndarray, np.ndarray]:
    """Start and stop delay grids [steps]: around the measured delays when known, else over
    ``lag_range_s``."""
    out = []
    for c in lag_center_s:
        lo, hi = (lag_range_s if c is None else (c - lag_halfwidth_s, c + lag_halfwidth_s))
        k_lo = int(np.floor(lo / dt + 1e-9))
        k_hi = int(np.ceil(hi / dt - 1e-9))
        out.append(np.arange(k_lo, max(k_hi, k_lo) + 1))
    return out[0], out[1]


def _coarse_seeds(prob: _Problem, p_hi: float, v_grid: np.ndarray, n_starts: int) -> list[np.ndarray]:
    """Start points of the coordinate ascents [parameter vectors].

    A joint coarse scan of the two on-thresholds (power up to ``p_hi`` [W], speed over
    ``v_grid`` [m/s]; offs at a fixed hysteresis); the best ``n_starts`` distinct points
    start one ascent each (a low power threshold and a speed threshold can explain the same
    starts: one local optimum is not enough).
    """
    start = prob.vec.copy()
    coarse = []
    for on in np.arange(2000.0, p_hi + 2000.0, 2000.0):
        for vs in v_grid:
            vec = start.copy()
            vec[IDX["engine_on_power_w"]], vec[IDX["engine_off_power_w"]] = on, on - 3000.0
            vec[IDX["engine_on_speed_mps"]], vec[IDX["engine_off_speed_mps"]] = vs, vs - 2.0
            coarse.append((prob.score(vec), on, vs, vec))
    coarse.sort(key=lambda c: -c[0])
    seeds: list[np.ndarray] = []
    picked: list[tuple[float, float]] = []
    for _, on, vs, vec in coarse:
        if all(abs(on - o) >= 4000.0 or abs(vs - w) >= 2.5 for o, w in picked):
            picked.append((on, vs))
            seeds.append(vec)
        if len(seeds) >= n_starts:
            break
    return seeds


def fit_rule(obs: np.ndarray, valid: np.ndarray, p_wh: np.ndarray, v: np.ndarray,  # noqa: PLR0913 - six aligned signals plus the fit's search options
             soc: np.ndarray, dt: float, base: dict, *, aux_w: float = 0.0,
             pdis_av: np.ndarray | None = None, tol: float = 0.002, rounds: int = 3,
             lag_range_s: tuple[float, float] = (-0.3, 1.0),
             lag_center_s: tuple[float | None, float | None] = (None, None),
             lag_halfwidth_s: float = 0.3, n_starts: int = 3) -> RuleFit:
    """Estimate the engine on/off rule that best reproduces the observed engine state.

    Parameters
    ----------
    obs, valid : ndarray of bool
        Observed engine state and the steps where it (and the demand) is known.
    p_wh : ndarray
        Wheel power demand [W] (:func:`vehval.analysis.demand.rule_demand`).
    v : ndarray
        Vehicle speed [m/s].
    soc : ndarray
        State of charge [-] (NaN where unknown).
    dt : float
        Step [s].
    base : dict
        Starting / fixed rule parameters (:func:`vehval.analysis.replay.base_params`).
    aux_w : float
        Auxiliary load [W] included in the total demand.
    pdis_av : ndarray, optional
        Battery discharge power available [W] (battery condition); default unlimited.
    tol : float
        Agreement tolerance [share of steps] defining the intervals and identifiability.
    rounds : int
        Coordinate-ascent rounds.
    lag_range_s : (float, float)
        Search range of the start / stop delays [s] when their centre is unknown.
    lag_center_s : (float or None, float or None)
        Measured start / stop delays [s] (spin-up / spin-down seen in the engine speed,
        :func:`vehval.analysis.demand.transition_windows`): the delays are then searched
        within ``lag_halfwidth_s`` of them. Without this constraint a low on-threshold and a
        long start delay can trade against each other.
    n_starts : int
        Coordinate ascents started from the best distinct points of the coarse scan.

    Returns
    -------
    RuleFit
    """
    obs = np.asarray(obs, bool)
    valid = np.asarray(valid, bool) & np.isfinite(v)
    prob = _Problem(obs, valid, np.asarray(p_wh, float), v, soc, dt, base, aux_w, pdis_av)
    notes: list[str] = []
    runs = run_durations(obs, dt, valid)
    boot = {k: bootstrap_quantile(runs[k]) for k in ("on", "off")}
    # ---- search ranges from the data
    p_fin = p_wh[valid & np.isfinite(p_wh)]
    v_max = float(np.nanmax(v[valid])) if valid.any() else 30.0
    # top of the power range: above every total demand seen, so "never binding" is a value
    p_hi = (float(np.max(p_fin)) if p_fin.size else 30e3) + aux_w + \
        max(prob.vec[IDX["soc_charge_power_max_w"]], 0.0) + 2000.0
    p_hi = float(np.ceil(max(p_hi, 4000.0) / 1000.0) * 1000.0)  # whole kW [W]: not a unit conversion
    for key, b in (("min_on_time_s", boot["on"]), ("min_off_time_s", boot["off"])):
        # start short: a long minimum time would mask the thresholds in the first scans
        prob.vec[IDX[key]] = min(max(b["estimate"] - 0.5, 0.0), 2.0) if b else 0.0
    lags = lag_grids(dt, lag_range_s, lag_center_s, lag_halfwidth_s)
    on_grid = np.arange(1000.0, p_hi + 1.0, 1000.0)
    gaps = np.arange(0.0, 12000.0 + 1.0, 1000.0)
    v_grid = np.arange(5.0, np.ceil(v_max) + 2.0, 1.0)
    v_gaps = np.arange(0.0, 6.01, 1.0)
    seeds = _coarse_seeds(prob, p_hi, v_grid, n_starts)
    t_step = max(dt, 0.5)
    rmax_on = float(runs["on"].max()) + 2.0 if runs["on"].size else 20.0
    rmax_off = float(runs["off"].max()) + 2.0 if runs["off"].size else 20.0
    results = []
    for seed in seeds:
        prob.vec, prob.lag = seed.copy(), (int(lags[0][len(lags[0]) // 2]), int(lags[1][len(lags[1]) // 2]))
        for r in range(rounds):
            _scan_lags(prob, lags)
            # later rounds search near the current point only
            on_p, on_v = prob.vec[IDX["engine_on_power_w"]], prob.vec[IDX["engine_on_speed_mps"]]
            near_p = on_grid if r == 0 else on_grid[np.abs(on_grid - on_p) <= 4000.0]
            near_v = v_grid if r == 0 else v_grid[np.abs(v_grid - on_v) <= 3.0]
            _scan_pair(prob, "engine_on_power_w", "engine_off_power_w", near_p, gaps)
            _scan_pair(prob, "engine_on_speed_mps", "engine_off_speed_mps", near_v, v_gaps)
            off_p, off_v = prob.vec[IDX["engine_off_power_w"]], prob.vec[IDX["engine_off_speed_mps"]]
            p_vals = np.arange(-6000.0, prob.vec[IDX["engine_on_power_w"]] + 1.0, 1000.0)
            v_vals = np.arange(3.0, prob.vec[IDX["engine_on_speed_mps"]] + 0.01, 1.0)
            if r > 0:
                p_vals = p_vals[np.abs(p_vals - off_p) <= 4000.0]
                v_vals = v_vals[np.abs(v_vals - off_v) <= 3.0]
            _scan_off(prob, p_vals, v_vals)
            _refine(prob, "min_on_time_s", 0.0, min(rmax_on, 30.0), t_step)
            _refine(prob, "min_off_time_s", 0.0, min(rmax_off, 30.0), t_step)
        _fine(prob, lags, p_hi, v_max, dt)
        results.append((prob.score(prob.vec), prob.vec.copy(), prob.lag))
    _, prob.vec, prob.lag = max(results, key=lambda r: r[0])
    params = {k: float(prob.vec[i]) for k, i in IDX.items()}
    rep = prob.replayed()
    agree = agreement(obs, rep, valid)
    # ---- identification: full-range scans
    grids = _ranges(prob, p_hi, v_max, 100.0, 0.1, dt)
    estimated, bounds, unc = identifiability(prob, grids, tol)
    for key, b in (("min_on_time_s", boot["on"]), ("min_off_time_s", boot["off"])):
        if b:
            unc[key]["bootstrap_q05_of_runs"] = b
    if agree < 0.9:
        notes.append(f"the replayed rule reproduces only {agree:.1%} of the steps: the engine "
                     "state depends on conditions the rule does not see (e.g. warm-up, "
                     "catalyst heating, driver modes) or on an unmeasured demand")
    ranges = {k: [round(float(g[0]), 4), round(float(g[-1]), 4)] for k, g in grids.items()}
    return RuleFit(params=params, estimated=estimated, bounds=bounds, uncertainty=unc,
                   agreement=agree, lag_s={"start": prob.lag[0] * dt, "stop": prob.lag[1] * dt},
                   replayed=rep, runs={k: runs[k].tolist() for k in runs}, notes=notes,
                   ranges=ranges)
