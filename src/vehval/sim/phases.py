"""The phases of one time step of the power-split loop (:func:`vehval.sim.kernel.run`).

A step runs, in order: :func:`driver_phase` (wheel force demand), :func:`supervisor_phase`
(battery limits, power demand, engine state machine), :func:`operating_point_phase`
(engine speed target and torque), :func:`torque_split_phase` (eq. 1-2 with the battery
limits and braking), :func:`plant_phase` (semi-implicit step of the two-DOF lever),
:func:`battery_phase` (bus, boost, current, SOC), then :func:`book_phase` (energy
accounts), :func:`memory_phase` (controller integrators) and :func:`record_phase`.

Every phase is a compiled function of plain scalars and map arrays (inlined into the loop
by LLVM); the loop keeps the parameters hoisted in locals, so the split costs no speed.
Units: SI throughout (m/s, rad/s, N, N·m, W, J, s; SOC as a fraction).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from vehval.sim.components.battery import current_from_power
from vehval.sim.components.body import road_load
from vehval.sim.components.boost import battery_side_power, output_voltage
from vehval.sim.components.electric_machine import electrical_power, torque_for_power, torque_limit
from vehval.sim.components.engine import fuel_rate, max_torque
from vehval.sim.control import (
    PROPEL_BRAKING,
    PROPEL_CHARGE_LIMIT,
    PROPEL_DISCHARGE_LIMIT,
    PROPEL_NORMAL,
    held,
    hold_timer,
    regen_fade,
    soc_power_demand,
    state_step,
)
from vehval.sim.driver import driver_force
from vehval.sim.indices import *  # noqa: F401,F403 - index constants
from vehval.sim.maps import interp1

LOCK_SPEED = 10.0  # [rad/s] below this an engine commanded off is taken as stopped


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


@njit(cache=True)
def system_cost(w, p_eng, wr, t_fd, aux, eS, eT, eF, eTm, gS, gT, gL, mS, mT, mL, rg, k1, k2,
                gen_tmax, gen_pmax, boost_eff, ocv, r_dis, r_chg, lhv, s_eq):
    """Fuel power plus the fuel-equivalent of the battery power [W] for engine speed ``w``.

    The engine gives ``p_eng`` [W] at ``w`` [rad/s]; MG1 reacts it (T_g = -T_e/k1) and MG2
    completes the wheel torque (eq. 1); the battery supplies the bus (MG1 + MG2 + losses),
    the boost losses and the accessories. ``s_eq`` [-] converts battery chemical power to
    fuel power. Returns inf where the engine or MG1 cannot hold the point.
    """
    te = p_eng / w
    if te > max_torque(eS, eTm, w):
        return np.inf
    wg = k1 * w - k2 * wr
    tg = -te / k1
    if -tg > torque_limit(gen_tmax, gen_pmax, wg):
        return np.inf
    t_m = t_fd - te * k2 / k1
    p_bus = electrical_power(gS, gT, gL, wg, tg) + mot_power(mS, mT, mL, rg, wr, t_m)
    p_bt = battery_side_power(p_bus, boost_eff) + aux
    cur = current_from_power(p_bt, ocv, r_dis if p_bt >= 0.0 else r_chg)
    return fuel_rate(eS, eT, eF, w, te) * lhv + s_eq * ocv * cur


@njit(cache=True)
def system_speed(p_eng, w_lo, w_hi, w_fallback, wr, t_fd, aux, eS, eT, eF, eTm, gS, gT, gL,
                 mS, mT, mL, rg, k1, k2, gen_tmax, gen_pmax, boost_eff, ocv, r_dis, r_chg,
                 lhv, s_eq):
    """Engine speed [rad/s] in [w_lo, w_hi] of least :func:`system_cost` (grid + refine).

    ``w_fallback`` is returned when no speed can hold the point.
    """
    if w_hi <= w_lo:
        return w_fallback
    n = 9
    step = (w_hi - w_lo) / (n - 1)
    best = np.inf
    w_best = w_fallback
    for j in range(n):
        w = w_lo + step * j
        c = system_cost(w, p_eng, wr, t_fd, aux, eS, eT, eF, eTm, gS, gT, gL, mS, mT, mL, rg,
                        k1, k2, gen_tmax, gen_pmax, boost_eff, ocv, r_dis, r_chg, lhv, s_eq)
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
        c = system_cost(w, p_eng, wr, t_fd, aux, eS, eT, eF, eTm, gS, gT, gL, mS, mT, mL, rg,
                        k1, k2, gen_tmax, gen_pmax, boost_eff, ocv, r_dis, r_chg, lhv, s_eq)
        if c < best:
            best = c
            w_best = w
    return w_best


@njit(cache=True)
def resplit(te, t_ring, k1, t_fd, tm_lim, wg0, wr_e, gS, gT, gL, mS, mT, mL, rg, boost_eff,
            aux):
    """Torque split again after the engine left its best line for a battery limit.

    Returns the generator feed-forward torque [N·m] (-te/k1), the motor torque [N·m] from
    eq. (1) within its limit, and the estimated generator electrical and battery-side
    powers [W] for engine torque ``te`` [N·m] and ring torque ``t_ring`` [N·m].
    """
    tg_ff = -te / k1
    t_m = min(max(t_fd - t_ring, -tm_lim), tm_lim)
    p_gen = electrical_power(gS, gT, gL, wg0, tg_ff)
    p_mot = mot_power(mS, mT, mL, rg, wr_e, t_m)
    return tg_ff, t_m, p_gen, battery_side_power(p_mot + p_gen, boost_eff) + aux


@njit(cache=True, inline="always")
def driver_phase(v0, vnow, vnext, dt, m22, rl_a, rl_b, rl_c, i_drv, drv_tau, f_min, f_max):
    """Wheel force demand [N] and the wheel power it asks over the step [W]."""
    if v0 > 0.0:
        fl_ff = road_load(v0, rl_a, rl_b, rl_c)
    elif vnext > 0.0:
        fl_ff = road_load(vnext, rl_a, rl_b, rl_c)
    else:
        fl_ff = 0.0
    f_dem = driver_force(v0, vnow, vnext, dt, m22, fl_ff, i_drv, drv_tau, f_min, f_max)
    return f_dem, f_dem * 0.5 * (v0 + vnext)


@njit(cache=True, inline="always")
def supervisor_phase(prm, soc, v0, p_wh, dt, p_filt, a_filt, tm_pwr, tm_spd, tm_bat, tm_soc,
                     tm_off, st, tst, bm, hold_on):
    """Battery limits, total power demand and one step of the engine state machine
    (``hold_on``: engine held on, e.g. for catalyst heating after a cold start).

    Returns OCV [V], the discharge/charge limits and what is available inside the margins
    [W], the filtered demand [W], the five condition timers [s], the new state and its time.
    """
    bSoc, bOcv, bRd, bRc, bPd, bPc = bm
    aux = prm[P_AUX_W]; soc_target = prm[P_SOC_TARGET]; soc_gain = prm[P_SOC_GAIN]
    on_pwr = prm[P_ON_PWR]; off_pwr = prm[P_OFF_PWR]; on_spd = prm[P_ON_SPD]
    off_spd = prm[P_OFF_SPD]; elec_eff = prm[P_ELEC_EFF]; soc_on = prm[P_SOC_ON]
    soc_force = prm[P_SOC_FORCE]
    ocv = interp1(bSoc, bOcv, soc)
    pdis_lim = interp1(bSoc, bPd, soc)
    pchg_lim = interp1(bSoc, bPc, soc)
    pdis_av = max(pdis_lim - prm[P_DIS_MARGIN], 0.0)
    pchg_av = max(pchg_lim - prm[P_CHG_MARGIN], 0.0)
    p_bdem = soc_power_demand(soc, soc_target, soc_gain, prm[P_SOC_PCHG_MAX],
                              prm[P_SOC_PDIS_MAX])
    p_tot = p_wh + aux + p_bdem
    p_filt += a_filt * (p_tot - p_filt)
    c_bat = max(p_wh, 0.0) / elec_eff + aux > pdis_av
    tm_pwr = hold_timer(tm_pwr, p_tot > on_pwr, dt)
    tm_spd = hold_timer(tm_spd, v0 > on_spd, dt)
    tm_bat = hold_timer(tm_bat, c_bat, dt)
    tm_soc = hold_timer(tm_soc, soc < soc_on, dt)
    on_req = (held(tm_pwr, prm[P_ON_PWR_HOLD]) or held(tm_spd, prm[P_ON_SPD_HOLD])
              or held(tm_bat, prm[P_BATT_HOLD]) or held(tm_soc, prm[P_SOC_ON_HOLD]))
    off_raw = p_tot < off_pwr and v0 < off_spd and (not c_bat) and soc >= soc_on
    tm_off = hold_timer(tm_off, off_raw, dt)
    off_req = held(tm_off, prm[P_OFF_HOLD])
    st_new, tst = state_step(st, tst, on_req, off_req, soc < soc_force or hold_on, dt,
                             prm[P_MIN_ON], prm[P_MIN_OFF])
    return (ocv, pdis_lim, pchg_lim, pdis_av, pchg_av, p_filt,
            tm_pwr, tm_spd, tm_bat, tm_soc, tm_off, st_new, tst)


@njit(cache=True, inline="always")
def operating_point_phase(prm, cmd_on, p_filt, f_dem, we0, wr0, wr_e, fired, v0, ocv, soc, geo,
                          wg_lim, s_eq, em, ol, m2, m1, bm):
    """Engine power and speed target, firing state, and the engine torque [N·m].

    The speed target comes from the best line or the system optimum, inside the MG1 speed
    window; the torque is the best-line torque (capped by full load, by what MG1 can react
    and above the speed window) or the drag of an engine spinning unfired.
    Returns the window (w_lo, w_hi), w_tgt, p_eng, fuel cut, fired, te, full-load te_max and
    the MG1 speed wg0 at the step start.
    """
    k1, k2, g, rw, fd, fd_eff, rg = geo
    eS, eT, eF, eTm = em
    oP, oS = ol
    mS, mT, mL = m2
    gS, gT, gL = m1
    bSoc, bOcv, bRd, bRc, bPd, bPc = bm
    aux = prm[P_AUX_W]; eng_idle = prm[P_ENG_IDLE]; eng_max = prm[P_ENG_MAX_SPD]
    eng_fire = prm[P_ENG_FIRE]; eng_pmax = prm[P_ENG_PMAX]; eng_min_pwr = prm[P_ENG_MIN_PWR]
    fuel_cut_pwr = prm[P_FUEL_CUT_PWR]; fuel_cut_spd = prm[P_FUEL_CUT_SPD]
    op_system = prm[P_OP_SYSTEM] > 0.5  # engine speed for the system, else the best line
    gen_tmax = prm[P_GEN_TMAX]; gen_pmax = prm[P_GEN_PMAX]; boost_eff = prm[P_BOOST_EFF]
    lhv = prm[P_FUEL_LHV]
    w_lo = max((k2 * wr0 - wg_lim) / k1, 0.0)
    w_hi = min(eng_max - prm[P_ENG_SPD_MARGIN], (wg_lim + k2 * wr0) / k1)
    fuelcut = False
    p_eng = 0.0
    if cmd_on:
        p_eng = max(p_filt, 0.0)
        if p_eng > fuel_cut_pwr:
            p_eng = min(max(p_eng, eng_min_pwr), eng_pmax)
            w_tgt = interp1(oP, oS, p_eng)
            if op_system:
                # speed of least fuel + fuel-equivalent of the electrical path
                t_wh_e = f_dem * rw
                t_fd_e = t_wh_e / (fd * fd_eff) if t_wh_e >= 0.0 else t_wh_e * fd_eff / fd
                w_tgt = system_speed(
                    p_eng, max(w_lo, eng_idle), w_hi, w_tgt, wr_e, t_fd_e, aux, eS, eT, eF,
                    eTm, gS, gT, gL, mS, mT, mL, rg, k1, k2, gen_tmax, gen_pmax, boost_eff,
                    ocv, interp1(bSoc, bRd, soc), interp1(bSoc, bRc, soc), lhv, s_eq)
        else:
            p_eng = 0.0
            fuelcut = v0 >= fuel_cut_spd
            w_tgt = eng_idle
        w_tgt = min(max(w_tgt, w_lo), w_hi)
    else:
        w_tgt = w_lo
    if cmd_on:
        fired = we0 >= (0.5 * eng_fire if fired else eng_fire)
    else:
        fired = False
    # full-load torque, capped by what MG1 can react (90 %: keep authority for speed
    # control) and cut above the speed window (over-speed protection)
    wg0 = k1 * we0 - k2 * wr0
    te_max_now = min(max_torque(eS, eTm, max(we0, eng_idle)),
                     0.9 * k1 * torque_limit(gen_tmax, gen_pmax, wg0))
    if we0 > w_hi:
        te_max_now *= max(0.0, 1.0 - (we0 - w_hi) / (0.03 * eng_max))
    return w_lo, w_hi, w_tgt, p_eng, fuelcut, fired, te_max_now, wg0


@njit(cache=True, inline="always")
def engine_torque(locked, fired, fuelcut, p_eng, w_tgt, we0, te_max_now, eng_drag):
    """Engine torque [N·m]: best-line torque when firing (above the target speed, the torque
    giving the demanded power), the drag of an engine spinning unfired, else 0."""
    if locked:
        return 0.0
    if fired and not fuelcut:
        return min(p_eng / max(w_tgt, we0), te_max_now) if p_eng > 0.0 else 0.0
    if we0 > 0.0:
        return -eng_drag
    return 0.0


@njit(cache=True, inline="always")
def torque_split_phase(prm, locked, fired, fuelcut, te, te_max_now, p_eng, f_dem, v0, we0,
                       wr0, wr_e, wg0, geo, pdis_av, pchg_av, m2, m1):
    """Eq. (1)-(2): MG1 feed-forward, ring and MG2 torques within the battery limits
    (leaving the best line when the battery cannot take the difference), regenerative
    share and friction braking.

    Returns te (possibly moved), tg_ff, t_ring, t_m, tm_lim, braking, the propulsion state
    and the friction brake force [N].
    """
    k1, k2, g, rw, fd, fd_eff, rg = geo
    mS, mT, mL = m2
    gS, gT, gL = m1
    mot_tmax = prm[P_MOT_TMAX]; mot_pmax = prm[P_MOT_PMAX]; eng_idle = prm[P_ENG_IDLE]
    boost_eff = prm[P_BOOST_EFF]; aux = prm[P_AUX_W]
    tg_ff = 0.0 if locked else -te / k1
    t_ring = 0.0 if locked else te * k2 / k1
    t_wh = f_dem * rw
    t_fd = t_wh / (fd * fd_eff) if t_wh >= 0.0 else t_wh * fd_eff / fd
    tm_lim = rg * torque_limit(mot_tmax, mot_pmax, rg * wr0)  # ring side
    braking = f_dem < 0.0
    t_req = t_fd - t_ring
    if braking and t_req < 0.0:
        t_m = t_req * prm[P_REGEN_FRAC] * regen_fade(v0, prm[P_FADE_LO], prm[P_FADE_HI])
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
                tg_ff, t_m, p_gen_est, p_b_est = resplit(
                    te, t_ring, k1, t_fd, tm_lim, wg0, wr_e, gS, gT, gL, mS, mT, mL, rg,
                    boost_eff, aux)
        if p_b_est > pdis_av:
            p_allow = bus_allowed(pdis_av - aux, boost_eff) - p_gen_est
            t_m = mot_torque_for_power(mS, mT, mL, rg, wr_e, p_allow, -tm_lim, t_m)
    elif p_b_est < -pchg_av:
        pstate = PROPEL_CHARGE_LIMIT
        if fired and (not fuelcut) and te > 0.0:
            # leave the best line: less engine torque at the present speed
            te_new = max(te - (-pchg_av - p_b_est) / max(we0, eng_idle), 0.0)
            t_ring += (te_new - te) * k2 / k1
            te = te_new
            tg_ff, t_m, p_gen_est, p_b_est = resplit(
                te, t_ring, k1, t_fd, tm_lim, wg0, wr_e, gS, gT, gL, mS, mT, mL, rg,
                boost_eff, aux)
        if p_b_est < -pchg_av:
            p_allow = bus_allowed(-pchg_av - aux, boost_eff) - p_gen_est
            t_m = max(t_m, mot_torque_for_power(mS, mT, mL, rg, wr_e, p_allow, t_m, max(t_m, 0.0)))
    f_pt_est = (t_m + t_ring) * g
    f_pt_est = f_pt_est * fd_eff if f_pt_est >= 0.0 else f_pt_est / fd_eff
    f_brk = min(max(f_pt_est - f_dem, 0.0), prm[P_BRK_MAX]) if braking else 0.0
    return te, tg_ff, t_ring, t_m, tm_lim, pstate, f_brk


@njit(cache=True, inline="always")
def plant_phase(prm, locked, dt, we0, v0, te, tg_ff, t_ring, t_m, tm_lim, w_tgt, r_full, mm,
                geo, i_gen, pdis_lim, pchg_lim, wg0, wr0, wr_e, m2, m1):
    """Semi-implicit step of the two-DOF lever.

    MG2 compensates the actual gear reaction: T_m = T_fd_cmd + k2 T_g (eq. 1 with the ring
    torque of the gear set), so the wheels get the commanded torque while MG1 moves the
    engine; if MG2 saturates (or a hard battery limit binds), its torque is held and the
    step re-solved; MG1 gives way at the charge limit. A final explicit solve with the
    torques fixed keeps the energy bookkeeping exact.

    Returns the new engine [rad/s] and vehicle [m/s] speeds, MG1 and MG2 (ring-side)
    torques [N·m], the resistance actually applied [N], whether MG1 saturated, and the
    final-drive efficiency factor of the step.
    """
    m11, m12, m22, det = mm
    k1, k2, g, rw, fd, fd_eff, rg = geo
    mS, mT, mL = m2
    gS, gT, gL = m1
    gen_kp = prm[P_GEN_KP]; gen_tmax = prm[P_GEN_TMAX]; gen_pmax = prm[P_GEN_PMAX]
    aux = prm[P_AUX_W]; boost_eff = prm[P_BOOST_EFF]
    t_fd_cmd = t_m + t_ring
    clipped = False
    if locked:
        t_g = 0.0
        eta_d = fd_eff if t_m >= 0.0 else 1.0 / fd_eff
        v1 = v0 + dt * (eta_d * g * t_m - r_full) / m22
        we1 = 0.0
        r_eff = r_full
        if v1 < 0.0:
            r_eff = r_full + v1 * m22 / dt
            v1 = 0.0
        return we1, v1, t_g, t_m, r_eff, clipped, eta_d
    eta_d = fd_eff if t_fd_cmd >= 0.0 else 1.0 / fd_eff
    kp_e = gen_kp * k1
    tg_c = tg_ff + i_gen + kp_e * w_tgt
    tg_lim = torque_limit(gen_tmax, gen_pmax, wg0)
    b1 = m11 * we0 + m12 * v0 + dt * (te + k1 * tg_c)
    b2 = m12 * we0 + m22 * v0 + dt * (eta_d * g * t_fd_cmd - r_full)
    we1 = (b1 * m22 - m12 * b2) / ((m11 + dt * kp_e * k1) * m22 - m12 * m12)
    t_g = min(max(tg_c - kp_e * we1, -tg_lim), tg_lim)
    t_m = t_fd_cmd + k2 * t_g
    # engine speed predicted with the (possibly clipped) torques
    we1 = ((m11 * we0 + m12 * v0 + dt * (te + k1 * t_g)) * m22 - m12 * (
        m12 * we0 + m22 * v0 + dt * (eta_d * g * (t_m - k2 * t_g) - r_full))) / det
    # hard battery limits on the actual torques (MG2 gives way, the trace may suffer)
    # MG1 power at the mid-step speed predicted by the implicit solve
    p_g_act = electrical_power(gS, gT, gL, k1 * 0.5 * (we0 + we1) - k2 * wr0, t_g)
    t_m_hi = tm_lim
    t_m_lo = -tm_lim
    p_m_hi = bus_allowed(pdis_lim - aux, boost_eff) - p_g_act
    if mot_power(mS, mT, mL, rg, wr_e, t_m) > p_m_hi:
        t_m_hi = mot_torque_for_power(mS, mT, mL, rg, wr_e, p_m_hi, -tm_lim,
                                      min(t_m, tm_lim))
    p_m_lo = bus_allowed(-pchg_lim - aux, boost_eff) - p_g_act
    if mot_power(mS, mT, mL, rg, wr_e, t_m) < p_m_lo:
        t_m_lo = mot_torque_for_power(mS, mT, mL, rg, wr_e, p_m_lo, max(t_m, -tm_lim),
                                      min(max(t_m, 0.0), tm_lim))
    if t_m > t_m_hi or t_m < t_m_lo:
        t_m = min(max(t_m, t_m_lo), t_m_hi)
        f2 = -k2 * g * eta_d
        b2 = m12 * we0 + m22 * v0 + dt * (eta_d * g * t_m - r_full + f2 * tg_c)
        we1 = (b1 * m22 - m12 * b2) / ((m11 + dt * kp_e * k1) * m22
                                      - m12 * (m12 + dt * kp_e * f2))
        t_g = min(max(tg_c - kp_e * we1, -tg_lim), tg_lim)
        we1 = ((m11 * we0 + m12 * v0 + dt * (te + k1 * t_g)) * m22 - m12 * (
            m12 * we0 + m22 * v0 + dt * (eta_d * g * (t_m - k2 * t_g) - r_full))) / det
    clipped = abs(t_g) >= tg_lim - 1e-12
    # charge limit: MG1 slowing the engine gives way too (scaled generating torque)
    wg_m = k1 * 0.5 * (we0 + we1) - k2 * wr0
    p_g_min = (bus_allowed(-pchg_lim - aux, boost_eff)
               - mot_power(mS, mT, mL, rg, wr_e, t_m))
    p_g_now = electrical_power(gS, gT, gL, wg_m, t_g)
    if p_g_now < p_g_min and p_g_now < 0.0:
        t_g *= min(p_g_min, 0.0) / p_g_now
        clipped = True
    # final explicit solve with the torques now fixed (exact energy bookkeeping)
    c1 = m11 * we0 + m12 * v0 + dt * (te + k1 * t_g)
    c2 = m12 * we0 + m22 * v0 + dt * (eta_d * g * (t_m - k2 * t_g) - r_full)
    we1 = (c1 * m22 - m12 * c2) / det
    v1 = (m11 * c2 - m12 * c1) / det
    r_eff = r_full
    if v1 < 0.0:
        r_eff = r_full + v1 * det / (dt * m11)
        c2 = c2 + dt * (r_full - r_eff)
        we1 = (c1 * m22 - m12 * c2) / det
        v1 = 0.0
    return we1, v1, t_g, t_m, r_eff, clipped, eta_d


@njit(cache=True, inline="always")
def battery_phase(p_mot_e, p_gen_e, aux, boost_eff, ocv, soc, dt, cap_c, bSoc, bRd, bRc):
    """Battery-side power [W] (bus through the boost converter plus accessories), the
    resistance used [ohm], current [A], terminal voltage [V] and the new SOC."""
    p_bus = p_mot_e + p_gen_e
    p_bt = battery_side_power(p_bus, boost_eff) + aux
    rb = interp1(bSoc, bRd, soc) if p_bt >= 0.0 else interp1(bSoc, bRc, soc)
    cur = current_from_power(p_bt, ocv, rb)
    vb = ocv - cur * rb
    return p_bus, p_bt, rb, cur, vb, soc - cur * dt / cap_c


@njit(cache=True, inline="always")
def book_phase(ys, dt, fuel, lhv, ocv, cur, rb, p_eng_mech, p_mot_e, p_gen_e, t_m, t_g, wr_a,
               wg_a, p_bt, p_bus, aux, g, t_fd_act, f_fd, v_a, brk_app, fl_app, vb,
               engine_delivering):
    """Add the step's energies [J], fuel [kg] and distance [m] to the summary ``ys``."""
    ys[Y_FUEL_MASS_KG] += fuel * dt
    ys[Y_FUEL_ENERGY_J] += fuel * lhv * dt
    ys[Y_ESS_CHEM_ENERGY_J] += ocv * cur * dt
    ys[Y_ESS_LOSS_J] += cur * cur * rb * dt
    ys[Y_ENG_LOSS_J] += (fuel * lhv - p_eng_mech) * dt
    ys[Y_MOT_LOSS_J] += (p_mot_e - t_m * wr_a) * dt
    ys[Y_GEN_LOSS_J] += (p_gen_e - t_g * wg_a) * dt
    ys[Y_BOOST_LOSS_J] += (p_bt - aux - p_bus) * dt
    ys[Y_AUX_ENERGY_J] += aux * dt
    ys[Y_FD_LOSS_J] += (g * t_fd_act - f_fd) * v_a * dt
    ys[Y_BRAKE_ENERGY_J] += brk_app * v_a * dt
    ys[Y_ROAD_ENERGY_J] += fl_app * v_a * dt
    ys[Y_UNMET_ENERGY_J] += (p_bt - vb * cur) * dt
    if engine_delivering and p_eng_mech > 0.0:
        ys[Y_ENG_OUT_ENERGY_J] += p_eng_mech * dt
    else:
        ys[Y_IDLE_FUEL_ENERGY_J] += fuel * lhv * dt
    # audit: wheel work of the powertrain, and engine power recirculated through MG1
    # (MG1 motoring while the engine delivers power: MG2 generates it back)
    p_whl = f_fd * v_a
    if p_whl >= 0.0:
        ys[Y_TRACTIVE_ENERGY_J] += p_whl * dt
    else:
        ys[Y_REGEN_WHEEL_ENERGY_J] -= p_whl * dt
    if p_eng_mech > 0.0 and t_g * wg_a > 0.0:
        ys[Y_RECIRC_ENERGY_J] += t_g * wg_a * dt
        ys[Y_GEN_MOTORING_LOSS_J] += (p_gen_e - t_g * wg_a) * dt
    ys[Y_DISTANCE_M] += v_a * dt


@njit(cache=True, inline="always")
def memory_phase(locked, clipped, w_tgt, we1, w_hi, eng_idle, ki_gen, k1, dt, gen_tmax, i_gen,
                 f_real, f_dem, vnext, v1, drv_ki, drv_lim, i_drv):
    """Controller integrators: generator speed PI [N·m] and driver PI [N].

    Generator speed PI, anti-windup whatever the state: integrate only near the target and
    with MG1 unsaturated; elsewhere the integral is frozen, and dropped when it opposes the
    proportional correction or the engine is beyond its speed window (a launch winds it up;
    a stale integral would hold MG1 against pulling the engine back and let MG1 pass its
    speed limit). The driver integrates only while the powertrain delivers the demand.
    """
    if not locked:
        err_w = w_tgt - we1
        beyond = we1 > w_hi  # engine above its window (MG1 or engine near its limit)
        if (not clipped) and (not beyond) and abs(err_w) < 0.2 * eng_idle:
            i_gen += ki_gen * k1 * err_w * dt
            i_gen = min(max(i_gen, -gen_tmax), gen_tmax)
        elif i_gen * err_w < 0.0:
            i_gen = 0.0
    if abs(f_real - f_dem) <= max(100.0, 0.05 * abs(f_dem)):
        i_drv += drv_ki * (vnext - v1) * dt
        i_drv = min(max(i_drv, -drv_lim), drv_lim)
    return i_gen, i_drv


@njit(cache=True, inline="always")
def record_phase(out, j, prm, geo, dt, v0, v1, vnext, f_fd, fl_app, eng, fired, fuelcut, wg1,
                 t_g, p_gen_e, t_m, p_mot_e, vb, cur, soc, pdis_lim, pchg_lim, brk_app, p_wh,
                 f_dem, st, pstate):
    """Write the step's signals into row ``j`` of ``out`` (columns of ``SIGNALS``).

    ``eng`` is (engine speed [rad/s], torque [N·m], power [W], speed target [rad/s], fuel
    rate [kg/s]).
    """
    k1, k2, g, rw, fd, fd_eff, rg = geo
    we1, te, p_eng_mech, w_tgt, fuel = eng
    out[j, S_VEH_SPD] = v1
    out[j, S_VEH_SPD_TARGET] = vnext
    out[j, S_VEH_ACC] = (v1 - v0) / dt
    out[j, S_VEH_FRC_IN] = f_fd
    out[j, S_VEH_FRC_LOSS] = fl_app
    out[j, S_WHL_TRQ_OUT] = f_fd * rw
    out[j, S_WHL_SPD] = v1 / rw
    out[j, S_ENG_SPD_OUT] = we1
    out[j, S_ENG_TRQ_OUT] = te
    out[j, S_ENG_PWR_OUT] = p_eng_mech
    out[j, S_ENG_SPD_TARGET] = w_tgt
    out[j, S_ENG_ON] = 1.0 if fired else 0.0
    out[j, S_ENG_FUEL_CUT] = 1.0 if (fired and fuelcut) else 0.0
    out[j, S_FUEL_RATE] = fuel
    out[j, S_GEN_SPD_OUT] = wg1
    out[j, S_GEN_TRQ_OUT] = t_g
    out[j, S_GEN_PWR_IN] = p_gen_e
    out[j, S_MOT_SPD_OUT] = rg * g * v1
    out[j, S_MOT_TRQ_OUT] = t_m / rg
    out[j, S_MOT_PWR_IN] = p_mot_e
    out[j, S_ESS_VOLT] = vb
    out[j, S_ESS_CURR] = cur
    out[j, S_ESS_PWR] = vb * cur
    out[j, S_ESS_SOC] = soc
    out[j, S_ESS_PWR_LIM_DIS] = pdis_lim
    out[j, S_ESS_PWR_LIM_CHG] = pchg_lim
    out[j, S_BOOST_VOLT_OUT] = output_voltage(
        vb, max(abs(wg1), rg * g * v1) / prm[P_BOOST_FULL_SPD], prm[P_BOOST_VMIN],
        prm[P_BOOST_VMAX])
    out[j, S_BRK_FRC] = brk_app
    out[j, S_DRV_PWR_DEMAND] = p_wh
    out[j, S_DRV_FRC_DEMAND] = f_dem
    out[j, S_PG_TRQ_RING] = -k2 * t_g
    out[j, S_ENG_CTRL_STATE] = st
    out[j, S_ESS_PWR_LIM_STATE] = pstate
