"""The phases of one time step of the power-split loop (:func:`vehval.sim.kernel.run`).

A step runs, in order: :func:`driver_phase` (wheel force demand), :func:`supervisor_phase`
(battery limits, power demand, the engine rule of :mod:`vehval.sim.supervisor`),
:func:`operating_point_phase` (engine speed target and torque), :func:`engine_torque_phase`,
:func:`torque_split_phase` (eq. 1-2 with the battery limits and braking), then the plant
phases of :mod:`vehval.sim.plant` (two-DOF lever, battery, energy accounts, controller
memories, recording).

Every phase is a compiled function ``phase(prm, maps, x)`` of the parameter vector
(:data:`vehval.sim.layout.PARAMS`), the map tuple (:data:`vehval.sim.packing.MAP_NAMES`)
and the loop's state vector (:data:`vehval.sim.layout.STATE`): it reads its inputs from
``x`` and writes its results back (inlined into the loop by LLVM). Index constants come
from :mod:`vehval.sim.indices`. Units: SI throughout (m/s, rad/s, N, N·m, W, J, s; SOC as
a fraction).
"""

from __future__ import annotations

import numpy as np

from vehval.numba_cache import njit
from vehval.sim.components.battery import current_from_power
from vehval.sim.components.body import road_load
from vehval.sim.components.boost import battery_side_power
from vehval.sim.components.electric_machine import electrical_power, torque_for_power, torque_limit
from vehval.sim.components.engine import fuel_rate, max_torque
from vehval.sim.control import (
    ENG_OFF,
    PROPEL_BRAKING,
    PROPEL_CHARGE_LIMIT,
    PROPEL_DISCHARGE_LIMIT,
    PROPEL_NORMAL,
    regen_fade,
)
from vehval.sim.driver import driver_force
from vehval.sim.indices import *  # noqa: F401,F403 - index constants
from vehval.sim.maps import interp1
from vehval.sim.supervisor import engine_rule


@njit(cache=True)
def bus_allowed(batt_power, eff):
    """Bus power [W] that corresponds to a battery-side power [W] (inverse of battery_side_power)."""
    if batt_power >= 0.0:
        return batt_power * eff
    return batt_power / eff


@njit(cache=True)
def mot_power(mS, mT, mL, rg, w_ring, t_ring_side):
    """MG2 DC power [W] for a ring-side speed [rad/s] and ring-side torque [N·m].

    ``rg`` is the MG2 reduction ratio (MG2 shaft speed / ring speed); the map is read at
    the shaft speed and torque.
    """
    return electrical_power(mS, mT, mL, rg * w_ring, t_ring_side / rg)


@njit(cache=True)
def mot_torque_for_power(mS, mT, mL, rg, w_ring, p_target, t_lo, t_hi):
    """Ring-side MG2 torque [N·m] in [t_lo, t_hi] drawing at most ``p_target`` [W]."""
    return rg * torque_for_power(mS, mT, mL, rg * w_ring, p_target, t_lo / rg, t_hi / rg)


@njit(cache=True, inline="always")
def start_phase(prm, maps, x, v_start, dt):
    """Constants of the run and the initial state (vehicle at ``v_start`` [m/s], engine off
    and stopped, SOC ``soc_init``) in the zeroed state vector ``x``."""
    ns = prm[P_N_SUN]; nr = prm[P_N_RING]; rw = prm[P_R_WHEEL]; fd = prm[P_FD_RATIO]
    rg = prm[P_MG2_RATIO]  # MG2 shaft speed / ring speed
    cold = prm[P_COLD_START] > 0.5
    k1 = (nr + ns) / ns
    k2 = nr / ns
    g = fd / rw
    j_gen = prm[P_J_GEN]
    m11 = prm[P_J_ENG] + prm[P_J_CARRIER] + j_gen * k1 * k1
    m12 = -j_gen * k1 * k2 * g
    m22 = (prm[P_MASS] + prm[P_J_WHEEL] / (rw * rw)
           + (prm[P_J_MOT] * rg * rg + prm[P_J_RING]) * g * g + j_gen * k2 * k2 * g * g)
    x[X_DT] = dt
    x[X_K1] = k1
    x[X_K2] = k2
    x[X_G] = g
    x[X_M11] = m11
    x[X_M12] = m12
    x[X_M22] = m22
    x[X_DET] = m11 * m22 - m12 * m12
    x[X_F_MIN] = -(prm[P_BRK_MAX] + prm[P_MOT_TMAX] * rg * fd / rw)
    x[X_WG_LIM] = prm[P_GEN_MAX_SPD] - prm[P_GEN_SPD_MARGIN]
    x[X_KI_GEN] = min(prm[P_GEN_KI], 0.5 * prm[P_GEN_KP] / dt)
    x[X_A_FILT] = min(dt / prm[P_ENG_PWR_TAU], 1.0) if prm[P_ENG_PWR_TAU] > 0.0 else 1.0
    x[X_HOLD_S] = prm[P_COLD_HOLD] if cold else 0.0  # engine held on after a cold start [s]
    x[X_WARM_FRAC] = prm[P_WARM_FRAC] if cold else 0.0  # warm-up extra fuel at t = 0 [-]
    x[X_COLD_PWR] = prm[P_COLD_PWR] if cold else 0.0  # engine power floor in the hold [W]
    x[X_V] = v_start
    x[X_SOC] = prm[P_SOC_INIT]
    x[X_LOCKED] = 1.0
    x[X_ENG_STATE] = ENG_OFF


@njit(cache=True, inline="always")
def driver_phase(prm, maps, x):
    """Wheel force demand ``f_dem`` [N] and the wheel power it asks over the step ``p_wh`` [W]."""
    v0 = x[X_V0]; vnext = x[X_VNEXT]
    rl_a = prm[P_RL_A]; rl_b = prm[P_RL_B]; rl_c = prm[P_RL_C]
    f_dem, p_wh = driver_demand(v0, x[X_VNOW], vnext, x[X_DT], x[X_M22], rl_a, rl_b, rl_c,
                                x[X_I_DRV], prm[P_DRV_TAU], x[X_F_MIN], prm[P_DRV_FMAX])
    x[X_F_DEM] = f_dem
    x[X_P_WH] = p_wh


@njit(cache=True, inline="always")
def driver_demand(v0, vnow, vnext, dt, m22, rl_a, rl_b, rl_c, i_drv, drv_tau, f_min, f_max):
    """Wheel force demand [N] and the wheel power it asks over the step [W] (the driver with
    road-load feed-forward; also the conventional loop's driver)."""
    if v0 > 0.0:
        fl_ff = road_load(v0, rl_a, rl_b, rl_c)
    elif vnext > 0.0:
        fl_ff = road_load(vnext, rl_a, rl_b, rl_c)
    else:
        fl_ff = 0.0
    f_dem = driver_force(v0, vnow, vnext, dt, m22, fl_ff, i_drv, drv_tau, f_min, f_max)
    return f_dem, f_dem * 0.5 * (v0 + vnext)


@njit(cache=True, inline="always")
def supervisor_phase(prm, maps, x):
    """Battery limits (OCV [V], discharge/charge limits and what is available inside the
    margins [W]), the filtered power demand [W] and one step of the engine rule
    (:func:`vehval.sim.supervisor.engine_rule`; the engine is held on during a cold
    start's hold)."""
    bSoc, bOcv, bPd, bPc = maps[12], maps[13], maps[16], maps[17]
    soc = x[X_SOC]
    x[X_OCV] = interp1(bSoc, bOcv, soc)
    x[X_PDIS_LIM] = interp1(bSoc, bPd, soc)
    x[X_PCHG_LIM] = interp1(bSoc, bPc, soc)
    x[X_PDIS_AV] = max(x[X_PDIS_LIM] - prm[P_DIS_MARGIN], 0.0)
    x[X_PCHG_AV] = max(x[X_PCHG_LIM] - prm[P_CHG_MARGIN], 0.0)
    engine_rule(prm, x)
    x[X_P_FILT] += x[X_A_FILT] * (x[X_P_TOT] - x[X_P_FILT])


@njit(cache=True)
def system_cost(prm, maps, w, p_eng, t_fd, wr, k1, k2, ocv, r_dis, r_chg):
    """Fuel power plus the fuel-equivalent of the battery power [W] for engine speed ``w``.

    The engine gives ``p_eng`` [W] at ``w`` [rad/s]; MG1 reacts it (T_g = -T_e/k1) and MG2
    completes the wheel torque ``t_fd`` [N·m] at the ring (eq. 1) at the ring speed ``wr``
    [rad/s] (lever ratios ``k1``, ``k2``); the battery (OCV ``ocv`` [V], resistances
    ``r_dis``/``r_chg`` [ohm]) supplies the bus (MG1 + MG2 + losses), the boost losses and
    the accessories; ``eq_factor`` [-]
    converts battery chemical power to fuel power. Returns inf where the engine or MG1
    cannot hold the point.
    """
    eS, eT, eF, eTm, mS = maps[0], maps[1], maps[2], maps[3], maps[6]
    mT, mL, gS, gT, gL = maps[7], maps[8], maps[9], maps[10], maps[11]
    te = p_eng / w
    if te > max_torque(eS, eTm, w):
        return np.inf
    wg = k1 * w - k2 * wr
    tg = -te / k1
    if -tg > torque_limit(prm[P_GEN_TMAX], prm[P_GEN_PMAX], wg):
        return np.inf
    t_m = t_fd - te * k2 / k1
    p_bus = (electrical_power(gS, gT, gL, wg, tg)
             + mot_power(mS, mT, mL, prm[P_MG2_RATIO], wr, t_m))
    p_bt = battery_side_power(p_bus, prm[P_BOOST_EFF]) + prm[P_AUX_W]
    cur = current_from_power(p_bt, ocv, r_dis if p_bt >= 0.0 else r_chg)
    return (fuel_rate(eS, eT, eF, w, te) * prm[P_FUEL_LHV]
            + prm[P_EQ_FACTOR] * ocv * cur)


@njit(cache=True)
def system_speed(prm, maps, p_eng, w_lo, w_hi, w_fallback, t_fd, wr, k1, k2, ocv, soc):
    """Engine speed [rad/s] in [w_lo, w_hi] of least :func:`system_cost` (grid + refine)
    at SOC ``soc`` [-] and OCV ``ocv`` [V].

    ``w_fallback`` is returned when no speed can hold the point.
    """
    bSoc, bRd, bRc = maps[12], maps[14], maps[15]
    if w_hi <= w_lo:
        return w_fallback
    r_dis = interp1(bSoc, bRd, soc)
    r_chg = interp1(bSoc, bRc, soc)
    n = 9
    step = (w_hi - w_lo) / (n - 1)
    best = np.inf
    w_best = w_fallback
    for j in range(n):
        w = w_lo + step * j
        c = system_cost(prm, maps, w, p_eng, t_fd, wr, k1, k2, ocv, r_dis, r_chg)
        if c < best:
            best = c
            w_best = w
    if best == np.inf:
        return w_fallback
    w0 = w_best
    for j in (-2, -1, 1, 2):  # refine between the neighbours of the grid optimum
        w = w0 + step * j / 3.0
        if w < w_lo or w > w_hi:
            continue
        c = system_cost(prm, maps, w, p_eng, t_fd, wr, k1, k2, ocv, r_dis, r_chg)
        if c < best:
            best = c
            w_best = w
    return w_best


@njit(cache=True, inline="always")
def operating_point_phase(prm, maps, x):
    """Engine power ``p_eng`` [W] and speed target ``w_tgt`` [rad/s] for the commanded power
    ``p_cmd``, the speed window (``w_lo``, ``w_hi``), fuel cut, firing state, full-load
    torque ``te_max`` [N·m] and the MG1 speed ``wg0`` [rad/s] at the step start.

    The speed target comes from the best line or the system optimum, inside the MG1 speed
    window; the full-load torque is capped by what MG1 can react and cut above the window.
    """
    eS, eTm, oP, oS = maps[0], maps[3], maps[4], maps[5]
    k1 = x[X_K1]; k2 = x[X_K2]; wr0 = x[X_WR0]; we0 = x[X_WE0]; wg_lim = x[X_WG_LIM]
    cmd_on = x[X_CMD_ON] > 0.5
    fired = x[X_FIRED] > 0.5
    eng_idle = prm[P_ENG_IDLE]; eng_max = prm[P_ENG_MAX_SPD]
    gen_tmax = prm[P_GEN_TMAX]; gen_pmax = prm[P_GEN_PMAX]
    w_lo = max((k2 * wr0 - wg_lim) / k1, 0.0)
    w_hi = min(eng_max - prm[P_ENG_SPD_MARGIN], (wg_lim + k2 * wr0) / k1)
    fuelcut = False
    p_eng = 0.0
    if cmd_on:
        p_eng = max(x[X_P_CMD], 0.0)
        if p_eng > prm[P_FUEL_CUT_PWR]:
            p_eng = min(max(p_eng, prm[P_ENG_MIN_PWR]), prm[P_ENG_PMAX])
            w_tgt = interp1(oP, oS, p_eng)
            if prm[P_OP_SYSTEM] > 0.5:
                # speed of least fuel + fuel-equivalent of the electrical path
                rw = prm[P_R_WHEEL]; fd = prm[P_FD_RATIO]; fd_eff = prm[P_FD_EFF]
                t_wh_e = x[X_F_DEM] * rw
                t_fd_e = t_wh_e / (fd * fd_eff) if t_wh_e >= 0.0 else t_wh_e * fd_eff / fd
                w_tgt = system_speed(prm, maps, p_eng, max(w_lo, eng_idle), w_hi, w_tgt,
                                     t_fd_e, x[X_WR_E], k1, k2, x[X_OCV], x[X_SOC])
        else:
            p_eng = 0.0
            fuelcut = x[X_V0] >= prm[P_FUEL_CUT_SPD]
            w_tgt = eng_idle
        w_tgt = min(max(w_tgt, w_lo), w_hi)
    else:
        w_tgt = w_lo
    if cmd_on:
        fired = we0 >= (0.5 * prm[P_ENG_FIRE] if fired else prm[P_ENG_FIRE])
    else:
        fired = False
    # full-load torque, capped by what MG1 can react (90 %: keep authority for speed
    # control) and cut above the speed window (over-speed protection)
    wg0 = k1 * we0 - k2 * wr0
    te_max_now = min(max_torque(eS, eTm, max(we0, eng_idle)),
                     0.9 * k1 * torque_limit(gen_tmax, gen_pmax, wg0))
    if we0 > w_hi:
        te_max_now *= max(0.0, 1.0 - (we0 - w_hi) / (0.03 * eng_max))
    x[X_W_LO] = w_lo
    x[X_W_HI] = w_hi
    x[X_W_TGT] = w_tgt
    x[X_P_ENG] = p_eng
    x[X_FUELCUT] = 1.0 if fuelcut else 0.0
    x[X_FIRED] = 1.0 if fired else 0.0
    x[X_TE_MAX] = te_max_now
    x[X_WG0] = wg0


@njit(cache=True, inline="always")
def engine_torque_phase(prm, maps, x):
    """Engine torque ``te`` [N·m]: best-line torque when firing (above the target speed,
    the torque giving the demanded power), the drag of an engine spinning unfired, else 0."""
    we0 = x[X_WE0]
    te = 0.0
    if x[X_LOCKED] > 0.5:
        te = 0.0
    elif x[X_FIRED] > 0.5 and not x[X_FUELCUT] > 0.5:
        p_eng = x[X_P_ENG]
        te = min(p_eng / max(x[X_W_TGT], we0), x[X_TE_MAX]) if p_eng > 0.0 else 0.0
    elif we0 > 0.0:
        te = -prm[P_ENG_DRAG]
    x[X_TE] = te


@njit(cache=True)
def resplit(prm, maps, te, t_ring, t_fd, tm_lim, k1, wg0, wr_e):
    """Torque split again after the engine left its best line for a battery limit.

    Returns the generator feed-forward torque [N·m] (-te/k1), the motor torque [N·m] from
    eq. (1) within its limit, and the estimated generator electrical and battery-side
    powers [W] for engine torque ``te`` [N·m] and ring torque ``t_ring`` [N·m] (MG1 speed
    ``wg0``, ring speed ``wr_e`` [rad/s]).
    """
    mS, mT, mL, gS, gT, gL = maps[6], maps[7], maps[8], maps[9], maps[10], maps[11]
    tg_ff = -te / k1
    t_m = min(max(t_fd - t_ring, -tm_lim), tm_lim)
    p_gen = electrical_power(gS, gT, gL, wg0, tg_ff)
    p_mot = mot_power(mS, mT, mL, prm[P_MG2_RATIO], wr_e, t_m)
    return tg_ff, t_m, p_gen, battery_side_power(p_mot + p_gen, prm[P_BOOST_EFF]) + prm[P_AUX_W]


@njit(cache=True, inline="always")
def torque_split_phase(prm, maps, x):
    """Eq. (1)-(2): MG1 feed-forward ``tg_ff``, ring ``t_ring`` and MG2 ``t_m`` torques [N·m]
    within the battery limits (leaving the best line when the battery cannot take the
    difference, which moves ``te``), the MG2 limit ``tm_lim``, the propulsion state and the
    friction brake force ``f_brk`` [N]."""
    mS, mT, mL, gS, gT, gL = maps[6], maps[7], maps[8], maps[9], maps[10], maps[11]
    k1 = x[X_K1]; k2 = x[X_K2]; g = x[X_G]; wr0 = x[X_WR0]; wr_e = x[X_WR_E]; we0 = x[X_WE0]
    wg0 = x[X_WG0]; te = x[X_TE]; te_max_now = x[X_TE_MAX]; p_eng = x[X_P_ENG]
    f_dem = x[X_F_DEM]; pdis_av = x[X_PDIS_AV]; pchg_av = x[X_PCHG_AV]
    locked = x[X_LOCKED] > 0.5
    fired = x[X_FIRED] > 0.5
    fuelcut = x[X_FUELCUT] > 0.5
    rw = prm[P_R_WHEEL]; fd = prm[P_FD_RATIO]; fd_eff = prm[P_FD_EFF]; rg = prm[P_MG2_RATIO]
    eng_idle = prm[P_ENG_IDLE]; boost_eff = prm[P_BOOST_EFF]; aux = prm[P_AUX_W]
    tg_ff = 0.0 if locked else -te / k1
    t_ring = 0.0 if locked else te * k2 / k1
    t_wh = f_dem * rw
    t_fd = t_wh / (fd * fd_eff) if t_wh >= 0.0 else t_wh * fd_eff / fd
    tm_lim = rg * torque_limit(prm[P_MOT_TMAX], prm[P_MOT_PMAX], rg * wr0)  # ring side
    braking = f_dem < 0.0
    t_req = t_fd - t_ring
    if braking and t_req < 0.0:
        t_m = t_req * prm[P_REGEN_FRAC] * regen_fade(x[X_V0], prm[P_FADE_LO], prm[P_FADE_HI])
    else:
        t_m = t_req
    t_m = min(max(t_m, -tm_lim), tm_lim)
    p_gen_est = 0.0 if locked else electrical_power(gS, gT, gL, wg0, tg_ff)
    p_mot_est = mot_power(mS, mT, mL, rg, wr_e, t_m)
    p_b_est = battery_side_power(p_mot_est + p_gen_est, boost_eff) + aux
    pstate = PROPEL_BRAKING if braking else PROPEL_NORMAL
    if p_b_est > pdis_av:
        pstate = PROPEL_DISCHARGE_LIMIT
        if fired and (not fuelcut) and (not braking):
            # leave the best line: more engine torque at the present speed
            te_new = min((p_eng + p_b_est - pdis_av) / max(we0, eng_idle), te_max_now)
            if te_new > te:
                t_ring += (te_new - te) * k2 / k1
                te = te_new
                tg_ff, t_m, p_gen_est, p_b_est = resplit(prm, maps, te, t_ring, t_fd, tm_lim,
                                                         k1, wg0, wr_e)
        if p_b_est > pdis_av:
            p_allow = bus_allowed(pdis_av - aux, boost_eff) - p_gen_est
            t_m = mot_torque_for_power(mS, mT, mL, rg, wr_e, p_allow, -tm_lim,
                                       t_m)
    elif p_b_est < -pchg_av:
        pstate = PROPEL_CHARGE_LIMIT
        if fired and (not fuelcut) and te > 0.0:
            # leave the best line: less engine torque at the present speed
            te_new = max(te - (-pchg_av - p_b_est) / max(we0, eng_idle), 0.0)
            t_ring += (te_new - te) * k2 / k1
            te = te_new
            tg_ff, t_m, p_gen_est, p_b_est = resplit(prm, maps, te, t_ring, t_fd, tm_lim, k1,
                                                     wg0, wr_e)
        if p_b_est < -pchg_av:
            p_allow = bus_allowed(-pchg_av - aux, boost_eff) - p_gen_est
            t_m = max(t_m, mot_torque_for_power(mS, mT, mL, rg, wr_e, p_allow, t_m,
                                                max(t_m, 0.0)))
    f_pt_est = (t_m + t_ring) * g
    f_pt_est = f_pt_est * fd_eff if f_pt_est >= 0.0 else f_pt_est / fd_eff
    f_brk = min(max(f_pt_est - f_dem, 0.0), prm[P_BRK_MAX]) if braking else 0.0
    x[X_TE] = te
    x[X_TG_FF] = tg_ff
    x[X_T_RING] = t_ring
    x[X_T_M] = t_m
    x[X_TM_LIM] = tm_lim
    x[X_PSTATE] = pstate
    x[X_F_BRK] = f_brk
