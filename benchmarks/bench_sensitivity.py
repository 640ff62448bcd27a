"""Sensitivity analysis cost, and the cost of the system-level engine operating point.

* ``sensitivity_20params_5cycles_dt1``: the 20 uncertain parameters of the 2004 Prius
  ranked first by a full run, each at both ends, on UDDS, HWFET, US06, Japan 10-15 and NEDC
  at dt = 1 s (5 charge-balanced base runs + 200 variants). Target: under 15 s on 2 cores.
  The note gives the same number of single UDDS simulations run one by one.
* ``simulate_udds_dt0.1_system_op``: one UDDS run at dt = 0.1 s with
  ``controller.operating_point: system``; baseline the same run on the best line; target
  ratio 3.
"""

from __future__ import annotations

import time

from benchmarks.common import best_of, row
from vehval.sim.sensitivity import DEFAULT_CYCLES, sensitivity, uncertain_parameters
from vehval.sim.simulate import simulate
from vehval.vehicle import load_vehicle


def run() -> list[dict]:
    veh = load_vehicle("prius_2004")
    params = [u.key for u in uncertain_parameters(veh) if "scale" not in u.spec][:20]
    sensitivity(veh, ["ece15"], params[:2], dt=1.0)  # compile
    t0 = time.perf_counter()
    res = sensitivity(veh, DEFAULT_CYCLES, params, dt=1.0, workers=2)
    t_sens = time.perf_counter() - t0
    n_runs = len(res["parameters"]) * 2 * len(DEFAULT_CYCLES)
    one = best_of(lambda: simulate(veh, "udds", dt=1.0, soc_initial=0.6), n=3)
    base = {op: best_of(lambda op=op: simulate(veh, "udds", dt=0.1, **{
        "controller.operating_point": op}), n=3) for op in ("best_line", "system")}
    return [
        row("sensitivity_20params_5cycles_dt1", t_sens, "s", target=15.0,
            note=f"{n_runs} variants + 5 balanced base runs (one by one it would take about "
                 f"{one * n_runs:.2f} s: UDDS run x variants)"),
        row("simulate_udds_dt0.1_system_op", base["system"], "s", baseline=base["best_line"],
            target=3.0, note="system-level operating point vs best line, same run"),
    ]
