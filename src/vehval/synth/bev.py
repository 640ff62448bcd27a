"""Virtual dyno test of a battery-electric car, with its SAE J1634 answer key.

:func:`make_bev_test` simulates a battery-electric vehicle on a cycle (dt 0.1 s) and writes
what a dyno facility records for such a car, in D3 style (10 Hz, TAB, ``Name[unit]``):
roller speed [mph], tractive force [N], high-voltage battery voltage [V] and current [A,
positive discharging] and the phase number; no engine or fuel channel. Beside it
``template.yaml`` (``architecture: battery_electric``) and ``truth.json``: the generating
parameters and the answer key, the J1634 figures per phase and for the whole test computed
from the true (noise-free) battery voltage, current and speed. Measurement effects, all
seeded: white noise on every channel (``NOISE``, channel units).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from vehval.constants import MPH_M_PER_S
from vehval.fuels.quantities import ac_energy_j, kwh_per_100km, mpge, wh_per_mile
from vehval.integrals import battery_power, integral
from vehval.synth.template import vehicle_line
from vehval.synth.writers import write_test_folder

NOISE = {"Dyno_Speed": 0.005, "Dyno_Tractive_Effort": 5.0, "HV_Battery_Voltage": 0.2,
         "HV_Battery_Current": 0.2}
UNITS = {"Dyno_Speed": "mph", "Dyno_Tractive_Effort": "N", "HV_Battery_Voltage": "V",
         "HV_Battery_Current": "A"}
NAMES = {"Dyno_Speed": "veh_spd_test", "Dyno_Tractive_Effort": "veh_frc_in_test",
         "HV_Battery_Voltage": "ess_volt_test", "HV_Battery_Current": "ess_curr_test"}


def _trapz(y: np.ndarray, t: np.ndarray, mask: np.ndarray) -> float:
    idx = np.nonzero(mask)[0]
    if idx.size < 2:
        return 0.0
    lo, hi = idx[0], idx[-1] + 1
    if hi < t.size:
        hi += 1  # the interval up to the next phase's first sample belongs to this phase
    return integral(t[lo:hi], y[lo:hi])


def j1634_key(t: np.ndarray, speed: np.ndarray, volt: np.ndarray, curr: np.ndarray,
              phase: np.ndarray, charger_efficiency: float) -> dict:
    """SAE J1634 figures per phase and for the test from true traces (the answer key).

    ``t`` [s], ``speed`` [m/s], ``volt`` [V], ``curr`` [A, positive discharging],
    ``phase`` (1, 2...); DC energy = ∫ V I dt, AC energy = DC / charger efficiency.
    """
    p = battery_power(volt, curr)
    out = {}
    scopes = {f"phase {int(k)}": phase == k for k in np.unique(phase) if k > 0}
    scopes["test"] = np.ones(t.size, bool)
    for name, m in scopes.items():
        dist = _trapz(speed, t, m)
        dc = _trapz(p, t, m)
        ac = ac_energy_j(dc, charger_efficiency)
        out[name] = {"distance_m": dist, "dc_energy_j": dc, "ac_energy_j": ac,
                     "dc_wh_per_mile": wh_per_mile(dc, dist),
                     "ac_wh_per_mile": wh_per_mile(ac, dist),
                     "ac_kwh_per_100km": kwh_per_100km(ac, dist), "mpge": mpge(ac, dist)}
    return out


def make_bev_test(veh, cyc, seed: int, outdir: str | Path,
                  vehicle_ref: str | None = None) -> dict:
    """Simulate ``veh`` (battery-electric) on ``cyc`` and write the virtual test into
    ``outdir`` (atomically). ``vehicle_ref``: the vehicle the template names
    (:func:`vehval.synth.template.vehicle_line`; none by default). Returns the truth
    dictionary (also written as ``truth.json``).
    """
    from vehval.sim.simulate import simulate
    from vehval.synth.clean import test_phase

    res = simulate(veh, cyc, dt=0.1)
    test = res.test
    t = test["veh_spd_simu"].time
    rng = np.random.default_rng(int(seed))
    true = {"Dyno_Speed": test["veh_spd_simu"].values / MPH_M_PER_S,
            "Dyno_Tractive_Effort": test["veh_frc_in_simu"].values,
            "HV_Battery_Voltage": test["ess_volt_simu"].values,
            "HV_Battery_Current": test["ess_curr_simu"].values}
    cols = {k: v + rng.normal(0.0, NOISE[k], t.size) for k, v in true.items()}
    cols["Dyno_Speed"] = np.maximum(cols["Dyno_Speed"], 0.0)
    phase = test_phase(t, cyc.name, float(t[-1]))
    test_id = f"virtual_{veh.name}_{cyc.name}_seed{int(seed)}"
    head = "Time[sec]\t" + "\t".join(f"{k}[{u}]" for k, u in UNITS.items()) + "\tPhase_#"
    lines = [head] + ["\t".join([f"{t[i]:.3f}"] + [f"{cols[k][i]:.4f}" for k in UNITS]
                                + [f"{phase[i]:.0f}"]) for i in range(t.size)]
    b = veh.body
    chans = "".join(f"      {k}: {{name: {NAMES[k]}, unit: {UNITS[k]}}}\n" for k in UNITS)
    template = (
        "template_version: 1\n"
        + vehicle_line(vehicle_ref) +
        "architecture: battery_electric\n"
        f"description: \"VIRTUAL battery-electric test of {veh.name} on {cyc.name} (seed "
        f"{seed}): synthetic, not a measurement\"\n"
        "synthetic: true\n"
        "constants:\n"
        f"  test_mass_kg: {b.mass_kg!r}\n  road_load_a_n: {b.road_load_a_n!r}\n"
        f"  road_load_b_n_per_mps: {b.road_load_b_n_per_mps!r}\n"
        f"  road_load_c_n_per_mps2: {b.road_load_c_n_per_mps2!r}\n"
        "files:\n  - match: \"*_d3.txt\"\n    source: dyno\n    format: d3\n"
        "    time: {column: Time, unit: s}\n    channels:\n" + chans
        + "      Phase_#: {name: test_phase_test}\n")
    key = j1634_key(t, test["veh_spd_simu"].values, true["HV_Battery_Voltage"],
                    true["HV_Battery_Current"], phase, veh.charger.efficiency)
    truth = {"format": "vehval-virtual-bev-truth", "test_id": test_id, "synthetic": True,
             "vehicle": veh.name, "cycle": cyc.name, "seed": int(seed), "noise": NOISE,
             "charger_efficiency": veh.charger.efficiency, "j1634": key,
             "parameters": veh.parameters()}
    return write_test_folder(outdir, f"{test_id}_d3.txt", lines, template, truth,
                             "the parameters that generated it and the SAE J1634 answer key")
