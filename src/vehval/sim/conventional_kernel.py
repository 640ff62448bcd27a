"""The compiled time loop of the forward-looking conventional simulation.

Engine -> torque converter (lock-up fluid coupling) -> automatic gearbox -> final drive ->
wheels, with the same driver, road load and fuel-map handling as the power-split loop.
State: vehicle speed ``v`` [m/s], engine speed ``w_e`` [rad/s], engaged gear, time since
the last shift. One step:

1. driver: wheel force demand (feed-forward + PI, :func:`vehval.sim.driver.driver_force`);
2. gear: up/down shift lines (vehicle speed against load = demanded power / engine maximum
   power), at most one shift per ``shift_time``;
3. converter: locked above the gear's lock-up speed (``ω_e = ω_t``), else the coupling law
   ``T_p = k ω_e (ω_e − ω_t)`` solved for ``ω_e`` with the demanded pump torque, never below
   idle; during a shift or with the converter open, the engine speed follows its target
   with the time constant ``shift_time / 2``;
4. engine: torque = pump torque + accessories + inertia, capped by the full-load curve;
   negative torque is overrun (fuel cut above the cut speed, motoring drag at most);
   standing, the idle fuel rate plus the map's extra fuel for accessory load beyond the
   one the idle rate was measured with (``idle_acc_pwr``; e.g. the A/C compressor);
5. vehicle: ``m_eq dv/dt = F_powertrain − F_brake − F_road``, ``F_powertrain`` net of the
   driveline drag ``drag_a + drag_b v`` (the car's own losses a dyno's set coefficients
   leave out); powers at mid-step speed.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from vehval.sim.components.body import road_load
from vehval.sim.components.engine import fuel_rate, max_torque, warmup_factor
from vehval.sim.phases import driver_demand

CONV_PARAMS = (
    "mass", "rl_a", "rl_b", "rl_c", "r_wheel", "fd_ratio", "fd_eff", "j_wheel", "brk_max",
    "gb_eff", "shift_time", "tc_k", "j_eng", "eng_idle", "eng_max_spd", "eng_drag",
    "eng_pmax", "fuel_lhv", "idle_fuel", "fuel_cut_spd", "overrun_fuel", "acc_pwr",
    "drv_tau", "drv_ki", "drv_int_lim", "drv_fmax", "idle_acc_pwr", "drag_a", "drag_b",
    "warm_frac", "warm_tau",
)
CONV_SIGNALS = (
    "veh_spd", "veh_spd_target", "veh_acc", "veh_frc_in", "veh_frc_loss", "whl_trq_out",
    "whl_spd", "eng_spd_out", "eng_trq_out", "eng_pwr_out", "eng_fuel_cut", "fuel_rate",
    "gb_gear", "gb_spd_in", "brk_frc", "drv_frc_demand", "drv_pwr_demand",
)
CONV_SUMMARY = (
    "fuel_mass_kg", "fuel_energy_j", "eng_out_energy_j", "eng_loss_j", "aux_energy_j",
    "eng_ke_change_j", "converter_loss_j", "gearbox_loss_j", "brake_energy_j", "road_energy_j",
    "ke_start_j", "ke_end_j", "wheel_energy_j", "distance_m", "idle_time_s",
    "fuel_cut_time_s", "unlocked_time_s", "gear_shifts", "eng_spd_max", "trace_max_miss_mps",
    "trace_n_miss", "duration_s",
)

# index constants (numba reads module globals as compile-time constants)
(C_MASS, C_RL_A, C_RL_B, C_RL_C, C_R_WHEEL, C_FD_RATIO, C_FD_EFF, C_J_WHEEL, C_BRK_MAX,
 C_GB_EFF, C_SHIFT_TIME, C_TC_K, C_J_ENG, C_ENG_IDLE, C_ENG_MAX_SPD, C_ENG_DRAG, C_ENG_PMAX,
 C_FUEL_LHV, C_IDLE_FUEL, C_FUEL_CUT_SPD, C_OVERRUN_FUEL, C_ACC_PWR, C_DRV_TAU, C_DRV_KI,
 C_DRV_INT_LIM, C_DRV_FMAX, C_IDLE_ACC_PWR, C_DRAG_A, C_DRAG_B, C_WARM_FRAC,
 C_WARM_TAU) = range(31)
(O_VEH_SPD, O_VEH_SPD_TARGET, O_VEH_ACC, O_VEH_FRC_IN, O_VEH_FRC_LOSS, O_WHL_TRQ_OUT,
 O_WHL_SPD, O_ENG_SPD_OUT, O_ENG_TRQ_OUT, O_ENG_PWR_OUT, O_ENG_FUEL_CUT, O_FUEL_RATE,
 O_GB_GEAR, O_GB_SPD_IN, O_BRK_FRC, O_DRV_FRC_DEMAND, O_DRV_PWR_DEMAND) = range(17)
(Y_FUEL, Y_FUEL_E, Y_ENG_OUT, Y_ENG_LOSS, Y_AUX, Y_ENG_KE, Y_TC_LOSS, Y_GB_LOSS, Y_BRAKE,
 Y_ROAD, Y_KE0, Y_KE1, Y_WHEEL, Y_DIST, Y_IDLE, Y_CUT, Y_UNLOCK, Y_SHIFTS, Y_ENG_SPD_MAX,
 Y_MISS_MAX, Y_MISS_N, Y_DUR) = range(22)
STANDSTILL_MPS = 0.05  # [m/s] below this (and a zero target) the car stands, engine idling


@njit(cache=True)
def coupling_pump_speed(w_t, t_pump, k):
    """Pump (engine) speed [rad/s] of the coupling ``T = k ω_p (ω_p − ω_t)`` for torque [N·m]."""
    disc = w_t * w_t + 4.0 * t_pump / k
    return 0.5 * (w_t + math.sqrt(max(disc, 0.0)))


@njit(cache=True)
def select_gear(gear, v, load, up0, up1, dn0, dn1):
    """Gear (1-based) after the shift lines at speed ``v`` [m/s] and load [0..1]."""
    n = up0.shape[0] + 1
    if gear < n and v > up0[gear - 1] + (up1[gear - 1] - up0[gear - 1]) * load:
        return gear + 1
    if gear > 1 and v < dn0[gear - 2] + (dn1[gear - 2] - dn0[gear - 2]) * load:
        return gear - 1
    return gear


@njit(cache=True)
def run_conventional(vt, band_lo, band_hi, dt, prm, eS, eT, eF, eTm, ratios, up0, up1, dn0,
                     dn1, lock_v, out, record):
    """Simulate one cycle; returns the summary vector (``CONV_SUMMARY`` order).

    ``vt`` target speed [m/s] on a uniform grid of step ``dt`` [s]; ``band_lo/hi`` its EPA
    band [m/s]; ``prm`` scalars (``CONV_PARAMS``, SI); ``eS, eT, eF, eTm`` engine speed
    [rad/s], torque [N·m] breakpoints, fuel map [kg/s], full-load torque [N·m]; ``ratios``
    gearbox ratios; ``up0/up1/dn0/dn1`` shift lines [m/s] at zero / full load; ``lock_v``
    lock-up speed per gear [m/s]; ``out`` (n, len(CONV_SIGNALS)) written when ``record``.
    """
    n = vt.shape[0]
    ys = np.zeros(22)
    rw = prm[C_R_WHEEL]; fd = prm[C_FD_RATIO]
    eff = prm[C_FD_EFF] * prm[C_GB_EFF]
    m_eq = prm[C_MASS] + prm[C_J_WHEEL] / (rw * rw)
    rl_a = prm[C_RL_A]; rl_b = prm[C_RL_B]; rl_c = prm[C_RL_C]
    idle = prm[C_ENG_IDLE]; j_e = prm[C_J_ENG]; k_tc = prm[C_TC_K]
    acc = prm[C_ACC_PWR]; pmax = prm[C_ENG_PMAX]; lhv = prm[C_FUEL_LHV]
    acc_idle = prm[C_IDLE_ACC_PWR]
    shift_time = prm[C_SHIFT_TIME]
    a_eng = min(dt / max(0.5 * shift_time, dt), 1.0)
    f_min = -(prm[C_BRK_MAX] + 1e4)
    v = vt[0]
    gear = 1
    t_shift = shift_time
    we = idle
    i_drv = 0.0
    ys[Y_KE0] = 0.5 * m_eq * v * v
    if record:
        out[0, O_VEH_SPD] = v; out[0, O_VEH_SPD_TARGET] = vt[0]; out[0, O_WHL_SPD] = v / rw
        out[0, O_ENG_SPD_OUT] = we; out[0, O_GB_GEAR] = 1.0
    for i in range(n - 1):
        v0 = v
        vnow = vt[i]
        vnext = vt[i + 1]
        # ---------------- driver
        f_dem, _ = driver_demand(v0, vnow, vnext, dt, m_eq, rl_a, rl_b, rl_c, i_drv,
                                prm[C_DRV_TAU], f_min, prm[C_DRV_FMAX])
        p_dem = f_dem * max(v0, 0.0)
        standstill = v0 < STANDSTILL_MPS and vnext < STANDSTILL_MPS
        # ---------------- gear
        t_shift += dt
        if standstill:
            new_gear = 1
        elif t_shift >= shift_time:
            load = min(max(p_dem / pmax, 0.0), 1.0)
            new_gear = select_gear(gear, v0, load, up0, up1, dn0, dn1)
        else:
            new_gear = gear
        if new_gear != gear:
            ys[Y_SHIFTS] += 1.0
            t_shift = 0.0
            gear = new_gear
        ratio = ratios[gear - 1] * fd
        w_t = ratio * v0 / rw
        locked = v0 >= lock_v[gear - 1] and w_t >= idle
        # ---------------- converter and engine speed
        f_drag = prm[C_DRAG_A] + prm[C_DRAG_B] * v0 if v0 >= STANDSTILL_MPS else 0.0
        t_wh = (f_dem + f_drag) * rw
        t_in = t_wh / (ratio * eff) if t_wh >= 0.0 else t_wh * eff / ratio
        if locked:
            w_tgt = w_t
        else:
            w_tgt = max(coupling_pump_speed(w_t, t_in, k_tc), idle)
        if locked and t_shift >= shift_time:
            we1 = w_tgt  # locked, no shift under way: the engine turns with the turbine
        else:
            we1 = we + a_eng * (w_tgt - we)
        we_a = 0.5 * (we + we1)
        t_inertia = j_e * (we1 - we) / dt
        t_acc = acc / max(we_a, idle)
        # ---------------- engine torque, limits, overrun
        t_full = max_torque(eS, eTm, we_a)
        if locked:
            t_pump = t_in
        else:
            # open converter: it passes the coupling torque up to the demand; without a
            # drive demand the engine idles (creep against the brakes is in the idle fuel)
            t_pump = min(k_tc * we_a * (we_a - w_t), max(t_in, 0.0))
        t_e = t_pump + t_acc + t_inertia
        if t_e > t_full:
            t_e = t_full
            t_pump = t_full - t_acc - t_inertia
        if t_e < -prm[C_ENG_DRAG]:
            t_e = -prm[C_ENG_DRAG]
            t_pump = t_e - t_acc - t_inertia
        if standstill:
            fuel = prm[C_IDLE_FUEL]
            if acc != acc_idle:
                t_base = t_e - t_acc + acc_idle / max(we_a, idle)
                fuel += max(fuel_rate(eS, eT, eF, we_a, t_e) - fuel_rate(eS, eT, eF, we_a, t_base),
                            0.0)
            cut = False
            ys[Y_IDLE] += dt
        elif t_e <= 0.0 and we_a >= prm[C_FUEL_CUT_SPD]:
            fuel = prm[C_OVERRUN_FUEL]
            cut = True
            ys[Y_CUT] += dt
        else:
            fuel = fuel_rate(eS, eT, eF, we_a, t_e)
            cut = False
        fuel *= warmup_factor(prm[C_WARM_FRAC], prm[C_WARM_TAU], (i + 0.5) * dt)
        # ---------------- vehicle
        f_pt = t_pump * ratio / rw
        f_pt = (f_pt * eff if f_pt >= 0.0 else f_pt / eff) - f_drag
        f_brk = min(max(f_pt - f_dem, 0.0), prm[C_BRK_MAX]) if f_dem < 0.0 else 0.0
        fl = road_load(v0, rl_a, rl_b, rl_c)
        v1 = v0 + dt * (f_pt - f_brk - fl) / m_eq
        if v1 < 0.0:
            # the car stops within the step: brake (then road load) take only what stops it
            v1 = 0.0
            f_brk = f_pt - fl + v0 * m_eq / dt
            if f_brk < 0.0:
                fl += f_brk
                f_brk = 0.0
        v_a = 0.5 * (v0 + v1)
        # ---------------- energy bookkeeping (mid-step speeds)
        w_t_a = ratio * v_a / rw
        p_e = t_e * we_a
        ys[Y_FUEL] += fuel * dt
        ys[Y_FUEL_E] += fuel * lhv * dt
        ys[Y_ENG_OUT] += p_e * dt
        ys[Y_ENG_LOSS] += (fuel * lhv - p_e) * dt
        ys[Y_AUX] += t_acc * we_a * dt
        ys[Y_ENG_KE] += t_inertia * we_a * dt
        ys[Y_TC_LOSS] += t_pump * (we_a - w_t_a) * dt
        ys[Y_GB_LOSS] += (t_pump * w_t_a - f_pt * v_a) * dt
        ys[Y_WHEEL] += f_pt * v_a * dt
        ys[Y_BRAKE] += f_brk * v_a * dt
        ys[Y_ROAD] += fl * v_a * dt
        ys[Y_DIST] += v_a * dt
        if not locked:
            ys[Y_UNLOCK] += dt
        ys[Y_ENG_SPD_MAX] = max(ys[Y_ENG_SPD_MAX], we1)
        # ---------------- driver memory (conditional integration)
        f_real = f_pt - f_brk
        if abs(f_real - f_dem) <= max(100.0, 0.05 * abs(f_dem)):
            i_drv += prm[C_DRV_KI] * (vnext - v1) * dt
            i_drv = min(max(i_drv, -prm[C_DRV_INT_LIM]), prm[C_DRV_INT_LIM])
        miss = max(band_lo[i + 1] - v1, v1 - band_hi[i + 1], 0.0)
        if miss > 0.0:
            ys[Y_MISS_N] += 1.0
        ys[Y_MISS_MAX] = max(ys[Y_MISS_MAX], miss)
        v = v1
        we = we1
        if record:
            j = i + 1
            out[j, O_VEH_SPD] = v1
            out[j, O_VEH_SPD_TARGET] = vnext
            out[j, O_VEH_ACC] = (v1 - v0) / dt
            out[j, O_VEH_FRC_IN] = f_pt - f_brk
            out[j, O_VEH_FRC_LOSS] = fl
            out[j, O_WHL_TRQ_OUT] = f_pt * rw
            out[j, O_WHL_SPD] = v1 / rw
            out[j, O_ENG_SPD_OUT] = we1
            out[j, O_ENG_TRQ_OUT] = t_e
            out[j, O_ENG_PWR_OUT] = p_e
            out[j, O_ENG_FUEL_CUT] = 1.0 if cut else 0.0
            out[j, O_FUEL_RATE] = fuel
            out[j, O_GB_GEAR] = gear
            out[j, O_GB_SPD_IN] = w_t_a
            out[j, O_BRK_FRC] = f_brk
            out[j, O_DRV_FRC_DEMAND] = f_dem
            out[j, O_DRV_PWR_DEMAND] = p_dem
    ys[Y_KE1] = 0.5 * m_eq * v * v
    ys[Y_DUR] = (n - 1) * dt
    return ys
