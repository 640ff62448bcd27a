"""Virtual dyno test of a conventional car: the answer key for identification.

:func:`make_conventional_test` simulates a conventional vehicle on a cycle (dt 0.1 s) and
writes what a dyno facility records for such a car, in D3 style (10 Hz, TAB,
``Name[unit]``): roller speed [mph], tractive force [N], engine speed [rpm], modal fuel
flow [g/s] and the phase number, plus ``template.yaml`` and ``truth.json`` (the generating
parameters and every measurement effect). Measurement effects, all seeded:

- the fuel bench is slow: the true rate delayed by ``fuel_delay_s`` and smoothed by a
  first-order lag ``fuel_tau_s``;
- the force is filtered: delayed by ``force_delay_s``;
- white noise on every channel (``noise`` standard deviations, channel units).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.signal import lfilter

from vehval.constants import MPH_M_PER_S, RPM_RAD_PER_S
from vehval.integrals import held_sum
from vehval.synth.template import vehicle_line
from vehval.synth.writers import write_test_folder
from vehval.vehicle.conventional import DRIVEN_AXLE_LOSS_SHARE

FUEL_DELAY_S = 1.5
FUEL_TAU_S = 1.0
FORCE_DELAY_S = 0.2
NOISE = {"Dyno_Speed": 0.005, "Dyno_Tractive_Effort": 5.0, "Engine_Speed": 2.0,
         "Fuel_Flow_Bench_Modal": 0.003}
RPM = 1.0 / RPM_RAD_PER_S  # [rpm] per [rad/s]


def _delay(x: np.ndarray, n: int) -> np.ndarray:
    return np.r_[np.full(n, x[0]), x[:-n]] if n > 0 else x


def make_conventional_test(veh, cyc, seed: int, outdir: str | Path,
                           vehicle_ref: str | None = None) -> dict:
    """Simulate ``veh`` on ``cyc`` and write the virtual test into ``outdir`` (atomically).

    ``vehicle_ref``: the vehicle the template names
    (:func:`vehval.synth.template.vehicle_line`; none by default). Returns the truth dictionary (also written as ``truth.json``).
    """
    from vehval.sim.simulate import simulate
    from vehval.synth.clean import test_phase

    res = simulate(veh, cyc, dt=0.1)
    test = res.test
    t = test["veh_spd_simu"].time
    dt = 0.1
    rng = np.random.default_rng(int(seed))
    fuel = test["fuel_rate_simu"].values * 1e3
    a = dt / (FUEL_TAU_S + dt)
    fuel_meas = _delay(lfilter([a], [1.0, a - 1.0], fuel, zi=[(1 - a) * fuel[0]])[0],
                       round(FUEL_DELAY_S / dt))
    cols = {
        "Dyno_Speed": test["veh_spd_simu"].values / MPH_M_PER_S,
        "Dyno_Tractive_Effort": _delay(test["veh_frc_in_simu"].values,
                                       round(FORCE_DELAY_S / dt)),
        "Engine_Speed": test["eng_spd_out_simu"].values * RPM,
        "Fuel_Flow_Bench_Modal": fuel_meas,
    }
    for k in cols:
        cols[k] = cols[k] + rng.normal(0.0, NOISE[k], t.size)
    cols["Dyno_Speed"] = np.maximum(cols["Dyno_Speed"], 0.0)
    phase = test_phase(t, cyc.name, float(t[-1]))  # the cycle's own bags, as a lab marks them
    units = {"Dyno_Speed": "mph", "Dyno_Tractive_Effort": "N", "Engine_Speed": "rpm",
             "Fuel_Flow_Bench_Modal": "g/s"}
    test_id = f"virtual_{veh.name}_{cyc.name}_seed{int(seed)}"
    head = "Time[sec]\t" + "\t".join(f"{k}[{u}]" for k, u in units.items()) + "\tPhase_#"
    lines = [head] + ["\t".join([f"{t[i]:.3f}"] + [f"{cols[k][i]:.4f}" for k in units]
                                + [f"{phase[i]:.0f}"]) for i in range(t.size)]
    b = veh.body
    e = veh.engine
    g = veh.gearbox
    # the template states the target coefficients: set (the body's road load, what the
    # roller force shows) + the car's own losses on the rollers, of which the driveline
    # drag is the driven axle's share (identification's stated assumption)
    share = DRIVEN_AXLE_LOSS_SHARE
    template = (
        "template_version: 1\n"
        + vehicle_line(vehicle_ref) + "synthetic: true\n"
        f"description: \"VIRTUAL conventional test of {veh.name} on {cyc.name} (seed {seed}): "
        "synthetic, not a measurement\"\n"
        "constants:\n"
        f"  test_mass_kg: {b.mass_kg!r}\n  road_load_a_n: {b.road_load_a_n + g.drag_force_n / share!r}\n"
        f"  road_load_b_n_per_mps: {b.road_load_b_n_per_mps + g.drag_force_n_per_mps / share!r}\n"
        f"  road_load_c_n_per_mps2: {b.road_load_c_n_per_mps2!r}\n"
        f"  fuel_density_kg_per_m3: {e.fuel_density_kg_per_m3!r}\n"
        f"  fuel_lhv_j_per_kg: {e.fuel_lhv_j_per_kg!r}\n"
        "files:\n  - match: \"*_d3.txt\"\n    source: dyno\n    format: d3\n"
        "    time: {column: Time, unit: s}\n    channels:\n"
        "      Dyno_Speed: {name: veh_spd_test, unit: mph}\n"
        "      Dyno_Tractive_Effort: {name: veh_frc_in_test, unit: N}\n"
        "      Engine_Speed: {name: eng_spd_out_test, unit: rpm}\n"
        "      Fuel_Flow_Bench_Modal: {name: fuel_rate_test, unit: g/s}\n"
        "      Phase_#: {name: test_phase_test}\n")
    truth = {"format": "vehval-virtual-conventional-truth", "test_id": test_id,
             "synthetic": True, "vehicle": veh.name, "cycle": cyc.name, "seed": int(seed),
             "fuel_delay_s": FUEL_DELAY_S, "fuel_tau_s": FUEL_TAU_S,
             "force_delay_s": FORCE_DELAY_S, "noise": NOISE,
             "fuel_g": held_sum(fuel, dt), "parameters": veh.parameters(),
             "gear_ratios": [float(r) for r in veh.overall_ratios()]}
    return write_test_folder(outdir, f"{test_id}_d3.txt", lines, template, truth,
                             "the parameters that generated it")
