"""Synthetic tests for the results stage: a cycle trace with a fuel model and a phase channel."""

from __future__ import annotations

import numpy as np
import yaml

from vehval.cycles import load_cycle
from vehval.test import Signal, Test
from vehval.test import TestMeta as Meta

#: Fuel model of the synthetic car: idle rate [kg/s] + energy at the wheel / efficiency / LHV.
IDLE_KG_S = 0.12e-3
MASS_KG = 1500.0


def true_signals(cycle: str = "udds", dt: float = 0.1) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Time [s] and true (clean) speed [m/s], fuel rate [kg/s] and phase number."""
    cyc = load_cycle(cycle).resampled(dt)
    t, v = np.asarray(cyc.time_s), np.asarray(cyc.speed_mps)
    a = np.gradient(v, t)
    p_wheel = (MASS_KG * a + 120.0 + 0.4 * v * v) * v
    fuel = IDLE_KG_S + np.maximum(p_wheel, 0.0) / 0.3 / 42.8e6
    phase = np.where(t < 505.0, 1.0, 2.0) if cycle == "udds" else np.ones_like(t)
    return t, {"veh_spd": v, "fuel_rate": fuel, "test_phase": phase}


def make_test(t: np.ndarray, sig: dict[str, np.ndarray], *, cycle: str = "udds",
              phase: bool = True, constants: dict | None = None) -> Test:
    test = Test(meta=Meta(test_id="synthetic", cycle=cycle, constants=constants or {}))
    test.add(Signal.standard("veh_spd_test", t, sig["veh_spd"], source="dyno"))
    test.add(Signal.standard("fuel_rate_test", t, sig["fuel_rate"], source="dyno"))
    if phase:
        test.add(Signal.standard("test_phase_test", t, sig["test_phase"], source="dyno"))
    return test


def cli_files(tmp_path, fuel="diesel", **extra):
    t, s = true_signals()
    raw = tmp_path / "run.csv"
    cols = np.column_stack([t, s["veh_spd"] / 0.44704, s["fuel_rate"] * 1e3, s["test_phase"]])
    np.savetxt(raw, cols, delimiter=",", fmt="%.6f",
               header="Time[s],Speed[mph],Fuel[g/s],Phase", comments="")
    tpl = {"template_version": 1, "files": [{"source": "dyno", "channels": {
        "Speed": {"name": "veh_spd_test", "unit": "mph"},
        "Fuel": {"name": "fuel_rate_test", "unit": "g/s"},
        "Phase": {"name": "test_phase_test"}}}], **extra}
    if fuel:
        tpl["fuel"] = fuel
    p = tmp_path / "t.yaml"
    p.write_text(yaml.safe_dump(tpl))
    return raw, p
