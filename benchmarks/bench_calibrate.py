"""Calibration time for a given number of parameters and tests, and validation cost.

Baseline: one simulation of every tuning test at the calibration step, measured in the same
run with the same vehicle object (compiled, best-efficiency line cached). The ratio of the
calibration time to it is the number of "simulation-equivalents" the whole calibration
costs (search + polish + before/after validation of tuned and held-out tests); compare it
with the number of simulations actually run to see the per-simulation overhead (objective
reduction, candidate validation, scipy).

Rows (two tuning tests, Japan 10-15 + HWFET; two held out, UDDS + NEDC; the perturbed
"true" Prius has 3 controller and 2 component parameters changed, see docs/validation.md):

* ``calibrate_3params_2tests_dt1_batch``: controller parameters only, component
  parameters at their true values, summary-only search (``mode='batch'``);
* ``calibrate_3params_2tests_dt1_traces``: the same problem, recorded-signal objective;
* ``calibrate_5params_2tests_dt1_traces``: controller + component parameters together;
* ``calibrate_5params_2tests_dt0.1_dyno_files``: the same five parameters on the virtual
  dyno's files (sensor chain, measured speed low-passed at 1 Hz) at dt = 0.1 s;
* ``validate_udds_dt0.1``: one full validation against the simulation alone.
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

from benchmarks.common import best_of, row
from vehval.sim.simulate import simulate
from vehval.test import Signal, Test, TestMeta
from vehval.vehicle import load_vehicle

TRUTH = {"controller.engine_on_power_w": 11000.0, "controller.soc_gain_w": 100000.0,
         "controller.regen_fraction_max": 0.75, "body.aux_power_w": 400.0,
         "driveline.final_drive_efficiency": 0.94}
CONTROLLER = [k for k in TRUTH if k.startswith("controller.")]
COMPONENT = {k: v for k, v in TRUTH.items() if not k.startswith("controller.")}
TUNE, HOLD = ("japan1015", "hwfet"), ("udds", "nedc")
SHORT = {"controller.engine_on_power_w": "eon", "controller.soc_gain_w": "soc_gain",
         "controller.regen_fraction_max": "regen", "body.aux_power_w": "aux",
         "driveline.final_drive_efficiency": "fd_eff"}


def _virtual(veh, cycle: str) -> Test:
    """Simulation of the perturbed car at dt = 1 s as a test (target speed as measured)."""
    r = simulate(veh, cycle, dt=1.0, soc_initial=0.6, **TRUTH)
    t = Test(meta=TestMeta(test_id=f"virtual_{cycle}", cycle=cycle, synthetic=True,
                           constants={"test_mass_kg": veh.body.mass_kg}))
    for s in r.test:
        if s.name.endswith("_simu") and s.name != "veh_spd_simu":
            base = s.name[:-5]
            t.add(Signal.standard("veh_spd_test" if base == "veh_spd_target" else base + "_test",
                                  s.time, s.values, source="dyno"))
    return t


def _dyno(root: Path, cycle: str) -> Test:
    """The perturbed car through the virtual dyno's files, imported and QA'd."""
    from vehval.synth import make_virtual_test
    from vehval.workflow import TestRun

    d = root / cycle
    make_virtual_test("prius_2004", cycle, seed=3, faults="none", outdir=d,
                      controller_overrides={k.split(".", 1)[1]: TRUTH[k] for k in CONTROLLER},
                      vehicle_overrides=COMPONENT)
    return TestRun.from_paths([d]).validated


def _note(res, names, extra: str) -> str:
    errs = ", ".join(f"{SHORT[n]} {100 * (res.best[n] - TRUTH[n]) / TRUTH[n]:+.2f} %" for n in names)
    hold = "; ".join(f"{t}: fuel {res.before[t]['fuel_pct']:.2f} -> {res.after[t]['fuel_pct']:.2f} %, "
                     f"SOC {res.before[t]['soc_pct']:.2f} -> {res.after[t]['soc_pct']:.2f} %"
                     for t in res.holdout)
    return (f"{res.n_simulations} simulations ({res.method}); {extra}parameter errors: {errs}; "
            f"held out {hold}")


def run() -> list[dict]:
    from vehval.validate import validate_test
    from vehval.validate.calibration import calibrate
    from vehval.validate.conditions import simulation_conditions, vehicle_variant

    veh = load_vehicle("prius_2004")
    tune = [_virtual(veh, c) for c in TUNE]
    hold = [_virtual(veh, c) for c in HOLD]

    def baseline(tests, dt, smooth_hz=None) -> float:
        conds = [simulation_conditions(t, veh, smooth_hz=smooth_hz) for t in tests]
        return best_of(lambda: [simulate(veh, c.cycle, dt=dt, soc_initial=c.soc_initial)
                                for c in conds], n=3)

    base1 = baseline(tune, 1.0)
    rows = []
    comp_true = vehicle_variant(veh, COMPONENT)
    for names, mode, start_veh in ((CONTROLLER, "batch", comp_true), (CONTROLLER, "traces", comp_true),
                                   (list(TRUTH), "traces", veh)):
        t0 = time.perf_counter()
        res = calibrate(tune, start_veh, names, holdout_tests=hold, dt=1.0, seed=0, mode=mode)
        el = time.perf_counter() - t0
        extra = "component parameters at their true values; " if len(names) < len(TRUTH) else ""
        rows.append(row(f"calibrate_{len(names)}params_2tests_dt1_{mode}", el, "s", baseline=base1,
                        target=4000.0, note=_note(res, names, extra + "baseline one simulation of "
                                                  "the 2 tuning tests at dt = 1 s; ")))
    with tempfile.TemporaryDirectory() as tmp:
        dt_tune = [_dyno(Path(tmp), c) for c in TUNE]
        dt_hold = [_dyno(Path(tmp), c) for c in HOLD]
    base01 = baseline(dt_tune, 0.1, 1.0)
    t0 = time.perf_counter()
    res = calibrate(dt_tune, veh, list(TRUTH), holdout_tests=dt_hold, dt=0.1, seed=0, smooth_hz=1.0)
    el = time.perf_counter() - t0
    rows.append(row("calibrate_5params_2tests_dt0.1_dyno_files", el, "s", baseline=base01,
                    target=4000.0, note=_note(res, list(TRUTH), "virtual dyno files (sensor chain, "
                                              "measured speed low-passed at 1 Hz); baseline one "
                                              "simulation of the 2 tuning tests at dt = 0.1 s; ")))
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
