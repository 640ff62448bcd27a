"""Virtual dyno test of a parallel hybrid: the answer key for its control analysis.

:func:`make_parallel_test` simulates a parallel hybrid (engine and motor on one shaft) on a
cycle (dt 0.1 s) and writes what the Insight's 10 Hz log records, in the same layout (TAB,
one header row): time [s], roller speed [mph], battery volts and amps (positive
discharging), engine speed [rpm], axle torque [N·m] and the motor torque [N·m], plus
``template.yaml`` (naming the vehicle) and ``truth.json``: the controller's rules (the
answer key of :mod:`vehval.analysis.parallel`), the battery energy [Wh] and the
generating parameters. Measurement effects, seeded: white noise on every channel
(``NOISE``, channel units).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from vehval.constants import MPH_M_PER_S, RPM_RAD_PER_S
from vehval.synth.writers import write_test_folder

NOISE = {"speed_mph": 0.02, "batt_volts": 0.1, "batt_amps": 0.1, "eng_rpm": 2.0,
         "axle_torque_nm": 1.0, "em_trq_nm": 0.1}
UNITS = {"speed_mph": "mph", "batt_volts": "V", "batt_amps": "A", "eng_rpm": "rpm",
         "axle_torque_nm": "N*m", "em_trq_nm": "N*m"}
NAMES = {"speed_mph": "veh_spd_test", "batt_volts": "ess_volt_test",
         "batt_amps": "ess_curr_test", "eng_rpm": "eng_spd_out_test",
         "axle_torque_nm": "whl_trq_out_test", "em_trq_nm": "mot_trq_out_test"}


def make_parallel_test(veh, cyc, seed: int, outdir: str | Path,
                       vehicle_ref: str | None = None) -> dict:
    """Simulate ``veh`` on ``cyc`` from its SOC target and write the virtual test into
    ``outdir`` (atomically). ``vehicle_ref``: what the template names as the vehicle
    (default the vehicle's name). Returns the truth dictionary (also ``truth.json``)."""
    from vehval.sim.simulate import simulate

    res = simulate(veh, cyc, dt=0.1)
    test = res.test
    t = test["veh_spd_simu"].time
    rng = np.random.default_rng(int(seed))
    cols = {
        "speed_mph": test["veh_spd_simu"].values / MPH_M_PER_S,
        "batt_volts": test["ess_volt_simu"].values,
        "batt_amps": test["ess_curr_simu"].values,
        "eng_rpm": test["eng_spd_out_simu"].values / RPM_RAD_PER_S,
        "axle_torque_nm": test["whl_trq_out_simu"].values,
        "em_trq_nm": test["mot_trq_out_simu"].values,
    }
    for k in cols:
        cols[k] = cols[k] + rng.normal(0.0, NOISE[k], t.size)
    cols["speed_mph"] = np.maximum(cols["speed_mph"], 0.0)
    cols["eng_rpm"] = np.maximum(cols["eng_rpm"], 0.0)
    test_id = f"virtual_{veh.name}_{cyc.name}_seed{int(seed)}"
    lines = ["time_s\t" + "\t".join(cols)]
    lines += ["\t".join([f"{t[i]:.1f}"] + [f"{cols[k][i]:.4f}" for k in cols])
              for i in range(t.size)]
    chans = "".join(f"      {k}: {{name: {NAMES[k]}, unit: {UNITS[k]}}}\n" for k in cols)
    template = (
        "template_version: 1\n"
        f"vehicle: {vehicle_ref or veh.name}\n"
        "architecture: parallel_hybrid\n"
        "synthetic: true\n"
        f"description: \"VIRTUAL parallel-hybrid test of {veh.name} on {cyc.name} (seed "
        f"{seed}): synthetic, not a measurement\"\n"
        "files:\n  - match: \"*_10hz.txt\"\n    source: dyno\n    format: csv\n"
        "    time: {column: time_s, unit: s}\n    options: {delimiter: \"\\t\"}\n"
        "    channels:\n" + chans)
    c = veh.controller
    p = test["ess_pwr_simu"].values
    truth = {
        "format": "vehval-virtual-parallel-truth", "test_id": test_id, "synthetic": True,
        "vehicle": veh.name, "cycle": cyc.name, "seed": int(seed), "noise": NOISE,
        "rules": {"assist_threshold_nm": c.assist_threshold_nm,
                  "assist_min_gear": c.assist_min_gear,
                  "regen_threshold_nm": c.regen_threshold_nm,
                  "regen_min_speed_mps": c.regen_min_speed_mps,
                  "engine_stop_speed_mps": c.engine_stop_speed_mps},
        "battery_out_wh": float(np.sum(np.maximum(p, 0.0)) * 0.1 / 3600),
        "battery_in_wh": float(np.sum(np.minimum(p, 0.0)) * -0.1 / 3600),
        "engine_starts": res.summary["engine_starts"],
        "gear_ratios": [float(r) for r in veh.overall_ratios()],
        "parameters": veh.parameters(),
    }
    return write_test_folder(outdir, f"{test_id}_10hz.txt", lines, template, truth,
                             "the controller rules and parameters that generated it")
