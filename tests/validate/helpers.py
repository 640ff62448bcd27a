"""Hand-built tests and simulated tests used as virtual measurements."""

from __future__ import annotations

import numpy as np

from vehval.test import Signal, Test, TestMeta


def hand_test(fuel_g_per_s: float = 0.5, soc0: float = 0.6, soc1: float = 0.58,
              duration_s: float = 100.0, test_id: str = "t", cycle: str = "udds",
              origin: str = "test", on_from_s: float = 20.0, on_to_s: float = 60.0,
              speed_mps: float = 10.0) -> Test:
    """A 1 Hz test with constant speed, a constant fuel rate while the engine runs
    (``on_from_s`` <= t < ``on_to_s``) and a linear SOC from ``soc0`` to ``soc1``."""
    t = np.arange(0.0, duration_s + 0.5, 1.0)
    on = (t >= on_from_s) & (t < on_to_s)
    src = "simu" if origin == "simu" else "dyno"
    test = Test(meta=TestMeta(test_id=test_id, cycle=cycle))
    sigs = {
        "veh_spd": np.full(t.size, speed_mps),
        "fuel_rate": np.where(on, fuel_g_per_s * 1e-3, 0.0),
        "ess_soc": np.linspace(soc0, soc1, t.size),
        "eng_spd_out": np.where(on, 1500 * np.pi / 30, 0.0),
        "eng_trq_out": np.where(on, 50.0, 0.0),
    }
    for base, v in sigs.items():
        name = f"{base}_{origin}" if origin == "simu" else f"{base}_test"
        test.add(Signal.standard(name, t, v, source=src))
    return test


def sim_as_test(sim_test: Test, test_id: str, cycle: str, constants: dict | None = None) -> Test:
    """A simulation's ``<base>_simu`` signals renamed ``<base>_test`` (a virtual measurement).

    The measured vehicle speed is the target speed the simulated driver followed, so that a
    model replaying the "measured" trace with the true parameters reproduces the run
    exactly (the achieved speed differs from the target by up to 0.3 m/s at dt = 1 s, and
    replaying that ripple alone changes the fuel by a few per cent).
    """
    out = Test(meta=TestMeta(test_id=test_id, cycle=cycle, constants=dict(constants or {}),
                             synthetic=True))
    for s in sim_test:
        if s.name.endswith("_simu") and s.name != "veh_spd_simu":
            base = s.name[:-5]
            name = "veh_spd_test" if base == "veh_spd_target" else base + "_test"
            out.add(Signal.standard(name, s.time, s.values, source="dyno"))
    return out


#: The perturbed ("true") parameters. The nominal file has 8000 W, 150 kW/SOC, 1.0 (controller),
#: 300 W accessory load and a final-drive efficiency of 0.97 (components).
TRUTH = {"controller.engine_on_power_w": 11000.0, "controller.soc_gain_w": 100000.0,
         "controller.regen_fraction_max": 0.75, "body.aux_power_w": 400.0,
         "driveline.final_drive_efficiency": 0.94}


CONTROLLER_TRUTH = {k.split(".", 1)[1]: v for k, v in TRUTH.items() if k.startswith("controller.")}


COMPONENT_TRUTH = {k: v for k, v in TRUTH.items() if not k.startswith("controller.")}


TUNE_CYCLES = ("japan1015", "hwfet")


HOLDOUT_CYCLES = ("udds", "nedc")


CONSTANTS = {"test_mass_kg": 1295.0, "road_load_a_n": 88.6, "road_load_b_n_per_mps": 0.14,
             "road_load_c_n_per_mps2": 0.36}


class _DynoDirs(dict):
    """cycle -> virtual dyno test directory, made on first use (once per test worker)."""

    def __init__(self, root, synth):
        super().__init__()
        self.root, self.synth = root, synth

    def __missing__(self, cycle: str):
        d = self.root / cycle
        self.synth.make_virtual_test("prius_2004", cycle, seed=3, faults="none", outdir=d,
                                     controller_overrides=CONTROLLER_TRUTH,
                                     vehicle_overrides=COMPONENT_TRUTH)
        self[cycle] = d
        return d
