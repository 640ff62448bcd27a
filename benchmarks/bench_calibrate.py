"""Calibration cost in simulation-equivalents, and validation cost against one simulation.

Baseline: one simulation of every tuning test at the calibration step (dt = 1 s), measured
in the same run with the same vehicle object (compiled, best-efficiency line cached). The
ratio of the calibration time to it is the number of "simulation-equivalents" the whole
calibration costs (search + polish + before/after validation of tuned and held-out tests);
compare it with the number of simulations actually run to see the per-simulation overhead
(objective reduction, candidate validation, scipy).
"""

from __future__ import annotations

import time

from benchmarks.common import best_of, row
from vehval.sim.simulate import simulate
from vehval.sim.vehicle import load_vehicle
from vehval.test import Signal, Test, TestMeta

TRUTH = {"controller.engine_on_power_w": 11000.0, "controller.soc_gain_w": 100000.0,
         "controller.regen_fraction_max": 0.75}


def _virtual(veh, cycle: str) -> Test:
    r = simulate(veh, cycle, dt=1.0, soc_initial=0.6, **TRUTH)
    t = Test(meta=TestMeta(test_id=f"virtual_{cycle}", cycle=cycle, synthetic=True))
    for s in r.test:
        if s.name.endswith("_simu") and s.name != "veh_spd_simu":
            base = s.name[:-5]
            t.add(Signal.standard("veh_spd_test" if base == "veh_spd_target" else base + "_test",
                                  s.time, s.values, source="dyno"))
    return t


def run() -> list[dict]:
    from vehval.validate import validate_test
    from vehval.validate.calibration import calibrate
    from vehval.validate.conditions import simulation_conditions

    veh = load_vehicle("prius_2004")
    tune = [_virtual(veh, c) for c in ("japan1015", "hwfet")]
    hold = [_virtual(veh, c) for c in ("udds", "nedc")]
    conds = [simulation_conditions(t, veh) for t in tune]

    def one_pass() -> None:
        for c in conds:
            simulate(veh, c.cycle, dt=1.0, soc_initial=c.soc_initial)

    base = best_of(one_pass, n=5)
    rows = []
    for names in (list(TRUTH)[:1], list(TRUTH)):
        t0 = time.perf_counter()
        res = calibrate(tune, veh, names, holdout_tests=hold, dt=1.0, seed=0)
        el = time.perf_counter() - t0
        err = max(abs(res.best[n] - TRUTH[n]) / TRUTH[n] for n in names)
        hold_fuel = max(res.after[t]["fuel_pct"] for t in res.holdout)
        rows.append(row(f"calibrate_{len(names)}params_2tests_dt1", el, "s", baseline=base,
                        target=2000.0,
                        note=f"{res.n_simulations} simulations ({res.method}); "
                             + ("model misspecified on purpose: the 2 other perturbed parameters "
                                "are not tuned; " if len(names) < len(TRUTH) else "")
                             + "baseline one "
                             f"simulation of the 2 tuning tests (japan1015 + hwfet); max parameter "
                             f"error {err * 100:.2f} %, held-out fuel error <= {hold_fuel:.2f} %"))
    tv = best_of(lambda: validate_test(hold[0], veh, dt=0.1), n=3)
    cu = simulation_conditions(hold[0], veh)
    ts = best_of(lambda: simulate(veh, cu.cycle, dt=0.1, soc_initial=cu.soc_initial), n=3)
    rows.append(row("validate_udds_dt0.1", tv, "s", baseline=ts, target=5.0,
                    note="conditions + simulation + full comparison (17 signals, energies, "
                         "events); baseline the simulation alone"))
    return rows


if __name__ == "__main__":  # pragma: no cover
    for r in run():
        print(r)
