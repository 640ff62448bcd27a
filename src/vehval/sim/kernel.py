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

The step is a sequence of named phases (:mod:`vehval.sim.phases`): driver, supervisor
(state machine), operating point, torque split, plant, battery, bookkeeping, controller
memories, recording. The parameters come as one vector laid out by
:data:`vehval.sim.layout.PARAMS` (index constants generated from it, :mod:`vehval.sim.indices`)
and the maps as one tuple in :data:`vehval.sim.packing.MAP_NAMES` order.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from vehval.sim.components.body import road_load
from vehval.sim.components.boost import output_voltage
from vehval.sim.components.electric_machine import electrical_power
from vehval.sim.components.engine import fuel_rate, warmup_factor
from vehval.sim.control import ENG_OFF, engine_commanded_on
from vehval.sim.indices import *  # noqa: F401,F403 - index constants
from vehval.sim.maps import interp1
from vehval.sim.phases import (
    LOCK_SPEED,
    battery_phase,
    book_phase,
    driver_phase,
    engine_torque,
    memory_phase,
    mot_power,
    operating_point_phase,
    plant_phase,
    record_phase,
    supervisor_phase,
    torque_split_phase,
)


@njit(cache=True)
def run(vt, band_lo, band_hi, dt, prm, maps, out, record):
    """Simulate one cycle.

    Parameters
    ----------
    vt : ndarray
        Target speed [m/s] on the uniform time grid (step ``dt`` [s]).
    band_lo, band_hi : ndarray
        EPA tolerance band of the target [m/s] on the same grid.
    prm : ndarray
        Scalar parameters packed as in :data:`vehval.sim.layout.PARAMS` (SI).
    maps : tuple of ndarray
        In :data:`vehval.sim.packing.MAP_NAMES` order: engine speed [rad/s] and torque
        [N·m] breakpoints, fuel map [kg/s], full-load torque; best-efficiency line power [W]
        -> speed [rad/s]; MG2 and MG1 speed, torque breakpoints and loss maps [W]; battery
        SOC breakpoints, OCV [V], discharge/charge resistance [ohm], power limits [W].
    out : ndarray (n, N_S)
        Recorded signals (written only when ``record``).
    record : bool

    Returns
    -------
    ndarray (N_Y,) : summary accumulators, see :data:`vehval.sim.layout.SUMMARY`.
    """
    eS, eT, eF, eTm, oP, oS, mS, mT, mL, gS, gT, gL, bSoc, bOcv, bRd, bRc, bPd, bPc = maps
    n = vt.shape[0]
    ys = np.zeros(N_Y)
    mass = prm[P_MASS]; rl_a = prm[P_RL_A]; rl_b = prm[P_RL_B]; rl_c = prm[P_RL_C]
    aux = prm[P_AUX_W]; rw = prm[P_R_WHEEL]; fd = prm[P_FD_RATIO]; fd_eff = prm[P_FD_EFF]
    brk_max = prm[P_BRK_MAX]; ns = prm[P_N_SUN]; nr = prm[P_N_RING]
    eng_idle = prm[P_ENG_IDLE]; eng_drag = prm[P_ENG_DRAG]; lhv = prm[P_FUEL_LHV]
    mot_tmax = prm[P_MOT_TMAX]; gen_tmax = prm[P_GEN_TMAX]; gen_max = prm[P_GEN_MAX_SPD]
    cap_c = prm[P_BATT_CAP_C]; boost_eff = prm[P_BOOST_EFF]
    gen_kp = prm[P_GEN_KP]; ki_gen = min(prm[P_GEN_KI], 0.5 * gen_kp / dt)
    drv_tau = prm[P_DRV_TAU]; drv_ki = prm[P_DRV_KI]; drv_lim = prm[P_DRV_INT_LIM]
    drv_fmax = prm[P_DRV_FMAX]

    cold = prm[P_COLD_START] > 0.5
    hold_s = prm[P_COLD_HOLD] if cold else 0.0  # engine held on after a cold start [s]
    warm_frac = prm[P_WARM_FRAC] if cold else 0.0  # warm-up extra fuel at t = 0 [-]
    warm_tau = prm[P_WARM_TAU]
    cold_pwr = prm[P_COLD_PWR] if cold else 0.0  # engine power floor during the hold [W]
    rg = prm[P_MG2_RATIO]  # MG2 shaft speed / ring speed
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
    geo = (k1, k2, g, rw, fd, fd_eff, rg)
    mm = (m11, m12, m22, det)
    em = (eS, eT, eF, eTm)
    ol = (oP, oS)
    m2 = (mS, mT, mL)
    m1 = (gS, gT, gL)
    bm = (bSoc, bOcv, bRd, bRc, bPd, bPc)

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
        f_dem, p_wh = driver_phase(v0, vnow, vnext, dt, m22, rl_a, rl_b, rl_c, i_drv, drv_tau,
                                   f_min, drv_fmax)
        (ocv, pdis_lim, pchg_lim, pdis_av, pchg_av, p_filt, tm_pwr, tm_spd, tm_bat, tm_soc,
         tm_off, st_new, tst) = supervisor_phase(
            prm, soc, v0, p_wh, dt, p_filt, a_filt, tm_pwr, tm_spd, tm_bat, tm_soc, tm_off, st,
            tst, bm, i * dt < hold_s)
        if st_new != st:
            ys[Y_STATE_SWITCHES] += 1.0
        st = st_new
        cmd_on = engine_commanded_on(st)
        if cmd_on:
            locked = False
        p_floor = cold_pwr if i * dt < hold_s else 0.0
        w_lo, w_hi, w_tgt, p_eng, fuelcut, fired, te_max_now, wg0 = operating_point_phase(
            prm, cmd_on, max(p_filt, p_floor), f_dem, we0, wr0, wr_e, fired, v0, ocv, soc, geo, wg_lim, s_eq,
            em, ol, m2, m1, bm)
        te = engine_torque(locked, fired, fuelcut, p_eng, w_tgt, we0, te_max_now, eng_drag)
        te, tg_ff, t_ring, t_m, tm_lim, pstate, f_brk = torque_split_phase(
            prm, locked, fired, fuelcut, te, te_max_now, p_eng, f_dem, v0, we0, wr0, wr_e, wg0,
            geo, pdis_av, pchg_av, m2, m1)
        fl = road_load(v0, rl_a, rl_b, rl_c)
        r_full = fl + f_brk
        we1, v1, t_g, t_m, r_eff, clipped, eta_d = plant_phase(
            prm, locked, dt, we0, v0, te, tg_ff, t_ring, t_m, tm_lim, w_tgt, r_full, mm, geo,
            i_gen, pdis_lim, pchg_lim, wg0, wr0, wr_e, m2, m1)
        # ---------------- powers at mid-step speeds, battery, energy accounts
        we_a = 0.5 * (we0 + we1)
        v_a = 0.5 * (v0 + v1)
        wr_a = g * v_a
        wg_a = k1 * we_a - k2 * wr_a
        fuel = fuel_rate(eS, eT, eF, we_a, te) if (fired and not fuelcut) else 0.0
        fuel *= warmup_factor(warm_frac, warm_tau, (i + 0.5) * dt)
        p_eng_mech = te * we_a
        p_gen_e = electrical_power(gS, gT, gL, wg_a, t_g)
        p_mot_e = mot_power(mS, mT, mL, rg, wr_a, t_m)
        t_fd_act = t_m - k2 * t_g
        f_fd = eta_d * g * t_fd_act
        fl_app = min(fl, max(r_eff, 0.0))
        brk_app = r_eff - fl_app
        p_bus, p_bt, rb, cur, vb, soc = battery_phase(p_mot_e, p_gen_e, aux, boost_eff, ocv, soc,
                                                      dt, cap_c, bSoc, bRd, bRc)
        book_phase(ys, dt, fuel, lhv, ocv, cur, rb, p_eng_mech, p_mot_e, p_gen_e, t_m, t_g,
                   wr_a, wg_a, p_bt, p_bus, aux, g, t_fd_act, f_fd, v_a, brk_app, fl_app, vb,
                   fired and not fuelcut)
        # ---------------- engine stop / reverse clamp (kinetic energy removed is booked)
        if we1 < 0.0 or ((not cmd_on) and we1 < LOCK_SPEED):
            ke_free = 0.5 * (m11 * we1 * we1 + 2.0 * m12 * we1 * v1 + m22 * v1 * v1)
            ys[Y_LOCK_LOSS_J] += ke_free - 0.5 * m22 * v1 * v1
            we1 = 0.0
            if not cmd_on:
                locked = True
                i_gen = 0.0
        i_gen, i_drv = memory_phase(locked, clipped, w_tgt, we1, w_hi, eng_idle, ki_gen, k1, dt,
                                    gen_tmax, i_gen, f_fd - brk_app, f_dem, vnext, v1, drv_ki,
                                    drv_lim, i_drv)
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
            record_phase(out, i + 1, prm, geo, dt, v0, v1, vnext, f_fd, fl_app,
                         (we1, te, p_eng_mech, w_tgt, fuel), fired, fuelcut, wg1, t_g, p_gen_e,
                         t_m, p_mot_e, vb, cur, soc, pdis_lim, pchg_lim, brk_app, p_wh, f_dem, st,
                         pstate)
    ys[Y_KE_END_J] = 0.5 * (m11 * we * we + 2.0 * m12 * we * v + m22 * v * v)
    ys[Y_SOC_FINAL] = soc
    ys[Y_DURATION_S] = (n - 1) * dt
    return ys


@njit(cache=True, parallel=True)
def run_batch(vt, band_lo, band_hi, dt, prms, maps):
    """Run :func:`run` for every parameter row of ``prms`` (shared maps), in parallel.

    Returns
    -------
    ndarray (n_variants, N_Y) of summaries.
    """
    nv = prms.shape[0]
    res = np.zeros((nv, N_Y))
    for k in prange(nv):
        dummy = np.zeros((1, N_S))
        res[k, :] = run(vt, band_lo, band_hi, dt, prms[k], maps, dummy, False)
    return res
