"""A conventional vehicle from public specifications: one EPA Test Car List configuration.

A test with only speed and fuel (no force, no engine speed) cannot identify a car; its
public specification can describe most of it. An EPA Test Car List row gives the
equivalent test weight, the road-load target A/B/C, the axle ratio, N/V (engine rpm per
mph in top gear), the number of gears and the transmission type, the displacement and
the rated power. :func:`specs_from_tests` reads them, :func:`vehicle_from_specs` builds
the :class:`~vehval.vehicle.conventional.ConventionalVehicle` the simulator runs, deriving
what the list does not state with generic, documented scaling (constants below):

* engine fuel (:mod:`vehval.epa.engine_model`): a Willans line in mean effective
  pressures, fuel power = (brake power + friction power) / indicated efficiency, with the
  friction mean effective pressure of a spark-ignition engine (Heywood 1988, eq. 13.13:
  FMEP [bar] = 0.97 + 0.15 N/1000 + 0.05 (N/1000)^2, N in rpm) times the displacement.
  Two factors stay free and are the calibrated parameters (:mod:`vehval.epa.specs_fit`):
  the indicated efficiency (``indicated_efficiency``) and a friction scale
  (``friction_scale``, 1 = Heywood's curve; it absorbs the throttled pumping work); from
  half the full-load torque the fuel rises to ``ENRICHMENT`` more at full load (knock
  retard, power enrichment); the warm idle fuel rate is measured in the calibration tests
  when they are given, and the map under idle control (up to the fuel-cut speed) burns it;
* full load: the BMEP of a naturally aspirated gasoline engine up to the power limit of
  the rated power, rated at a generic speed;
* gearbox: top-gear overall ratio from N/V (engine speed per vehicle speed, exact), the
  other gears geometric over a ratio spread typical of the gear count; shift lines from
  engine speeds; a converter sized by its stall speed, locked from third gear (an
  automatic; a CVT, an automated manual or dual-clutch box and a manual are built by
  their family, :mod:`vehval.epa.transmissions`);
* generic technology coefficients (:mod:`vehval.epa.technology`): when no fuel value is
  given, the indicated efficiency, friction scale, warm idle factor, part-load pumping
  and gearbox efficiency of the engine technology and transmission family, fitted across
  a list year (docs/validation.md);
* cold start: the extra fuel of the FTP's first bag over its third in the list's own
  FTP rows of the configuration (the same car, same road load), placed as the vehicle's
  warm-up fuel with a generic time constant.

Every value carries its source in the vehicle file.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from vehval.constants import MPH_M_PER_S as MPH
from vehval.constants import RPM_RAD_PER_S as RPM
from vehval.epa import engine_model as em
from vehval.epa import technology as tech
from vehval.epa.procedures import (
    UDDS_BAG1_END_S,
    fuel_family,
    procedure_key,
    road_load_without_b,
)
from vehval.epa.reader import EpaTest
from vehval.epa.specs_rows import (  # noqa: F401 - the row checks, re-exported
    _SPEC_KEYS,
    ENGINE_FUELS,
    HYBRID_WORDS,
    IDLE_SPEED_RPM,
    RATED_SPEED_RPM,
    SPARK_FUELS,
    SPECIFIC_POWER_W_PER_L,
    _check_car,
    _check_values,
    _is_gasoline,
    _refuse_mixed,
    _refuse_transmission,
    _spec_rows,
    _where,
    hybrid_mark,
)
from vehval.epa.transmissions import (  # noqa: F401 - the generic gearbox values, re-exported
    DOWNSHIFT_FULL,
    DOWNSHIFT_RPM,
    LOCKUP_FROM_GEAR,
    LOCKUP_RPM,
    RATIO_SPREAD,
    STALL_SPEED_RPM,
    UPSHIFT_FULL,
    UPSHIFT_RPM,
    family_of,
    gearbox_blocks,
)
from vehval.errors import ConfigError
from vehval.vehicle.conventional import ConventionalVehicle

#: generic values for what a Test Car List row does not state (engineering estimates)
FMEP_BAR = em.FMEP_BAR  # Heywood eq. 13.13: a + b (N/1000) + c (N/1000)^2 [bar]
INDICATED_EFFICIENCY = 0.38  # start value: gross indicated efficiency of a modern SI engine
BMEP_MAX_PA = 12.0e5  # full-load BMEP of a naturally aspirated gasoline engine [Pa]
#: a turbocharged direct-injection car diesel: rated power at about 4000 rpm, full-load BMEP
#: about 18 bar from 1750 rpm (engineering estimate of the car diesels of the 2016-2019
#: lists: 2.0-3.0 L, 100-190 kW, 350-600 N m); no enrichment at full load (a diesel runs
#: lean at every load: its full load is smoke-limited, not enriched)
DIESEL_RATED_SPEED_RPM = 4000.0
DIESEL_BMEP_MAX_PA = 18.0e5
ENRICHMENT = em.HIGH_LOAD_FUEL  # extra fuel at full load [-] (knock retard, enrichment)
WHEEL_RADIUS_M = 0.33  # rolling radius [m]: only engine speed / vehicle speed matters
ACCESSORY_POWER_W = 300.0  # alternator, pumps [W]
FUEL_CUT_IDLE_RATIO = 1.6  # fuel cut on overrun above this x idle speed [-]
WARMUP_TIME_CONSTANT_S = 200.0  # decay of a cold engine's extra fuel [s]
_EST = "engineering estimate (generic, vehval.epa.specs)"


@dataclass
class Specs:
    """Public specification of one test-vehicle configuration (SI; see module docstring).

    Attributes
    ----------
    name : str
        Vehicle name (``toyota_camry_xle_xse_2019``).
    mass_kg : float
        Equivalent test weight [kg].
    target_a_n, target_b_n_per_mps, target_c_n_per_mps2 : float
        Road-load target coefficients [N, N/(m/s), N/(m/s)^2].
    axle_ratio : float
        Final drive ratio [-].
    n_v_ratio : float
        Engine speed per vehicle speed in top gear [rpm/mph].
    gears : int
        Number of gears.
    displacement_l : float
        Displacement [L].
    rated_power_w : float
        Rated power [W].
    cold_bag_ratio : float
        FTP bag 3 / bag 1 fuel economy of the configuration's FTP rows [-] (NaN: none).
    fuel : str
        Fuel family of the rows the car is built for (``gasoline``, ``e85``, ``diesel``: a
        key of :data:`ENGINE_FUELS`; a diesel is a compression-ignition engine).
    rows : list of str
        ``test (file:line)`` of the rows used.
    """

    name: str
    make: str
    model: str
    year: int
    vehicle_id: str
    mass_kg: float
    target_a_n: float
    target_b_n_per_mps: float
    target_c_n_per_mps2: float
    axle_ratio: float
    n_v_ratio: float
    gears: int
    transmission: str
    displacement_l: float
    rated_power_w: float
    cold_bag_ratio: float = math.nan
    fuel: str = "gasoline"  # fuel family of the rows: a key of ENGINE_FUELS
    rows: list[str] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    @property
    def family(self) -> str:
        """Transmission family (:func:`vehval.epa.transmissions.family_of`)."""
        return family_of(self.transmission, self.gears, self.name)

    @property
    def engine_technology(self) -> str:
        """``diesel`` for a car built for its diesel rows, else ``spark_na`` or
        ``spark_turbo`` (:func:`vehval.epa.technology.engine_technology`)."""
        if self.fuel == "diesel":
            return "diesel"
        return tech.engine_technology(self.rated_power_w, self.displacement_l)

    @property
    def where(self) -> str:
        """Source text of a listed value."""
        return (f"EPA Test Car List {self.year}, {self.make} {self.model}, test vehicle "
                f"{self.vehicle_id} ({', '.join(self.rows)})")


def specs_from_tests(tests: list[EpaTest], fuel: str = "gasoline") -> Specs:
    """The specification of the one configuration the selected list rows describe.

    The rows must agree on the test vehicle's weight, road load, axle ratio, N/V,
    gears, displacement and rated power (one car; cold CO rows, whose road load is raised
    for -7 degC, are not compared); a transmission of a modelled family
    (:func:`vehval.epa.transmissions.family_of`: automatic, CVT, automated manual or
    dual-clutch, manual), a test on ``fuel`` (a fuel family of :data:`ENGINE_FUELS`: the
    car's engine burns it; its cold start is read from that fuel's FTP rows) and a model name
    without a hybrid mark are required, and the listed power and N/V must be plausible.

    Raises
    ------
    ConfigError
        Naming the row, the value and what to choose or why the car is not modelled.
    """
    if not tests:
        raise ConfigError("no EPA list row selected: name the make, model and year")
    _check_car(tests, fuel)
    rows = _spec_rows(tests)
    t0 = rows[0]
    _check_values(rows)
    for key in _SPEC_KEYS:
        vals = [getattr(t, key) for t in rows]
        if max(vals) - min(vals) > 1e-6 * max(abs(v) for v in vals) + 1e-9:
            _refuse_mixed(rows, key)
    gears = {t.gears for t in rows}
    trans = {t.transmission for t in rows}
    if len(gears) != 1 or len(trans) != 1:
        raise ConfigError("the selected rows differ in transmission or gear count: narrow "
                          "the selection")
    _refuse_transmission(t0)
    ratios = []
    for t in rows:
        if (procedure_key(t) == "ftp75" and fuel_family(t.fuel) == fuel
                and all(math.isfinite(b) for b in t.bags[:3])):
            ratios.append(t.bags[2] / t.bags[0])
    name = f"{t0.make} {t0.model} {t0.year}{'' if fuel == 'gasoline' else ' ' + fuel}".lower()
    return Specs(
        name="".join(c if c.isalnum() else "_" for c in name).strip("_"),
        make=t0.make, model=t0.model, year=t0.year, vehicle_id=t0.vehicle_id,
        **{k: float(getattr(t0, k)) for k in _SPEC_KEYS}, gears=t0.gears,
        transmission=t0.transmission,
        cold_bag_ratio=float(np.mean(ratios)) if ratios else math.nan,
        rows=[f"{t.label} ({t.source})" for t in rows], fuel=fuel)


def friction_torque_nm(speed_rpm: np.ndarray, displacement_l: float,
                       scale: float = 1.0) -> np.ndarray:
    """Friction torque [N·m] of a four-stroke engine: FMEP (Heywood eq. 13.13, times
    ``scale``) x displacement / (4 pi)."""
    return em.torque_nm(em.fmep_pa(speed_rpm, scale), displacement_l)


def gear_ratios(specs: Specs) -> tuple[list[float], float]:
    """Gearbox ratios (first first) and the top gear's overall ratio [-] from N/V (a CVT:
    its ratio steps, the lowest from N/V)."""
    from vehval.epa.transmissions import CVT_SPREAD, CVT_STEPS, stepped_ratios

    top_overall = specs.n_v_ratio * RPM * WHEEL_RADIUS_M / MPH
    top = top_overall / specs.axle_ratio
    if specs.family == "cvt":
        return stepped_ratios(top, CVT_STEPS, CVT_SPREAD), top_overall
    return stepped_ratios(top, specs.gears, RATIO_SPREAD[specs.gears]), top_overall


def vehicle_from_specs(specs: Specs, indicated_efficiency: float | None = None,  # long: one vehicle document, each value beside its source
                       friction_scale: float | None = None, cold_start: bool = True,
                       note: str = "", idle_fuel_g_per_s: float | None = None,
                       idle_source: str = "",
                       enrichment: float | None = None, technology: bool | None = None,
                       coefficients: tech.Coefficients | None = None) -> ConventionalVehicle:
    """The conventional vehicle of ``specs`` with the two free fuel parameters.

    Parameters
    ----------
    specs : Specs
        From :func:`specs_from_tests`.
    indicated_efficiency : float, optional
        Slope of the Willans line: brake + friction power over fuel power [-]; default the
        technology coefficient of the engine (``technology``) or ``INDICATED_EFFICIENCY``.
    friction_scale : float, optional
        Factor on Heywood's friction MEP [-]; default the technology coefficient or 1.
    cold_start : bool
        Include the warm-up fuel from the list's FTP bags (when it has them).
    note : str
        Appended to the description (e.g. the calibration).
    idle_fuel_g_per_s : float, optional
        Measured warm idle fuel rate [g/s] (``idle_source`` says where from); default the
        fuel map at idle with the accessory load.
    enrichment : float, optional
        Extra fuel at full load [-] (power enrichment, knock-limited spark), rising
        linearly from ``engine_model.HIGH_LOAD_FROM`` x the full-load torque; default
        ``ENRICHMENT`` for a spark-ignition engine, 0 for a diesel (lean at every load).
    technology : bool, optional
        Take what is not given (indicated efficiency, friction scale, the warm idle as a
        factor on the map, part-load pumping, the gearbox efficiency) from the generic
        technology coefficients (:mod:`vehval.epa.technology`); False: the generic constants
        of this module (the structure a calibration fits). Default: True when neither the
        indicated efficiency nor the friction scale is given, else False (a caller giving
        them calibrates the generic model).
    coefficients : Coefficients, optional
        The technology coefficients (default: the package's file).
    """
    if technology is None:
        technology = indicated_efficiency is None and friction_scale is None
    coef = (coefficients or tech.load_coefficients()) if technology else None
    engine_tech = specs.engine_technology
    family = specs.family

    e = tech.engine_values(coef, engine_tech, specs.rated_power_w, specs.displacement_l,
                           indicated_efficiency, friction_scale, INDICATED_EFFICIENCY,
                           ACCESSORY_POWER_W)
    indicated_efficiency, eta_src = e["indicated_efficiency"]
    friction_scale, kf_src = e["friction_scale"]
    idle_factor, idle_f_src = e["idle_factor"]
    pumping_bar, pump_src = e["pumping_bar"]
    accessory_w, acc_src = e["accessory_power_w"]
    gb_eff = coef.transmission_value(family, "efficiency") if coef is not None else None
    gb_up = coef.transmission_value(family, "upshift_scale") if coef is not None else None
    diesel = specs.fuel == "diesel"
    if enrichment is None:
        enrichment = 0.0 if diesel else ENRICHMENT
    rated_rpm = DIESEL_RATED_SPEED_RPM if diesel else RATED_SPEED_RPM
    bmep_max = DIESEL_BMEP_MAX_PA if diesel else BMEP_MAX_PA
    if not (0.1 <= indicated_efficiency <= 0.6 and 0.2 <= friction_scale <= 4.0
            and 0.0 <= enrichment <= 1.0):
        raise ConfigError(f"indicated efficiency {indicated_efficiency:g} (0.1-0.6) or "
                          f"friction scale {friction_scale:g} (0.2-4) or enrichment "
                          f"{enrichment:g} (0-1) out of range")
    s, where = specs, specs.where
    eta, kf = float(indicated_efficiency), float(friction_scale)
    vd = s.displacement_l
    w_rated = rated_rpm * RPM
    t_peak = max(bmep_max * vd * 1e-3 / (4 * math.pi), s.rated_power_w / w_rated)
    max_rpm = 1.1 * rated_rpm
    cut_rpm = FUEL_CUT_IDLE_RATIO * IDLE_SPEED_RPM
    # grid with the idle and fuel-cut speeds as breakpoints (idle control between them)
    speeds = np.unique(np.r_[np.linspace(IDLE_SPEED_RPM * 0.8, max_rpm, 16),
                             IDLE_SPEED_RPM, cut_rpm])
    shape = np.interp(speeds, [0.0, 0.6 * rated_rpm, max_rpm], [0.75, 1.0, 1.0])
    tmax = np.minimum(t_peak * shape, s.rated_power_w / (speeds * RPM))
    torques = np.linspace(0.0, 1.05 * t_peak, 14)
    lhv = _lhv(ENGINE_FUELS[s.fuel])
    high = (enrichment, em.HIGH_LOAD_FROM)
    pump = {"pumping_pa": pumping_bar * 1e5} if pumping_bar else {}
    fuel = em.fuel_rate_g_per_s(speeds, torques, tmax, vd, eta, kf, lhv, high, **pump)
    tf = friction_torque_nm(np.array([IDLE_SPEED_RPM, 2000.0]), vd, kf)
    t_acc = accessory_w / (IDLE_SPEED_RPM * RPM)
    i_idle = int(np.flatnonzero(np.isclose(speeds, IDLE_SPEED_RPM))[0])
    idle_fuel = float(np.interp(t_acc, torques, fuel[i_idle]))
    willans = willans_text(eta, kf, s, enrichment)
    if pumping_bar:
        willans += (f"; part-load pumping {pumping_bar:.4g} bar MEP at zero load falling to 0 at "
                    "full load (engine_model.pumping_mep_pa)")
    if eta_src or kf_src or pump_src:
        willans += "; " + "; ".join(x for x in (eta_src, kf_src, pump_src) if x)
    idle_src = f"the fuel map at idle with the accessory load ({willans})"
    if idle_fuel_g_per_s is None and idle_factor != 1.0:
        idle_fuel_g_per_s = idle_factor * idle_fuel
        idle_source = f"{idle_factor:.4g} x the fuel map at idle: {idle_f_src}"
    if idle_fuel_g_per_s is not None:
        # idle control: the map at idle burns the measured idle fuel (to the fuel-cut speed)
        fuel = np.maximum(fuel + em.idle_control_shift(
            speeds, IDLE_SPEED_RPM, cut_rpm, idle_fuel, float(idle_fuel_g_per_s))[:, None], 0)
        willans += (f"; idle control: shifted to burn the measured idle fuel at idle speed, "
                    f"the shift fading to nothing at the fuel-cut speed {cut_rpm:g} rpm")
        idle_fuel, idle_src = float(idle_fuel_g_per_s), idle_source or "measured"
    ratios, top_overall = gear_ratios(s)
    r = WHEEL_RADIUS_M
    gearbox, converter = gearbox_blocks(
        family, ratios[-1], s.axle_ratio, s.gears, r, rated_rpm, t_peak,
        f"top gear from N/V {s.n_v_ratio:g} rpm/mph and axle ratio {s.axle_ratio:g} with the "
        f"rolling radius {r} m (overall top ratio {top_overall:.4f}; exact in engine speed "
        f"per vehicle speed), {where}",
        efficiency=None if gb_eff is None else gb_eff.value,
        upshift_scale=1.0 if gb_up is None else gb_up.value)
    if gb_eff is not None:
        gearbox["sources"]["efficiency"] = (f"{family.replace('_', ' ')} gearbox: "
                                            f"{gb_eff.text()} ({coef.where if coef else ''})")
    if gb_up is not None:
        gearbox["sources"]["upshift_speed_mps"] += (
            f"; upshift scale {gb_up.value:.4g} of the {family.replace('_', ' ')} family: "
            f"{gb_up.text()} ({coef.where if coef else ''})")
    warm = 0.0
    warm_src = "no FTP bags of the configuration in the list: no warm-up model"
    if cold_start and math.isfinite(s.cold_bag_ratio):
        warm = warmup_fraction(s.cold_bag_ratio)
        warm_src = (f"from the list's FTP rows of the configuration: bag 3 / bag 1 fuel "
                    f"economy {s.cold_bag_ratio:.4f} (the cold UDDS transient phase burns "
                    f"{100 * (s.cold_bag_ratio - 1):.1f} % more than the hot one), placed as "
                    f"x (1 + f exp(-t / {WARMUP_TIME_CONSTANT_S:g} s)) over bag 1 ({UDDS_BAG1_END_S:g} s): "
                    f"f = {warm:.4f}")
    est = _EST
    rl = road_load_without_b(s.target_a_n, s.target_b_n_per_mps,
                             max(s.target_c_n_per_mps2, 0.0))
    refit = ("" if s.target_b_n_per_mps >= 0 else
             f" (listed B {s.target_b_n_per_mps:.4g} N/(m/s) < 0: A and C refitted with B = 0 "
             "over the UDDS, HWFET and US06 speeds, vehval.epa.procedures."
             "road_load_without_b)")
    data = {
        "architecture": "conventional", "name": s.name,
        "description": (f"{s.make} {s.model} ({s.year} EPA Test Car List, test vehicle "
                        f"{s.vehicle_id}) from its public specification: vehval epa "
                        f"vehicle{note}"),
        "body": {"mass_kg": s.mass_kg, "road_load_a_n": rl[0],
                 "road_load_b_n_per_mps": rl[1], "road_load_c_n_per_mps2": rl[2],
                 "aux_power_w": 0.0,
                 "sources": {"mass_kg": f"equivalent test weight, {where}",
                             "road_load_a_n": f"road-load target A, {where}{refit}",
                             "road_load_b_n_per_mps": f"road-load target B, {where}{refit}",
                             "road_load_c_n_per_mps2": f"road-load target C, {where}{refit}",
                             "aux_power_w": "accessories are in engine_control"}},
        "engine": {"speed_rpm": speeds.tolist(), "torque_nm": torques.tolist(),
                   "fuel_rate_g_per_s": fuel.tolist(), "max_torque_nm": tmax.tolist(),
                   "max_power_w": s.rated_power_w, "max_speed_rpm": max_rpm,
                   "idle_speed_rpm": IDLE_SPEED_RPM, "fire_speed_rpm": IDLE_SPEED_RPM / 2,
                   "motoring_torque_nm": float(tf[1]),
                   "inertia_kg_m2": 0.15 + 0.05 * vd, "fuel": ENGINE_FUELS[s.fuel],
                   "displacement_l": vd, "warmup_fuel_fraction": warm,
                   "warmup_time_constant_s": WARMUP_TIME_CONSTANT_S,
                   "sources": {
                       "speed_rpm": "grid from below idle to the maximum speed",
                       "torque_nm": "grid up to the peak torque",
                       "fuel_rate_g_per_s": willans,
                       "max_torque_nm": (f"{bmep_max / 1e5:g} bar BMEP x displacement, "
                                         f"limited by the rated power at "
                                         f"{rated_rpm:g} rpm: {est}"),
                       "max_power_w": f"rated horsepower, {where}",
                       "max_speed_rpm": f"1.1 x the rated-power speed: {est}",
                       "idle_speed_rpm": est, "fire_speed_rpm": f"half the idle: {est}",
                       "motoring_torque_nm": f"friction torque at 2000 rpm of the {willans}",
                       "inertia_kg_m2": f"0.15 + 0.05 kg m^2 per litre: {est}",
                       "fuel": ("Tier 2 certification gasoline, the fuel of the list's tests"
                                if s.fuel == "gasoline" else
                                "diesel: the fuel of the list's diesel tests, burnt by a "
                                "compression-ignition engine (vehval fuel table)" if diesel else
                                f"{ENGINE_FUELS[s.fuel]}: the fuel of the list's {s.fuel} "
                                "tests (vehval fuel table)"),
                       "displacement_l": f"test vehicle displacement, {where}",
                       "warmup_fuel_fraction": warm_src,
                       "warmup_time_constant_s": est}},
        "engine_control": {
            "idle_fuel_rate_g_per_s": idle_fuel,
            "fuel_cut_min_speed_rpm": cut_rpm,
            "overrun_fuel_rate_g_per_s": 0.0, "accessory_power_w": accessory_w,
            "sources": {"idle_fuel_rate_g_per_s": idle_src,
                        "fuel_cut_min_speed_rpm": f"{FUEL_CUT_IDLE_RATIO:g} x idle: {est}",
                        "overrun_fuel_rate_g_per_s": f"full fuel cut on overrun: {est}",
                        "accessory_power_w": acc_src or est}},
        "gearbox": gearbox,
        "converter": converter,
        "driveline": {
            "final_drive_ratio": s.axle_ratio, "final_drive_efficiency": 0.97,
            "wheel_radius_m": r, "wheel_inertia_kg_m2": 0.0,
            "brake_max_force_n": 0.9 * 9.81 * s.mass_kg,
            "sources": {"final_drive_ratio": f"axle ratio, {where}",
                        "final_drive_efficiency": est,
                        "wheel_radius_m": f"{est}; the ratios are set with it (N/V)",
                        "wheel_inertia_kg_m2": "0: the equivalent test weight is the inertia",
                        "brake_max_force_n": f"0.9 g at the test weight: {est}"}},
        "driver": {"response_time_s": 0.5, "ki_n_per_m": 50.0, "integrator_limit_n": 1500.0,
                   "max_force_n": 0.8 * 9.81 * s.mass_kg, "tolerance_speed_mph": 2.0,
                   "tolerance_time_s": 1.0,
                   "sources": {k: "engineering choice (speed-trace follower)" for k in (
                       "response_time_s", "ki_n_per_m", "integrator_limit_n", "max_force_n",
                       "tolerance_speed_mph", "tolerance_time_s")}},
    }
    return ConventionalVehicle.model_validate(data)


def willans_text(eta: float, kf: float, s: Specs, enrichment: float = ENRICHMENT) -> str:
    """Source text of the Willans fuel map."""
    return (f"Willans line: (brake + friction power) / (indicated efficiency {eta:.4g} x "
            f"LHV); friction MEP {kf:.4g} x Heywood eq. 13.13 (0.97 + 0.15 N/1000 + 0.05 "
            f"(N/1000)^2 bar) x displacement {s.displacement_l:g} L ({s.where}); fuel x "
            + (f"(1 + {enrichment:g} s), s from 0 at {em.HIGH_LOAD_FROM:g} x full-load "
               f"torque to 1 at full load (knock-limited spark, power enrichment: {_EST})"
               if enrichment else "no enrichment (a diesel runs lean at every load)"))


def model_fuel_lhv() -> float:
    """Lower heating value of the fuel of a vehicle built from the list (certification
    gasoline, ``gasoline_e0``) [J/kg]."""
    return _lhv()


def _lhv(name: str = "gasoline_e0") -> float:
    from vehval.fuels import table_fuel

    lhv = table_fuel(name).lhv_j_per_kg
    if lhv is None:
        raise ConfigError(f"fuel table: {name} has no lower heating value")
    return float(lhv)


def warmup_fraction(bag_ratio: float, tau: float = WARMUP_TIME_CONSTANT_S,
                    bag_s: float = UDDS_BAG1_END_S) -> float:
    """Warm-up fraction f whose extra fuel f exp(-t / tau) over a bag of ``bag_s`` seconds
    equals the cold bag's excess ``bag_ratio - 1`` (fuel rate taken as even over the bag)."""
    mean_decay = tau / bag_s * (1.0 - math.exp(-bag_s / tau))
    return max(bag_ratio - 1.0, 0.0) / mean_decay
