"""The compiled time loop of the forward-looking parallel hybrid (engine + motor on one shaft).

Engine and motor share the crankshaft (one speed ``ω``), ahead of a clutch (manual) or a
lock-up coupling (automatic), the gearbox and the final drive. State: vehicle speed ``v``
[m/s], shaft speed ``ω`` [rad/s], gear, engine on/off, SOC, time since the last shift.
One step:

1. driver: wheel force demand (:func:`vehval.sim.phases.driver_demand`);
2. gear: the conventional car's shift lines (:func:`select_gear`);
3. engine on/off (:func:`engine_on_rule`): idle stop below ``stop_spd`` while decelerating
   or standing, restart on a drive demand or a low SOC; the motor cranks the shaft
   (``restart_j`` from the battery);
4. shaft speed: with the gearbox input above idle and the clutch closed (manual) or the
   coupling locked (automatic), ``ω`` is the gearbox input speed; else the clutch slips
   at idle (manual) or the coupling law sets it (automatic);
5. motor torque (:func:`motor_torque_rule`): assist / regen / charge thresholds, capped by
   the machine and the battery's power limits;
6. engine torque = shaft demand − motor torque + accessories + shaft inertia, within the
   full-load curve and the motoring drag; fuel cut on overrun;
7. battery: ``P = P_motor,el + P_aux,el (+ restart)``, current from OCV and R (discharge or
   charge resistance), SOC by charge counting;
8. vehicle: ``m_eq dv/dt = F_powertrain − F_brake − F_road``.
"""

from __future__ import annotations

import numpy as np

from vehval.numba_cache import njit
from vehval.sim.components.battery import current_from_power, terminal_voltage
from vehval.sim.components.body import longitudinal_step
from vehval.sim.components.electric_machine import (
    electrical_power,
    torque_for_power,
    torque_limit,
)
from vehval.sim.components.engine import fuel_rate, max_torque, warmup_factor
from vehval.sim.conventional_kernel import STANDSTILL_MPS, coupling_pump_speed, select_gear
from vehval.sim.driver import band_miss, driver_memory
from vehval.sim.indices import *  # noqa: F401,F403 - index constants
from vehval.sim.layout import PAR_PARAMS, PAR_SIGNALS, PAR_SUMMARY
from vehval.sim.maps import interp1
from vehval.sim.phases import driver_demand

__all__ = ["PAR_PARAMS", "PAR_SIGNALS", "PAR_SUMMARY", "engine_on_rule", "motor_torque_rule",
           "run_parallel"]

#: motor-rule modes (the ``mode`` returned by :func:`motor_torque_rule`)
MODE_NONE, MODE_ASSIST, MODE_REGEN, MODE_CHARGE = 0, 1, 2, 3
#: [s] cranking time: the restart energy is drawn at ``restart_j / CRANK_S`` [W]
CRANK_S = 0.5


@njit(cache=True)
def engine_on_rule(on, f_dem, v0, standstill, soc, stop_spd, stop_soc):
    """Engine state after the idle-stop rule (True: running).

    A running engine stops when SOC >= ``stop_soc`` and the car stands, or decelerates
    (no drive demand, ``f_dem`` <= 0 [N]) below ``stop_spd`` [m/s]; a stopped engine
    restarts on a drive demand of a car that moves (a standing car's demand is the driver
    memory's residual, a few newtons, held by the brake) or when SOC falls below
    ``stop_soc``."""
    if on:
        if soc >= stop_soc and f_dem <= 0.0 and (standstill or v0 < stop_spd):
            return False
        return True
    return (f_dem > 0.0 and not standstill) or soc < stop_soc


@njit(cache=True)
def motor_torque_rule(prm, t_req, gear, v0, soc, coupled):
    """Motor torque [N·m] before the machine and battery limits, and its mode.

    ``t_req`` shaft torque demand [N·m]; ``coupled``: the shaft drives the wheels (clutch
    closed / coupling locked). Returns (torque, mode) with the modes ``MODE_*``."""
    if not coupled:
        return 0.0, MODE_NONE
    if t_req > prm[HP_ASSIST_THR] and gear >= prm[HP_ASSIST_GEAR] and soc > prm[HP_ASSIST_SOC]:
        t = prm[HP_ASSIST_MIN] + prm[HP_ASSIST_SLOPE] * (t_req - prm[HP_ASSIST_THR])
        return min(t, prm[HP_ASSIST_MAX]), MODE_ASSIST
    if t_req < prm[HP_REGEN_THR] and v0 > prm[HP_REGEN_SPD] and soc < prm[HP_REGEN_SOC]:
        return prm[HP_REGEN_FRAC] * t_req, MODE_REGEN
    if t_req >= 0.0 and soc < prm[HP_SOC_TARGET] - prm[HP_CHARGE_BAND]:
        return -prm[HP_CHARGE_TRQ], MODE_CHARGE
    return 0.0, MODE_NONE


@njit(cache=True)
def _limit_motor(t_m, w, prm, mS, mT, mL, p_dis, p_chg):
    """Motor torque within its torque/power curve and the battery's power limits [W]."""
    if w <= 0.0:
        return 0.0
    tl = torque_limit(prm[HP_MOT_TMAX], prm[HP_MOT_PMAX], w)
    t_m = min(max(t_m, -tl), tl)
    acc = prm[HP_ELEC_ACC]
    if t_m > 0.0 and electrical_power(mS, mT, mL, w, t_m) + acc > p_dis:
        t_m = torque_for_power(mS, mT, mL, w, p_dis - acc, 0.0, t_m)
    elif t_m < 0.0 and electrical_power(mS, mT, mL, w, t_m) + acc < -p_chg:
        a, b = t_m, 0.0  # bisection: the most negative torque inside the charge limit
        for _ in range(30):
            m = 0.5 * (a + b)
            if electrical_power(mS, mT, mL, w, m) + acc < -p_chg:
                a = m
            else:
                b = m
        t_m = b
    return t_m


@njit(cache=True)
def _start_stop(ys, on, new_on, w, w_g, idle, auto, j_sh, restart_j, crank_j):
    """A restart: the motor cranks the shaft to its running speed (``restart_j`` [J] owed by
    the battery, at least the shaft's kinetic energy); a stop: the engine's friction takes
    the shaft's kinetic energy. Returns the shaft speed [rad/s] and the cranking energy
    still owed [J]."""
    if new_on and not on:
        w_start = max(w_g, idle) if not auto else idle
        ke = 0.5 * j_sh * w_start * w_start
        e_bat = max(restart_j, ke)
        ys[HY_RESTART_LOSS_J] += e_bat - ke
        ys[HY_SHAFT_KE_CHANGE_J] += ke
        ys[HY_ENGINE_STARTS] += 1.0
        return w_start, crank_j + e_bat
    if on and not new_on:
        ke = 0.5 * j_sh * w * w
        ys[HY_SHAFT_KE_CHANGE_J] -= ke
        ys[HY_ENG_LOSS_J] += ke
        return 0.0, crank_j
    return w, crank_j


@njit(cache=True)
def _shaft(prm, on, auto, v0, w, w_g, t_in, idle, lock_v, standstill, t_shift, shift_time,
           a_eng):
    """Shaft speed at the end of the step and its mean [rad/s], whether the shaft drives the
    wheels (clutch closed / coupling locked), and the torque the clutch or coupling passes
    [N·m]: (coupled, w1, w_a, t_req). ``w_g`` gearbox input speed, ``t_in`` the demand at
    the gearbox input, ``lock_v`` the gear's lock-up speed (automatic)."""
    if not on:
        return False, 0.0, 0.0, 0.0
    if auto:
        coupled = v0 >= lock_v and w_g >= idle
        w_tgt = w_g if coupled else max(coupling_pump_speed(w_g, max(t_in, 0.0),
                                                            prm[HP_TC_K]), idle)
    else:
        coupled = w_g >= idle and not standstill
        w_tgt = w_g if coupled else idle
    if coupled and t_shift >= shift_time:
        w1 = w_tgt
    else:
        w1 = w + a_eng * (w_tgt - w)
    w_a = 0.5 * (w + w1)
    if standstill or (not auto and t_shift < shift_time):
        t_req = 0.0  # clutch open: standing, or a manual shift under way
    elif coupled:
        t_req = t_in
    elif auto:
        t_req = min(prm[HP_TC_K] * w_a * (w_a - w_g), max(t_in, 0.0))
    else:
        t_req = max(t_in, 0.0)  # the slipping launch clutch passes the demand
    return coupled, w1, w_a, t_req


@njit(cache=True)
def _engine(prm, eS, eT, eF, eTm, on, standstill, t_req, t_m, t_acc, t_inertia, w, w1, w_a,
            j_sh, dt, t_mid):
    """Engine torque [N·m] within full load and motoring drag, fuel [kg/s] (cut on
    overrun); standing with the clutch open, the shaft speed takes what a limit leaves.
    Returns (t_e, t_inertia, w1, w_a, fuel, cut)."""
    if not on:
        return 0.0, t_inertia, w1, w_a, 0.0, False
    t_e = t_req - t_m + t_acc + t_inertia
    t_full = max_torque(eS, eTm, w_a)
    if t_e > t_full:
        t_e = t_full
    if t_e < -prm[HP_ENG_DRAG]:
        t_e = -prm[HP_ENG_DRAG]
    if standstill and t_e != t_req - t_m + t_acc + t_inertia:
        t_inertia = t_e + t_m - t_acc
        w1 = max(w + t_inertia * dt / j_sh, 0.0)
        t_inertia = j_sh * (w1 - w) / dt
        w_a = 0.5 * (w + w1)
        t_e = t_acc + t_inertia - t_m
    cut = False
    fuel = 0.0
    if t_e <= 0.0 and w_a >= prm[HP_FUEL_CUT_SPD] and not standstill:
        cut = True
    else:
        fuel = fuel_rate(eS, eT, eF, w_a, t_e)
    fuel *= warmup_factor(prm[HP_WARM_FRAC], prm[HP_WARM_TAU], t_mid)
    return t_e, t_inertia, w1, w_a, fuel, cut


@njit(cache=True)
def _book(ys, dt, lhv, elec_acc, fuel, p_e, p_el, t_m, w_a, ocv, cur, r, vb, t_acc, t_inertia,
          t_sh, w_in, f_pt, v_a, f_brk, fl, on, mode, w1, soc):
    """Energy bookkeeping of one step (mid-step speeds) into the summary vector ``ys``."""
    ys[HY_FUEL_MASS_KG] += fuel * dt
    ys[HY_FUEL_ENERGY_J] += fuel * lhv * dt
    ys[HY_ENG_OUT_ENERGY_J] += p_e * dt
    ys[HY_ENG_LOSS_J] += (fuel * lhv - p_e) * dt
    ys[HY_MOT_LOSS_J] += (p_el - t_m * w_a) * dt
    ys[HY_ESS_CHEM_ENERGY_J] += ocv * cur * dt
    ys[HY_ESS_LOSS_J] += cur * cur * r * dt
    if cur >= 0.0:
        ys[HY_ESS_OUT_ENERGY_J] += vb * cur * dt
    else:
        ys[HY_ESS_IN_ENERGY_J] -= vb * cur * dt
    ys[HY_AUX_MECH_ENERGY_J] += t_acc * w_a * dt
    ys[HY_AUX_ELEC_ENERGY_J] += elec_acc * dt
    ys[HY_SHAFT_KE_CHANGE_J] += t_inertia * w_a * dt
    ys[HY_CLUTCH_LOSS_J] += t_sh * (w_a - w_in) * dt
    ys[HY_GEARBOX_LOSS_J] += (t_sh * w_in - f_pt * v_a) * dt
    ys[HY_WHEEL_ENERGY_J] += f_pt * v_a * dt
    ys[HY_BRAKE_ENERGY_J] += f_brk * v_a * dt
    ys[HY_ROAD_ENERGY_J] += fl * v_a * dt
    ys[HY_DISTANCE_M] += v_a * dt
    if on:
        ys[HY_ENG_ON_TIME_S] += dt
    if mode == MODE_ASSIST and t_m > 0.0:
        ys[HY_ASSIST_TIME_S] += dt
        ys[HY_ASSIST_ENERGY_J] += t_m * w_a * dt
    elif mode == MODE_REGEN and t_m < 0.0:
        ys[HY_REGEN_TIME_S] += dt
        ys[HY_REGEN_ENERGY_J] -= t_m * w_a * dt
    ys[HY_ENG_SPD_MAX] = max(ys[HY_ENG_SPD_MAX], w1)
    ys[HY_SOC_MIN_SEEN] = min(ys[HY_SOC_MIN_SEEN], soc)
    ys[HY_SOC_MAX_SEEN] = max(ys[HY_SOC_MAX_SEEN], soc)


@njit(cache=True)
def _record(out, j, dt, v0, v1, vnext, f_pt, f_brk, fl, rw, w1, t_e, p_e, on, cut, fuel, t_m,
            p_el, vb, cur, p_bt, soc, gear, w_g_a, f_dem, p_dem):
    """Row ``j`` of the recorded signals (``PAR_SIGNALS`` columns, SI)."""
    out[j, HS_VEH_SPD] = v1
    out[j, HS_VEH_SPD_TARGET] = vnext
    out[j, HS_VEH_ACC] = (v1 - v0) / dt
    out[j, HS_VEH_FRC_IN] = f_pt - f_brk
    out[j, HS_VEH_FRC_LOSS] = fl
    out[j, HS_WHL_TRQ_OUT] = f_pt * rw
    out[j, HS_WHL_SPD] = v1 / rw
    out[j, HS_ENG_SPD_OUT] = w1
    out[j, HS_ENG_TRQ_OUT] = t_e
    out[j, HS_ENG_PWR_OUT] = p_e
    out[j, HS_ENG_ON] = 1.0 if on else 0.0
    out[j, HS_ENG_FUEL_CUT] = 1.0 if cut else 0.0
    out[j, HS_FUEL_RATE] = fuel
    out[j, HS_MOT_SPD_OUT] = w1
    out[j, HS_MOT_TRQ_OUT] = t_m
    out[j, HS_MOT_PWR_IN] = p_el
    out[j, HS_ESS_VOLT] = vb
    out[j, HS_ESS_CURR] = cur
    out[j, HS_ESS_PWR] = p_bt
    out[j, HS_ESS_SOC] = soc
    out[j, HS_GB_GEAR] = gear
    out[j, HS_GB_SPD_IN] = w_g_a
    out[j, HS_BRK_FRC] = f_brk
    out[j, HS_DRV_FRC_DEMAND] = f_dem
    out[j, HS_DRV_PWR_DEMAND] = p_dem


@njit(cache=True)
def run_parallel(vt, band_lo, band_hi, dt, prm, eS, eT, eF, eTm, mS, mT, mL, bS, bV, bRd, bRc,
                 bPd, bPc, ratios, up0, up1, dn0, dn1, lock_v, out, record):  # long: one compiled time loop (numba)
    """Simulate one cycle; returns the summary vector (``PAR_SUMMARY`` order).

    ``vt`` target speed [m/s] on a uniform grid of step ``dt`` [s]; ``band_lo/hi`` its EPA
    band; ``prm`` scalars (``PAR_PARAMS``, SI); engine maps ``eS, eT, eF, eTm`` (speed
    [rad/s], torque [N·m], fuel [kg/s], full load [N·m]); motor loss map ``mS, mT, mL``;
    battery tables over SOC ``bS``: OCV [V], discharge / charge resistance [Ω], power
    limits [W]; gearbox ``ratios``, shift lines [m/s], lock-up speeds ``lock_v`` [m/s]
    (automatic); ``out`` (n, len(PAR_SIGNALS)) written when ``record``.
    """
    n = vt.shape[0]
    ys = np.zeros(N_HY)
    rw = prm[HP_R_WHEEL]; fd = prm[HP_FD_RATIO]
    eff = prm[HP_FD_EFF] * prm[HP_GB_EFF]
    m_eq = prm[HP_MASS] + prm[HP_J_WHEEL] / (rw * rw)
    rl_a = prm[HP_RL_A]; rl_b = prm[HP_RL_B]; rl_c = prm[HP_RL_C]
    idle = prm[HP_ENG_IDLE]; j_sh = prm[HP_J_ENG] + prm[HP_J_MOT]
    lhv = prm[HP_FUEL_LHV]; shift_time = prm[HP_SHIFT_TIME]; auto = prm[HP_AUTOMATIC] > 0.5
    a_eng = min(dt / max(0.5 * shift_time, dt), 1.0)
    f_min = -(prm[HP_BRK_MAX] + 1e4)
    cap = prm[HP_BATT_CAP_C]
    v = vt[0]; gear = 1; t_shift = shift_time; w = idle; on = True; i_drv = 0.0
    soc = prm[HP_SOC_INIT]
    crank_j = 0.0  # [J] cranking energy the battery still owes
    p_crank = prm[HP_RESTART_J] / CRANK_S
    ys[HY_KE_START_J] = 0.5 * m_eq * v * v
    ys[HY_SOC_MIN_SEEN] = soc; ys[HY_SOC_MAX_SEEN] = soc
    if record:
        out[0, HS_VEH_SPD] = v; out[0, HS_VEH_SPD_TARGET] = vt[0]; out[0, HS_WHL_SPD] = v / rw
        out[0, HS_ENG_SPD_OUT] = w; out[0, HS_MOT_SPD_OUT] = w; out[0, HS_GB_GEAR] = 1.0
        out[0, HS_ENG_ON] = 1.0; out[0, HS_ESS_SOC] = soc
        out[0, HS_ESS_VOLT] = interp1(bS, bV, soc)
    for i in range(n - 1):
        v0 = v
        vnext = vt[i + 1]
        f_dem, _ = driver_demand(v0, vt[i], vnext, dt, m_eq, rl_a, rl_b, rl_c, i_drv,
                                 prm[HP_DRV_TAU], f_min, prm[HP_DRV_FMAX])
        p_dem = f_dem * max(v0, 0.0)
        standstill = v0 < STANDSTILL_MPS and vnext < STANDSTILL_MPS
        # ---------------- gear
        t_shift += dt
        new_gear = gear
        if standstill:
            new_gear = 1
        elif t_shift >= shift_time:
            load = min(max(p_dem / prm[HP_ENG_PMAX], 0.0), 1.0)
            new_gear = select_gear(gear, v0, load, up0, up1, dn0, dn1)
        if new_gear != gear:
            ys[HY_GEAR_SHIFTS] += 1.0
            t_shift = 0.0
            gear = new_gear
        ratio = ratios[gear - 1] * fd
        w_g = ratio * v0 / rw
        f_drag = 0.0
        t_wh = f_dem * rw
        t_in = t_wh / (ratio * eff) if t_wh >= 0.0 else t_wh * eff / ratio
        # ---------------- battery limits, engine on/off
        ocv = interp1(bS, bV, soc)
        p_dis = interp1(bS, bPd, soc) if soc > prm[HP_SOC_LO] else 0.0
        p_chg = interp1(bS, bPc, soc) if soc < prm[HP_SOC_HI] else 0.0
        new_on = engine_on_rule(on, f_dem, v0, standstill, soc, prm[HP_STOP_SPD],
                                prm[HP_STOP_SOC])
        p_restart = 0.0
        w, crank_j = _start_stop(ys, on, new_on, w, w_g, idle, auto, j_sh, prm[HP_RESTART_J],
                                 crank_j)
        on = new_on
        if crank_j > 0.0:
            p_restart = min(crank_j, p_crank * dt) / dt
            crank_j -= p_restart * dt
        # ---------------- shaft speed and what the clutch / coupling passes
        coupled, w1, w_a, t_req = _shaft(prm, on, auto, v0, w, w_g, t_in, idle, lock_v[gear - 1],
                                         standstill, t_shift, shift_time, a_eng)
        # ---------------- motor and engine torque
        t_m, mode = motor_torque_rule(prm, t_req, gear, v0, soc, coupled and on)
        t_m = _limit_motor(t_m, w_a, prm, mS, mT, mL, p_dis, p_chg)
        t_inertia = j_sh * (w1 - w) / dt if on else 0.0
        t_acc = prm[HP_MECH_ACC] / max(w_a, idle) if on else 0.0
        t_e, t_inertia, w1, w_a, fuel, cut = _engine(prm, eS, eT, eF, eTm, on, standstill,
                                                     t_req, t_m, t_acc, t_inertia, w, w1, w_a,
                                                     j_sh, dt, (i + 0.5) * dt)
        t_sh = t_e + t_m - t_acc - t_inertia if on and not standstill else 0.0
        # a motor commanded to no torque draws nothing when the inverter switches off
        idle_off = t_m == 0.0 and prm[HP_MOT_IDLE_OFF] > 0.5
        p_el = electrical_power(mS, mT, mL, w_a, t_m) if on and not idle_off else 0.0
        # ---------------- battery
        p_bt = p_el + prm[HP_ELEC_ACC] + p_restart
        r = interp1(bS, bRd, soc) if p_bt >= 0.0 else interp1(bS, bRc, soc)
        cur = current_from_power(p_bt, ocv, r)
        vb = terminal_voltage(ocv, r, cur)
        soc = soc - cur * dt / cap
        # ---------------- vehicle
        f_pt = t_sh * ratio / rw
        f_pt = (f_pt * eff if f_pt >= 0.0 else f_pt / eff) - f_drag
        v1, f_brk, fl = longitudinal_step(v0, f_pt, f_dem, prm[HP_BRK_MAX], rl_a, rl_b, rl_c,
                                            m_eq, dt)
        v_a = 0.5 * (v0 + v1)
        # ---------------- energy bookkeeping (mid-step speeds)
        w_g_a = ratio * v_a / rw
        p_e = t_e * w_a
        w_in = w_a if coupled else w_g_a  # gearbox input speed (the shaft's when coupled)
        _book(ys, dt, lhv, prm[HP_ELEC_ACC], fuel, p_e, p_el, t_m, w_a, ocv, cur, r, vb, t_acc,
              t_inertia, t_sh, w_in, f_pt, v_a, f_brk, fl, on, mode, w1, soc)
        # ---------------- driver memory (conditional integration)
        i_drv = driver_memory(i_drv, f_pt - f_brk, f_dem, prm[HP_DRV_KI], prm[HP_DRV_INT_LIM],
                              vnext, v1, dt)
        miss = band_miss(band_lo[i + 1], band_hi[i + 1], v1)
        if miss > 0.0:
            ys[HY_TRACE_N_MISS] += 1.0
        ys[HY_TRACE_MAX_MISS_MPS] = max(ys[HY_TRACE_MAX_MISS_MPS], miss)
        v = v1
        w = w1
        if record:
            _record(out, i + 1, dt, v0, v1, vnext, f_pt, f_brk, fl, rw, w1, t_e, p_e, on, cut,
                    fuel, t_m, p_el, vb, cur, p_bt, soc, gear, w_g_a, f_dem, p_dem)
    ys[HY_KE_END_J] = 0.5 * m_eq * v * v
    ys[HY_RESTART_LOSS_J] -= crank_j  # cranking energy not yet drawn at the end
    ys[HY_SOC_FINAL] = soc
    ys[HY_DURATION_S] = (n - 1) * dt
    return ys
