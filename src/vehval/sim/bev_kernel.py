"""The compiled time loop of the forward-looking battery-electric simulation.

Battery -> inverter + motor -> single reduction -> wheels. State: vehicle speed ``v``
[m/s], battery SOC [-]. One step of ``dt``:

1. driver: wheel force demand (feed-forward + PI, :func:`vehval.sim.phases.driver_demand`);
2. motor torque: traction demand through the reduction, capped by the motor's peak torque,
   its peak power and the battery's discharge power limit (less the accessories); braking
   demand: the driven axle's share, faded out below ``regen_fade_hi`` (none below
   ``regen_fade_lo``), capped by the regeneration power, the motor's limits and the
   battery's charge power limit; friction brakes take the rest;
3. vehicle: ``m_eq dv/dt = F_motor − F_brake − F_road`` (``m_eq`` holds the wheels' and the
   rotor's inertia referred to the wheel), the car stopping within a step taking only the
   brake force that stops it;
4. electric: at mid-step speed, the motor + inverter loss from its map, DC bus power =
   shaft power + loss + accessories; battery current from ``P = (V_oc − I R) I`` with the
   discharge or charge resistance at the SOC; ``SOC -= I dt / capacity``.

Energy closure: chemical energy ``∫ V_oc I dt`` = battery I²R loss + motor loss +
accessories + reduction loss + brakes + road load + kinetic energy change (exact to
rounding: every power is taken at the same mid-step speed).
"""

from __future__ import annotations

import numpy as np

from vehval.numba_cache import njit
from vehval.sim.components.battery import current_from_power, terminal_voltage
from vehval.sim.components.body import longitudinal_step
from vehval.sim.driver import band_miss, driver_memory
from vehval.sim.indices import *  # noqa: F401,F403 - index constants
from vehval.sim.layout import BEV_PARAMS, BEV_SIGNALS, BEV_SUMMARY
from vehval.sim.maps import interp1, interp2
from vehval.sim.phases import driver_demand

__all__ = ["BEV_PARAMS", "BEV_SIGNALS", "BEV_SUMMARY", "STANDSTILL_MPS", "motor_torque_limit",
           "run_bev"]

STANDSTILL_MPS = 0.05  # [m/s] below this (and a zero target) the car stands


@njit(cache=True)
def motor_torque_limit(w, tmax, pmax):
    """Peak torque [N·m] at motor speed ``w`` [rad/s]: ``min(T_max, P_max / |w|)``."""
    aw = abs(w)
    if aw * tmax <= pmax:
        return tmax
    return pmax / aw


@njit(cache=True)
def run_bev(vt, band_lo, band_hi, dt, prm, mS, mT, mL, bSoc, bOcv, bRd, bRc, bPd, bPc, out,
            record):  # long: one compiled time loop (numba)
    """Simulate one cycle; returns the summary vector (``BEV_SUMMARY`` order).

    ``vt`` target speed [m/s] on a uniform grid of step ``dt`` [s]; ``band_lo/hi`` its EPA
    band [m/s]; ``prm`` scalars (``BEV_PARAMS``, SI); ``mS, mT, mL`` motor + inverter loss
    map: speed [rad/s], torque [N·m] breakpoints, loss [W]; ``bSoc`` SOC breakpoints,
    ``bOcv`` OCV [V], ``bRd/bRc`` discharge / charge resistance [Ω], ``bPd/bPc`` discharge /
    charge power limits [W]; ``out`` (n, len(BEV_SIGNALS)) written when ``record``.
    """
    n = vt.shape[0]
    ys = np.zeros(N_BY)
    rw = prm[BP_R_WHEEL]; fd = prm[BP_FD_RATIO]; eff = prm[BP_FD_EFF]
    g = fd / rw  # [rad/m] motor speed per vehicle speed
    m_eq = prm[BP_MASS] + prm[BP_J_WHEEL] / (rw * rw) + prm[BP_J_MOT] * g * g
    rl_a = prm[BP_RL_A]; rl_b = prm[BP_RL_B]; rl_c = prm[BP_RL_C]
    aux = prm[BP_AUX_W]; tmax = prm[BP_MOT_TMAX]; pmax = prm[BP_MOT_PMAX]
    cap = prm[BP_BATT_CAP_C]
    f_min = -(prm[BP_BRK_MAX] + 1e4)
    fade_lo = prm[BP_REGEN_FADE_LO]; fade_hi = prm[BP_REGEN_FADE_HI]
    v = vt[0]
    soc = prm[BP_SOC_INIT]
    i_drv = 0.0
    ys[BY_KE_START_J] = 0.5 * m_eq * v * v
    ys[BY_SOC_MIN_SEEN] = soc
    if record:
        out[0, BS_VEH_SPD] = v; out[0, BS_VEH_SPD_TARGET] = vt[0]; out[0, BS_WHL_SPD] = v / rw
        out[0, BS_MOT_SPD_OUT] = v * g; out[0, BS_ESS_SOC] = soc
        out[0, BS_ESS_VOLT] = interp1(bSoc, bOcv, soc)
    for i in range(n - 1):
        v0 = v
        vnext = vt[i + 1]
        f_dem, p_dem = driver_demand(v0, vt[i], vnext, dt, m_eq, rl_a, rl_b, rl_c, i_drv,
                                     prm[BP_DRV_TAU], f_min, prm[BP_DRV_FMAX])
        ocv = interp1(bSoc, bOcv, soc)
        p_dis = interp1(bSoc, bPd, soc)
        p_chg = interp1(bSoc, bPc, soc)
        if soc <= prm[BP_SOC_MIN]:
            p_dis = 0.0
        if soc >= prm[BP_SOC_MAX]:
            p_chg = 0.0
        # ---------------- motor torque (limits at the step's start speed)
        w0 = v0 * g
        t_lim = motor_torque_limit(w0, tmax, pmax)
        t_wh = f_dem * rw
        if f_dem >= 0.0:
            t_m = min(t_wh / (fd * eff), t_lim)
            p_av = max(p_dis - aux, 0.0)
            if t_m * w0 > p_av:
                t_m = p_av / w0  # the battery cannot give more (losses ignored in the cap)
        else:
            share = prm[BP_REGEN_SHARE]
            if v0 <= fade_lo:
                fade = 0.0
            elif v0 >= fade_hi:
                fade = 1.0
            else:
                fade = (v0 - fade_lo) / (fade_hi - fade_lo)
            f_reg = f_dem * share * fade  # [N] < 0, electric braking force asked
            if -f_reg * v0 > prm[BP_REGEN_PMAX]:
                f_reg = -prm[BP_REGEN_PMAX] / max(v0, 1e-6)
            t_m = max(f_reg * rw * eff / fd, -t_lim)
            p_in = p_chg + aux  # [W] the battery's charge limit plus what the bus consumes
            if -t_m * w0 > p_in:
                t_m = -p_in / max(w0, 1e-6)
        # ---------------- vehicle
        f_pt = t_m * g
        f_pt = f_pt * eff if f_pt >= 0.0 else f_pt / eff
        v1, f_brk, fl = longitudinal_step(v0, f_pt, f_dem, prm[BP_BRK_MAX], rl_a, rl_b, rl_c,
                                            m_eq, dt)
        v_a = 0.5 * (v0 + v1)
        # ---------------- electric (mid-step speed)
        w_a = v_a * g
        p_mech = t_m * w_a
        # standing without torque the inverter does not switch: no machine loss
        loss = interp2(mS, mT, mL, w_a, t_m) if (t_m != 0.0 or w_a > 0.0) else 0.0
        p_bus = p_mech + loss + aux
        r = interp1(bSoc, bRd, soc) if p_bus >= 0.0 else interp1(bSoc, bRc, soc)
        cur = current_from_power(p_bus, ocv, r)
        vb = terminal_voltage(ocv, r, cur)
        p_term = vb * cur
        unmet = p_bus - p_term  # [W] > 0 only beyond the pack's maximum power
        soc -= cur * dt / cap
        # ---------------- energy bookkeeping
        ys[BY_ESS_CHEM_ENERGY_J] += ocv * cur * dt
        ys[BY_ESS_DC_ENERGY_J] += p_term * dt
        if p_term >= 0.0:
            ys[BY_ESS_DC_DISCHARGE_J] += p_term * dt
        else:
            ys[BY_ESS_DC_CHARGE_J] -= p_term * dt
        ys[BY_ESS_LOSS_J] += cur * cur * r * dt
        ys[BY_MOT_LOSS_J] += loss * dt
        ys[BY_MOT_OUT_ENERGY_J] += p_mech * dt
        if p_mech < 0.0:
            ys[BY_REGEN_MECH_ENERGY_J] -= p_mech * dt
        ys[BY_AUX_ENERGY_J] += aux * dt
        ys[BY_FD_LOSS_J] += (p_mech - f_pt * v_a) * dt
        ys[BY_WHEEL_ENERGY_J] += f_pt * v_a * dt
        ys[BY_BRAKE_ENERGY_J] += f_brk * v_a * dt
        ys[BY_ROAD_ENERGY_J] += fl * v_a * dt
        ys[BY_UNMET_ENERGY_J] += unmet * dt
        ys[BY_DISTANCE_M] += v_a * dt
        ys[BY_SOC_MIN_SEEN] = min(ys[BY_SOC_MIN_SEEN], soc)
        # ---------------- driver memory (conditional integration)
        i_drv = driver_memory(i_drv, f_pt - f_brk, f_dem, prm[BP_DRV_KI], prm[BP_DRV_INT_LIM],
                              vnext, v1, dt)
        miss = band_miss(band_lo[i + 1], band_hi[i + 1], v1)
        if miss > 0.0:
            ys[BY_TRACE_N_MISS] += 1.0
        ys[BY_TRACE_MAX_MISS_MPS] = max(ys[BY_TRACE_MAX_MISS_MPS], miss)
        v = v1
        if record:
            j = i + 1
            out[j, BS_VEH_SPD] = v1
            out[j, BS_VEH_SPD_TARGET] = vnext
            out[j, BS_VEH_ACC] = (v1 - v0) / dt
            out[j, BS_VEH_FRC_IN] = f_pt - f_brk
            out[j, BS_VEH_FRC_LOSS] = fl
            out[j, BS_WHL_TRQ_OUT] = f_pt * rw
            out[j, BS_WHL_SPD] = v1 / rw
            out[j, BS_MOT_SPD_OUT] = v1 * g
            out[j, BS_MOT_TRQ_OUT] = t_m
            out[j, BS_MOT_PWR_IN] = p_mech + loss
            out[j, BS_ESS_VOLT] = vb
            out[j, BS_ESS_CURR] = cur
            out[j, BS_ESS_PWR] = p_term
            out[j, BS_ESS_SOC] = soc
            out[j, BS_ESS_PWR_LIM_DIS] = p_dis
            out[j, BS_ESS_PWR_LIM_CHG] = p_chg
            out[j, BS_BRK_FRC] = f_brk
            out[j, BS_DRV_FRC_DEMAND] = f_dem
            out[j, BS_DRV_PWR_DEMAND] = p_dem
    ys[BY_KE_END_J] = 0.5 * m_eq * v * v
    ys[BY_SOC_FINAL] = soc
    ys[BY_DURATION_S] = (n - 1) * dt
    return ys
