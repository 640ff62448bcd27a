"""Estimate the engine on/off rule from an observed engine state.

Estimator: the rule is the simulator's state machine (:mod:`vehval.analysis.replay`);
its thresholds are chosen to maximise the share of time steps where the replayed state
(fed with the measured demand, speed and SOC) agrees with the observed engine state.
The objective is piecewise constant, so the search is a coordinate ascent over grids:
joint (on, off) grids for the power and for the speed thresholds, 1-D grids for the
minimum times and the spin-up lag; each round refines the grids around the best point.
Initial values come from the demand and speed distributions at the observed on-transitions
and from the run-length distribution.

Uncertainty is the classification margin: the interval of values whose agreement is within
``tol`` (default 0.2 % of the steps) of the best with everything else fixed. A threshold whose
interval reaches the end of its search range never bound (e.g. a speed threshold above
every speed driven) and is reported as a bound, not an estimate. The minimum times also get
a bootstrap interval of the lower quantile of the on/off run lengths.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from vehval.analysis.modes import run_lengths
from vehval.analysis.replay import IDX, agreement, replay, rule_vector

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
        Parameters the data bounded but did not pin down: key -> {"low", "high", "why"}.
    uncertainty : dict
        Key -> {"low", "high", "method"} (and bootstrap figures for the minimum times).
    agreement : float
        Share of valid time steps where the replayed rule matches the observed state.
    lag_s : float
        Estimated delay between commanded and observed engine state [s].
    replayed : ndarray of bool
        Replayed (lagged) engine state.
    """

    params: dict
    estimated: dict
    bounds: dict
    uncertainty: dict
    agreement: float
    lag_s: float
    replayed: np.ndarray
    runs: dict = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)


def run_durations(state: np.ndarray, dt: float, valid: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """Durations [s] of complete on and off runs (the first and last runs are censored and
    left out, as are runs touching invalid samples)."""
    starts, lengths, vals = run_lengths(np.asarray(state, bool))
    on, off = [], []
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
        self.obs, self.valid = obs, valid
        self.p_wh, self.v, self.soc, self.dt = p_wh, v, soc, dt
        self.aux_w, self.pdis_av = aux_w, pdis_av
        self.vec = rule_vector(base)
        self.state0 = bool(obs[np.argmax(valid)]) if valid.any() else False
        self.lag = 0
        self.calls = 0

    def score(self, vec: np.ndarray, lag: int | None = None) -> float:
        self.calls += 1
        rep = replay(self.p_wh, self.v, self.soc, self.dt, vec, aux_w=self.aux_w,
                     pdis_av_w=self.pdis_av, state0=self.state0,
                     lag_steps=self.lag if lag is None else lag)
        return agreement(self.obs, rep, self.valid)

    def replayed(self) -> np.ndarray:
        return replay(self.p_wh, self.v, self.soc, self.dt, self.vec, aux_w=self.aux_w,
                      pdis_av_w=self.pdis_av, state0=self.state0, lag_steps=self.lag)


def _pick(values: np.ndarray, scores: np.ndarray, prefer: str) -> tuple[float, int]:
    """Best value of a 1-D scan: ties -> middle of the best plateau, or its upper end."""
    best = np.max(scores)
    idx = np.nonzero(scores >= best - 1e-12)[0]
    if prefer == "high":
        return float(values[idx[-1]]), int(idx[-1])
    # the longest contiguous run of tied indices, its middle
    groups = np.split(idx, np.nonzero(np.diff(idx) > 1)[0] + 1)
    g = max(groups, key=len)
    return float(values[g[len(g) // 2]]), int(g[len(g) // 2])


def _scan(prob: _Problem, key: str, values: np.ndarray) -> np.ndarray:
    """Agreement for each value of ``key``, the other parameters fixed."""
    out = np.empty(values.size)
    for i, x in enumerate(values):
        vec = prob.vec.copy()
        vec[IDX[key]] = x
        out[i] = prob.score(vec)
    return out


def _scan_pair(prob: _Problem, on_key: str, off_key: str, on_vals: np.ndarray,
               off_fracs: np.ndarray) -> tuple[float, float]:
    """Joint grid over (on threshold, off threshold = on - gap); sets the best in place."""
    best, arg = -1.0, (prob.vec[IDX[on_key]], prob.vec[IDX[off_key]])
    for on in on_vals:
        for gap in off_fracs:
            vec = prob.vec.copy()
            vec[IDX[on_key]] = on
            vec[IDX[off_key]] = on - gap
            s = prob.score(vec)
            if s > best + 1e-12:
                best, arg = s, (on, on - gap)
    prob.vec[IDX[on_key]], prob.vec[IDX[off_key]] = arg
    return arg


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


def _refine(prob: _Problem, key: str, lo: float, hi: float, step: float, prefer: str,
            limit: tuple[float, float] | None = None) -> tuple[float, np.ndarray, np.ndarray]:
    values = np.arange(lo, hi + step / 2, step)
    if limit is not None:
        values = values[(values >= limit[0]) & (values <= limit[1])]
    if values.size == 0:
        return float(prob.vec[IDX[key]]), values, values
    scores = _scan(prob, key, values)
    x, _ = _pick(values, scores, prefer)
    prob.vec[IDX[key]] = x
    return x, values, scores


def _margin(values: np.ndarray, scores: np.ndarray, x: float, tol: float) -> tuple[float, float]:
    """Contiguous interval around ``x`` whose score is within ``tol`` of the best."""
    if values.size == 0:
        return (x, x)
    best = np.max(scores)
    ok = scores >= best - tol
    i = int(np.argmin(np.abs(values - x)))
    lo = hi = i
    while lo > 0 and ok[lo - 1]:
        lo -= 1
    while hi < values.size - 1 and ok[hi + 1]:
        hi += 1
    return float(values[lo]), float(values[hi])


def fit_rule(obs: np.ndarray, valid: np.ndarray, p_wh: np.ndarray, v: np.ndarray,
             soc: np.ndarray, dt: float, base: dict, *, aux_w: float = 0.0,
             pdis_av: np.ndarray | None = None, tol: float = 0.002, rounds: int = 3,
             max_lag_s: float = 1.0) -> RuleFit:
    """Estimate the engine on/off rule that best reproduces the observed engine state.

    Parameters
    ----------
    obs, valid : ndarray of bool
        Observed engine state and the steps where it (and the demand) is known.
    p_wh : ndarray
        Wheel power demand [W].
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
        Agreement tolerance [share of steps] defining the uncertainty intervals.
    rounds : int
        Coordinate-ascent rounds.

    Returns
    -------
    RuleFit
    """
    obs = np.asarray(obs, bool)
    valid = np.asarray(valid, bool) & np.isfinite(p_wh) & np.isfinite(v)
    prob = _Problem(obs, valid, np.where(np.isfinite(p_wh), p_wh, 0.0), v, soc, dt, base,
                    aux_w, pdis_av)
    notes: list[str] = []
    runs = run_durations(obs, dt, valid)
    boot = {k: bootstrap_quantile(runs[k]) for k in ("on", "off")}
    # ---- initial values from the data
    p_pos = p_wh[valid & (p_wh > 0)]
    v_max = float(np.nanmax(v[valid])) if valid.any() else 30.0
    # top of the power search: above every total demand seen, so "never binding" is a value
    p_hi = (float(np.max(p_pos)) if p_pos.size else 30e3) + aux_w + \
        max(prob.vec[IDX["soc_charge_power_max_w"]], 0.0) + 2000.0
    onsets = np.nonzero(obs[1:] & ~obs[:-1] & valid[1:])[0] + 1
    if onsets.size:
        look = max(1, int(round(1.0 / dt)))
        p_on = np.array([np.nanmax(p_wh[max(0, i - look):i + 1]) for i in onsets])
        prob.vec[IDX["engine_on_power_w"]] = float(np.clip(np.nanquantile(p_on, 0.25), 1e3, p_hi))
    p_grid_hi = p_hi
    for key, b in (("min_on_time_s", boot["on"]), ("min_off_time_s", boot["off"])):
        if b:
            # start short: a long minimum time would mask the thresholds in the first scans
            prob.vec[IDX[key]] = min(max(b["estimate"] - 0.5, 0.0), 2.0)
    # ---- spin-up lag
    lags = np.arange(0, max(1, int(round(max_lag_s / dt))) + 1)
    # ---- coordinate ascent
    p_step = 1000.0
    on_grid = np.arange(1000.0, max(p_hi, 4000.0) + p_step, p_step)
    gaps = np.arange(0.0, 12000.0 + 1, 1000.0)
    v_grid = np.arange(5.0, np.ceil(v_max) + 2.0, 1.0)
    v_gaps = np.arange(0.0, 6.01, 1.0)
    trace = {}
    # joint coarse scan of the two on-thresholds (offs follow at a fixed hysteresis), so the
    # ascent does not start by explaining speed-triggered starts with a power threshold
    best = -1.0
    start = prob.vec.copy()
    for on in np.arange(2000.0, max(p_hi, 4000.0) + 2000.0, 2000.0):
        for vs in v_grid:
            vec = start.copy()
            vec[IDX["engine_on_power_w"]], vec[IDX["engine_off_power_w"]] = on, on - 3000.0
            vec[IDX["engine_on_speed_mps"]], vec[IDX["engine_off_speed_mps"]] = vs, vs - 2.0
            sc = prob.score(vec)
            if sc > best + 1e-12:
                best, prob.vec = sc, vec
    for r in range(rounds):
        ls = np.array([prob.score(prob.vec, lag=int(k)) for k in lags])
        prob.lag = int(lags[int(np.argmax(ls))])
        _scan_pair(prob, "engine_on_power_w", "engine_off_power_w", on_grid, gaps)
        _scan_pair(prob, "engine_on_speed_mps", "engine_off_speed_mps", v_grid, v_gaps)
        _scan_off(prob, np.arange(-6000.0, prob.vec[IDX["engine_on_power_w"]] + 1.0, 1000.0),
                  np.arange(3.0, prob.vec[IDX["engine_on_speed_mps"]] + 0.01, 1.0))
        x = prob.vec
        rmax_on = float(runs["on"].max()) + 2.0 if runs["on"].size else 20.0
        rmax_off = float(runs["off"].max()) + 2.0 if runs["off"].size else 20.0
        _refine(prob, "min_on_time_s", 0.0, min(rmax_on, 30.0), max(dt, 0.5), "high")
        _refine(prob, "min_off_time_s", 0.0, min(rmax_off, 30.0), max(dt, 0.5), "high")
        if r == rounds - 1:
            # fine refinement with margins
            on = x[IDX["engine_on_power_w"]]
            trace["engine_on_power_w"] = _refine(prob, "engine_on_power_w", on - 1500, on + 1500, 100.0,
                                                 "mid", (x[IDX["engine_off_power_w"]], np.inf))
            off = x[IDX["engine_off_power_w"]]
            trace["engine_off_power_w"] = _refine(prob, "engine_off_power_w", off - 1500, off + 1500,
                                                  100.0, "mid", (-np.inf, x[IDX["engine_on_power_w"]]))
            vs = x[IDX["engine_on_speed_mps"]]
            trace["engine_on_speed_mps"] = _refine(prob, "engine_on_speed_mps", vs - 1.5, vs + 1.5, 0.1,
                                                   "mid", (x[IDX["engine_off_speed_mps"]], v_max + 2.0))
            vo = x[IDX["engine_off_speed_mps"]]
            trace["engine_off_speed_mps"] = _refine(prob, "engine_off_speed_mps", vo - 1.5, vo + 1.5, 0.1,
                                                    "mid", (0.5, x[IDX["engine_on_speed_mps"]]))
            mo = x[IDX["min_on_time_s"]]
            trace["min_on_time_s"] = _refine(prob, "min_on_time_s", max(mo - 2.0, 0.0), mo + 2.0, dt, "high")
            mf = x[IDX["min_off_time_s"]]
            trace["min_off_time_s"] = _refine(prob, "min_off_time_s", max(mf - 2.0, 0.0), mf + 2.0, dt, "high")
    params = {k: float(prob.vec[i]) for k, i in IDX.items()}
    rep = prob.replayed()
    agree = agreement(obs, rep, valid)
    # ---- identification and uncertainty
    estimated, bounds, unc = {}, {}, {}
    for key in ESTIMATED:
        _, values, scores = trace[key]
        x = params[key]
        lo, hi = _margin(values, scores, x, tol)
        # a wide margin means the rule did not bind inside the refine window: widen the scan
        unc[key] = {"low": lo, "high": hi, "method": f"classification margin: agreement within "
                    f"{tol:.1%} of the best with the other parameters fixed"}
    # speed: never binding when the whole plateau lies above the speeds driven
    for key in ("engine_on_speed_mps", "engine_off_speed_mps"):
        full = np.arange(0.5, v_max + 2.05, 0.25)
        sc = _scan(prob, key, full)
        lo, hi = _margin(full, sc, params[key], tol)
        unc[key]["low"], unc[key]["high"] = lo, hi
        if hi >= full[-1] - 1e-9:
            bounds[key] = {"low": lo, "high": None,
                           "why": "the rule never switched on speed in this test: any value "
                                  f"above {lo:.1f} m/s reproduces it"}
    for key, b in (("min_on_time_s", boot["on"]), ("min_off_time_s", boot["off"])):
        kind = "on" if key == "min_on_time_s" else "off"
        if b:
            unc[key]["bootstrap_q05_of_runs"] = b
        x = params[key]
        d = runs[kind]
        n_close = int(np.sum((d >= x - 0.5) & (d <= x + 1.5))) if d.size else 0
        if n_close < 2:
            bounds[key] = {"low": None, "high": float(d.min()) if d.size else None,
                           "why": f"fewer than 2 {kind} runs end near the minimum time: the "
                                  f"shortest {kind} run bounds it from above"}
        unc[key]["runs_near_minimum"] = n_close
    full = np.arange(1000.0, p_hi + 1.0, 250.0)
    sc = _scan(prob, "engine_on_power_w", full)
    lo, hi = _margin(full, sc, params["engine_on_power_w"], tol)
    if hi >= full[-1] - 1e-9:
        bounds["engine_on_power_w"] = {
            "low": lo, "high": None, "why": "the rule never switched on power demand in this test: "
            f"any value above {lo:.0f} W reproduces it"}
    for key in ("engine_on_power_w", "engine_off_power_w"):
        lo, hi = unc[key]["low"], unc[key]["high"]
        if hi - lo > 2500.0:
            bounds[key] = {"low": lo, "high": hi, "why": "agreement is flat over a wide range"}
    for key in ESTIMATED:
        for side in ("low", "high"):
            if unc[key].get(side) is not None:
                unc[key][side] = round(float(unc[key][side]), 4)
        if key not in bounds:
            estimated[key] = round(params[key], 4)
    if agree < 0.9:
        notes.append(f"the replayed rule reproduces only {agree:.1%} of the steps: the engine "
                     "state depends on conditions the rule does not see (e.g. warm-up, "
                     "catalyst heating, driver modes) or on an unmeasured demand")
    return RuleFit(params=params, estimated=estimated, bounds=bounds, uncertainty=unc,
                   agreement=agree, lag_s=prob.lag * dt, replayed=rep,
                   runs={k: runs[k].tolist() for k in runs}, notes=notes)
