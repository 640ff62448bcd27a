"""Engine fuel map from measured fuel flow: a smooth Willans surface with idle and fuel cut.

Engine power is rebuilt from the roller force plus the driveline drag ``F_d = A_d + B_d v``
(the car's own losses on the rollers that the measured force leaves out; see
:func:`vehval.identify.build.identify_conventional` for how much of them): pump torque =
gearbox input torque ``T_in = (F + F_d) r / (i η)`` (driving; ``(F + F_d) r η / i``
overrun; torque ratio 1 in the converter), ``P_e = T_in ω_e + P_acc + J_e ω_e dω_e/dt``. Every sample is one of three states:

- standing (speed < 0.05 m/s): fuel = idle fuel rate (a constant);
- overrun (``P_e <= 0`` and ``ω_e`` >= the fuel-cut speed): fuel = residual overrun rate;
- fired: fuel = c0 + c1 ω + c2 ω² + (d0 + d1 ω) P + e P²  (Willans lines whose intercept
  and slope vary smoothly with speed, plus a curvature term).

The surface is constrained to be physical over the engine's speed range (half the idle
speed to the maximum speed), where it is used beyond the data too: the zero-power fuel
``c0 + c1 ω + c2 ω²`` (friction and pumping) does not fall with speed, and the fuel per
unit of power ``d0 + d1 ω`` is at least ``1 / (ETA_MAX · LHV)``: no engine turns fuel into
added power more efficiently than ``ETA_MAX`` (0.5, above any road engine's indicated
efficiency). A least-squares surface fitted on a few cycles can break both where the data
are thin (fitted on the UDDS and the US06, the Cruze's marginal fuel fell to the equivalent
of 72 % efficiency at 4400 rpm and its friction fuel rose to 4.9 g/s); the bounds are
met by a bounded least squares in an equivalent parametrisation (the slope of the
zero-power fuel and the fuel per power at both ends of the speed range), so the form and
the stored coefficients are unchanged.

The fuel meter (modal bench) is slow: the measured rate is the true rate delayed by ``d``
and smoothed by a first-order lag ``τ``. Both are identified: every regressor column goes
through the same delay and lag, so the model stays linear in its coefficients, and
(d, τ) and the fuel-cut speed are chosen on a grid by the best R².
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import lsq_linear
from scipy.signal import lfilter

from vehval.constants import RPM_RAD_PER_S
from vehval.identify.traces import IdentificationError, Trace, smooth

STANDING_MPS = 0.05
DELAYS_S = np.round(np.arange(0.0, 4.01, 0.2), 2)
TAUS_S = (0.0, 0.5, 1.0, 1.5, 2.0, 3.0)
W_SCALE = 100.0    # [rad/s] regressors scaled for conditioning
P_SCALE = 1e4      # [W]
MIN_FIRED_S = 300.0  # [s] of fired driving needed to fit the surface
ETA_MAX = 0.5      # bound of the marginal (indicated) efficiency of the surface (module doc)


@dataclass
class FuelMapFit:
    """Coefficients (SI: kg/s, rad/s, W), meter dynamics, fuel-cut speed and fit quality."""

    willans: dict[str, float]
    idle_fuel_kg_s: float
    overrun_fuel_kg_s: float
    fuel_cut_speed_rad_s: float
    delay_s: float
    tau_s: float
    r2: float
    r2_5s: float
    total_error_rel: dict[str, float]
    n_fired: int
    power_range_w: tuple[float, float]
    speed_range_rad_s: tuple[float, float]
    points: dict[str, np.ndarray]
    uncertainty: dict = field(default_factory=dict)

    def rate(self, w: np.ndarray, p: np.ndarray) -> np.ndarray:
        """Fired fuel rate [kg/s] at engine speed [rad/s] and power [W] (>= 0)."""
        c = self.willans
        return np.maximum(c["c0"] + c["c1"] * w + c["c2"] * w * w + (c["d0"] + c["d1"] * w) * p
                          + c["e"] * p * p, 0.0)

    def to_dict(self) -> dict:
        return {"willans": self.willans, "idle_fuel_g_per_s": 1e3 * self.idle_fuel_kg_s,
                "overrun_fuel_g_per_s": 1e3 * self.overrun_fuel_kg_s,
                "fuel_cut_speed_rpm": self.fuel_cut_speed_rad_s / RPM_RAD_PER_S,
                "meter_delay_s": self.delay_s, "meter_tau_s": self.tau_s, "r2": self.r2,
                "r2_5s_means": self.r2_5s, "total_error_rel": self.total_error_rel,
                "n_fired": self.n_fired, "power_range_w": list(self.power_range_w),
                "speed_range_rad_s": list(self.speed_range_rad_s),
                "uncertainty": self.uncertainty}


def engine_power(tr: Trace, gear: np.ndarray, ratios: np.ndarray, wheel_radius_m: float,
                 efficiency: float, lag_s: float, acc_w: float, j_eng: float,
                 drag: tuple[float, float] = (0.0, 0.0)) -> np.ndarray:
    """Engine brake power [W] rebuilt from roller force and engine speed (see module doc);
    ``drag`` = (A_d [N], B_d [N/(m/s)]), applied while the car moves."""
    f = np.interp(tr.t + lag_s, tr.t, tr.force)
    f = f + np.where(tr.v >= STANDING_MPS, drag[0] + drag[1] * tr.v, 0.0)
    r = ratios[np.maximum(gear, 1) - 1]
    t_in = np.where(f >= 0, f * wheel_radius_m / (r * efficiency), f * wheel_radius_m * efficiency / r)
    t_in = np.where(gear > 0, t_in, 0.0)
    dw = np.gradient(smooth(tr.w_eng, 5), tr.dt)
    return t_in * tr.w_eng + acc_w + j_eng * tr.w_eng * dw


def _meter(x: np.ndarray, dt: float, delay_s: float, tau_s: float) -> np.ndarray:
    """Columns of ``x`` through a first-order lag ``tau_s`` then a delay ``delay_s``."""
    y = x.copy()
    if tau_s > 0:
        a = dt / (tau_s + dt)
        y = lfilter([a], [1.0, a - 1.0], x, axis=0, zi=(1 - a) * x[:1])[0]
    k = round(delay_s / dt)
    if k:
        y = np.vstack([np.repeat(y[:1], k, axis=0), y[:-k]])
    return y


def _columns(w, p, standing, overrun, fired):
    ws = w / W_SCALE
    ps = np.maximum(p, 0.0) / P_SCALE  # the engine's map starts at zero torque
    f = fired.astype(float)
    return np.column_stack([f, f * ws, f * ws * ws, f * ps, f * ps * ws,
                            overrun.astype(float), standing.astype(float)])


def _unscale(th) -> dict[str, float]:
    return {"c0": th[0], "c1": th[1] / W_SCALE, "c2": th[2] / W_SCALE ** 2,
            "d0": th[3] / P_SCALE, "d1": th[4] / (P_SCALE * W_SCALE), "e": 0.0}


def fit_fuel_map(traces: list[Trace], powers: list[np.ndarray], idle_rad_s: float,
                 meter: tuple[float, float] | None = None,
                 cut_rad_s: float | None = None, block_s: float | None = None,
                 max_speed_rad_s: float | None = None,
                 lhv_j_per_kg: float | None = None) -> FuelMapFit:
    """Fit the fuel model on ``traces`` with rebuilt engine ``powers`` [W] (see module doc).

    ``meter`` (delay [s], lag [s]) and ``cut_rad_s`` (fuel-cut speed) are searched on their
    grids unless given. The coefficients are least squares of the 10 Hz samples, or with
    ``block_s`` [s] of the fuel of consecutive blocks that long (:func:`_solve_blocks`; the
    meter and cut searches stay on the samples). The final coefficients meet the bounds of
    the module doc from ``0.5 idle_rad_s`` to ``max_speed_rad_s`` [rad/s] (default 1.1 x the
    highest measured engine speed), with ``lhv_j_per_kg`` (default the test fuel's; without
    one the fuel per power is only bounded at 0).
    """
    on = [tr.w_eng > 0.5 * idle_rad_s for tr in traces]
    fired_s = sum(float(np.count_nonzero(o & (tr.v > STANDING_MPS) & (p > 0)) * tr.dt)
                  for tr, p, o in zip(traces, powers, on))
    if fired_s < MIN_FIRED_S:
        raise IdentificationError(
            f"fuel map: only {fired_s:.0f} s of driving with the engine pulling in "
            f"{', '.join(t.test_id for t in traces)}; the map needs at least {MIN_FIRED_S:.0f} s "
            "(give a longer test or a second one)")

    cache: dict = {}

    def design(cut, delay, tau):
        key = (float(cut), float(tau))
        if key not in cache:
            cols = []
            for tr, p, o in zip(traces, powers, on):
                standing = o & (tr.v < STANDING_MPS)
                moving = o & ~standing
                overrun = moving & (p <= 0) & (tr.w_eng >= cut)
                fired = moving & ~overrun
                cols.append(_meter(_columns(tr.w_eng, p, standing, overrun, fired), tr.dt,
                                   0.0, tau))
            cache.clear()
            cache[key] = cols
        xs = [_meter(x, tr.dt, delay, 0.0) for x, tr in zip(cache[key], traces)]
        return xs, [tr.fuel for tr in traces], on

    def solve(cut, delay, tau):
        xs, ys, masks = design(cut, delay, tau)
        x = np.vstack([a[m] for a, m in zip(xs, masks)])
        y = np.concatenate([b[m] for b, m in zip(ys, masks)])
        # einsum, not BLAS: a threaded BLAS spin-waits on a loaded machine (10x slower here)
        xtx = np.einsum("ij,ik->jk", x, x)
        th = np.linalg.solve(xtx + 1e-12 * np.eye(x.shape[1]), np.einsum("ij,i->j", x, y))
        r = y - np.einsum("ij,j->i", x, th)
        return th, float(1 - np.sum(r * r) / np.sum((y - y.mean()) ** 2))

    cut0 = idle_rad_s * 1.3 if cut_rad_s is None else cut_rad_s
    if meter is None:  # delays on a 0.4 s grid for every lag, then the 0.2 s neighbours
        coarse = max(((d, t) for t in TAUS_S for d in DELAYS_S[::2]),
                     key=lambda dt_: solve(cut0, *dt_)[1])
        fine = [(d, coarse[1]) for d in DELAYS_S if abs(d - coarse[0]) < 0.25]
        best = max(fine, key=lambda dt_: solve(cut0, *dt_)[1])
    else:
        best = meter
    cuts = idle_rad_s * np.arange(1.05, 2.01, 0.05)
    cut = cut_rad_s or max(cuts, key=lambda c: solve(c, *best)[1])
    xs, ys, masks = design(cut, *best)
    if lhv_j_per_kg is None and traces[0].test_fuel is not None:
        lhv_j_per_kg = traces[0].test_fuel.lhv_j_per_kg
    w_hi = max_speed_rad_s or 1.1 * float(max(tr.w_eng.max() for tr in traces))
    th = _solve_blocks(xs, ys, masks, max(round(block_s / traces[0].dt), 1) if block_s else 1,
                       (0.5 * idle_rad_s, max(w_hi, idle_rad_s)), lhv_j_per_kg)
    r = np.concatenate([b[m] - a[m] @ th for a, b, m in zip(xs, ys, masks)])
    yy = np.concatenate([b[m] for b, m in zip(ys, masks)])
    r2 = float(1 - np.sum(r * r) / np.sum((yy - yy.mean()) ** 2))
    unc = _uncertainty(traces, xs, ys, masks, th)
    err, means_m, means_p = {}, [], []
    for tr, x, y, m in zip(traces, xs, ys, masks):
        pred = x @ th
        err[tr.test_id] = float((pred.sum() - y.sum()) / y.sum())
        n5 = round(5.0 / tr.dt)
        k = (y.size // n5) * n5
        means_m.append(y[:k].reshape(-1, n5).mean(axis=1))
        means_p.append(pred[:k].reshape(-1, n5).mean(axis=1))
    mm, mp = np.concatenate(means_m), np.concatenate(means_p)
    r2_5 = float(1 - np.sum((mm - mp) ** 2) / np.sum((mm - mm.mean()) ** 2))
    fired_w = np.concatenate([tr.w_eng[(p > 0) & (tr.v > STANDING_MPS)]
                              for tr, p in zip(traces, powers)])
    fired_p = np.concatenate([p[(p > 0) & (tr.v > STANDING_MPS)] for tr, p in zip(traces, powers)])
    k = round(best[0] / traces[0].dt)
    pts_f = np.concatenate([np.r_[tr.fuel[k:], np.full(k, np.nan)][(p > 0) & (tr.v > STANDING_MPS)]
                            for tr, p in zip(traces, powers)])
    return FuelMapFit(willans={k_: float(v) for k_, v in _unscale(th).items()},
                      idle_fuel_kg_s=float(th[6]), overrun_fuel_kg_s=float(max(th[5], 0.0)),
                      fuel_cut_speed_rad_s=float(cut), delay_s=float(best[0]),
                      tau_s=float(best[1]), r2=r2, r2_5s=r2_5, total_error_rel=err,
                      n_fired=int(fired_w.size),
                      power_range_w=(float(fired_p.min()), float(np.percentile(fired_p, 99.5))),
                      speed_range_rad_s=(float(fired_w.min()), float(fired_w.max())),
                      points={"w": fired_w, "p": fired_p, "fuel": pts_f}, uncertainty=unc)


def _solve_blocks(xs, ys, masks, n: int, speeds: tuple[float, float] | None = None,
                  lhv_j_per_kg: float | None = None) -> np.ndarray:
    """Least squares of the fuel of consecutive ``n``-sample blocks of each test (``n`` = 1:
    of the samples), bounded as in the module doc over ``speeds`` [rad/s] when given.

    The meter model (delay, lag) catches the bulk of the bench's dynamics, not all of it
    (dispersion, a delay varying with the exhaust flow): fitted sample by sample, a timing
    residual weighs on the transients and biases a surface fitted on transient cycles
    against one fitted on smooth ones. Over blocks several times the meter's delay the
    timing error is an edge effect; the fitted quantity is the fuel mass, what a
    prediction is judged on. On the Cruze's ten-pair cross-validation (5 s blocks) it
    lowers the mean |error|, but the intervals' coverage falls below 90 %, so it is not the
    default (docs/identification.md, "What limits accuracy").
    """
    xb, yb = [], []
    for a, b, m in zip(xs, ys, masks):
        if n == 1:
            xb.append(a[m])
            yb.append(b[m])
            continue
        k = (b.size // n) * n
        xb.append((a * m[:, None])[:k].reshape(-1, n, a.shape[1]).sum(axis=1))
        yb.append((b * m)[:k].reshape(-1, n).sum(axis=1))
    x, y = np.vstack(xb), np.concatenate(yb)
    xtx = np.einsum("ij,ik->jk", x, x) + 1e-12 * np.eye(x.shape[1])
    xty = np.einsum("ij,i->j", x, y)
    if speeds is None:
        return np.linalg.solve(xtx, xty)
    return _bounded(xtx, xty, speeds, lhv_j_per_kg)


def _bounded(xtx: np.ndarray, xty: np.ndarray, speeds: tuple[float, float],
             lhv_j_per_kg: float | None) -> np.ndarray:
    """The scaled coefficients minimising the squares ``th' xtx th - 2 xty' th`` under the
    bounds of the module doc, over engine speeds ``speeds`` [rad/s].

    Parametrisation ``th = M phi``, phi = (c0, slope of the zero-power fuel at the low and
    the high speed, fuel per power at the low and the high speed, overrun, idle): the
    zero-power fuel is quadratic in speed, so its slope is linear and is >= 0 over the range
    when it is at both ends; the fuel per power is linear in speed likewise.
    """
    lo, hi = speeds[0] / W_SCALE, speeds[1] / W_SCALE
    d = hi - lo
    m = np.eye(7)
    m[1, 1:3] = (1 + lo / d, -lo / d)          # c1 from the slopes g_lo, g_hi
    m[2, 1:3] = (-0.5 / d, 0.5 / d)            # c2
    m[3, 3:5] = (1 + lo / d, -lo / d)          # d0 from the fuel per power s_lo, s_hi
    m[4, 3:5] = (-1 / d, 1 / d)                # d1
    h, q = m.T @ xtx @ m, m.T @ xty
    s_min = P_SCALE / (ETA_MAX * lhv_j_per_kg) if lhv_j_per_kg else 0.0
    lb = np.array([-np.inf, 0.0, 0.0, s_min, s_min, -np.inf, -np.inf])
    phi = np.linalg.solve(h, q)
    if np.all(phi >= lb):
        return m @ phi
    # bounded least squares on the Cholesky factor, columns scaled to unit diagonal, in g/s
    sc = 1.0 / np.sqrt(np.diag(h))
    hs = h * np.outer(sc, sc)
    chol = np.linalg.cholesky(hs)
    rhs = np.linalg.solve(chol, 1e3 * q * sc)
    res = lsq_linear(chol.T, rhs, bounds=(1e3 * lb / sc, np.inf), method="bvls")
    return m @ (res.x * sc / 1e3)


def _uncertainty(traces, xs, ys, masks, th, block_s: float = 5.0) -> dict:
    """What a prediction's interval needs (see :mod:`vehval.identify.uncertainty`): the
    covariance of the scaled coefficients (sandwich over ``block_s`` blocks, so serially
    correlated 10 Hz residuals count once per block), the variance of the residual fuel of
    one block [kg²], and the relative fuel errors of every phase of the identification tests
    on their measured operating points."""
    x = np.vstack([a[m] for a, m in zip(xs, masks)])
    y = np.concatenate([b[m] for b, m in zip(ys, masks)])
    dt = traces[0].dt
    r = y - x @ th
    n = max(round(block_s / dt), 1)
    k = (r.size // n) * n
    g = (x[:k] * r[:k, None]).reshape(-1, n, x.shape[1]).sum(axis=1)
    inv = np.linalg.inv(x.T @ x + 1e-12 * np.eye(x.shape[1]))
    cov = inv @ (g.T @ g) @ inv
    rb = r[:k].reshape(-1, n).sum(axis=1) * dt
    phase_err: dict = {}
    for tr, xa, ya, m in zip(traces, xs, ys, masks):
        pred, rows = xa @ th, {}
        for ph in np.unique(tr.phase[tr.phase > 0]):
            sel = m & (tr.phase == ph)
            if ya[sel].sum() > 0:
                rows[str(int(ph))] = float(pred[sel].sum() / ya[sel].sum() - 1)
        phase_err[tr.test_id] = rows
    flat = [v for rows in phase_err.values() for v in rows.values()]
    return {"theta_cov_scaled": cov.tolist(), "block_s": block_s,
            "block_var_kg2": float(np.var(rb)), "phase_errors": phase_err,
            "phase_error_rms": float(np.sqrt(np.mean(np.square(flat)))) if flat else 0.0,
            "w_scale": W_SCALE, "p_scale": P_SCALE}
