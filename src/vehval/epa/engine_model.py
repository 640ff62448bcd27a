"""Generic spark-ignition engine of a car built from its specification: mean effective pressures.

The fuel map of :func:`vehval.epa.specs.vehicle_from_specs` is written in mean effective
pressures (MEP: work per cycle over the displacement), which scale a map to any
displacement. At engine speed N and brake torque T of a four-stroke engine of displacement
V_d:

* brake MEP ``BMEP = 4 pi T / V_d``;
* total friction MEP ``FMEP`` (rubbing friction and the pumping work at wide-open
  throttle) of four-cylinder spark-ignition engines, Heywood (1988, eq. 13.13):
  ``0.97 + 0.15 (N/1000) + 0.05 (N/1000)^2`` bar, times a free friction scale (it also
  absorbs the part-load throttling work);
* fuel MEP ``(BMEP + FMEP) / eta_i`` (a Willans line in MEP, ``eta_i`` the free indicated
  efficiency), times ``1 + k_h s`` at high load: above ``HIGH_LOAD_FROM`` of the full-load
  torque the spark of a high-compression engine is retarded from its best timing to avoid
  knock and, nearer full load, the mixture is enriched for power (Heywood 1988: a
  full-load equivalence ratio of about 1.1-1.2); ``s`` rises linearly from 0 there to 1 at full load
  and ``k_h = HIGH_LOAD_FUEL`` (0.2, the top of the enrichment range, which also stands for
  the retarded spark);
* idle control: at idle speed the engine control holds the speed with retarded spark and
  its own air flow, off the Willans line; the map at idle speed and the accessory load is
  shifted to burn the warm idle fuel rate measured in the tests, the shift fading linearly
  to nothing at the fuel-cut speed (:func:`idle_control_shift`), so that a car rolling
  below the fuel-cut speed (the converter open, the engine at idle) burns its idle fuel.

Fuel power is ``MEP x V_d x N / 2`` (one cycle per two revolutions) over the fuel's lower
heating value. Every function is pure and vectorised; units are SI unless the name says.
"""

from __future__ import annotations

import math

import numpy as np

from vehval.constants import RPM_RAD_PER_S as RPM

FMEP_BAR = (0.97, 0.15, 0.05)  # Heywood eq. 13.13: a + b (N/1000) + c (N/1000)^2 [bar]
#: fuel increase at full load [-] and the share of full-load torque it starts from [-]:
#: knock-limited spark retard and power enrichment of a modern high-compression engine
HIGH_LOAD_FUEL, HIGH_LOAD_FROM = 0.2, 0.5


def fmep_pa(speed_rpm: np.ndarray | float, scale: float = 1.0) -> np.ndarray:
    """Friction MEP [Pa] at engine speed [rpm]: Heywood eq. 13.13 times ``scale`` [-]."""
    n = np.asarray(speed_rpm, float) / 1000.0
    return scale * (FMEP_BAR[0] + FMEP_BAR[1] * n + FMEP_BAR[2] * n ** 2) * 1e5


def mep_pa(torque_nm: np.ndarray | float, displacement_l: float) -> np.ndarray:
    """Mean effective pressure [Pa] of a four-stroke engine's torque [N·m]."""
    return 4.0 * math.pi * np.asarray(torque_nm, float) / (displacement_l * 1e-3)


def torque_nm(mep: np.ndarray | float, displacement_l: float) -> np.ndarray:
    """Torque [N·m] of a mean effective pressure [Pa] (inverse of :func:`mep_pa`)."""
    return np.asarray(mep, float) * displacement_l * 1e-3 / (4.0 * math.pi)


def high_load_factor(torque_share: np.ndarray, fuel: float = HIGH_LOAD_FUEL,
                     start: float = HIGH_LOAD_FROM) -> np.ndarray:
    """Fuel factor [-] near full load: ``1 + fuel s``, s from 0 at ``start`` to 1 at full load
    (``torque_share`` = torque / full-load torque [-])."""
    s = np.clip((np.asarray(torque_share, float) - start) / (1.0 - start), 0.0, 1.0)
    return 1.0 + fuel * s


def fuel_rate_g_per_s(speed_rpm: np.ndarray, torque: np.ndarray, full_load_nm: np.ndarray,
                      displacement_l: float, eta_i: float, friction_scale: float,
                      lhv_j_per_kg: float,
                      high_load: tuple[float, float] = (HIGH_LOAD_FUEL, HIGH_LOAD_FROM),
                      pumping_pa: float = 0.0) -> np.ndarray:
    """Willans fuel map [g/s] on the grid ``speed_rpm`` [rpm] x ``torque`` [N·m].

    ``full_load_nm`` is the full-load torque at each speed [N·m]; ``eta_i`` the indicated
    efficiency [-]; ``high_load`` the (fuel increase, start share) of
    :func:`high_load_factor`; ``pumping_pa`` the part-load pumping MEP at zero load [Pa]
    (:func:`pumping_mep_pa`). Negative torque is overrun: the fuel at zero torque.
    """
    spd = np.asarray(speed_rpm, float)[:, None]
    trq = np.maximum(np.asarray(torque, float)[None, :], 0.0)
    tmax = np.asarray(full_load_nm, float)[:, None]
    bmep = mep_pa(trq, displacement_l)
    pump = pumping_mep_pa(bmep, mep_pa(tmax, displacement_l), pumping_pa) if pumping_pa else 0.0
    fuel_mep = ((bmep + fmep_pa(spd, friction_scale) + pump) / eta_i
                * high_load_factor(trq / tmax, *high_load))
    power = fuel_mep * displacement_l * 1e-3 * spd * RPM / (4.0 * math.pi)  # MEP V_d N/2 [W]
    return power / lhv_j_per_kg * 1e3


def pumping_mep_pa(bmep: np.ndarray, full_bmep: np.ndarray, zero_load_pa: float) -> np.ndarray:
    """Part-load pumping MEP [Pa] of a throttled spark-ignition engine: ``zero_load_pa`` at
    zero brake load falling linearly to 0 at full load (the intake pressure rises about in
    proportion to the load; Heywood 1988, section 13.5: the pumping MEP of a throttled
    engine is a fraction of a bar at light load, near zero at wide-open throttle, which eq.
    13.13 counts)."""
    share = np.clip(np.asarray(bmep, float) / np.maximum(full_bmep, 1.0), 0.0, 1.0)
    return zero_load_pa * (1.0 - share)


def idle_control_shift(speed_rpm: np.ndarray, idle_rpm: float, cut_rpm: float,
                       map_at_idle_g_per_s: float, idle_fuel_g_per_s: float) -> np.ndarray:
    """Shift [g/s] added to the map rows at ``speed_rpm`` [rpm] under idle control.

    The map at idle speed and the accessory load (``map_at_idle_g_per_s``) is moved to the
    measured idle fuel rate; the shift is whole up to ``idle_rpm`` and fades linearly to
    zero at the fuel-cut speed ``cut_rpm`` [rpm]. It may be negative (an idle leaner than
    the Willans line) and is affine in the map, so the fuel stays affine in 1 / eta_i.
    """
    w = np.clip((cut_rpm - np.asarray(speed_rpm, float)) / (cut_rpm - idle_rpm), 0.0, 1.0)
    return (idle_fuel_g_per_s - map_at_idle_g_per_s) * w


__all__ = ["FMEP_BAR", "HIGH_LOAD_FROM", "HIGH_LOAD_FUEL", "fmep_pa", "fuel_rate_g_per_s",
           "high_load_factor", "idle_control_shift", "mep_pa", "pumping_mep_pa", "torque_nm"]
