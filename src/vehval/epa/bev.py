"""Battery-electric rows of the EPA Test Car Lists: a vehicle from a row, judging rows.

The lists give battery-electric cars' charge-depleting UDDS (procedure code 81) and Highway
(84) results under ``FE_UNIT`` ``MPG``, in one of two quantities: values above
:data:`MPGE_THRESHOLD` are unadjusted MPGe on AC (wall) recharge energy, lower values are
AC consumptions in kWh/100 mi (Tesla, Kia, Hyundai rows). :func:`listed_figure` tells them
apart; a row is judged in its own unit.

:func:`bev_from_row` builds a vehicle from one row plus the generic values and maps of
:mod:`vehval.vehicle.bev_generic`: test mass (equivalent test weight), target road load,
reduction ratio (axle ratio), wheel radius from the N/V ratio, motor peak power (rated
horsepower). :func:`judge_row` simulates the row's cycle and forms the normalised error
against the lists' reproducibility (:func:`vehval.uncertainty.verdict.judge_published`,
the packaged precision of family ``electric``; the pooled figure of all families where the
electric rows are too few).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from pydantic import ValidationError

from vehval.constants import MPH_M_PER_S, RPM_RAD_PER_S
from vehval.epa.reader import EpaTest
from vehval.errors import ConfigError
from vehval.fuels.quantities import mpge_from_kwh_per_100mi
from vehval.vehicle.bev import BatteryElectricVehicle
from vehval.vehicle.bev_generic import bev_vehicle_data

#: Procedure codes of the charge-depleting cycles -> the cycle simulated.
CD_CYCLES = {81: "udds", 84: "hwfet"}
#: Listed values above this are MPGe, at or below it kWh/100 mi (no BEV reaches 60 MPGe;
#: no BEV uses 60 kWh/100 mi).
MPGE_THRESHOLD = 60.0
#: Generic peak-torque basis: peak power [W] / this speed [rad/s] (base speed of a BEV
#: traction motor, about 3,300 rpm: Leaf 2019 3,283 rpm, i3 4,800 rpm).
BASE_SPEED_RAD_S = 3300.0 * RPM_RAD_PER_S
_EST = "engineering estimate (generic, vehval.epa.bev)"
#: Pack energy [kWh] of a row without a sheet (the lists give none); it sets the pack's
#: resistance and SOC change, a second-order effect on consumption.
GENERIC_BATTERY_KWH = 30.0
#: Plausible rolling radius of a car's wheel [mm] (13 in to 22 in wheels).
WHEEL_RADIUS_MM = (200, 450)
#: Rolling radius [m] of a row whose ratios disagree (a 16-17 in wheel).
GENERIC_WHEEL_RADIUS_M = 0.31


def is_bev_row(t: EpaTest) -> bool:
    """A battery-electric charge-depleting row: electricity, procedure 81/84, no engine
    (displacement absent, below 0.2 L or the 99.999 placeholder)."""
    if t.procedure_code not in CD_CYCLES:
        return False
    d = t.displacement_l
    return d is None or not math.isfinite(d) or d < 0.2 or d > 99.0


def figure_unit(value: float) -> str:
    """The unit of an electricity figure of the lists (their FE_UNIT says MPG for MPGe):
    ``MPGe`` above :data:`MPGE_THRESHOLD`, else a ``kWh/100mi`` consumption."""
    return "MPGe" if value > MPGE_THRESHOLD else "kWh/100mi"


def listed_figure(t: EpaTest) -> tuple[float, str]:
    """The row's figure and its unit (:func:`figure_unit`)."""
    if not (math.isfinite(t.fe) and t.fe > 0):
        raise ConfigError(f"{t.source}: no listed result")
    return t.fe, figure_unit(t.fe)


def wheel_radius_from_nv(axle_ratio: float, n_v: float) -> float:
    """Wheel radius [m] from the axle ratio and N/V (motor rpm per mph)."""
    return axle_ratio * MPH_M_PER_S / (RPM_RAD_PER_S * n_v)


def reduction_of_row(t: EpaTest) -> tuple[float, float, tuple[str, str]]:
    """Reduction ratio [-], wheel radius [m] and how each was found, from a row.

    Only motor speed per vehicle speed (the N/V ratio) matters to the energy. The axle
    ratio and N/V give the radius when it is plausible (:data:`WHEEL_RADIUS_MM`); else the
    row's two figures disagree: an axle ratio of a single reduction (5-15) is kept with the
    generic radius, otherwise (a final-drive-only ratio) N/V sets the ratio at the generic
    radius.
    """
    r = wheel_radius_from_nv(t.axle_ratio, t.n_v_ratio)
    if WHEEL_RADIUS_MM[0] <= 1e3 * r <= WHEEL_RADIUS_MM[1]:
        return t.axle_ratio, r, ("axle ratio", "computed from the axle ratio and N/V")
    gen = f"{_EST}: {GENERIC_WHEEL_RADIUS_M} m rolling radius (the row's axle ratio and N/V " \
          f"imply {r:.3f} m)"
    if 5.0 <= t.axle_ratio <= 15.0:
        return t.axle_ratio, GENERIC_WHEEL_RADIUS_M, ("axle ratio", gen)
    ratio = t.n_v_ratio * RPM_RAD_PER_S * GENERIC_WHEEL_RADIUS_M / MPH_M_PER_S
    if not 3.0 <= ratio <= 20.0:
        raise ConfigError(f"{t.source}: axle ratio {t.axle_ratio:g} and N/V {t.n_v_ratio:g} "
                          "describe no single-reduction electric drive (implied radius "
                          f"{r:.3f} m, implied reduction {ratio:.2f})")
    return ratio, GENERIC_WHEEL_RADIUS_M, ("computed from N/V at the generic radius", gen)


def row_conditions(t: EpaTest) -> dict[str, Any]:
    """Overrides (dotted paths) that put a vehicle on the row's test conditions."""
    out: dict[str, Any] = {"body.mass_kg": t.mass_kg, "body.road_load_a_n": t.target_a_n,
                           "body.road_load_b_n_per_mps": t.target_b_n_per_mps,
                           "body.road_load_c_n_per_mps2": t.target_c_n_per_mps2}
    if math.isfinite(t.n_v_ratio) and t.n_v_ratio > 0 and math.isfinite(t.axle_ratio):
        r = wheel_radius_from_nv(t.axle_ratio, t.n_v_ratio)
        if WHEEL_RADIUS_MM[0] <= 1e3 * r <= WHEEL_RADIUS_MM[1]:  # else the vehicle's own radius
            out["driveline.wheel_radius_m"] = r
    return out


def bev_from_row(t: EpaTest, generic: dict[str, tuple[Any, str]] | None = None
                 ) -> BatteryElectricVehicle:
    """A battery-electric vehicle from one list row plus generic values (``generic``:
    key -> (value, source) replacing the defaults of :data:`GENERIC`)."""
    if not (math.isfinite(t.rated_power_w) and t.rated_power_w > 0):
        raise ConfigError(f"{t.source}: no rated horsepower: a vehicle needs its motor power")
    if not (math.isfinite(t.axle_ratio) and t.axle_ratio > 0 and math.isfinite(t.n_v_ratio)
            and t.n_v_ratio > 0):
        raise ConfigError(f"{t.source}: axle ratio and N/V are needed for the reduction and "
                          "the wheel radius")
    row = f"EPA Test Car List {t.source} ({t.make} {t.model} {t.vehicle_id})"
    ratio, r, how = reduction_of_row(t)
    p = t.rated_power_w
    vals: dict[str, Any] = {
        "mass_kg": t.mass_kg, "road_load_a_n": t.target_a_n,
        "road_load_b_n_per_mps": t.target_b_n_per_mps,
        "road_load_c_n_per_mps2": t.target_c_n_per_mps2, "max_power_w": p,
        "max_torque_nm": p / BASE_SPEED_RAD_S, "final_drive_ratio": ratio,
        "wheel_radius_m": r,
        "battery_kwh": GENERIC_BATTERY_KWH, "cells_series": 96}
    src = {"mass_kg": f"{row}: equivalent test weight", "road_load_a_n": f"{row}: target A",
           "road_load_b_n_per_mps": f"{row}: target B",
           "road_load_c_n_per_mps2": f"{row}: target C",
           "max_power_w": f"{row}: rated horsepower",
           "max_torque_nm": _EST + ": rated power / 3,300 rpm base speed",
           "final_drive_ratio": f"{row}: {how[0]}",
           "wheel_radius_m": f"{row}: {how[1]}",
           "battery_kwh": _EST + ": 30 kWh pack (the lists give no pack energy)",
           "cells_series": _EST + ": 96 cells in series (a 350 V class pack)"}
    for k, (v, s) in (generic or {}).items():
        vals[k], src[k] = v, s
    name = f"{t.make}_{t.model}_{t.year}".lower().replace(" ", "_")
    data = bev_vehicle_data(name=name, description=f"battery-electric car from {row} and "
                            "generic maps", values=vals, sources=src)
    try:
        return BatteryElectricVehicle.model_validate(data)
    except ValidationError as exc:
        e = exc.errors()[0]
        raise ConfigError(f"{t.source}: vehicle from the row refused: key "
                          f"'{'.'.join(str(x) for x in e['loc'])}': {e['msg']}") from None


@dataclass
class RowJudgement:
    """One row judged: the listed and the simulated figure in the row's unit."""

    row: EpaTest
    cycle: str
    unit: str
    listed: float
    model: float
    en: float
    u_model: float
    u_meas: float
    in_sample: bool = False

    @property
    def error(self) -> float:
        """Relative error model / listed - 1 [-]."""
        return self.model / self.listed - 1.0

    def to_dict(self) -> dict[str, Any]:
        t = self.row
        return {"row": t.source, "make": t.make, "model": t.model, "vehicle_id": t.vehicle_id,
                "year": t.year, "cycle": self.cycle, "unit": self.unit, "listed": self.listed,
                "simulated": self.model, "error": self.error, "en": self.en,
                "U_model": self.u_model, "U_meas": self.u_meas, "in_sample": self.in_sample}


def simulate_row(veh: BatteryElectricVehicle, t: EpaTest, dt: float = 1.0,
                 on_row_conditions: bool = True) -> tuple[float, str, str]:
    """The row's figure simulated: (value in the row's unit, unit, cycle)."""
    from vehval.sim.simulate import simulate

    cycle = CD_CYCLES[t.procedure_code]
    _, unit = listed_figure(t)
    over = row_conditions(t) if on_row_conditions else {}
    s = simulate(veh, cycle, dt=dt, **over).summary
    return (s["mpge"] if unit == "MPGe" else s["ac_kwh_per_100mi"]), unit, cycle


def judge_row(veh: BatteryElectricVehicle, t: EpaTest, u_model_rel: float, dt: float = 1.0,
              in_sample: bool = False) -> RowJudgement:
    """Simulate and judge one row; ``u_model_rel``: the model's expanded relative
    uncertainty (k = 2) [-]."""
    from vehval.uncertainty.verdict import judge_published

    model, unit, cycle = simulate_row(veh, t, dt)
    listed, _ = listed_figure(t)
    cmp, _basis = judge_published(model, listed, u_model=abs(model) * u_model_rel,
                                  cycle=cycle, family="electric",
                                  u_stated=2 * 0.05 / math.sqrt(3),  # listed to 0.1
                                  label=f"{t.make} {t.model} {cycle}")
    return RowJudgement(t, cycle, unit, listed, model, cmp.en, cmp.u_model, cmp.u_meas,
                        in_sample)


def as_mpge(value: float, unit: str) -> float:
    """A listed or simulated figure as MPGe (kWh/100 mi converted)."""
    return value if unit == "MPGe" else mpge_from_kwh_per_100mi(value)


__all__ = ["CD_CYCLES", "MPGE_THRESHOLD", "RowJudgement", "bev_from_row", "figure_unit",
           "is_bev_row",
           "judge_row", "as_mpge", "listed_figure", "row_conditions",
           "simulate_row", "wheel_radius_from_nv"]


#: Expanded relative uncertainty (k = 2) of a simulated list figure [-]: twice the standard
#: deviation of the held-out relative errors of vehicles built from a row alone (2016 list
#: judged with the loss scale fitted on 2019: 14.5 %; docs/validation.md).
MODEL_U_REL = 2 * 0.145
#: Where :data:`MODEL_U_REL` comes from, as notes state it.
MODEL_U_SOURCE = ("declared bound: twice the standard deviation (14.5 %) of the held-out "
                  "relative errors of battery-electric vehicles built from a list row alone "
                  "(docs/validation.md); the parameter ranges of a battery-electric vehicle "
                  "file are not propagated (vehval.sim.model_uncertainty runs fuel figures)")


def is_bev_vehicle(vehicle: Any) -> bool:
    """Whether a vehicle (name, path or model) is battery-electric."""
    from vehval.vehicle import load_vehicle

    return getattr(load_vehicle(vehicle), "architecture", "") == "battery_electric"


def validate_bev(vehicle: Any, tests: list[EpaTest], dt: float = 1.0,
                 u_model_rel: float = MODEL_U_REL) -> dict[str, Any]:
    """Judge list rows on electricity with one battery-electric vehicle, each row on its own
    test conditions (:func:`row_conditions`): rows, relative-error statistics, skipped rows.
    """
    from vehval.vehicle import load_vehicle

    veh = load_vehicle(vehicle)
    judged, skipped = [], []
    for t in tests:
        if not is_bev_row(t):
            skipped.append({"row": t.source, "reason": "not a battery-electric "
                            "charge-depleting UDDS or Highway row"})
            continue
        try:
            judged.append(judge_row(veh, t, u_model_rel, dt).to_dict())
        except ConfigError as exc:
            skipped.append({"row": t.source, "reason": str(exc)})
    errs = [j["error"] for j in judged]
    stats = {"n": len(errs)}
    if errs:
        stats.update({"mean_error": sum(errs) / len(errs),
                      "mean_abs_error": sum(abs(e) for e in errs) / len(errs),
                      "n_consistent": sum(abs(j["en"]) <= 1 for j in judged)})
    return {"vehicle": veh.name, "u_model_rel": u_model_rel, "rows": judged, "stats": stats,
            "skipped": skipped}


def shown_figure(value: float, unit: str, system_name: str | None = None
                 ) -> tuple[float, str]:
    """A row's figure as the reader reads it: as the list states it (MPGe or kWh/100 mi) in
    the ``us`` system, kWh/100 km in ``metric``."""
    from vehval.constants import MILE_M
    from vehval.display import system
    from vehval.fuels.quantities import kwh_per_100mi_from_mpge

    if system(system_name) == "us":
        return value, unit
    return kwh_per_100mi_from_mpge(as_mpge(value, unit)) / (MILE_M / 1000.0), "kWh/100 km"


def validation_text(doc: dict[str, Any]) -> str:
    """Screen text of :func:`validate_bev` (figures in the display units; the error is of
    the row's own figure, as in the JSON)."""
    lines = [f"{'row':22s} {'cycle':6s} {'listed':>8} {'sim':>8} unit       {'err %':>6} "
             f"{'En':>6}"]
    for j in doc["rows"]:
        listed, unit = shown_figure(j["listed"], j["unit"])
        sim, _ = shown_figure(j["simulated"], j["unit"])
        lines.append(f"{j['row'][:22]:22s} {j['cycle']:6s} {listed:8.1f} "
                     f"{sim:8.1f} {unit:10s} {100 * j['error']:+6.1f} "
                     f"{j['en']:+6.2f}")
    for s in doc["skipped"]:
        lines.append(f"skipped {s['row']}: {s['reason']}")
    if doc["rows"] and shown_figure(1.0, "MPGe")[1] != "MPGe":
        lines.append("err %: of the list's own figure (MPGe or kWh/100 mi), as the JSON; "
                     "a consumption reads the other way round")
    st = doc["stats"]
    if st["n"]:
        lines.append(f"{st['n']} rows: mean error {100 * st['mean_error']:+.1f} %, mean "
                     f"|error| {100 * st['mean_abs_error']:.1f} %, {st['n_consistent']} with "
                     f"|En| <= 1 (U_model {100 * doc['u_model_rel']:.0f} %, k = 2)")
    return "\n".join(lines)


def vehicle_from_rows(rows: list[EpaTest]) -> BatteryElectricVehicle:
    """`epa vehicle` for electricity rows: the vehicle of the first battery-electric row
    (rows of one test vehicle share weight, road load and ratios)."""
    bev = [t for t in rows if is_bev_row(t)]
    if not bev:
        raise ConfigError("no battery-electric charge-depleting row among the selected rows")
    return bev_from_row(bev[0])
