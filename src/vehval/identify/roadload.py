"""Road load from the test: F = A + B v + C v^2 + m_eff a, fitted on measured tractive force.

On a chassis dynamometer the roller force is what the dyno applies to simulate the road:
its road-load curve plus the test inertia times the acceleration. A least-squares fit on
every moving sample (speed above ``min_speed``) gives A, B, C and the effective inertia
mass. Confidence intervals are 95 % intervals from the OLS covariance, widened for the
serial correlation of the residuals (effective sample count n (1 - rho) / (1 + rho), rho the
lag-1 autocorrelation), since 10 Hz samples are far from independent.

The dyno force and the speed are not sampled at exactly the same instant (the force is
filtered by the load cell and the controller): a time lag of the force, scanned over
±1 s in 0.05 s steps, is identified with the coefficients (the best R^2). Without it the
coefficients are biased (inertia force at the wrong time leaks into A, B and C).

The coefficients are those the car must meet at the roller (dyno *set* coefficients, the
vehicle's own losses on the rollers excluded), so A may come out negative.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from vehval.identify.traces import IdentificationError, Trace

MIN_SPEED_MPS = 1.0  # [m/s] samples slower than this carry no road-load information
NAMES = ("road_load_a_n", "road_load_b_n_per_mps", "road_load_c_n_per_mps2", "mass_kg")


@dataclass
class RoadLoadFit:
    """Fitted coefficients, their 95 % half-widths and the fit quality."""

    values: dict[str, float]
    ci95: dict[str, float]
    r2: float
    rmse_n: float
    n_samples: int
    n_effective: float
    tests: list[str]
    template: dict[str, float] = field(default_factory=dict)
    lag_s: float = 0.0

    def force(self, v: np.ndarray, a: np.ndarray) -> np.ndarray:
        """Predicted tractive force [N] at speed [m/s] and acceleration [m/s^2]."""
        x = self.values
        return (x["road_load_a_n"] + x["road_load_b_n_per_mps"] * v
                + x["road_load_c_n_per_mps2"] * v * v + x["mass_kg"] * a)

    def to_dict(self) -> dict:
        return {"values": self.values, "ci95": self.ci95, "r2": self.r2, "rmse_n": self.rmse_n,
                "n_samples": self.n_samples, "n_effective": self.n_effective,
                "tests": self.tests, "template": self.template, "lag_s": self.lag_s}


def _design(v: np.ndarray, a: np.ndarray) -> np.ndarray:
    return np.column_stack([np.ones_like(v), v, v * v, a])


def force_at_lag(trace: Trace, lag_s: float) -> np.ndarray:
    """Measured force [N] taken ``lag_s`` [s] later (aligned with speed and acceleration)."""
    return np.interp(trace.t + lag_s, trace.t, trace.force)


def _solve(traces, lag_s, min_speed):
    xs, ys = [], []
    for tr in traces:
        m = tr.v > min_speed
        xs.append(_design(tr.v[m], tr.a[m]))
        ys.append(force_at_lag(tr, lag_s)[m])
    x = np.vstack(xs)
    y = np.concatenate(ys)
    if y.size < 50:
        raise IdentificationError(f"road load: only {y.size} moving samples in "
                                  f"{', '.join(t.test_id for t in traces)}; give a driven test")
    # normal equations by einsum (no threaded BLAS: it spin-waits on a loaded machine)
    theta = np.linalg.solve(np.einsum("ij,ik->jk", x, x), np.einsum("ij,i->j", x, y))
    r = y - np.einsum("ij,j->i", x, theta)
    return x, y, xs, ys, theta, float(1 - np.sum(r * r) / np.sum((y - y.mean()) ** 2))


def fit_road_load(traces: list[Trace], min_speed: float = MIN_SPEED_MPS) -> RoadLoadFit:
    """Least-squares road load, effective mass and force lag over the moving samples."""
    lags = np.round(np.arange(-1.0, 1.0001, 0.05), 2)
    best = max(lags, key=lambda lag: _solve(traces, lag, min_speed)[5])
    x, y, xs, ys, theta, r2 = _solve(traces, float(best), min_speed)
    r = y - x @ theta
    n, p = x.shape
    res_rho = []
    for xi, yi in zip(xs, ys):
        ri = yi - xi @ theta
        if ri.size > 2:
            res_rho.append(float(np.corrcoef(ri[:-1], ri[1:])[0, 1]))
    rho = min(max(float(np.mean(res_rho)) if res_rho else 0.0, 0.0), 0.999)
    n_eff = max(n * (1 - rho) / (1 + rho), p + 1.0)
    s2 = float(np.sum(r * r)) / (n - p)
    cov = s2 * np.linalg.inv(x.T @ x) * (n / n_eff)
    half = 1.96 * np.sqrt(np.diag(cov))
    tpl = {}
    c = traces[0].constants
    for k in NAMES[:3]:
        if c.get(k) is not None:
            tpl[k] = float(c[k])
    if c.get("test_mass_kg") is not None:
        tpl["mass_kg"] = float(c["test_mass_kg"])
    return RoadLoadFit(values={k: float(v) for k, v in zip(NAMES, theta)},
                       ci95={k: float(h) for k, h in zip(NAMES, half)}, r2=r2,
                       rmse_n=float(np.sqrt(np.mean(r * r))), n_samples=int(n),
                       n_effective=float(n_eff), tests=[t.test_id for t in traces], template=tpl,
                       lag_s=float(best))


def check_road_load(fit: RoadLoadFit, trace: Trace, min_speed: float = MIN_SPEED_MPS) -> dict:
    """How the fitted road load reproduces the measured force of ``trace``.

    Returns ``r2`` [-], ``mean_offset_n`` (mean measured - predicted) [N], ``rmse_n`` [N].
    """
    m = trace.v > min_speed
    y = force_at_lag(trace, fit.lag_s)[m]
    r = y - fit.force(trace.v[m], trace.a[m])
    return {"test": trace.test_id, "r2": float(1 - np.sum(r * r) / np.sum((y - y.mean()) ** 2)),
            "mean_offset_n": float(r.mean()), "rmse_n": float(np.sqrt(np.mean(r * r)))}
