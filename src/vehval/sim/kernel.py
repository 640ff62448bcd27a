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

The step is a sequence of named phases (:mod:`vehval.sim.phases`, :mod:`vehval.sim.plant`):
driver, supervisor (the engine rule of :mod:`vehval.sim.supervisor`), operating point,
engine torque, torque split, plant, powers, battery, bookkeeping, engine stop, controller
memories, end of step, recording. Each phase is ``phase(prm, maps, x)``: the parameters as
one vector laid out by :data:`vehval.sim.layout.PARAMS`, the maps as one tuple in
:data:`vehval.sim.packing.MAP_NAMES` order and the loop state as one vector laid out by
:data:`vehval.sim.layout.STATE` (index constants generated from the layouts,
:mod:`vehval.sim.indices`).
"""

from __future__ import annotations

import numpy as np
from numba import prange

from vehval.numba_cache import njit
from vehval.sim.components.body import road_load
from vehval.sim.components.boost import output_voltage
from vehval.sim.control import engine_commanded_on
from vehval.sim.indices import *  # noqa: F401,F403 - index constants
from vehval.sim.maps import interp1
from vehval.sim.phases import (
    driver_phase,
    engine_torque_phase,
    operating_point_phase,
    start_phase,
    supervisor_phase,
    torque_split_phase,
)
from vehval.sim.plant import (
    battery_phase,
    book_phase,
    end_phase,
    memory_phase,
    plant_phase,
    power_phase,
    record_phase,
    stop_phase,
)
from vehval.sim.stack import borrowed_maps, stack_vector


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
    n = vt.shape[0]
    ys = np.zeros(N_Y)
    maps = borrowed_maps(maps)  # no reference counting of the tables inside the loop
    x = stack_vector(N_X)  # the loop state, kept in registers (see vehval.sim.stack)
    start_phase(prm, maps, x, vt[0], dt)
    v = x[X_V]
    soc = x[X_SOC]
    ys[Y_KE_START_J] = 0.5 * x[X_M22] * v * v
    ys[Y_SOC_MIN_SEEN] = soc
    ys[Y_SOC_MAX_SEEN] = soc
    if record:
        bSoc, bOcv, bPd, bPc = maps[12], maps[13], maps[16], maps[17]
        rw = prm[P_R_WHEEL]; g = x[X_G]
        ocv0 = interp1(bSoc, bOcv, soc)
        for k in range(N_S):
            out[0, k] = 0.0
        out[0, S_VEH_SPD] = v; out[0, S_VEH_SPD_TARGET] = vt[0]; out[0, S_WHL_SPD] = v / rw
        out[0, S_MOT_SPD_OUT] = prm[P_MG2_RATIO] * g * v
        out[0, S_GEN_SPD_OUT] = -x[X_K2] * g * v
        out[0, S_ESS_SOC] = soc; out[0, S_ESS_VOLT] = ocv0
        out[0, S_BOOST_VOLT_OUT] = output_voltage(ocv0, 0.0, prm[P_BOOST_VMIN], prm[P_BOOST_VMAX])
        out[0, S_ESS_PWR_LIM_DIS] = interp1(bSoc, bPd, soc)
        out[0, S_ESS_PWR_LIM_CHG] = interp1(bSoc, bPc, soc)
        out[0, S_ENG_CTRL_STATE] = x[X_ENG_STATE]

    for i in range(n - 1):
        g = x[X_G]
        v0 = x[X_V]
        vnext = vt[i + 1]
        x[X_T] = i * dt
        x[X_T_MID] = (i + 0.5) * dt
        x[X_V0] = v0
        x[X_WE0] = x[X_WE]
        x[X_VNOW] = vt[i]
        x[X_VNEXT] = vnext
        x[X_WR0] = g * v0
        x[X_WR_E] = g * 0.5 * (v0 + vnext)  # expected mid-step ring speed (power estimates)
        driver_phase(prm, maps, x)
        st = x[X_ENG_STATE]
        supervisor_phase(prm, maps, x)
        if x[X_ENG_STATE] != st:
            ys[Y_STATE_SWITCHES] += 1.0
        cmd_on = engine_commanded_on(int(x[X_ENG_STATE]))
        x[X_CMD_ON] = 1.0 if cmd_on else 0.0
        if cmd_on:
            x[X_LOCKED] = 0.0
        p_floor = x[X_COLD_PWR] if x[X_T] < x[X_HOLD_S] else 0.0
        x[X_P_CMD] = max(x[X_P_FILT], p_floor)
        operating_point_phase(prm, maps, x)
        engine_torque_phase(prm, maps, x)
        torque_split_phase(prm, maps, x)
        fl = road_load(v0, prm[P_RL_A], prm[P_RL_B], prm[P_RL_C])
        x[X_FL] = fl
        plant_phase(prm, maps, x, fl + x[X_F_BRK])
        power_phase(prm, maps, x)
        battery_phase(prm, maps, x)
        book_phase(prm, maps, x, ys)
        stop_phase(prm, maps, x, ys)
        memory_phase(prm, maps, x)
        end_phase(prm, maps, x, ys, band_lo, band_hi, i + 1)
        if record:
            record_phase(prm, maps, x, out, i + 1)
    v = x[X_V]
    we = x[X_WE]
    ys[Y_KE_END_J] = 0.5 * (x[X_M11] * we * we + 2.0 * x[X_M12] * we * v + x[X_M22] * v * v)
    ys[Y_SOC_FINAL] = x[X_SOC]
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
