"""Model uncertainty of one predicted figure (:mod:`vehval.sim.model_uncertainty`).

* ``model_uncertainty_udds_mc200_dt1``: U (k = 2) of the 2004 Prius's SOC-corrected UDDS
  fuel economy by Monte Carlo, 200 joint draws of its scalar parameter ranges (maps by
  their linearised contribution), dt = 1 s, kernel compiled beforehand. Baseline: the same
  200 draws as single UDDS simulations (``simulate`` of the vehicle with each draw's
  overrides) in a plain Python loop, same step and initial SOC, measured in the same run;
  target ratio <= 1.5 (the figure also runs the charge-balanced base and two runs per map,
  which the loop does not). ``..._seconds``: the same time against the goal of 2 s.
* ``model_uncertainty_udds_linear_dt1``: the same figure by the linearisation (two runs per
  parameter); baseline the same plain loop of as many single runs.
"""

from __future__ import annotations

import time

import numpy as np

from benchmarks.common import row
from vehval.sim.model_uncertainty import figure_uncertainty
from vehval.sim.sensitivity import _draw, uncertain_parameters
from vehval.sim.simulate import simulate
from vehval.vehicle import load_vehicle

DRAWS = 200


def _loop(veh, n: int) -> float:
    """The plain way: ``n`` joint draws, one ``simulate`` each."""
    rng = np.random.default_rng(0)
    unc = [u for u in uncertain_parameters(veh) if "scale" not in u.spec]
    draws = [{u.key: _draw(u, rng) for u in unc} for _ in range(n)]
    soc0 = simulate(veh, "udds", dt=1.0, charge_balance=True).summary["soc_initial"]
    t0 = time.perf_counter()
    for d in draws:
        simulate(veh.with_overrides(d), "udds", dt=1.0, soc_initial=soc0)
    return time.perf_counter() - t0


def run() -> list[dict]:
    veh = load_vehicle("prius_2004")
    figure_uncertainty(veh, "ece15", method="monte_carlo", draws=100)  # compile
    t0 = time.perf_counter()
    mc = figure_uncertainty(veh, "udds", method="monte_carlo", draws=DRAWS)
    t_mc = time.perf_counter() - t0
    t0 = time.perf_counter()
    lin = figure_uncertainty(veh, "udds", method="linear")
    t_lin = time.perf_counter() - t0
    n_lin = 2 * len(uncertain_parameters(veh))
    base_mc = _loop(veh, DRAWS)
    base_lin = base_mc * n_lin / DRAWS
    return [
        row(f"model_uncertainty_udds_mc{DRAWS}_dt1", t_mc, "s", baseline=base_mc, target=1.5,
            note=f"U = {100 * mc.u_rel:.2f} % (sampling error {100 * mc.sampling_error_rel:.0f} "
                 f"% of U); baseline the {DRAWS} draws as single UDDS runs in a loop"),
        row(f"model_uncertainty_udds_mc{DRAWS}_dt1_seconds", t_mc, "s", target=2.0,
            note="the same run against the goal of 2 s"),
        row("model_uncertainty_udds_linear_dt1", t_lin, "s", baseline=base_lin,
            note=f"U = {100 * lin.u_rel:.2f} %, {n_lin} runs; baseline as many single runs "
                 f"(scaled from the loop of {DRAWS})"),
    ]
