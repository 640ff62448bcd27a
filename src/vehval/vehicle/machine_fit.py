"""A physically shaped loss surface for a permanent-magnet machine with its inverter.

Measured efficiency maps cover part of the speed-torque envelope (ORNL measured the 2004
Prius MG2 in the motoring quadrant only). To extend them without flat extrapolation the
losses are fitted with the terms each loss mechanism contributes, all non-negative:

    L(ω, T) = c0                      inverter control and gate drive [W]
            + c1 |ω| + c2 ω²          hysteresis and eddy-current iron losses, windage
            + c3 |T|                  inverter switching and diode/IGBT conduction (∝ current)
            + c4 T²                   copper losses (current ∝ torque below base speed)
            + c5 (T ω)²               field-weakening current at high power and speed

with ω [rad/s] and T [N·m]. The coefficients come from a non-negative least-squares fit
weighted toward relative error (:func:`fit_loss_surface`). Generating is taken as the
mirror of motoring at the same |ω| and |T| (the current, and so the copper, switching and
conduction losses, are the same for the same torque; iron losses depend on speed and flux).

A machine of another rating is derived by the scaling ADVISOR and Autonomie use
(:func:`scaled_losses`): speeds scale with the maximum speed, torques with rated power /
maximum speed, losses with rated power.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vehval.constants import RPM_RAD_PER_S as RPM

TERMS = ("c0_w", "c1_w_per_radps", "c2_w_per_radps2", "c3_w_per_nm", "c4_w_per_nm2",
         "c5_w_per_w2")


def _basis(w: np.ndarray, t: np.ndarray) -> np.ndarray:
    w, t = np.broadcast_arrays(np.abs(np.asarray(w, float)), np.abs(np.asarray(t, float)))
    return np.stack([np.ones_like(w), w, w * w, t, t * t, (t * w) ** 2], axis=-1)


@dataclass(frozen=True)
class LossSurface:
    """Fitted loss surface: coefficients (``TERMS`` order) and the quality of the fit."""

    coef: tuple[float, ...]
    rms_w: float = 0.0
    rms_efficiency: float = 0.0
    n_points: int = 0

    def loss(self, speed_radps, torque_nm) -> np.ndarray:
        """Loss [W] at speed [rad/s] and torque [N·m] (any quadrant)."""
        return _basis(speed_radps, torque_nm) @ np.asarray(self.coef)


def fit_loss_surface(speed_rpm, torque_nm, loss_w, floor_w: float = 300.0) -> LossSurface:
    """Non-negative least-squares fit of :class:`LossSurface` to measured losses.

    Parameters
    ----------
    speed_rpm, torque_nm, loss_w : array_like
        Measured points: speed [rpm], torque [N·m], loss = DC power - shaft power [W].
    floor_w : float
        Residuals are weighted by 1/sqrt(max(loss, floor_w)) [W], between absolute and
        relative error, so that the many small-loss points are not drowned by the few large.
    """
    from scipy.optimize import nnls

    w = np.asarray(speed_rpm, float) * RPM
    t = np.asarray(torque_nm, float)
    y = np.asarray(loss_w, float)
    a = _basis(w, t)
    scale = np.abs(a).max(axis=0)
    scale[scale == 0] = 1.0
    wt = 1.0 / np.sqrt(np.maximum(y, floor_w))
    c, _ = nnls(a / scale * wt[:, None], y * wt)
    c = c / scale
    pred = a @ c
    p_mech = np.abs(t * w)
    eff_m = p_mech / (p_mech + y)
    eff_p = p_mech / (p_mech + pred)
    return LossSurface(coef=tuple(float(x) for x in c),
                       rms_w=float(np.sqrt(np.mean((pred - y) ** 2))),
                       rms_efficiency=float(np.sqrt(np.mean((eff_p - eff_m) ** 2))),
                       n_points=int(y.size))


def scaled_losses(surface: LossSurface, speed_radps, torque_nm, speed_scale: float,
                  power_scale: float) -> np.ndarray:
    """Losses [W] of a machine scaled from ``surface``.

    The scaled machine reaches ``speed_scale`` times the speeds and ``power_scale`` times
    the power of the fitted one; its torque scales with power_scale / speed_scale and its
    losses with power_scale (same efficiency at corresponding points).
    """
    t_scale = power_scale / speed_scale
    return power_scale * surface.loss(np.asarray(speed_radps, float) / speed_scale,
                                      np.asarray(torque_nm, float) / t_scale)


def loss_table(loss_fn, speed_rpm, torque_nm, spin_loss=None) -> list[list[float]]:
    """Loss table [W] (rows = speeds, columns = torques) rounded to 0.1 W, never negative.

    ``spin_loss(speed_radps)`` [W], when given, is subtracted: a loss the vehicle's
    coast-down road load already contains (open-circuit rotor losses).
    """
    w = np.asarray(speed_rpm, float)[:, None] * RPM
    t = np.asarray(torque_nm, float)[None, :]
    w, t = np.broadcast_arrays(w, t)
    loss = np.asarray(loss_fn(w, t), float)
    if spin_loss is not None:
        loss = loss - spin_loss(np.abs(w))
    return np.round(np.maximum(loss, 0.0), 1).tolist()
