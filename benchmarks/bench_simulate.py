"""Speed of the forward-looking simulation (vehval.sim) against FASTSim 3.

Rows (see benchmarks/common.py):

* ``simulate_udds_dt0.1`` / ``simulate_udds_dt1``: wall time of one UDDS run of the 2004
  Prius after warm-up (numba compiled and cached), baseline FASTSim 3's Prius on UDDS when
  ``import fastsim`` works (FASTSim ships a 2016 Prius Two only; it is backward-facing with a
  simpler HEV controller, so this compares cost, not physics). Without FASTSim the row
  reports the peer as unavailable.
* ``simulate_batch_1000_udds_dt1``: 1,000 parameter variants over UDDS at dt = 1 s on
  2 workers; target < 20 s.

Run standalone: ``python -m benchmarks.bench_simulate``.
"""

from __future__ import annotations

import json
import time
import warnings

import numpy as np

from benchmarks.common import best_of, row
from vehval.cycles import load_cycle
from vehval.sim.batch import simulate_batch
from vehval.sim.simulate import simulate
from vehval.vehicle import load_vehicle


def _fastsim_udds():
    """A callable running FASTSim 3's Prius on UDDS, or (None, reason)."""
    try:
        import fastsim as fsim
    except Exception as exc:  # noqa: BLE001 - any import failure means "unavailable"
        return None, f"fastsim unavailable ({type(exc).__name__}: {exc})"
    try:
        names = [str(r) for r in fsim.Vehicle.list_resources()]
        prius = next(n for n in names if "prius" in n.lower())
        veh = fsim.Vehicle.from_resource(prius)
        cyc = fsim.Cycle.from_resource("udds.csv")
    except Exception as exc:  # noqa: BLE001
        return None, f"fastsim Prius/UDDS resources unavailable ({exc})"

    def run():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            sd = fsim.SimDrive(veh, cyc)
            (sd.run if hasattr(sd, "run") else sd.walk)()
    return run, f"FASTSim 3 {prius} on udds.csv (1 Hz)"


def run() -> list[dict]:
    veh = load_vehicle("prius_2004")
    cyc = load_cycle("udds")
    simulate(veh, cyc, dt=1.0)  # compile / load the numba cache
    peer, note = _fastsim_udds()
    t_peer = best_of(peer, n=5) if peer is not None else None
    rows = []
    for dt, label in ((0.1, "dt0.1"), (1.0, "dt1")):
        t = best_of(lambda: simulate(veh, cyc, dt=dt), n=5)
        rows.append(row(f"simulate_udds_{label}", t, "s", baseline=t_peer,
                        target=None if t_peer is None else (1.0 if dt == 1.0 else 3.0),  # issue targets
                        note=note + ("" if peer is not None else "; no ratio")))
    variants = [{"controller.soc_gain_w": g, "controller.engine_on_power_w": p}
                for g, p in zip(np.linspace(5e4, 3e5, 1000), np.linspace(6e3, 14e3, 1000))]
    simulate_batch(veh, cyc, variants[:4], dt=1.0, workers=2)  # compile run_batch
    t0 = time.perf_counter()
    simulate_batch(veh, cyc, variants, dt=1.0, workers=2)
    tb = time.perf_counter() - t0
    rows.append(row("simulate_batch_1000_udds_dt1", tb, "s", target=20.0,
                    note="1,000 controller variants, numba prange on 2 threads; target < 20 s"))
    return rows


if __name__ == "__main__":
    for r in run():
        print(json.dumps(r))
