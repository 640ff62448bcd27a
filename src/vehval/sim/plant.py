"""The plant phases of one time step of the power-split loop (:func:`vehval.sim.kernel.run`).

After the controller phases of :mod:`vehval.sim.phases`: :func:`plant_phase`
(semi-implicit step of the two-DOF lever), :func:`power_phase` (mid-step speeds, fuel,
machine powers, wheel force), :func:`battery_phase` (bus, boost, current, SOC),
:func:`book_phase` (energy accounts), :func:`stop_phase` (engine stop / reverse clamp),
:func:`memory_phase` (controller integrators), :func:`end_phase` (state carried to the
next step, extrema, trace check) and :func:`record_phase`. Same convention as the
controller phases: ``phase(prm, maps, x, ...)`` with the state vector ``x``
(:data:`vehval.sim.layout.STATE`). Units: SI throughout.
"""

from __future__ import annotations

from vehval.numba_cache import njit
from vehval.sim.components.battery import current_from_power
from vehval.sim.components.boost import battery_side_power, output_voltage
from vehval.sim.components.electric_machine import electrical_power, torque_limit
from vehval.sim.components.engine import fuel_rate, warmup_factor
from vehval.sim.driver import band_miss, driver_memory
from vehval.sim.indices import *  # noqa: F401,F403 - index constants
from vehval.sim.maps import interp1
from vehval.sim.phases import bus_allowed, mot_power, mot_torque_for_power

LOCK_SPEED = 10.0  # [rad/s] below this an engine commanded off is taken as stopped


@njit(cache=True, inline="always")
def plant_phase(prm, maps, x, r_full):
    """Semi-implicit step of the two-DOF lever against the resistance ``r_full`` [N].

    MG2 compensates the actual gear reaction: T_m = T_fd_cmd + k2 T_g (eq. 1 with the ring
    torque of the gear set), so the wheels get the commanded torque while MG1 moves the
    engine; if MG2 saturates (or a hard battery limit binds), its torque is held and the
    step re-solved; MG1 gives way at the charge limit. A final explicit solve with the
    torques fixed keeps the energy bookkeeping exact.

    Writes the new engine ``we1`` [rad/s] and vehicle ``v1`` [m/s] speeds, MG1 ``t_g`` and
    MG2 (ring-side) ``t_m`` torques [N·m], the resistance actually applied ``r_eff`` [N],
    whether MG1 saturated (``clipped``) and the final-drive efficiency factor ``eta_d``.
    """
    mS, mT, mL, gS, gT, gL = maps[6], maps[7], maps[8], maps[9], maps[10], maps[11]
    m11 = x[X_M11]; m12 = x[X_M12]; m22 = x[X_M22]; det = x[X_DET]
    k1 = x[X_K1]; k2 = x[X_K2]; g = x[X_G]; dt = x[X_DT]
    we0 = x[X_WE0]; v0 = x[X_V0]; te = x[X_TE]; tg_ff = x[X_TG_FF]; t_ring = x[X_T_RING]
    t_m = x[X_T_M]; tm_lim = x[X_TM_LIM]; w_tgt = x[X_W_TGT]; i_gen = x[X_I_GEN]
    pdis_lim = x[X_PDIS_LIM]; pchg_lim = x[X_PCHG_LIM]; wg0 = x[X_WG0]; wr0 = x[X_WR0]
    wr_e = x[X_WR_E]
    fd_eff = prm[P_FD_EFF]; rg = prm[P_MG2_RATIO]
    gen_kp = prm[P_GEN_KP]; gen_tmax = prm[P_GEN_TMAX]; gen_pmax = prm[P_GEN_PMAX]
    aux = prm[P_AUX_W]; boost_eff = prm[P_BOOST_EFF]
    t_fd_cmd = t_m + t_ring
    clipped = False
    if x[X_LOCKED] > 0.5:
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
        p_g_act = electrical_power(gS, gT, gL,
                                   k1 * 0.5 * (we0 + we1) - k2 * wr0, t_g)
        t_m_hi = tm_lim
        t_m_lo = -tm_lim
        p_m_hi = bus_allowed(pdis_lim - aux, boost_eff) - p_g_act
        if mot_power(mS, mT, mL, rg, wr_e, t_m) > p_m_hi:
            t_m_hi = mot_torque_for_power(mS, mT, mL, rg, wr_e, p_m_hi, -tm_lim,
                                          min(t_m, tm_lim))
        p_m_lo = bus_allowed(-pchg_lim - aux, boost_eff) - p_g_act
        if mot_power(mS, mT, mL, rg, wr_e, t_m) < p_m_lo:
            t_m_lo = mot_torque_for_power(mS, mT, mL, rg, wr_e, p_m_lo,
                                          max(t_m, -tm_lim), min(max(t_m, 0.0), tm_lim))
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
    x[X_WE1] = we1
    x[X_V1] = v1
    x[X_T_G] = t_g
    x[X_T_M] = t_m
    x[X_R_EFF] = r_eff
    x[X_CLIPPED] = 1.0 if clipped else 0.0
    x[X_ETA_D] = eta_d


@njit(cache=True, inline="always")
def power_phase(prm, maps, x):
    """Mid-step speeds, fuel rate [kg/s] (with the warm-up factor at mid-step), engine,
    MG1 and MG2 powers [W], final-drive torque [N·m] and wheel force [N], and the split of
    the applied resistance into road load and friction braking [N]."""
    eS, eT, eF, mS = maps[0], maps[1], maps[2], maps[6]
    mT, mL, gS, gT, gL = maps[7], maps[8], maps[9], maps[10], maps[11]
    k1 = x[X_K1]; k2 = x[X_K2]; g = x[X_G]
    te = x[X_TE]; t_g = x[X_T_G]; t_m = x[X_T_M]; r_eff = x[X_R_EFF]; fl = x[X_FL]
    we_a = 0.5 * (x[X_WE0] + x[X_WE1])
    v_a = 0.5 * (x[X_V0] + x[X_V1])
    wr_a = g * v_a
    wg_a = k1 * we_a - k2 * wr_a
    fuel = (fuel_rate(eS, eT, eF, we_a, te)
            if (x[X_FIRED] > 0.5 and not x[X_FUELCUT] > 0.5) else 0.0)
    fuel *= warmup_factor(x[X_WARM_FRAC], prm[P_WARM_TAU], x[X_T_MID])
    t_fd_act = t_m - k2 * t_g
    fl_app = min(fl, max(r_eff, 0.0))
    x[X_WE_A] = we_a
    x[X_V_A] = v_a
    x[X_WR_A] = wr_a
    x[X_WG_A] = wg_a
    x[X_FUEL] = fuel
    x[X_P_ENG_MECH] = te * we_a
    x[X_P_GEN_E] = electrical_power(gS, gT, gL, wg_a, t_g)
    x[X_P_MOT_E] = mot_power(mS, mT, mL, prm[P_MG2_RATIO], wr_a, t_m)
    x[X_T_FD_ACT] = t_fd_act
    x[X_F_FD] = x[X_ETA_D] * g * t_fd_act
    x[X_FL_APP] = fl_app
    x[X_BRK_APP] = r_eff - fl_app


@njit(cache=True, inline="always")
def battery_phase(prm, maps, x):
    """Bus power [W], battery-side power [W] (through the boost converter, plus
    accessories), the resistance used [ohm], current [A], terminal voltage [V] and the new
    SOC [-]."""
    bSoc, bRd, bRc = maps[12], maps[14], maps[15]
    soc = x[X_SOC]; ocv = x[X_OCV]
    p_bus = x[X_P_MOT_E] + x[X_P_GEN_E]
    p_bt = battery_side_power(p_bus, prm[P_BOOST_EFF]) + prm[P_AUX_W]
    rb = interp1(bSoc, bRd, soc) if p_bt >= 0.0 else interp1(bSoc, bRc, soc)
    cur = current_from_power(p_bt, ocv, rb)
    x[X_P_BUS] = p_bus
    x[X_P_BT] = p_bt
    x[X_RB] = rb
    x[X_CUR] = cur
    x[X_VB] = ocv - cur * rb
    x[X_SOC] = soc - cur * x[X_DT] / prm[P_BATT_CAP_C]


@njit(cache=True, inline="always")
def book_phase(prm, maps, x, ys):
    """Add the step's energies [J], fuel [kg] and distance [m] to the summary ``ys``."""
    dt = x[X_DT]; fuel = x[X_FUEL]; lhv = prm[P_FUEL_LHV]; ocv = x[X_OCV]; cur = x[X_CUR]
    rb = x[X_RB]; p_eng_mech = x[X_P_ENG_MECH]; p_mot_e = x[X_P_MOT_E]
    p_gen_e = x[X_P_GEN_E]; t_m = x[X_T_M]; t_g = x[X_T_G]; wr_a = x[X_WR_A]
    wg_a = x[X_WG_A]; p_bt = x[X_P_BT]; p_bus = x[X_P_BUS]; aux = prm[P_AUX_W]; g = x[X_G]
    f_fd = x[X_F_FD]; v_a = x[X_V_A]; vb = x[X_VB]
    ys[Y_FUEL_MASS_KG] += fuel * dt
    ys[Y_FUEL_ENERGY_J] += fuel * lhv * dt
    ys[Y_ESS_CHEM_ENERGY_J] += ocv * cur * dt
    ys[Y_ESS_LOSS_J] += cur * cur * rb * dt
    ys[Y_ENG_LOSS_J] += (fuel * lhv - p_eng_mech) * dt
    ys[Y_MOT_LOSS_J] += (p_mot_e - t_m * wr_a) * dt
    ys[Y_GEN_LOSS_J] += (p_gen_e - t_g * wg_a) * dt
    ys[Y_BOOST_LOSS_J] += (p_bt - aux - p_bus) * dt
    ys[Y_AUX_ENERGY_J] += aux * dt
    ys[Y_FD_LOSS_J] += (g * x[X_T_FD_ACT] - f_fd) * v_a * dt
    ys[Y_BRAKE_ENERGY_J] += x[X_BRK_APP] * v_a * dt
    ys[Y_ROAD_ENERGY_J] += x[X_FL_APP] * v_a * dt
    ys[Y_UNMET_ENERGY_J] += (p_bt - vb * cur) * dt
    if (x[X_FIRED] > 0.5 and not x[X_FUELCUT] > 0.5) and p_eng_mech > 0.0:
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
def stop_phase(prm, maps, x, ys):
    """Engine stop / reverse clamp: an engine turning backwards, or commanded off and
    slower than :data:`LOCK_SPEED`, is stopped (its kinetic energy booked as lost); one
    commanded off is then held (carrier locked, generator integral reset)."""
    we1 = x[X_WE1]; v1 = x[X_V1]
    cmd_on = x[X_CMD_ON] > 0.5
    if we1 < 0.0 or ((not cmd_on) and we1 < LOCK_SPEED):
        m11 = x[X_M11]; m12 = x[X_M12]; m22 = x[X_M22]
        ke_free = 0.5 * (m11 * we1 * we1 + 2.0 * m12 * we1 * v1 + m22 * v1 * v1)
        ys[Y_LOCK_LOSS_J] += ke_free - 0.5 * m22 * v1 * v1
        x[X_WE1] = 0.0
        if not cmd_on:
            x[X_LOCKED] = 1.0
            x[X_I_GEN] = 0.0


@njit(cache=True, inline="always")
def memory_phase(prm, maps, x):
    """Controller integrators: generator speed PI [N·m] and driver PI [N].

    Generator speed PI, anti-windup whatever the state: integrate only near the target and
    with MG1 unsaturated; elsewhere the integral is frozen, and dropped when it opposes the
    proportional correction or the engine is beyond its speed window (a launch winds it up;
    a stale integral would hold MG1 against pulling the engine back and let MG1 pass its
    speed limit). The driver integrates only while the powertrain delivers the demand.
    """
    dt = x[X_DT]; we1 = x[X_WE1]; i_gen = x[X_I_GEN]; i_drv = x[X_I_DRV]
    if not x[X_LOCKED] > 0.5:
        err_w = x[X_W_TGT] - we1
        beyond = we1 > x[X_W_HI]  # engine above its window (MG1 or engine near its limit)
        if (not x[X_CLIPPED] > 0.5) and (not beyond) and abs(err_w) < 0.2 * prm[P_ENG_IDLE]:
            gen_tmax = prm[P_GEN_TMAX]
            i_gen += x[X_KI_GEN] * x[X_K1] * err_w * dt
            i_gen = min(max(i_gen, -gen_tmax), gen_tmax)
        elif i_gen * err_w < 0.0:
            i_gen = 0.0
    f_real = x[X_F_FD] - x[X_BRK_APP]
    f_dem = x[X_F_DEM]
    i_drv = driver_memory(i_drv, f_real, f_dem, prm[P_DRV_KI], prm[P_DRV_INT_LIM], x[X_VNEXT],
                          x[X_V1], dt)
    x[X_I_GEN] = i_gen
    x[X_I_DRV] = i_drv


@njit(cache=True, inline="always")
def end_phase(prm, maps, x, ys, band_lo, band_hi, j):
    """Carry the step's end to the next step; engine starts and on time, speed and SOC
    extrema, and the trace check against the band at row ``j`` of the grid."""
    dt = x[X_DT]; we1 = x[X_WE1]; v1 = x[X_V1]; g = x[X_G]
    fired = x[X_FIRED] > 0.5
    if fired and not x[X_WAS_FIRED] > 0.5:
        ys[Y_ENGINE_STARTS] += 1.0
    x[X_WAS_FIRED] = x[X_FIRED]
    if fired:
        ys[Y_ENG_ON_TIME_S] += dt
    x[X_V] = v1
    x[X_WE] = we1
    wg1 = x[X_K1] * we1 - x[X_K2] * g * v1
    x[X_WG1] = wg1
    soc = x[X_SOC]
    ys[Y_ENG_SPD_MAX] = max(ys[Y_ENG_SPD_MAX], we1)
    ys[Y_GEN_SPD_MAX_ABS] = max(ys[Y_GEN_SPD_MAX_ABS], abs(wg1))
    ys[Y_MOT_SPD_MAX] = max(ys[Y_MOT_SPD_MAX], prm[P_MG2_RATIO] * g * v1)
    ys[Y_SOC_MIN_SEEN] = min(ys[Y_SOC_MIN_SEEN], soc)
    ys[Y_SOC_MAX_SEEN] = max(ys[Y_SOC_MAX_SEEN], soc)
    miss = band_miss(band_lo[j], band_hi[j], v1)
    if miss > 0.0:
        ys[Y_TRACE_N_MISS] += 1.0
    ys[Y_TRACE_MAX_MISS_MPS] = max(ys[Y_TRACE_MAX_MISS_MPS], miss)


@njit(cache=True, inline="always")
def record_phase(prm, maps, x, out, j):
    """Write the step's signals into row ``j`` of ``out`` (columns of ``SIGNALS``)."""
    g = x[X_G]; rw = prm[P_R_WHEEL]; rg = prm[P_MG2_RATIO]
    v1 = x[X_V1]; f_fd = x[X_F_FD]; wg1 = x[X_WG1]; vb = x[X_VB]; cur = x[X_CUR]
    fired = x[X_FIRED] > 0.5
    out[j, S_VEH_SPD] = v1
    out[j, S_VEH_SPD_TARGET] = x[X_VNEXT]
    out[j, S_VEH_ACC] = (v1 - x[X_V0]) / x[X_DT]
    out[j, S_VEH_FRC_IN] = f_fd
    out[j, S_VEH_FRC_LOSS] = x[X_FL_APP]
    out[j, S_WHL_TRQ_OUT] = f_fd * rw
    out[j, S_WHL_SPD] = v1 / rw
    out[j, S_ENG_SPD_OUT] = x[X_WE1]
    out[j, S_ENG_TRQ_OUT] = x[X_TE]
    out[j, S_ENG_PWR_OUT] = x[X_P_ENG_MECH]
    out[j, S_ENG_SPD_TARGET] = x[X_W_TGT]
    out[j, S_ENG_ON] = 1.0 if fired else 0.0
    out[j, S_ENG_FUEL_CUT] = 1.0 if (fired and x[X_FUELCUT] > 0.5) else 0.0
    out[j, S_FUEL_RATE] = x[X_FUEL]
    out[j, S_GEN_SPD_OUT] = wg1
    out[j, S_GEN_TRQ_OUT] = x[X_T_G]
    out[j, S_GEN_PWR_IN] = x[X_P_GEN_E]
    out[j, S_MOT_SPD_OUT] = rg * g * v1
    out[j, S_MOT_TRQ_OUT] = x[X_T_M] / rg
    out[j, S_MOT_PWR_IN] = x[X_P_MOT_E]
    out[j, S_ESS_VOLT] = vb
    out[j, S_ESS_CURR] = cur
    out[j, S_ESS_PWR] = vb * cur
    out[j, S_ESS_SOC] = x[X_SOC]
    out[j, S_ESS_PWR_LIM_DIS] = x[X_PDIS_LIM]
    out[j, S_ESS_PWR_LIM_CHG] = x[X_PCHG_LIM]
    out[j, S_BOOST_VOLT_OUT] = output_voltage(
        vb, max(abs(wg1), rg * g * v1) / prm[P_BOOST_FULL_SPD], prm[P_BOOST_VMIN],
        prm[P_BOOST_VMAX])
    out[j, S_BRK_FRC] = x[X_BRK_APP]
    out[j, S_DRV_PWR_DEMAND] = x[X_P_WH]
    out[j, S_DRV_FRC_DEMAND] = x[X_F_DEM]
    out[j, S_PG_TRQ_RING] = -x[X_K2] * x[X_T_G]
    out[j, S_ENG_CTRL_STATE] = x[X_ENG_STATE]
    out[j, S_ESS_PWR_LIM_STATE] = x[X_PSTATE]
