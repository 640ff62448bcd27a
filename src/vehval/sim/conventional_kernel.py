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

from vehval.numba_cache import njit
from vehval.sim.components.body import longitudinal_step
from vehval.sim.components.engine import fuel_rate, max_torque, warmup_factor
from vehval.sim.driver import band_miss, driver_memory
from vehval.sim.indices import *  # noqa: F401,F403 - index constants
from vehval.sim.layout import CONV_PARAMS, CONV_SIGNALS, CONV_SUMMARY
from vehval.sim.phases import driver_demand

__all__ = ["CONV_PARAMS", "CONV_SIGNALS", "CONV_SUMMARY", "STANDSTILL_MPS", "coupling_pump_speed",
           "run_conventional", "select_gear"]

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
                     dn1, lock_v, out, record):  # long: one compiled time loop (numba)
    """Simulate one cycle; returns the summary vector (``CONV_SUMMARY`` order).

    ``vt`` target speed [m/s] on a uniform grid of step ``dt`` [s]; ``band_lo/hi`` its EPA
    band [m/s]; ``prm`` scalars (``CONV_PARAMS``, SI); ``eS, eT, eF, eTm`` engine speed
    [rad/s], torque [N·m] breakpoints, fuel map [kg/s], full-load torque [N·m]; ``ratios``
    gearbox ratios; ``up0/up1/dn0/dn1`` shift lines [m/s] at zero / full load; ``lock_v``
    lock-up speed per gear [m/s]; ``out`` (n, len(CONV_SIGNALS)) written when ``record``.
    """
    n = vt.shape[0]
    ys = np.zeros(N_CY)
    rw = prm[CP_R_WHEEL]; fd = prm[CP_FD_RATIO]
    eff = prm[CP_FD_EFF] * prm[CP_GB_EFF]
    m_eq = prm[CP_MASS] + prm[CP_J_WHEEL] / (rw * rw)
    rl_a = prm[CP_RL_A]; rl_b = prm[CP_RL_B]; rl_c = prm[CP_RL_C]
    idle = prm[CP_ENG_IDLE]; j_e = prm[CP_J_ENG]; k_tc = prm[CP_TC_K]
    acc = prm[CP_ACC_PWR]; pmax = prm[CP_ENG_PMAX]; lhv = prm[CP_FUEL_LHV]
    acc_idle = prm[CP_IDLE_ACC_PWR]
    shift_time = prm[CP_SHIFT_TIME]
    a_eng = min(dt / max(0.5 * shift_time, dt), 1.0)
    f_min = -(prm[CP_BRK_MAX] + 1e4)
    v = vt[0]
    gear = 1
    t_shift = shift_time
    we = idle
    i_drv = 0.0
    ys[CY_KE_START_J] = 0.5 * m_eq * v * v
    if record:
        out[0, CS_VEH_SPD] = v; out[0, CS_VEH_SPD_TARGET] = vt[0]; out[0, CS_WHL_SPD] = v / rw
        out[0, CS_ENG_SPD_OUT] = we; out[0, CS_GB_GEAR] = 1.0
    for i in range(n - 1):
        v0 = v
        vnow = vt[i]
        vnext = vt[i + 1]
        # ---------------- driver
        f_dem, _ = driver_demand(v0, vnow, vnext, dt, m_eq, rl_a, rl_b, rl_c, i_drv,
                                prm[CP_DRV_TAU], f_min, prm[CP_DRV_FMAX])
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
            ys[CY_GEAR_SHIFTS] += 1.0
            t_shift = 0.0
            gear = new_gear
        ratio = ratios[gear - 1] * fd
        w_t = ratio * v0 / rw
        locked = v0 >= lock_v[gear - 1] and w_t >= idle
        # ---------------- converter and engine speed
        f_drag = prm[CP_DRAG_A] + prm[CP_DRAG_B] * v0 if v0 >= STANDSTILL_MPS else 0.0
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
        if t_e < -prm[CP_ENG_DRAG]:
            t_e = -prm[CP_ENG_DRAG]
            t_pump = t_e - t_acc - t_inertia
        if standstill:
            fuel = prm[CP_IDLE_FUEL]
            if acc != acc_idle:
                t_base = t_e - t_acc + acc_idle / max(we_a, idle)
                fuel += max(fuel_rate(eS, eT, eF, we_a, t_e) - fuel_rate(eS, eT, eF, we_a, t_base),
                            0.0)
            cut = False
            ys[CY_IDLE_TIME_S] += dt
        elif t_e <= 0.0 and we_a >= prm[CP_FUEL_CUT_SPD]:
            fuel = prm[CP_OVERRUN_FUEL]
            cut = True
            ys[CY_FUEL_CUT_TIME_S] += dt
        else:
            fuel = fuel_rate(eS, eT, eF, we_a, t_e)
            cut = False
        fuel *= warmup_factor(prm[CP_WARM_FRAC], prm[CP_WARM_TAU], (i + 0.5) * dt)
        # ---------------- vehicle
        f_pt = t_pump * ratio / rw
        f_pt = (f_pt * eff if f_pt >= 0.0 else f_pt / eff) - f_drag
        v1, f_brk, fl = longitudinal_step(v0, f_pt, f_dem, prm[CP_BRK_MAX], rl_a, rl_b, rl_c,
                                            m_eq, dt)
        v_a = 0.5 * (v0 + v1)
        # ---------------- energy bookkeeping (mid-step speeds)
        w_t_a = ratio * v_a / rw
        p_e = t_e * we_a
        ys[CY_FUEL_MASS_KG] += fuel * dt
        ys[CY_FUEL_ENERGY_J] += fuel * lhv * dt
        ys[CY_ENG_OUT_ENERGY_J] += p_e * dt
        ys[CY_ENG_LOSS_J] += (fuel * lhv - p_e) * dt
        ys[CY_AUX_ENERGY_J] += t_acc * we_a * dt
        ys[CY_ENG_KE_CHANGE_J] += t_inertia * we_a * dt
        ys[CY_CONVERTER_LOSS_J] += t_pump * (we_a - w_t_a) * dt
        ys[CY_GEARBOX_LOSS_J] += (t_pump * w_t_a - f_pt * v_a) * dt
        ys[CY_WHEEL_ENERGY_J] += f_pt * v_a * dt
        ys[CY_BRAKE_ENERGY_J] += f_brk * v_a * dt
        ys[CY_ROAD_ENERGY_J] += fl * v_a * dt
        ys[CY_DISTANCE_M] += v_a * dt
        if not locked:
            ys[CY_UNLOCKED_TIME_S] += dt
        ys[CY_ENG_SPD_MAX] = max(ys[CY_ENG_SPD_MAX], we1)
        # ---------------- driver memory (conditional integration)
        i_drv = driver_memory(i_drv, f_pt - f_brk, f_dem, prm[CP_DRV_KI], prm[CP_DRV_INT_LIM],
                              vnext, v1, dt)
        miss = band_miss(band_lo[i + 1], band_hi[i + 1], v1)
        if miss > 0.0:
            ys[CY_TRACE_N_MISS] += 1.0
        ys[CY_TRACE_MAX_MISS_MPS] = max(ys[CY_TRACE_MAX_MISS_MPS], miss)
        v = v1
        we = we1
        if record:
            j = i + 1
            out[j, CS_VEH_SPD] = v1
            out[j, CS_VEH_SPD_TARGET] = vnext
            out[j, CS_VEH_ACC] = (v1 - v0) / dt
            out[j, CS_VEH_FRC_IN] = f_pt - f_brk
            out[j, CS_VEH_FRC_LOSS] = fl
            out[j, CS_WHL_TRQ_OUT] = f_pt * rw
            out[j, CS_WHL_SPD] = v1 / rw
            out[j, CS_ENG_SPD_OUT] = we1
            out[j, CS_ENG_TRQ_OUT] = t_e
            out[j, CS_ENG_PWR_OUT] = p_e
            out[j, CS_ENG_FUEL_CUT] = 1.0 if cut else 0.0
            out[j, CS_FUEL_RATE] = fuel
            out[j, CS_GB_GEAR] = gear
            out[j, CS_GB_SPD_IN] = w_t_a
            out[j, CS_BRK_FRC] = f_brk
            out[j, CS_DRV_FRC_DEMAND] = f_dem
            out[j, CS_DRV_PWR_DEMAND] = p_dem
    ys[CY_KE_END_J] = 0.5 * m_eq * v * v
    ys[CY_DURATION_S] = (n - 1) * dt
    return ys
