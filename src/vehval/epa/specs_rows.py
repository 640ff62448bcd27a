"""The checks of the EPA list rows a conventional car is built from: one car (the rows agree
on its specification), a fuel the engine model burns, a transmission a family models, no
hybrid mark, plausible listed values. Each refusal is one line naming the row and value."""

from __future__ import annotations

import math
import re
import statistics

from vehval.constants import LB_KG
from vehval.epa.consistency import impossible_values
from vehval.epa.procedures import fuel_family, is_gasoline, procedure_key
from vehval.epa.reader import EpaTest
from vehval.epa.transmissions import family_of
from vehval.errors import ConfigError

#: specification keys of the rows compared (mass, road load, ratios, engine)
_SPEC_KEYS = ("mass_kg", "target_a_n", "target_b_n_per_mps", "target_c_n_per_mps2",
              "axle_ratio", "n_v_ratio", "displacement_l", "rated_power_w")
RATED_SPEED_RPM = 6000.0  # speed of the rated power of a gasoline car engine [rpm]
IDLE_SPEED_RPM = 700.0  # warm idle [rpm]


def _refuse_transmission(t0: EpaTest) -> None:
    """Refuse a transmission no family models (:func:`vehval.epa.transmissions.family_of`)."""
    family_of(t0.transmission, t0.gears, f"EPA list row {_where(t0)}")


#: what a specification key is called in a message
_SPEC_NAMES = {"mass_kg": "equivalent test weight", "target_a_n": "road-load target A",
               "target_b_n_per_mps": "road-load target B",
               "target_c_n_per_mps2": "road-load target C", "axle_ratio": "axle ratio",
               "n_v_ratio": "N/V [rpm/mph]", "displacement_l": "displacement [L]",
               "rated_power_w": "rated power"}
#: list columns of the specification keys (named when a list lacks one)
_SPEC_COLUMNS = {"mass_kg": "Equivalent Test Weight (lbs.)", "axle_ratio": "Axle Ratio",
                 "n_v_ratio": "N/V Ratio", "displacement_l": "Test Veh Displacement (L)",
                 "rated_power_w": "Rated Horsepower"}
#: words of a model name that mark a hybrid or plug-in (whole words, upper case; any name
#: containing HYBRID is one too, e.g. 'ActiveHybrid 5'): the generic words, and the names
#: the makers give only to hybrid and plug-in models in the 2016-2019 lists (Toyota Prius,
#: Honda Insight and CR-Z, Kia Niro, Hyundai Ioniq, Acura NSX, Ford Energi, Chevrolet
#: Volt, Cadillac ELR, BMW i8, Honda Clarity, Porsche E-Hybrid, Volvo T8 Twin Engine)
HYBRID_WORDS = ("HEV", "PHEV", "FHEV", "MHEV", "PLUG-IN", "PRIUS", "INSIGHT", "CR-Z", "NIRO",
                "IONIQ", "NSX", "ENERGI", "VOLT", "ELR", "I8", "CLARITY", "E-HYBRID", "T8")
#: model-name words of the makers' hybrid and plug-in suffixes: Lexus 'NX 300h', 'RX 450h'
#: (three digits and h); BMW '330e', 'X5 xDrive40e', Mercedes-Benz 'GLC 350e' (two or three
#: digits and e)
HYBRID_SUFFIX = re.compile(r"^(?:\d{3}H|[A-Z]*\d{2,3}E)$")
#: a car whose listed FTP-75 reaches this share of its HWFET is a hybrid, whatever its name:
#: regenerative braking and the engine off at low speed make the city figure the higher;
#: the conventional cars of the 2016-2019 lists sit at 0.55-0.80 (99.9th percentile 0.80)
HYBRID_CITY_HIGHWAY_RATIO = 0.85
#: plausible rated power per litre of a car engine [W/L] (naturally aspirated to racing
#: turbo: 40-140 kW/L in the 2016-2019 lists); outside it the listed power or displacement
#: is a typing error
SPECIFIC_POWER_W_PER_L = (20e3, 200e3)
#: plausible equivalent test weight [lb] (the 2016-2019 lists: 2375-7000 lb) and axle ratio
#: [-] (1.0-9.99; the what-if's range): outside them the value is a typing error or a
#: column shifted (the vehicle model refused them with an internal error)
TEST_WEIGHT_LB = (1000.0, 15000.0)
AXLE_RATIO = (0.5, 10.0)


def _refuse_mixed(tests: list[EpaTest], key: str) -> None:
    """Refuse rows of several configurations, naming the value of ``key`` (display units)
    of each test vehicle and configuration number and the options that choose one."""
    from vehval.display import format_keyed, number

    by_cfg: dict[str, set[str]] = {}
    for t in tests:
        value = float(getattr(t, key))
        text = (format_keyed(key, value) if key in ("mass_kg", "rated_power_w")
                or key.startswith("target_") else number(value))
        by_cfg.setdefault(f"{t.vehicle_id or '?'} config {t.config or '?'}", set()).add(text)
    shown = "; ".join(f"{k}: {', '.join(sorted(v))}" for k, v in sorted(by_cfg.items()))
    t0 = tests[0]
    how = ("choose one with --vehicle-id ID and, when one test vehicle has several, "
           "--config N")
    if any(not t.config for t in tests):
        how = ("the list has no configuration number (the reduced column set of some "
               "years) to choose one by: use another year's list that lists this test "
               "vehicle with its configurations")
    raise ConfigError(f"the selected {t0.make} {t0.model} rows describe more than one "
                      f"configuration ({_SPEC_NAMES.get(key, key)} by test vehicle and "
                      f"configuration: {shown}): {how}")


def _where(t: EpaTest) -> str:
    """``test (file:line)``, or ``file:line`` for a row without a test number."""
    return f"{t.test_number} ({t.source})" if t.test_number else t.source


def _is_gasoline(t: EpaTest) -> bool:
    return is_gasoline(t.fuel)


#: fuel family of the list's tests -> fuel-table name of the spark-ignition engine built for
#: them (a flex-fuel car's E85 rows run on E85, its gasoline rows on certification gasoline)
SPARK_FUELS = {"gasoline": "gasoline_e0", "e85": "ethanol_e85"}
#: every fuel family the model from specs builds an engine for -> its fuel-table name: the
#: spark-ignition fuels and the compression-ignition engine's diesel
ENGINE_FUELS = {**SPARK_FUELS, "diesel": "diesel"}


def _spec_rows(tests: list[EpaTest]) -> list[EpaTest]:
    """The rows that state the configuration: all but the cold CO tests, whose road-load
    coefficients are the warm ones raised for -7 degC (about +10 %) and whose fuel is the
    cold CO fuel; every row is used when only cold CO rows are selected."""
    warm = [t for t in tests if procedure_key(t) != "coldco"]
    return warm or tests


def hybrid_name_mark(model: str) -> str:
    """The word of a model name that marks a hybrid or plug-in ('' when none)."""
    name = model.upper()
    words = set(name.replace("(", " ").replace(")", " ").replace(",", " ").split())
    marks = sorted((words & set(HYBRID_WORDS)) | {w for w in words if HYBRID_SUFFIX.match(w)})
    return "HYBRID" if "HYBRID" in name else next(iter(marks), "")


def hybrid_mark(tests: list[EpaTest]) -> str:
    """What marks the rows of one car as a hybrid or plug-in hybrid ('' when nothing does):
    a hybrid word in the model name (:data:`HYBRID_WORDS`, :data:`HYBRID_SUFFIX`, or HYBRID
    anywhere), a charge-depleting test among the rows, a four-phase FTP-75
    (:func:`four_bag_ftp`), or the city / highway signature (:func:`_city_highway_mark`)."""
    mark = hybrid_name_mark(tests[0].model)
    if mark:
        return f"'{mark}' in the model name"
    plug = next((t for t in tests if procedure_key(t) in ("cd_udds", "cd_hwfet")), None)
    if plug is not None:
        return f"charge-depleting test {plug.label} in the list"
    four = next((t for t in tests if four_bag_ftp(t)), None)
    if four is not None:
        return (f"FTP-75 {four.label} listed with a bag 4 result: the four-phase test of a "
                "hybrid (mild 48 V and belt starter-generator hybrids included)")
    return _city_highway_mark(tests)


def four_bag_ftp(t: EpaTest) -> bool:
    """An FTP-75 row with a bag 4 figure: the four-phase FTP that hybrids are tested on (a
    conventional car's FTP-75 has three bags)."""
    return procedure_key(t) == "ftp75" and len(t.bags) > 3 and math.isfinite(t.bags[3])


def _city_highway_mark(tests: list[EpaTest]) -> str:
    """The hybrid's signature in the list's own figures ('' when absent): the median FTP-75
    of the car's rows on one fuel at or above :data:`HYBRID_CITY_HIGHWAY_RATIO` x its HWFET."""
    by: dict[tuple[str, str], list[float]] = {}
    for t in tests:
        key = procedure_key(t)
        if key in ("ftp75", "hwfet") and 3.0 <= t.fe <= 1000.0:  # NaN fails the test
            by.setdefault((fuel_family(t.fuel), key), []).append(t.fe)
    for (fam, key), city in sorted(by.items()):
        highway = by.get((fam, "hwfet"))
        if key != "ftp75" or not highway:
            continue
        ratio = statistics.median(city) / statistics.median(highway)
        if ratio >= HYBRID_CITY_HIGHWAY_RATIO:
            return (f"its listed FTP-75 ({statistics.median(city):.1f} mpg) is {ratio:.2f} of "
                    f"its HWFET ({statistics.median(highway):.1f} mpg), at or above "
                    f"{HYBRID_CITY_HIGHWAY_RATIO}: a hybrid's signature (a conventional car's "
                    "city figure is well below its highway figure)")
    return ""


def _check_car(tests: list[EpaTest], fuel: str = "gasoline") -> None:
    """Refuse what the conventional model cannot describe: a hybrid or
    plug-in by its model name, a configuration tested on no ``fuel`` (a fuel family of
    :data:`ENGINE_FUELS`), a transmission no family models (``OT``, a one-gear automatic, an
    unknown code)."""
    t0 = tests[0]
    why = hybrid_mark(tests)
    if why:
        raise ConfigError(f"{t0.make} {t0.model}: {why}: a hybrid or plug-in hybrid is not "
                          "modelled from specs (the model is a conventional car); use a "
                          "hybrid vehicle file with `vehval epa validate`")
    if fuel not in ENGINE_FUELS:
        raise ConfigError(f"{t0.make} {t0.model} ({t0.vehicle_id}): fuel '{fuel}': the model "
                          "from specs builds an engine on "
                          f"{', '.join(ENGINE_FUELS)} only")
    if not any(fuel_family(t.fuel) == fuel for t in tests):
        fuels = ", ".join(sorted({f"'{t.fuel}'" for t in tests}))
        raise ConfigError(f"{t0.make} {t0.model} ({t0.vehicle_id}): tested on {fuels}, no "
                          f"{fuel}: the model from specs is a spark-ignition engine on "
                          "certification gasoline, or on E85 for a car's E85 tests, or a "
                          "compression-ignition engine for a car's diesel tests (an "
                          "electric test is not modelled)")
    _refuse_transmission(t0)  # before any other check: no narrowing makes it modelled


def _check_values(tests: list[EpaTest]) -> None:
    """Refuse a missing or implausible listed value, naming the row and the column."""
    for key in _SPEC_KEYS:
        if key.startswith("target_"):
            continue
        for t in tests:
            v = float(getattr(t, key))
            bad = impossible_values(t, (key,))
            if bad:
                raise ConfigError(f"EPA list row {_where(t)}: {bad[key]}; the specs need weight, "
                                  "road load, axle ratio, N/V, displacement and rated power: "
                                  "use a list row that gives it for this test vehicle")
            if not math.isfinite(v):
                col = _SPEC_COLUMNS[key]
                raise ConfigError(f"EPA list row {_where(t)}: no "
                                  f"{_SPEC_NAMES[key]} ('{col}' empty or absent: some years' "
                                  "lists have a reduced column set); the specs need weight, "
                                  "road load, axle ratio, N/V, displacement and rated power: "
                                  "use a list that gives them for this test vehicle")
    t0 = tests[0]
    for t in tests:
        for key, (lo, hi), si, unit in (("mass_kg", TEST_WEIGHT_LB, LB_KG, " lb"),
                                        ("axle_ratio", AXLE_RATIO, 1.0, "")):
            v = float(getattr(t, key)) / si
            if not lo <= v <= hi:
                raise ConfigError(f"EPA list row {_where(t)}: {_SPEC_NAMES[key]} {v:g}{unit} as "
                                  f"listed ('{_SPEC_COLUMNS[key]}') is outside the "
                                  f"{lo:g}-{hi:g}{unit} of cars: a typing error or a shifted "
                                  "column; the specs cannot build the car")
    spec = t0.rated_power_w / t0.displacement_l
    lo, hi = SPECIFIC_POWER_W_PER_L
    if not lo <= spec <= hi:
        raise ConfigError(f"EPA list row {_where(t0)}: rated power "
                          f"{t0.rated_power_w / 1e3:.1f} kW for {t0.displacement_l:g} L is "
                          f"{spec / 1e3:.0f} kW/L, outside the {lo / 1e3:.0f}-{hi / 1e3:.0f} "
                          "kW/L of car engines: a typing error in the list (horsepower or "
                          "displacement); the specs cannot size the engine")
    rpm60 = 60.0 * t0.n_v_ratio
    if not 1.3 * IDLE_SPEED_RPM <= rpm60 <= 0.9 * RATED_SPEED_RPM:
        raise ConfigError(f"EPA list row {_where(t0)}: N/V {t0.n_v_ratio:g} "
                          f"rpm/mph puts the engine at {rpm60:.0f} rpm at 60 mph in top gear, "
                          f"outside {1.3 * IDLE_SPEED_RPM:.0f}-{0.9 * RATED_SPEED_RPM:.0f} "
                          "rpm: not a plausible N/V (a typing error in the list?); the specs "
                          "cannot set the gear ratios")
