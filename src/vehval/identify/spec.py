"""What the dyno data cannot separate: a declared specification, else a generic scaling.

Identification finds road load, gears, converter, shifts and the fuel model in the data;
some values the data cannot give (the full-load curve above the measured envelope, the
engine's inertia and motoring torque, the wheel radius the ratios are expressed with, the
gearbox efficiency...). Each comes, in this order, from

1. a command-line option (``--rated-power-kw``, ``--gears``...),
2. the specification file (``--spec FILE``, keys of :data:`SPEC_KEYS`, each optionally with
   its source under ``sources:``),
3. a documented generic scaling from displacement and rated power (:func:`resolve`),

and :class:`Assumptions` records, per value, which (``origin``: ``option``, ``spec``,
``generic``) and why (``source``). No value of any particular car is a default.

Generic scaling (passenger-car engines; references in docs/identification.md):

- rated speed: 4000 rpm (diesel) or 6000 rpm (spark ignition); maximum speed 1.1 x rated;
- rated power: specific power 50 kW/L (diesel) or 60 kW/L (spark ignition) x displacement;
  without a displacement, 1.25 x the highest wheel power of the tests / gearbox efficiency;
- displacement (when only the rated power is known): rated power / specific power;
- peak torque: brake mean effective pressure 20 bar (diesel) or 12 bar x displacement / 4 pi;
- full-load curve: the peak torque, rising linearly from 45 % at 600 rpm to 100 % at
  45 % of the rated speed, capped by the rated power, 10 % below it at the maximum speed;
- engine inertia 0.12 kg·m² per litre (flywheel and converter pump included);
- motoring torque: friction mean effective pressure 2 bar x displacement / 4 pi;
- wheel radius: 0.97 x the tyre's unloaded radius (``225/50 R17``), else 0.31 m (the gear
  ratios are identified as engine-to-wheel ratios with it, so the model is consistent
  whatever radius is used);
- gearbox efficiency 0.93, engine-driven accessories 300 W, driven-axle share 0.5 of the
  car's own losses on the rollers (two of the four tyres).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path

from vehval.constants import RPM_RAD_PER_S
from vehval.errors import ConfigError

SPEC_KEYS = {
    "rated_power_kw": "rated engine power [kW]",
    "rated_speed_rpm": "engine speed at rated power [rpm]",
    "peak_torque_nm": "peak engine torque [N·m]",
    "displacement_l": "engine displacement [L]",
    "max_speed_rpm": "highest engine speed [rpm]",
    "fuel": "engine type for the scaling: diesel or gasoline (the test fuel otherwise)",
    "tyre": "tyre size, e.g. 225/50 R17",
    "wheel_radius_m": "rolling radius [m] (instead of the tyre size)",
    "gears": "number of forward gears",
    "gearbox_efficiency": "gearbox and final drive efficiency [-]",
    "accessory_power_w": "engine-driven accessory power [W]",
    "driven_axle_loss_share": "share of the car's losses on the rollers on the driven axle [-]",
    "test_mass_kg": "test (inertia) mass [kg], checked against the identified inertia",
}
SPECIFIC_POWER_KW_PER_L = {"diesel": 50.0, "gasoline": 60.0}
BMEP_PA = {"diesel": 20e5, "gasoline": 12e5}
RATED_SPEED_RPM = {"diesel": 4000.0, "gasoline": 6000.0}
FMEP_PA = 2e5
DIESEL_DENSITY = 800.0  # [kg/m³] test fuels at least this dense are diesel (petrol ~745)
INERTIA_KG_M2_PER_L = 0.12
#: Sizes of road-car tyres (ETRTO, Tire and Rim Association): section width [mm], aspect
#: ratio [%] and rim diameter [in]; their rolling radii span about 0.25-0.45 m
TYRE_WIDTH_MM = (105, 395)
TYRE_ASPECT_PCT = (20, 95)
TYRE_RIM_IN = (10, 26)
TYRE_RE = re.compile(r"^\s*(\d{3})\s*/\s*(\d{2})\s*Z?R\s*(\d{2})\s*$", re.IGNORECASE)
_RANGES = {"rated_power_kw": (5, 1000), "rated_speed_rpm": (1500, 12000),
           "peak_torque_nm": (20, 2000), "displacement_l": (0.3, 10), "max_speed_rpm": (1500, 13000),
           "wheel_radius_m": (0.15, 0.6), "gears": (1, 12), "gearbox_efficiency": (0.5, 1.0),
           "accessory_power_w": (0, 10000), "driven_axle_loss_share": (0, 1),
           "test_mass_kg": (300, 10000)}


def tyre_radius_m(tyre: str) -> float:
    """Rolling radius [m] of a tyre size ``WWW/AA Rdd``: 0.97 x (rim / 2 + sidewall)."""
    m = TYRE_RE.match(str(tyre))
    if m is None:
        raise ConfigError(f"tyre {tyre!r}: give the size as width/aspect Rrim, e.g. 225/50 R17")
    w, ar, rim = (int(g) for g in m.groups())
    for what, x, (lo, hi), unit in (("width", w, TYRE_WIDTH_MM, "mm"),
                                    ("aspect ratio", ar, TYRE_ASPECT_PCT, "%"),
                                    ("rim", rim, TYRE_RIM_IN, "in")):
        if not lo <= x <= hi:
            raise ConfigError(f"tyre {tyre!r}: {what} {x} {unit} is outside {lo}-{hi} {unit} "
                              "(road-car tyres, e.g. 225/50 R17)")
    radius = 0.97 * (rim * 0.0254 / 2 + w * ar / 100 / 1000)
    r_lo, r_hi = _RANGES["wheel_radius_m"]
    if not r_lo <= radius <= r_hi:
        raise ConfigError(f"tyre {tyre!r}: its rolling radius {radius:.3f} m is outside "
                          f"{r_lo}-{r_hi} m (road-car wheels)")
    return radius


def load_spec(path: str | Path | None, options: dict | None = None) -> dict:
    """Declared specification: ``path`` (YAML mapping of :data:`SPEC_KEYS` plus ``sources``)
    overlaid with the non-None ``options``. Returns {key: (value, origin, source)}."""
    out: dict = {}
    if path is not None:
        from vehval.safe_yaml import read_yaml
        doc = read_yaml(path) or {}
        if not isinstance(doc, dict):
            raise ConfigError(f"{path}: a specification is a mapping of "
                              f"{', '.join(SPEC_KEYS)}")
        srcs = doc.pop("sources", None) or {}
        doc.pop("name", None)
        doc.pop("description", None)
        for k, v in doc.items():
            if k not in SPEC_KEYS:
                raise ConfigError(f"{path}: unknown key '{k}'; a specification has "
                                  f"{', '.join(SPEC_KEYS)}")
            if v is not None:
                out[k] = (_check(k, v, str(path)), "spec",
                          f"declared in {Path(path).name}" + (f": {srcs[k]}" if k in srcs else ""))
    for k, v in (options or {}).items():
        if v is not None:
            opt = "--" + k.replace("_", "-")
            out[k] = (_check(k, v, opt), "option", f"declared on the command line ({opt})")
    return out


def _check(key: str, v, where: str):
    if key in ("fuel", "tyre"):
        if key == "fuel" and str(v).lower() not in SPECIFIC_POWER_KW_PER_L:
            raise ConfigError(f"{where}: fuel {v!r}: give diesel or gasoline")
        if key == "tyre":
            try:
                tyre_radius_m(str(v))
            except ConfigError as exc:
                raise ConfigError(f"{where}: {exc}") from None
        return str(v).lower() if key == "fuel" else str(v)
    try:
        x = float(v)
    except (TypeError, ValueError):
        raise ConfigError(f"{where}: {key} {v!r} is not a number ({SPEC_KEYS[key]})") from None
    lo, hi = _RANGES[key]
    if not (lo <= x <= hi) or (key == "gears" and x != int(x)):
        raise ConfigError(f"{where}: {key} {v} is outside {lo}-{hi} ({SPEC_KEYS[key]})")
    return int(x) if key == "gears" else x


@dataclass
class Assumptions:
    """Values the dyno data cannot separate; ``provenance`` says per value where it came from:
    {key: {"value", "origin" (option/spec/generic), "source"}}."""

    wheel_radius_m: float
    gearbox_efficiency: float
    accessory_power_w: float
    engine_inertia_kg_m2: float
    max_power_w: float
    max_speed_rpm: float
    full_load_rpm: tuple
    full_load_nm: tuple
    motoring_torque_nm: float
    driven_axle_loss_share: float
    gears: int | None = None
    test_mass_kg: float | None = None
    fuel_density_kg_per_m3: float | None = None
    fuel_lhv_j_per_kg: float | None = None
    provenance: dict = field(default_factory=dict)

    def source(self, key: str) -> str:
        p = self.provenance.get(key)
        return "" if p is None else f"{p['origin']}: {p['source']}"

    def floor_full_load(self, torque_seen_nm: float) -> None:
        """Raise a generic peak torque to 1.1 x the highest engine torque [N·m] the tests
        showed: the generic full-load curve is never below the measurements."""
        prov = self.provenance
        t_pk = float(prov.get("peak_torque_nm", {}).get("value") or max(self.full_load_nm))
        if (prov.get("peak_torque_nm", {}).get("origin") != "generic"
                or 1.1 * torque_seen_nm <= t_pk):
            return
        new_t = 1.1 * torque_seen_nm
        rpm, nm = full_load_curve(self.max_power_w, float(prov["rated_speed_rpm"]["value"]),
                                  self.max_speed_rpm, new_t)
        self.full_load_rpm, self.full_load_nm = tuple(rpm), tuple(nm)
        why = (f"; raised to {new_t:.0f} N·m, 1.1 x the highest engine torque of the tests "
               f"({torque_seen_nm:.0f} N·m)")
        prov["peak_torque_nm"] = {**prov["peak_torque_nm"], "value": new_t,
                                  "source": prov["peak_torque_nm"]["source"] + why}
        prov["full_load"] = {**prov["full_load"], "source": prov["full_load"]["source"] + why}

    def generic(self) -> list[str]:
        """Keys whose value is a generic estimate (not declared)."""
        return [k for k, p in self.provenance.items() if p["origin"] == "generic"]


def resolve(declared: dict, fuel_name: str | None, wheel_power_max_w: float,
            fuel_density: float | None = None) -> Assumptions:
    """:class:`Assumptions` from ``declared`` (:func:`load_spec`), the test fuel's name and
    density [kg/m³] (engine type when the spec gives none: diesel when named so or denser
    than ``DIESEL_DENSITY``) and the tests' highest wheel power [W] (rated power when
    neither it nor a displacement is declared)."""
    prov: dict = {}

    def put(key, value, origin, source):
        prov[key] = {"value": value, "origin": origin, "source": source}
        return value

    def dec(key):
        if key in declared:
            v, o, s = declared[key]
            return put(key, v, o, s)
        return None

    kind = dec("fuel")
    if kind is None:
        named = bool(fuel_name and "diesel" in fuel_name.lower())
        dense = fuel_density is not None and fuel_density >= DIESEL_DENSITY
        kind = "diesel" if named or dense else "gasoline"
        put("fuel", kind, "generic", f"engine type from the test fuel ({fuel_name or 'not named'}"
            + (f", {fuel_density:.0f} kg/m³" if fuel_density else "") + ")")
    n_rated = dec("rated_speed_rpm")
    if n_rated is None:
        n_rated = put("rated_speed_rpm", RATED_SPEED_RPM[kind], "generic",
                      f"typical rated speed of a {kind} passenger-car engine")
    n_max = dec("max_speed_rpm")
    if n_max is None:
        n_max = put("max_speed_rpm", 1.1 * n_rated, "generic", "1.1 x the rated speed")
    disp = dec("displacement_l")
    p_kw = dec("rated_power_kw")
    sp = SPECIFIC_POWER_KW_PER_L[kind]
    plain = {k: dec(k) for k in _PLAIN}
    for k, (v, why) in _PLAIN.items():
        if plain[k] is None:
            plain[k] = put(k, v, "generic", why)
    eff, acc, share = (plain[k] for k in _PLAIN)
    if p_kw is None:
        if disp is not None:
            p_kw = put("rated_power_kw", sp * disp, "generic",
                       f"specific power {sp:.0f} kW/L x the displacement")
        else:
            p_kw = put("rated_power_kw", 1.25 * wheel_power_max_w / eff / 1e3, "generic",
                       "1.25 x the highest wheel power of the tests / gearbox efficiency "
                       "(no rated power or displacement declared)")
    if disp is None:
        disp = put("displacement_l", p_kw / sp, "generic",
                   f"rated power / specific power {sp:.0f} kW/L")
    t_pk = dec("peak_torque_nm")
    if t_pk is None:
        t_pk = put("peak_torque_nm", BMEP_PA[kind] * disp * 1e-3 / (4 * math.pi), "generic",
                   f"BMEP {BMEP_PA[kind] / 1e5:.0f} bar x the displacement / 4 pi")
    radius = dec("wheel_radius_m")
    if radius is None and "tyre" in declared:
        tyre, o, s = declared["tyre"]
        radius = put("wheel_radius_m", tyre_radius_m(tyre), o,
                     f"0.97 x the unloaded radius of the {tyre} tyre ({s})")
    if radius is None:
        radius = put("wheel_radius_m", 0.31, "generic", "typical passenger-car rolling radius; "
                     "the gear ratios are engine-to-wheel ratios with it, so the model is "
                     "consistent whatever the true radius")
    rpm, nm = full_load_curve(p_kw * 1e3, n_rated, n_max, t_pk)
    put("full_load", None, "generic", f"peak torque {t_pk:.0f} N·m from 45 % at 600 rpm to 100 % at {0.45 * n_rated:.0f} rpm, "
        f"capped by the rated power {p_kw:.1f} kW at {n_rated:.0f} rpm, 10 % below it at "
        f"{n_max:.0f} rpm (generic shape)")
    j = put("engine_inertia_kg_m2", INERTIA_KG_M2_PER_L * disp, "generic",
            f"{INERTIA_KG_M2_PER_L} kg·m² per litre x {disp:.2f} L (flywheel and converter pump)")
    t_mot = put("motoring_torque_nm", FMEP_PA * disp * 1e-3 / (4 * math.pi), "generic",
                f"FMEP {FMEP_PA / 1e5:.0f} bar x {disp:.2f} L / 4 pi")
    gears = dec("gears")
    mass = dec("test_mass_kg")
    return Assumptions(wheel_radius_m=float(radius), gearbox_efficiency=float(eff),
                       accessory_power_w=float(acc), engine_inertia_kg_m2=float(j),
                       max_power_w=float(p_kw * 1e3), max_speed_rpm=float(n_max),
                       full_load_rpm=tuple(rpm), full_load_nm=tuple(nm),
                       motoring_torque_nm=float(t_mot), driven_axle_loss_share=float(share),
                       gears=None if gears is None else int(gears),
                       test_mass_kg=None if mass is None else float(mass), provenance=prov)


_PLAIN = {
    "gearbox_efficiency": (0.93, "typical stepped automatic with final drive (the fuel map is "
                           "identified with it, so it is consistent in the model)"),
    "accessory_power_w": (300.0, "alternator and pumps; not separable from the engine's "
                          "friction fuel in dyno data"),
    "driven_axle_loss_share": (0.5, "two of the four tyres plus the differential carry the "
                               "car's own losses on the rollers (the fuel data cannot "
                               "separate it)"),
}


def full_load_curve(p_w: float, n_rated: float, n_max: float, t_peak: float):
    """Generic full-load curve (speeds [rpm], torques [N·m]); see the module docstring."""
    rpm = sorted({600.0, *(round(n_rated * f, -1) for f in (0.2, 0.3, 0.45, 0.6, 0.75, 0.9)),
                  float(n_rated), float(n_max)})
    out = []
    n_knee = 0.45 * n_rated
    for n in rpm:
        ramp = min(1.0, 0.45 + 0.55 * max(n - 600.0, 0.0) / max(n_knee - 600.0, 1.0))
        p = p_w if n <= n_rated else p_w * (1 - 0.1 * (n - n_rated) / max(n_max - n_rated, 1.0))
        out.append(round(min(t_peak * ramp, p / (n * RPM_RAD_PER_S)), 1))
    return rpm, out
