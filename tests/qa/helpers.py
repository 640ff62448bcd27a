"""Hand-constructed Prius-like tests for the QA library (no simulator needed).

Imported by the tests of this folder (and its conftest); fixtures stay in conftest.py.
"""

from __future__ import annotations

import numpy as np

from vehval.equations import powertrain as pt
from vehval.test import Signal, Test, TestMeta

M, A, B, C = 1295.0, 88.6, 0.14, 0.36


R, FD, NR, NS = 0.305, 4.113, 78.0, 30.0


CONSTANTS = dict(test_mass_kg=M, road_load_a_n=A, road_load_b_n_per_mps=B,
                 road_load_c_n_per_mps2=C, wheel_radius_m=R, final_drive_ratio=FD,
                 fuel_lhv_j_per_kg=42.6e6)


def speed_trace(duration: float, dt: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """A drive of random accel / cruise / decel / stop phases [s], [m/s] (smooth, C1)."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, duration + 1e-9, dt)
    acc = np.zeros_like(t)
    i = int(5 / dt)
    while i < t.size:
        target = rng.uniform(5, 25)
        for a_mag, n in ((rng.uniform(0.6, 1.5), None), (0.0, rng.uniform(5, 20)),
                         (-rng.uniform(0.6, 1.5), None), (0.0, rng.uniform(3, 10))):
            if n is None:
                n = target / abs(a_mag)
            k = int(n / dt)
            acc[i:i + k] = a_mag
            i += k
    # smooth the jerk (1 s window) and integrate
    w = int(1.0 / dt)
    acc = np.convolve(acc, np.ones(w) / w, mode="same")
    v = np.maximum(np.cumsum(acc) * dt, 0.0)
    return t, v


def prius_signals(t: np.ndarray, v: np.ndarray) -> dict[str, np.ndarray]:
    """Clean SI signals consistent with equations (1)-(7)."""
    a = np.gradient(v, t)
    f_in = pt.vehicle_force_in(pt.vehicle_force_out(M, a), pt.road_load(v, A, B, C, 0.1))
    whl = v / R
    mot = whl * FD
    eng_on = v > 6.0
    eng = np.where(eng_on, 120.0 + 8.0 * v, 0.0)
    eng = np.convolve(eng, np.ones(20) / 20, mode="same")          # 2 s start ramp
    gen = pt.willis_gen_speed(eng, mot, NR, NS)
    eng_trq = np.where(eng > 50, 40.0 + 2.0 * v, 0.0)
    whl_trq = pt.wheel_torque(f_in, R)
    mot_trq = pt.motor_torque(whl_trq, FD, pt.ring_torque(eng_trq, NR, NS))
    fuel = np.where(eng > 50, eng * eng_trq / (0.33 * 42.6e6), 0.0)
    volt = 300.0 + 0.0 * v
    p_elec = mot_trq * mot + pt.sun_torque(eng_trq, NR, NS) * gen
    curr = p_elec / volt
    return dict(veh_spd=v, veh_frc_in=f_in, whl_trq_out=whl_trq, eng_spd_out=eng,
                eng_trq_out=eng_trq, fuel_rate=fuel, mot_spd_out=mot, gen_spd_out=gen,
                mot_trq_out=mot_trq, ess_volt=volt, ess_curr=curr)


NOISE = dict(veh_spd=0.005, veh_frc_in=5.0, whl_trq_out=1.5, eng_spd_out=0.3, eng_trq_out=0.5,
             fuel_rate=2e-6, mot_spd_out=0.3, gen_spd_out=0.3, mot_trq_out=0.5, ess_volt=0.1,
             ess_curr=0.2)


def make_test(seed: int = 1, duration: float = 300.0, obd_offset_s: float = 0.0,
              obd: tuple[str, ...] = ("eng_spd_out", "veh_spd", "mot_spd_out", "gen_spd_out",
                                      "mot_trq_out"),
              facility: tuple[str, ...] = ("veh_spd", "veh_frc_in", "whl_trq_out", "eng_spd_out",
                                           "eng_trq_out", "fuel_rate", "ess_volt", "ess_curr"),
              noise: bool = True) -> Test:
    """Facility file at 10 Hz (source ``dyno``) + OBD at ~1 Hz with jitter (source ``obd``).

    ``obd_offset_s``: the OBD clock error; the OBD sample at its time stamp ``t`` holds the
    true value at ``t + obd_offset_s``, so alignment must return ``+obd_offset_s``.
    """
    rng = np.random.default_rng(seed + 1000)
    t, v = speed_trace(duration + 40, 0.1, seed)
    clean = prius_signals(t, v)
    sigs = []
    tf = t[t <= duration]
    for base in facility:
        x = clean[base][: tf.size] + (rng.normal(0, NOISE[base], tf.size) if noise else 0)
        sigs.append(Signal.standard(f"{base}_test", tf, x, source="dyno"))
    t_obd = 2.0 + np.cumsum(1.0 + rng.normal(0, 0.04, int(duration)))
    t_obd = t_obd[t_obd < duration - 2]
    for base in obd:
        x = np.interp(t_obd + obd_offset_s, t, clean[base])
        x = x + (rng.normal(0, NOISE[base], t_obd.size) if noise else 0)
        sigs.append(Signal.standard(f"{base}_obd_test", t_obd, x, source="obd"))
    return Test(sigs, meta=TestMeta(test_id=f"hand{seed}", constants=dict(CONSTANTS),
                                    synthetic=True))
