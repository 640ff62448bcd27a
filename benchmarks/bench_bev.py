"""Speed of the battery-electric kernel against the power-split kernel, and FASTSim 3's BEV.

Rows (see benchmarks/common.py):

* ``simulate_bev_udds_dt1``: wall time of one UDDS run at dt = 1 s of the shipped 2016 Leaf
  (``bev/nissan_leaf_2016``) after warm-up, baseline the 2004 Prius (power-split kernel) on
  the same cycle and step in the same run; target ratio <= 2 (issue 41).
* ``fastsim_leaf_udds_mpge``: when ``import fastsim`` works, FASTSim 3's packaged 2016 Leaf
  on UDDS side by side with ours (unadjusted MPGe on AC energy; FASTSim's charger
  efficiency 0.86); without FASTSim the row says so and the issue's measurement stands
  (docs/validation.md).

Run standalone: ``python -m benchmarks.bench_bev``.
"""

from __future__ import annotations

import json

from benchmarks.common import best_of, row
from vehval.cycles import load_cycle
from vehval.sim.simulate import simulate
from vehval.vehicle import load_vehicle


def _fastsim_leaf() -> tuple[float | None, str]:
    """FASTSim 3's 2016 Leaf on UDDS: (MPGe on AC energy, note) or (None, reason)."""
    try:
        import fastsim as fsim
    except Exception as exc:  # noqa: BLE001 - any import failure means "unavailable"
        return None, f"fastsim unavailable ({type(exc).__name__}: {exc})"
    try:
        names = [str(r) for r in fsim.Vehicle.list_resources()]
        leaf = next(n for n in names if "leaf" in n.lower())
        sd = fsim.SimDrive(fsim.Vehicle.from_resource(leaf), fsim.Cycle.from_resource("udds.csv"))
        (sd.run if hasattr(sd, "run") else sd.walk)()
        d = sd.to_pydict()
        ess = d["veh"]["pt_type"]["BatteryElectricVehicle"]["res"]["history"]
        kwh = sum(ess["pwr_out_electrical_watts"]) / 3.6e6
        miles = sum(d["cyc"]["speed_meters_per_second"]) / 1609.344
        return miles / (kwh / 0.86 / 33.705), f"FASTSim 3 {leaf}"
    except Exception as exc:  # noqa: BLE001
        return None, f"fastsim Leaf run unavailable ({type(exc).__name__}: {exc})"


def run() -> list[dict]:
    leaf = load_vehicle("bev/nissan_leaf_2016")
    prius = load_vehicle("prius_2004")
    cyc = load_cycle("udds")
    simulate(leaf, cyc, dt=1.0)  # compile / load the numba caches
    simulate(prius, cyc, dt=1.0)
    t_ps = best_of(lambda: simulate(prius, cyc, dt=1.0), n=7)
    t_bev = best_of(lambda: simulate(leaf, cyc, dt=1.0), n=7)
    rows = [row("simulate_bev_udds_dt1", t_bev, "s", baseline=t_ps, target=2.0,
                note="2016 Leaf (battery-electric kernel) against the 2004 Prius "
                     "(power-split kernel), UDDS at dt 1 s, same run; target ratio <= 2")]
    ours = simulate(leaf, cyc, dt=1.0).summary["mpge"]
    peer, note = _fastsim_leaf()
    rows.append(row("fastsim_leaf_udds_mpge", ours, "MPGe", baseline=peer,
                    note=note + ("" if peer is not None else
                                 "; the issue's FASTSim figures stand (docs/validation.md)")))
    return rows


if __name__ == "__main__":
    for r in run():
        print(json.dumps(r))
