"""The compiled time loop of the forward-looking power-split simulation.

State: vehicle speed ``v`` [m/s], engine (carrier) speed ``w_e`` [rad/s] and SOC. The
planetary set has two degrees of freedom, q = (w_e, v); MG1 (sun) speed follows from Willis,
MG2 (ring) speed from the final drive. Lagrange with massless pinions gives

    M q' = Q,   M = [[J_e + J_g k1^2, -J_g k1 k2 g], [-J_g k1 k2 g, m_eq + J_g k2^2 g^2]]
    Q = (T_e + k1 T_g,  eta g (T_m - k2 T_g) - F_road - F_brake)

with k1 = (N_r + N_s)/N_s, k2 = N_r/N_s, g = ratio_fd / r_wheel. A step is semi-implicit:
the proportional part of the generator speed controller is solved implicitly (stable at
any step), the rest explicitly. All mechanical powers use mid-step speeds, so the work
of the torques equals the kinetic-energy change exactly and the energy bookkeeping closes.
When the engine is off and stopped the carrier is held (one DOF).
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from vehval.sim.components.battery import current_from_power
from vehval.sim.components.body import road_load
from vehval.sim.components.boost import battery_side_power, output_voltage
from vehval.sim.components.electric_machine import electrical_power, torque_for_power, torque_limit
from vehval.sim.components.engine import fuel_rate, max_torque
from vehval.sim.control import (
    ENG_OFF,
    PROPEL_BRAKING,
    PROPEL_CHARGE_LIMIT,
    PROPEL_DISCHARGE_LIMIT,
    PROPEL_NORMAL,
    engine_commanded_on,
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
def _bus_allowed(batt_power, eff):
    """Bus power [W] that corresponds to a battery-side power [W] (inverse of battery_side_power)."""
    if batt_power >= 0.0:
        return batt_power * eff
    return batt_power / eff


@njit(cache=True)
def _mot_power(mS, mT, mL, rg, w_ring, t_ring_side):
    """MG2 DC power [W] for a ring-side speed [rad/s] and ring-side torque [N·m].

    ``rg`` is the MG2 reduction ratio (MG2 shaft speed / ring speed); the map is read at
    the shaft speed and torque.
    """
    return electrical_power(mS, mT, mL, rg * w_ring, t_ring_side / rg)


@njit(cache=True)
def _mot_torque_for_power(mS, mT, mL, rg, w_ring, p_target, t_lo, t_hi):
    """Ring-side MG2 torque [N·m] in [t_lo, t_hi] drawing at most ``p_target`` [W]."""
    return rg * torque_for_power(mS, mT, mL, rg * w_ring, p_target, t_lo / rg, t_hi / rg)


@njit(cache=True)
def _system_cost(w, p_eng, wr, t_fd, aux, eS, eT, eF, eTm, gS, gT, gL, mS, mT, mL, rg, k1, k2,
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
    p_bus = electrical_power(gS, gT, gL, wg, tg) + _mot_power(mS, mT, mL, rg, wr, t_m)
    p_bt = battery_side_power(p_bus, boost_eff) + aux
    cur = current_from_power(p_bt, ocv, r_dis if p_bt >= 0.0 else r_chg)
    return fuel_rate(eS, eT, eF, w, te) * lhv + s_eq * ocv * cur


@njit(cache=True)
def _system_speed(p_eng, w_lo, w_hi, w_fallback, wr, t_fd, aux, eS, eT, eF, eTm, gS, gT, gL,
                  mS, mT, mL, rg, k1, k2, gen_tmax, gen_pmax, boost_eff, ocv, r_dis, r_chg,
                  lhv, s_eq):
    """Engine speed [rad/s] in [w_lo, w_hi] of least :func:`_system_cost` (grid + refine).

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
        c = _system_cost(w, p_eng, wr, t_fd, aux, eS, eT, eF, eTm, gS, gT, gL, mS, mT, mL, rg,
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
        c = _system_cost(w, p_eng, wr, t_fd, aux, eS, eT, eF, eTm, gS, gT, gL, mS, mT, mL, rg,
                         k1, k2, gen_tmax, gen_pmax, boost_eff, ocv, r_dis, r_chg, lhv, s_eq)
        if c < best:
            best = c
            w_best = w
    return w_best


@njit(cache=True)
def _resplit(te, t_ring, k1, t_fd, tm_lim, wg0, wr_e, gS, gT, gL, mS, mT, mL, rg, boost_eff,
             aux):
    """Torque split again after the engine left its best line for a battery limit.

    Returns the generator feed-forward torque [N·m] (-te/k1), the motor torque [N·m] from
    eq. (1) within its limit, and the estimated generator electrical and battery-side
    powers [W] for engine torque ``te`` [N·m] and ring torque ``t_ring`` [N·m].
    """
    tg_ff = -te / k1
    t_m = min(max(t_fd - t_ring, -tm_lim), tm_lim)
    p_gen = electrical_power(gS, gT, gL, wg0, tg_ff)
    p_mot = _mot_power(mS, mT, mL, rg, wr_e, t_m)
    return tg_ff, t_m, p_gen, battery_side_power(p_mot + p_gen, boost_eff) + aux


@njit(cache=True)
def run(vt, band_lo, band_hi, dt, prm, eS, eT, eF, eTm, oP, oS, mS, mT, mL, gS, gT, gL,
        bSoc, bOcv, bRd, bRc, bPd, bPc, out, record):
    """Simulate one cycle.

    Parameters
    ----------
    vt : ndarray
        Target speed [m/s] on the uniform time grid (step ``dt`` [s]).
    band_lo, band_hi : ndarray
        EPA tolerance band of the target [m/s] on the same grid.
    prm : ndarray
        Scalar parameters packed as in :data:`vehval.sim.layout.PARAMS` (SI).
    eS, eT, eF, eTm : ndarray
        Engine speed [rad/s] and torque [N·m] breakpoints, fuel map [kg/s], full-load torque.
    oP, oS : ndarray
        Best-efficiency line: power [W] -> speed [rad/s].
    mS, mT, mL / gS, gT, gL : ndarray
        MG2 / MG1 speed [rad/s], torque [N·m] breakpoints and loss map [W].
    bSoc, bOcv, bRd, bRc, bPd, bPc : ndarray
        Battery SOC breakpoints, OCV [V], discharge/charge resistance [ohm], power limits [W].
    out : ndarray (n, N_S)
        Recorded signals (written only when ``record``).
    record : bool

    Returns
    -------
    ndarray (N_Y,) : summary accumulators, see :data:`vehval.sim.layout.SUMMARY`.
    """
    n = vt.shape[0]
    ys = np.zeros(N_Y)
    mass = prm[P_MASS]; rl_a = prm[P_RL_A]; rl_b = prm[P_RL_B]; rl_c = prm[P_RL_C]
    aux = prm[P_AUX_W]; rw = prm[P_R_WHEEL]; fd = prm[P_FD_RATIO]; fd_eff = prm[P_FD_EFF]
    brk_max = prm[P_BRK_MAX]; ns = prm[P_N_SUN]; nr = prm[P_N_RING]
    eng_idle = prm[P_ENG_IDLE]; eng_max = prm[P_ENG_MAX_SPD]; eng_fire = prm[P_ENG_FIRE]
    eng_drag = prm[P_ENG_DRAG]; eng_pmax = prm[P_ENG_PMAX]; lhv = prm[P_FUEL_LHV]
    mot_tmax = prm[P_MOT_TMAX]; mot_pmax = prm[P_MOT_PMAX]
    gen_tmax = prm[P_GEN_TMAX]; gen_pmax = prm[P_GEN_PMAX]; gen_max = prm[P_GEN_MAX_SPD]
    cap_c = prm[P_BATT_CAP_C]; boost_eff = prm[P_BOOST_EFF]
    soc_target = prm[P_SOC_TARGET]; soc_gain = prm[P_SOC_GAIN]
    on_pwr = prm[P_ON_PWR]; off_pwr = prm[P_OFF_PWR]; on_spd = prm[P_ON_SPD]
    off_spd = prm[P_OFF_SPD]; elec_eff = prm[P_ELEC_EFF]; soc_on = prm[P_SOC_ON]
    soc_force = prm[P_SOC_FORCE]; eng_min_pwr = prm[P_ENG_MIN_PWR]
    fuel_cut_pwr = prm[P_FUEL_CUT_PWR]; fuel_cut_spd = prm[P_FUEL_CUT_SPD]
    gen_kp = prm[P_GEN_KP]; ki_gen = min(prm[P_GEN_KI], 0.5 * gen_kp / dt)
    drv_tau = prm[P_DRV_TAU]; drv_ki = prm[P_DRV_KI]; drv_lim = prm[P_DRV_INT_LIM]

    rg = prm[P_MG2_RATIO]  # MG2 shaft speed / ring speed
    op_system = prm[P_OP_SYSTEM] > 0.5  # engine speed for the system, else the best line
    s_eq = prm[P_EQ_FACTOR]  # fuel J per J of battery chemical energy
    k1 = (nr + ns) / ns
    k2 = nr / ns
    g = fd / rw
    j_gen = prm[P_J_GEN]
    m11 = prm[P_J_ENG] + prm[P_J_CARRIER] + j_gen * k1 * k1
    m12 = -j_gen * k1 * k2 * g
    m22 = (mass + prm[P_J_WHEEL] / (rw * rw) + (prm[P_J_MOT] * rg * rg + prm[P_J_RING]) * g * g
           + j_gen * k2 * k2 * g * g)
    det = m11 * m22 - m12 * m12
    f_min = -(brk_max + mot_tmax * rg * fd / rw)
    wg_lim = gen_max - prm[P_GEN_SPD_MARGIN]

    v = vt[0]
    we = 0.0
    soc = prm[P_SOC_INIT]
    locked = True
    st = ENG_OFF
    tst = 0.0
    tm_pwr = 0.0; tm_spd = 0.0; tm_bat = 0.0; tm_soc = 0.0; tm_off = 0.0
    i_drv = 0.0; i_gen = 0.0; p_filt = 0.0
    a_filt = min(dt / prm[P_ENG_PWR_TAU], 1.0) if prm[P_ENG_PWR_TAU] > 0.0 else 1.0
    fired = False
    was_fired = False
    ys[Y_KE_START_J] = 0.5 * m22 * v * v
    ys[Y_SOC_MIN_SEEN] = soc
    ys[Y_SOC_MAX_SEEN] = soc
    if record:
        ocv0 = interp1(bSoc, bOcv, soc)
        for k in range(N_S):
            out[0, k] = 0.0
        out[0, S_VEH_SPD] = v; out[0, S_VEH_SPD_TARGET] = vt[0]; out[0, S_WHL_SPD] = v / rw
        out[0, S_MOT_SPD_OUT] = rg * g * v; out[0, S_GEN_SPD_OUT] = -k2 * g * v
        out[0, S_ESS_SOC] = soc; out[0, S_ESS_VOLT] = ocv0
        out[0, S_BOOST_VOLT_OUT] = output_voltage(ocv0, 0.0, prm[P_BOOST_VMIN], prm[P_BOOST_VMAX])
        out[0, S_ESS_PWR_LIM_DIS] = interp1(bSoc, bPd, soc)
        out[0, S_ESS_PWR_LIM_CHG] = interp1(bSoc, bPc, soc)
        out[0, S_ENG_CTRL_STATE] = st

    for i in range(n - 1):
        v0 = v
        we0 = we
        vnow = vt[i]
        vnext = vt[i + 1]
        wr0 = g * v0
        wr_e = g * 0.5 * (v0 + vnext)  # expected mid-step ring speed (for power estimates)
        # ---------------- driver: wheel force demand
        if v0 > 0.0:
            fl_ff = road_load(v0, rl_a, rl_b, rl_c)
        elif vnext > 0.0:
            fl_ff = road_load(vnext, rl_a, rl_b, rl_c)
        else:
            fl_ff = 0.0
        f_dem = driver_force(v0, vnow, vnext, dt, m22, fl_ff, i_drv, drv_tau, f_min,
                             prm[P_DRV_FMAX])
        p_wh = f_dem * 0.5 * (v0 + vnext)
        # ---------------- supervisory control: demands and the engine state machine
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
        st_new, tst = state_step(st, tst, on_req, off_req, soc < soc_force, dt,
                                 prm[P_MIN_ON], prm[P_MIN_OFF])
        if st_new != st:
            ys[Y_STATE_SWITCHES] += 1.0
        st = st_new
        cmd_on = engine_commanded_on(st)
        if cmd_on:
            locked = False
        # ---------------- engine operating point (best line or system optimum, inside the
        # MG1 speed window)
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
                    w_tgt = _system_speed(
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
        if locked:
            te = 0.0
        elif fired and not fuelcut:
            # best-line torque; above the target speed, the torque that gives the demanded power
            te = min(p_eng / max(w_tgt, we0), te_max_now) if p_eng > 0.0 else 0.0
        elif we0 > 0.0:
            te = -eng_drag
        else:
            te = 0.0
        # ---------------- torque split: eq. (1)-(2), battery limits, braking
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
        p_mot_est = _mot_power(mS, mT, mL, rg, wr_e, t_m)
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
                    tg_ff, t_m, p_gen_est, p_b_est = _resplit(
                        te, t_ring, k1, t_fd, tm_lim, wg0, wr_e, gS, gT, gL, mS, mT, mL, rg,
                        boost_eff, aux)
            if p_b_est > pdis_av:
                p_allow = _bus_allowed(pdis_av - aux, boost_eff) - p_gen_est
                t_m = _mot_torque_for_power(mS, mT, mL, rg, wr_e, p_allow, -tm_lim, t_m)
        elif p_b_est < -pchg_av:
            pstate = PROPEL_CHARGE_LIMIT
            if fired and (not fuelcut) and te > 0.0:
                # leave the best line: less engine torque at the present speed
                te_new = max(te - (-pchg_av - p_b_est) / max(we0, eng_idle), 0.0)
                t_ring += (te_new - te) * k2 / k1
                te = te_new
                tg_ff, t_m, p_gen_est, p_b_est = _resplit(
                    te, t_ring, k1, t_fd, tm_lim, wg0, wr_e, gS, gT, gL, mS, mT, mL, rg,
                    boost_eff, aux)
            if p_b_est < -pchg_av:
                p_allow = _bus_allowed(-pchg_av - aux, boost_eff) - p_gen_est
                t_m = max(t_m, _mot_torque_for_power(mS, mT, mL, rg, wr_e, p_allow, t_m, max(t_m, 0.0)))
        f_pt_est = (t_m + t_ring) * g
        f_pt_est = f_pt_est * fd_eff if f_pt_est >= 0.0 else f_pt_est / fd_eff
        f_brk = min(max(f_pt_est - f_dem, 0.0), brk_max) if braking else 0.0
        fl = road_load(v0, rl_a, rl_b, rl_c)
        r_full = fl + f_brk
        # ---------------- plant: semi-implicit step of the two-DOF lever
        # MG2 compensates the actual gear reaction: T_m = T_fd_cmd + k2 T_g (eq. 1 with the
        # ring torque of the gear set), so the wheels get the commanded torque while MG1
        # moves the engine; if MG2 saturates, its torque is held and the step re-solved.
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
        else:
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
            p_m_hi = _bus_allowed(pdis_lim - aux, boost_eff) - p_g_act
            if _mot_power(mS, mT, mL, rg, wr_e, t_m) > p_m_hi:
                t_m_hi = _mot_torque_for_power(mS, mT, mL, rg, wr_e, p_m_hi, -tm_lim, t_m)
            p_m_lo = _bus_allowed(-pchg_lim - aux, boost_eff) - p_g_act
            if _mot_power(mS, mT, mL, rg, wr_e, t_m) < p_m_lo:
                t_m_lo = _mot_torque_for_power(mS, mT, mL, rg, wr_e, p_m_lo, t_m, max(t_m, 0.0))
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
            p_g_min = (_bus_allowed(-pchg_lim - aux, boost_eff)
                       - _mot_power(mS, mT, mL, rg, wr_e, t_m))
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
        # ---------------- powers and energy bookkeeping (mid-step speeds)
        we_a = 0.5 * (we0 + we1)
        v_a = 0.5 * (v0 + v1)
        wr_a = g * v_a
        wg_a = k1 * we_a - k2 * wr_a
        fuel = fuel_rate(eS, eT, eF, we_a, te) if (fired and not fuelcut) else 0.0
        p_eng_mech = te * we_a
        p_gen_e = electrical_power(gS, gT, gL, wg_a, t_g)
        p_mot_e = _mot_power(mS, mT, mL, rg, wr_a, t_m)
        t_fd_act = t_m - k2 * t_g
        f_fd = eta_d * g * t_fd_act
        fl_app = min(fl, max(r_eff, 0.0))
        brk_app = r_eff - fl_app
        p_bus = p_mot_e + p_gen_e
        p_bt = battery_side_power(p_bus, boost_eff) + aux
        rb = interp1(bSoc, bRd, soc) if p_bt >= 0.0 else interp1(bSoc, bRc, soc)
        cur = current_from_power(p_bt, ocv, rb)
        vb = ocv - cur * rb
        soc = soc - cur * dt / cap_c
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
        if fired and not fuelcut and p_eng_mech > 0.0:
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
        # ---------------- engine stop / reverse clamp (kinetic energy removed is booked)
        if we1 < 0.0 or ((not cmd_on) and we1 < LOCK_SPEED):
            ke_free = 0.5 * (m11 * we1 * we1 + 2.0 * m12 * we1 * v1 + m22 * v1 * v1)
            ys[Y_LOCK_LOSS_J] += ke_free - 0.5 * m22 * v1 * v1
            we1 = 0.0
            if not cmd_on:
                locked = True
                i_gen = 0.0
        # ---------------- controller memories
        # generator speed PI, anti-windup whatever the state: integrate only near the target
        # and with MG1 unsaturated; elsewhere the integral is frozen, and dropped when it
        # opposes the proportional correction or the engine is beyond its speed window (a
        # launch winds it up; a stale integral would hold MG1 against pulling the engine back
        # and let MG1 pass its speed limit)
        if not locked:
            err_w = w_tgt - we1
            beyond = we1 > w_hi  # engine above its window (MG1 or engine near its limit)
            if (not clipped) and (not beyond) and abs(err_w) < 0.2 * eng_idle:
                i_gen += ki_gen * k1 * err_w * dt
                i_gen = min(max(i_gen, -gen_tmax), gen_tmax)
            elif i_gen * err_w < 0.0:
                i_gen = 0.0
        f_real = f_fd - brk_app
        if abs(f_real - f_dem) <= max(100.0, 0.05 * abs(f_dem)):
            i_drv += drv_ki * (vnext - v1) * dt
            i_drv = min(max(i_drv, -drv_lim), drv_lim)
        if fired and not was_fired:
            ys[Y_ENGINE_STARTS] += 1.0
        was_fired = fired
        if fired:
            ys[Y_ENG_ON_TIME_S] += dt
        v = v1
        we = we1
        wg1 = k1 * we1 - k2 * g * v1
        ys[Y_ENG_SPD_MAX] = max(ys[Y_ENG_SPD_MAX], we1)
        ys[Y_GEN_SPD_MAX_ABS] = max(ys[Y_GEN_SPD_MAX_ABS], abs(wg1))
        ys[Y_MOT_SPD_MAX] = max(ys[Y_MOT_SPD_MAX], rg * g * v1)
        ys[Y_SOC_MIN_SEEN] = min(ys[Y_SOC_MIN_SEEN], soc)
        ys[Y_SOC_MAX_SEEN] = max(ys[Y_SOC_MAX_SEEN], soc)
        miss = max(band_lo[i + 1] - v1, v1 - band_hi[i + 1], 0.0)
        if miss > 0.0:
            ys[Y_TRACE_N_MISS] += 1.0
        ys[Y_TRACE_MAX_MISS_MPS] = max(ys[Y_TRACE_MAX_MISS_MPS], miss)
        if record:
            j = i + 1
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
    ys[Y_KE_END_J] = 0.5 * (m11 * we * we + 2.0 * m12 * we * v + m22 * v * v)
    ys[Y_SOC_FINAL] = soc
    ys[Y_DURATION_S] = (n - 1) * dt
    return ys


@njit(cache=True, parallel=True)
def run_batch(vt, band_lo, band_hi, dt, prms, eS, eT, eF, eTm, oP, oS, mS, mT, mL, gS, gT, gL,
              bSoc, bOcv, bRd, bRc, bPd, bPc):
    """Run :func:`run` for every parameter row of ``prms`` (shared maps), in parallel.

    Returns
    -------
    ndarray (n_variants, N_Y) of summaries.
    """
    nv = prms.shape[0]
    res = np.zeros((nv, N_Y))
    for k in prange(nv):
        dummy = np.zeros((1, N_S))
        res[k, :] = run(vt, band_lo, band_hi, dt, prms[k], eS, eT, eF, eTm, oP, oS, mS, mT, mL,
                        gS, gT, gL, bSoc, bOcv, bRd, bRc, bPd, bPc, dummy, False)
    return res
