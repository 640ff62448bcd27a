"""Loads the roller force does not show: the car's own driveline drag, and the A/C compressor.

**Driveline drag.** A chassis dyno is set so that roller force + the car's own losses on the
rollers = the target road load: the measured force leaves out the driven axle's losses
(tyres on the rollers, bearings, differential), which the engine does supply. The dyno's
setting tells their total: target minus set coefficients (:mod:`vehval.identify.roadload`
identifies the set coefficients; the template states the target). Which share of that total
loads the engine (the driven axle's part) the setting does not tell, and the fuel data
cannot either: the fuel model's R² changes by a few thousandths over shares 0 to 1, and on
virtual tests its optimum missed the true share. The share ``s`` is therefore a stated
assumption (:class:`vehval.identify.build.Assumptions`, 0.5: the driven axle carries two of
the four tyres), the R² over shares is reported as evidence: drag ``F_d = s (ΔA + ΔB v)``.
ΔC is left out: the template's C is often a placeholder and the fitted C is within its own
uncertainty.

**A/C compressor.** With the A/C at maximum the engine drives the compressor: a constant
shaft power ``P_ac`` (a documented simplification: a compressor's torque varies with its
speed and cycling, the data give only its mean). It is identified from a test run with the
A/C on, from its phases after the first (the first bag of every test, hot or cold, carries
start-up fuel the model has no term for): the ``P_ac`` with which the identified model,
driving that test's speed trace, burns the measured fuel of those phases (the model as it
will predict, converter and idle included, rather than the fuel map alone).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq

from vehval.identify.fuelmap import FuelMapFit, fit_fuel_map
from vehval.identify.traces import IdentificationError, Trace

DRAG_SHARES = tuple(round(0.1 * k, 1) for k in range(11))
AC_MAX_W = 10000.0  # [W] search bound of the A/C load


@dataclass
class DragFit:
    """Identified driveline drag: share of the dyno losses, force terms, the R² curve."""

    share: float
    force_n: float
    force_n_per_mps: float
    dyno_loss_a_n: float
    dyno_loss_b_n_per_mps: float
    r2_5s_by_share: dict[float, float]
    note: str

    def to_dict(self) -> dict:
        return {"share": self.share, "drag_force_n": self.force_n,
                "drag_force_n_per_mps": self.force_n_per_mps,
                "dyno_loss_a_n": self.dyno_loss_a_n,
                "dyno_loss_b_n_per_mps": self.dyno_loss_b_n_per_mps,
                "r2_5s_by_share": {str(k): v for k, v in self.r2_5s_by_share.items()},
                "note": self.note}


def dyno_losses(traces: list[Trace], set_a: float, set_b: float) -> tuple[float, float] | None:
    """Target minus set coefficients (ΔA [N], ΔB [N/(m/s)]) from the template's target
    constants; None when the template states no target."""
    c = traces[0].constants
    if c.get("road_load_a_n") is None or c.get("road_load_b_n_per_mps") is None:
        return None
    return float(c["road_load_a_n"]) - set_a, float(c["road_load_b_n_per_mps"]) - set_b


def fit_drag(traces: list[Trace], power_fn, idle_rad_s: float, set_a: float,
             set_b: float, share: float, evidence: bool = True,
             limits: dict | None = None) -> tuple[DragFit, FuelMapFit]:
    """Driveline drag as ``share`` of the dyno losses, the fuel model fitted with it, and
    the fuel model's 5 s R² over shares 0-1 as evidence (see the module docstring).

    ``evidence=False`` skips the R² curve (cross-validation runs many identifications).
    ``power_fn(drag)`` returns the rebuilt engine powers [W] of ``traces`` for a drag
    (A_d, B_d). ``limits`` (``max_speed_rad_s``, ``lhv_j_per_kg``) go to
    :func:`.fuelmap.fit_fuel_map`.
    """
    lim = limits or {}
    loss = dyno_losses(traces, set_a, set_b)
    if loss is None or loss[0] + 30.0 * loss[1] <= 0.0:
        note = ("no target road load in the template: no drag" if loss is None else
                "target below the set coefficients: no drag")
        fm = fit_fuel_map(traces, power_fn((0.0, 0.0)), idle_rad_s, **lim)
        da, db = (0.0, 0.0) if loss is None else loss
        return DragFit(0.0, 0.0, 0.0, da, db, {0.0: fm.r2_5s}, note), fm
    da, db = max(loss[0], 0.0), max(loss[1], 0.0)
    fm = fit_fuel_map(traces, power_fn((share * da, share * db)), idle_rad_s, **lim)
    meter, cut = (fm.delay_s, fm.tau_s), fm.fuel_cut_speed_rad_s
    curve = {s: fm.r2_5s if s == share else
             fit_fuel_map(traces, power_fn((s * da, s * db)), idle_rad_s, meter, cut,
                          **lim).r2_5s
             for s in (DRAG_SHARES if evidence else (share,))}
    lo, hi = min(curve.values()), max(curve.values())
    note = (f"assumed share {share:.2f} of the dyno losses (target - set: {da:.1f} N + "
            f"{db:.3f} N/(m/s)); the fuel data do not identify it (R² of 5 s means "
            f"{lo:.4f}-{hi:.4f} over shares 0-1)")
    return DragFit(share, share * da, share * db, da, db, curve, note), fm


def fit_ac_load(vehicle, tr: Trace) -> dict:
    """A/C compressor power [W] of the conventional ``vehicle`` from ``tr`` (A/C on): the
    power with which the model, driving ``tr``'s speed, burns the measured fuel of the
    phases after the first (see the module docstring)."""
    from vehval.identify.predict import predict_trace, with_ac

    phases = np.unique(tr.phase[tr.phase > 0])
    used = [int(p) for p in (phases[1:] if phases.size > 1 else phases)]
    if not used:
        raise IdentificationError(f"A/C load: {tr.test_id} has no numbered phases to fit on")

    veh = with_ac(vehicle, True)

    def fuel(p_ac: float) -> tuple[float, float]:
        veh.engine_control.ac_power_w = p_ac
        rows = [r for r in predict_trace(veh, tr, ac="on")["phases"] if r["phase"] in used]
        return sum(r["predicted_g"] for r in rows), sum(r["measured_g"] for r in rows)

    f0, meas = fuel(0.0)
    if f0 >= meas:
        p_ac = 0.0
    elif fuel(AC_MAX_W)[0] < meas:
        raise IdentificationError(
            f"A/C load: {tr.test_id} burns more than the model with a {AC_MAX_W / 1e3:.0f} kW "
            "A/C load; is it a cold start or a different car?")
    else:
        p_ac = float(brentq(lambda p: fuel(p)[0] - meas, 0.0, AC_MAX_W, xtol=1.0))
    return {"ac_power_w": p_ac, "test": tr.test_id, "phases": used,
            "fuel_measured_g": meas, "fuel_model_without_ac_g": f0}
