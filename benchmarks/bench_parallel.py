"""Speed of the parallel-hybrid kernel (vehval.sim.parallel_kernel) against the power-split one.

Row ``simulate_parallel_udds_dt1``: wall time of one UDDS run of the 2000 Insight at dt = 1 s
after warm-up (numba compiled and cached), baseline the 2004 Prius's power-split run over
the same cycle and step in the same process; target: within 2x the power-split kernel's time.

Run standalone: ``python -m benchmarks.bench_parallel``.
"""

from __future__ import annotations

import json

from benchmarks.common import best_of, row
from vehval.cycles import load_cycle
from vehval.sim.simulate import simulate
from vehval.vehicle import load_vehicle


def run() -> list[dict]:
    cyc = load_cycle("udds")
    ins, prius = load_vehicle("insight_2000"), load_vehicle("prius_2004")
    simulate(ins, cyc, dt=1.0)  # compile / load the numba caches
    simulate(prius, cyc, dt=1.0)
    t_ps = best_of(lambda: simulate(prius, cyc, dt=1.0), n=7)
    t_par = best_of(lambda: simulate(ins, cyc, dt=1.0), n=7)
    return [row("simulate_parallel_udds_dt1", t_par, "s", baseline=t_ps, target=2.0 * t_ps,
                note="2000 Insight (parallel hybrid) vs the 2004 Prius (power-split), UDDS at "
                     "dt = 1 s, same run; target within 2x the power-split time")]


if __name__ == "__main__":
    for r in run():
        print(json.dumps(r))
