"""Scale measured component maps to another machine or engine (later power-split generations).

The method is the one ADVISOR and Autonomie use to size components from a reference map:

* electric machine, by rated power and maximum speed: speed breakpoints x ``k_n`` (new /
  reference maximum speed), losses x ``k_p`` (new / reference rated power), torque
  breakpoints x ``k_p / k_n``. Efficiency is kept at corresponding points of the
  normalised map: a point at the same fraction of maximum speed and torque has the same
  efficiency.
* a 1-D efficiency curve over the fraction of rated power (a published or modelled figure
  for the newer machine) can be a floor on the scaled map's efficiency
  (:func:`efficiency_floor_losses`): at every point the loss is at most what that curve
  allows for the point's power.
* battery pack, by nominal voltage and capacity (:func:`scale_battery`): open-circuit
  voltage x ``k_v`` (new / reference nominal voltage) at the same SOC, resistances x
  ``k_v / k_c`` (``k_c`` new / reference capacity), power limits x ``k_v k_c`` (or to a
  given rating). At the same C-rate the current scales by ``k_c``, so the resistive loss
  as a fraction of the power, ``I R / V``, is unchanged: the cells work as the reference
  cells do. Across chemistries (NiMH to Li-ion) the reference's OCV shape over SOC is kept,
  a stated approximation where no measured cell curve exists.
* engine, by rated speed and peak torque: speed x ``k_n``, torque x ``k_t``, fuel rate x
  ``k_n k_t`` (efficiency kept), then x ``eta_ref / eta_new`` to move the peak efficiency to
  a published figure (every point improved by the same ratio).

:func:`fit_loss_surface` turns scattered measured machine points (speed, torque, loss) into a
physically shaped surface (non-negative terms in |T|, T^2, w^2, w^3 and |T| w) that can be
evaluated on any grid and then scaled.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from vehval.constants import RPM_RAD_PER_S
from vehval.vehicle.components import BatteryParams


def loss_basis(speed_rad_s: np.ndarray, torque_nm: np.ndarray) -> np.ndarray:
    """Loss terms [W per unit coefficient]: inverter conduction ~|T|, copper ~T^2, iron
    ~w^2 (x 1e-2), windage ~w^3 (x 1e-5), switching/iron under load ~|T| w (x 1e-2)."""
    w = np.asarray(speed_rad_s, float)
    t = np.abs(np.asarray(torque_nm, float))
    return np.column_stack([t, t**2, w**2 / 1e2, w**3 / 1e5, t * w / 1e2])


@dataclass(frozen=True)
class LossSurface:
    """A fitted loss surface ``loss = loss_basis(w, T) @ coef`` [W]."""

    coef: np.ndarray
    rms_w: float
    n_points: int

    def __call__(self, speed_rpm, torque_nm) -> np.ndarray:
        """Loss [W] at speed [rpm] (sign ignored) and torque [N·m]; any broadcastable shape."""
        w, t = np.broadcast_arrays(np.abs(np.asarray(speed_rpm, float)) * RPM_RAD_PER_S,
                                   np.asarray(torque_nm, float))
        return (loss_basis(w.ravel(), t.ravel()) @ self.coef).reshape(w.shape)

    def describe(self) -> str:
        c = self.coef
        return (f"loss = {c[0]:.4g}|T| + {c[1]:.4g}T^2 + {c[2]:.4g}e-2 w^2 + {c[3]:.4g}e-5 w^3 "
                f"+ {c[4]:.4g}e-2 |T| w [W; T N·m, w rad/s], {self.n_points} points, rms "
                f"residual {self.rms_w:.0f} W")


def fit_loss_surface(speed_rpm, torque_nm, loss_w) -> LossSurface:
    """Non-negative least-squares fit of :func:`loss_basis` to measured points.

    Parameters
    ----------
    speed_rpm, torque_nm, loss_w : array_like
        Measured operating points: shaft speed [rpm], torque [N·m], loss [W] (electrical
        minus mechanical power for a motoring machine).
    """
    from scipy.optimize import nnls

    w = np.abs(np.asarray(speed_rpm, float)) * RPM_RAD_PER_S
    t = np.asarray(torque_nm, float)
    y = np.asarray(loss_w, float)
    basis = loss_basis(w, t)
    coef, _ = nnls(basis, y)
    rms = float(np.sqrt(np.mean((basis @ coef - y) ** 2)))
    return LossSurface(coef=coef, rms_w=rms, n_points=int(y.size))


@dataclass(frozen=True)
class MachineScale:
    """Factors of :func:`machine_scale`: speed, torque and loss (power) multipliers."""

    speed: float
    torque: float
    loss: float


def machine_scale(ref_max_speed_rpm: float, ref_power_w: float, new_max_speed_rpm: float,
                  new_power_w: float) -> MachineScale:
    """ADVISOR/Autonomie machine scaling by rated power and maximum speed."""
    k_n = new_max_speed_rpm / ref_max_speed_rpm
    k_p = new_power_w / ref_power_w
    return MachineScale(speed=k_n, torque=k_p / k_n, loss=k_p)


def scale_machine_map(speed_rpm, torque_nm, loss_w, k: MachineScale):
    """Scaled breakpoints and loss map (lists): speed x k.speed, torque x k.torque, loss x k.loss.

    Efficiency at corresponding points is unchanged: output power and loss both scale by
    ``k.speed * k.torque = k.loss``.
    """
    return ([float(x) * k.speed for x in speed_rpm], [float(x) * k.torque for x in torque_nm],
            (np.asarray(loss_w, float) * k.loss).tolist())


def efficiency_floor_losses(speed_rpm, torque_nm, loss_w, rated_power_w: float,
                            power_fraction, efficiency) -> np.ndarray:
    """Loss map [W] limited by a 1-D efficiency floor ``efficiency(|P| / rated_power_w)``.

    At each point of mechanical power P = T w the loss becomes
    ``min(loss, |P| (1 / eta - 1))`` (motoring form, also used for generating, where it is
    the larger bound). At P = 0 (zero torque or standstill) the allowed loss is 0: a curve of
    efficiency over power cannot describe the holding loss at stall.
    """
    spd = np.asarray(speed_rpm, float) * RPM_RAD_PER_S
    p = np.abs(spd[:, None] * np.asarray(torque_nm, float)[None, :])
    eta = np.interp(p / rated_power_w, np.asarray(power_fraction, float),
                    np.asarray(efficiency, float))
    return np.minimum(np.asarray(loss_w, float), p * (1.0 / eta - 1.0))


def scale_engine_map(speed_rpm, torque_nm, fuel_g_per_s, max_torque_nm, k_speed: float,
                     k_torque: float, efficiency_ratio: float = 1.0):
    """Scaled engine map: speed x k_speed, torque x k_torque, fuel x k_speed k_torque /
    efficiency_ratio (``efficiency_ratio`` = new / reference peak efficiency)."""
    k_f = k_speed * k_torque / efficiency_ratio
    return ([float(x) * k_speed for x in speed_rpm], [float(x) * k_torque for x in torque_nm],
            (np.asarray(fuel_g_per_s, float) * k_f).tolist(),
            [float(x) * k_torque for x in max_torque_nm])


def scale_battery(ref: BatteryParams, *, n_cells: int, n_modules: int, capacity_ah: float,
                  nominal_voltage_v: float | None = None,
                  chemistry: Literal["nimh", "li_ion"] | None = None,
                  power_limit_w: float | None = None,
                  ref_name: str = "the reference pack") -> BatteryParams:
    """A pack scaled from ``ref`` by nominal voltage and capacity (ADVISOR/Autonomie method).

    Parameters
    ----------
    ref : BatteryParams
        Reference pack (its OCV [V], resistances [ohm] and power limits [W] over SOC).
    n_cells, n_modules : int
        Cells in series and modules of the new pack.
    capacity_ah : float
        Capacity of the new pack [A·h].
    nominal_voltage_v : float, optional
        Nominal voltage of the new pack [V]. Default: ``ref``'s per cell x ``n_cells``
        (same chemistry only; required when ``chemistry`` differs from the reference's).
    chemistry : {"nimh", "li_ion"}, optional
        Chemistry of the new pack. Default: the reference's.
    power_limit_w : float, optional
        Rated charge and discharge power [W]: the limit curves keep their shape over SOC,
        scaled to this peak. Default: the reference's x ``k_v k_c`` (same C-rate). The
        resistances are scaled by ``k_v² / k_p`` so that the rated power is drawn at the same
        fraction of the OCV as in the reference (at the same C-rate: ``k_v / k_c``).
    ref_name : str
        How the sources name the reference pack.

    Returns
    -------
    BatteryParams
        The new pack, SOC breakpoints and window of ``ref``, every value with its source.

    Raises
    ------
    ValueError
        A chemistry change without a nominal voltage, or a value out of range.
    """
    chem = chemistry or ref.chemistry
    if chem != ref.chemistry and nominal_voltage_v is None:
        raise ValueError(f"a {chem} pack scaled from a {ref.chemistry} one needs its "
                         "'nominal_voltage_v' (cells x the cell's nominal voltage): the "
                         "reference's voltage per cell is another chemistry's")
    derived_voltage = nominal_voltage_v is None
    if nominal_voltage_v is None:
        nominal_voltage_v = ref.nominal_voltage_v / ref.n_cells * n_cells
    if not (nominal_voltage_v > 0 and capacity_ah > 0):
        raise ValueError("nominal voltage and capacity of the new pack must be positive")
    k_v = nominal_voltage_v / ref.nominal_voltage_v
    k_c = capacity_ah / ref.capacity_ah

    def times(values, k):
        return [float(v) * k for v in values]

    peak = max(max(ref.discharge_power_limit_w), max(ref.charge_power_limit_w))
    k_p = k_v * k_c if power_limit_w is None else power_limit_w / peak
    how = (f"scaled from {ref_name} ({ref.n_cells} cells, {ref.nominal_voltage_v:g} V, "
           f"{ref.capacity_ah:g} Ah, {ref.chemistry}) by vehval.vehicle.scaling.scale_battery:")
    power_how = (f"{how} x {k_p:.4g} (to the {power_limit_w:g} W rating, shape over SOC kept)"
                 if power_limit_w is not None else
                 f"{how} x k_v k_c = {k_p:.4g} (same C-rate limits)")
    # resistance: the rated power at the same fraction of the OCV (same current share of
    # the short-circuit current): R x k_v^2 / k_p; at the same C-rate (k_p = k_v k_c) this
    # is R x k_v / k_c, the same loss fraction at the same C-rate
    k_r = k_v * k_v / k_p
    r_how = (f"{how} x k_v^2 / k_p = {k_r:.4g} (the rated power at the same fraction of "
             "the OCV" + ("; at the same C-rate k_v / k_c: the same loss fraction)"
                          if power_limit_w is None else ")"))
    sources = {
        "soc": f"{ref_name} breakpoints", "soc_min": f"{ref_name}", "soc_max": f"{ref_name}",
        "ocv_v": f"{how} x k_v = {k_v:.4g} (OCV shape over SOC of {ref_name})",
        "resistance_discharge_ohm": r_how, "resistance_charge_ohm": r_how,
        "discharge_power_limit_w": power_how, "charge_power_limit_w": power_how,
        "capacity_ah": "given", "n_cells": "given", "n_modules": "given",
        "nominal_voltage_v": (f"{ref_name}'s voltage per cell x {n_cells} cells"
                              if derived_voltage else "given"),
    }
    if chem != "nimh":  # a non-default value needs its source
        sources["chemistry"] = "given" if chemistry else ref_name
    return BatteryParams(
        soc=list(ref.soc), ocv_v=times(ref.ocv_v, k_v),
        resistance_discharge_ohm=times(ref.resistance_discharge_ohm, k_r),
        resistance_charge_ohm=times(ref.resistance_charge_ohm, k_r),
        discharge_power_limit_w=times(ref.discharge_power_limit_w, k_p),
        charge_power_limit_w=times(ref.charge_power_limit_w, k_p),
        capacity_ah=capacity_ah, n_cells=n_cells, n_modules=n_modules,
        nominal_voltage_v=nominal_voltage_v, soc_min=ref.soc_min, soc_max=ref.soc_max,
        chemistry=chem, sources=sources)
