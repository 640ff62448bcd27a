"""Uncertainty of results: declared channel accuracies propagated through the calculation.

Error model. A channel's declared accuracy (template ``accuracy:``) is a limit of error held
over the whole test: the measured value is ``x (1 + g) + o`` with a gain error ``g`` within
+-``reading_pct`` % and an offset ``o`` within +-(``full_scale_pct`` % of ``full_scale`` +
``offset``). Both are taken as rectangular distributions (GUM 4.3.7: a limit with no stated
confidence), standard uncertainty = limit / sqrt(3). Sample-to-sample noise averages out over
the thousands of samples of a phase and is left out. Fuel properties of the table carry their
batch-to-batch spread the same way. Signals without a declared accuracy get the default of
their class (:data:`DEFAULT_ACCURACY`), flagged ``assumed``.

Propagation. Every result is a function of a small set of phase integrals (distance, fuel
mass, battery energy...) that are linear in ``g`` and ``o``; the results (fuel economy is a
ratio, the FTP-75 weighting is harmonic) are evaluated through that calculation graph for a
vector of parameter sets at once:

* ``first_order``: central differences, one pair per parameter, step = its standard
  uncertainty; u(R)^2 = sum of (c_i u_i)^2 (GUM law of propagation, uncorrelated inputs).
* ``monte_carlo``: N draws of every parameter from its distribution (GUM Supplement 1);
  u(R) = standard deviation, and the 2.5-97.5 % interval of the draws.

The expanded uncertainty is U = k u(R) with k = 2 (about 95 %). Contributors are the shares
(c_i u_i)^2 / u(R)^2 of the first-order budget.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from vehval.uncertainty.sensors import ChannelAccuracy, Parameter, channel_accuracy, sensor_defaults

__all__ = [
    "COVERAGE_K",
    "DEFAULT_ACCURACY",
    "MIN_DRAWS",
    "SOURCE_ACCURACY",
    "ChannelAccuracy",
    "Parameter",
    "channel_accuracy",
    "propagate",
]

#: Coverage factor of the expanded uncertainty.
COVERAGE_K = 2.0
#: Fewest Monte Carlo draws: the standard deviation of n draws is itself uncertain by about
#: 1 / sqrt(2 (n - 1)) of its value (7 % at 100 draws, 71 % at 2) and the 95 % interval's
#: ends rest on the 2.5 % of draws beyond each (none below 40 draws).
MIN_DRAWS = 100
_SQRT3 = math.sqrt(3.0)

#: Default accuracy per signal class (base name): reading [%], offset [SI unit], and why;
#: defaults of a class measured by a given source (base name, source) are looked up first (an
#: OBD speed is no roll speed); a base in neither gets the fallback (1 % of reading). The
#: table and its sources: data/uncertainty/sensor_accuracy.yaml.
DEFAULT_ACCURACY, SOURCE_ACCURACY, FALLBACK_ACCURACY = sensor_defaults()


def _summary(values: np.ndarray, nominal: float) -> tuple[float, float]:
    return float(nominal), float(np.std(values, ddof=1))


def propagate(evaluate: Callable[[dict[str, np.ndarray]], dict[str, np.ndarray]],
              params: list[Parameter], *, method: str = "first_order", draws: int = 1000,
              seed: int = 0, top: int = 3) -> tuple[dict[str, float], dict[str, dict]]:
    """Nominal results and their uncertainty.

    Parameters
    ----------
    evaluate : callable
        Maps parameter arrays (name -> shape (n,) errors) to result arrays (key -> (n,)).
    params : list of Parameter
    method : {'first_order', 'monte_carlo'}
    draws : int
        Monte Carlo draws.
    seed : int
        Seed of the Monte Carlo generator (reproducible results).
    top : int
        Contributors listed per result.

    Returns
    -------
    nominal : dict
        Result key -> value.
    uncertainty : dict
        Result key -> ``{"U": k u, "k": 2, "u": u, "method", "contributors": [{"parameter",
        "share", "assumed"}], "interval_95": [lo, hi] (Monte Carlo only)}``; ``method`` is
        what the entry's U comes from: ``monte_carlo`` only where the draws gave it (a
        result without a parameter to draw keeps ``first_order``).

    Raises
    ------
    ConfigError
        A Monte Carlo of fewer than :data:`MIN_DRAWS` draws.
    """
    if method not in ("first_order", "monte_carlo"):
        from vehval.errors import VehvalError
        raise VehvalError(f"uncertainty method '{method}': use first_order or monte_carlo")
    if method == "monte_carlo" and not draws >= MIN_DRAWS:
        from vehval.errors import ConfigError
        raise ConfigError(f"{draws} Monte Carlo draws: at least {MIN_DRAWS} are needed (the "
                          "standard deviation of n draws is uncertain by 1/sqrt(2(n-1)) of its "
                          "value: 7 % at 100 draws); ask for more draws or first-order "
                          "propagation")
    m = len(params)
    n = 1 + 2 * m
    theta = {p.name: np.zeros(n) for p in params}
    for i, p in enumerate(params):
        theta[p.name][1 + 2 * i] = p.std
        theta[p.name][2 + 2 * i] = -p.std
    res = evaluate(theta)
    nominal = {k: float(v[0]) for k, v in res.items()}
    unc: dict[str, dict] = {}
    for key, v in res.items():
        if not math.isfinite(nominal[key]):
            continue
        ci = np.array([(v[1 + 2 * i] - v[2 + 2 * i]) / 2.0 for i in range(m)]) if m else np.zeros(0)
        ci = np.where(np.isfinite(ci), ci, 0.0)
        var = float(np.sum(ci ** 2))
        u = math.sqrt(var)
        order: list[int] = [int(j) for j in np.argsort(-ci ** 2)[:top]] if m else []
        contrib = [{"parameter": params[j].name, "share": round(float(ci[j] ** 2 / var), 4),
                    "assumed": params[j].assumed} for j in order if var > 0 and ci[j] != 0]
        unc[key] = {"u": u, "U": COVERAGE_K * u, "k": COVERAGE_K, "method": "first_order",
                    "contributors": contrib}
    if method == "monte_carlo" and m:
        from vehval.sim.budget import check_samples

        # the draws, the result arrays and their per-scope intermediates
        check_samples(draws, m + 3 * len(res) + 16, f"{draws} Monte Carlo draws",
                      "ask for fewer draws (--monte-carlo)")
        rng = np.random.default_rng(seed)
        draw = {p.name: rng.uniform(-p.limit, p.limit, draws) for p in params}
        mc = evaluate(draw)
        for key, v in mc.items():
            if key not in unc:
                continue
            ok = v[np.isfinite(v)]
            if ok.size < 2:
                continue
            u = float(np.std(ok, ddof=1))
            lo, hi = np.percentile(ok, [2.5, 97.5])
            unc[key].update(u=u, U=COVERAGE_K * u, interval_95=[float(lo), float(hi)],
                            draws=int(draws), method="monte_carlo")
    return nominal, unc
