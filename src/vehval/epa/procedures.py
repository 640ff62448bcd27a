"""EPA test procedures as simulation plans: which cycle runs, where the bags are, how the
lab combines them.

* FTP-75 (40 CFR 86.135): a cold-start UDDS (bag 1 = 0-505 s cold transient, bag 2 =
  505 s to the end, stabilised), a 10-minute soak with the engine off, then the first
  505 s again hot (bag 3); hybrids run the stabilised phase again (bag 4, the "4-bag
  FTP"). The composite is 0.43 x cold UDDS + 0.57 x hot UDDS by fuel per distance, the
  hot UDDS being bags 3 + 4 (bags 3 + 2 in a 3-bag test).
* HWFET (40 CFR 600.111): one highway cycle after a preconditioning run.
* US06 (40 CFR 86.159, 600.114): bag 1 (city) = 0-130 s and 495 s to the end, bag 2
  (highway) = 130-495 s.

SAE J1711 basis: the lab result of a charge-sustaining hybrid is taken with the battery
charge balanced over the whole test (net battery energy within 1 % of the fuel energy, or
corrected); the per-bag values are not individually balanced, so a bag can show a large
fuel economy when it spends charge stored in an earlier bag.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from vehval.cycles import part_boundary_s
from vehval.epa.reader import EpaTest

#: UDDS time at which bag 1 (cold transient) ends and bag 2 starts [s] (the cycles' part table)
UDDS_BAG1_END_S = part_boundary_s("udds", "bag1")
#: US06 city / highway split points [s] (the cycles' part table)
US06_CITY_END_S = part_boundary_s("us06", "city")
US06_HWY_END_S = part_boundary_s("us06", "highway")
#: engine-off soak between the cold and hot UDDS of the FTP-75 [s]
FTP_SOAK_S = 600.0


@dataclass(frozen=True)
class Bag:
    """One bag: which run of the plan and which time windows of it [s] (end None = end)."""

    number: int
    name: str
    run: int
    windows: tuple[tuple[float, float | None], ...]
    cold_start: bool = False


@dataclass(frozen=True)
class Procedure:
    """A simulation plan: runs of package cycles (SOC carried, a soak between) and bags."""

    key: str
    name: str
    runs: tuple[str, ...]
    bags: tuple[Bag, ...]
    composite: str  # "ftp" (results.composites.FTP_WEIGHTS) or "distance" (fuel over distance)


FTP75 = Procedure(
    key="ftp75", name="FTP-75 (cold UDDS, 10 min soak, hot UDDS)", runs=("udds", "udds"),
    bags=(Bag(1, "bag 1 cold transient", 0, ((0.0, UDDS_BAG1_END_S),), cold_start=True),
          Bag(2, "bag 2 stabilised", 0, ((UDDS_BAG1_END_S, None),)),
          Bag(3, "bag 3 hot transient", 1, ((0.0, UDDS_BAG1_END_S),)),
          Bag(4, "bag 4 hot stabilised", 1, ((UDDS_BAG1_END_S, None),))),
    composite="ftp")
HWFET = Procedure(key="hwfet", name="HWFET", runs=("hwfet",),
                  bags=(Bag(1, "whole test", 0, ((0.0, None),)),), composite="distance")
US06 = Procedure(
    key="us06", name="US06 (city and highway parts)", runs=("us06",),
    bags=(Bag(1, "bag 1 city part", 0, ((0.0, US06_CITY_END_S), (US06_HWY_END_S, None))),
          Bag(2, "bag 2 highway part", 0, ((US06_CITY_END_S, US06_HWY_END_S),))),
    composite="distance")

RUNNABLE = {"ftp75": FTP75, "hwfet": HWFET, "us06": US06}

#: procedure code -> key (EPA Test Car List codes)
_CODES = {2: "ftp75", 21: "ftp75", 31: "ftp75", 25: "ftp75", 35: "ftp75", 3: "hwfet",
          90: "us06", 95: "sc03", 11: "coldco", 81: "cd_udds", 84: "cd_hwfet"}

#: why the simulator cannot run a procedure (key -> reason)
UNRUNNABLE = {
    "sc03": "SC03 is run at 35 degC with the air conditioning on; the model has no climate "
            "or A/C load model",
    "coldco": "cold CO FTP is run at -7 degC on cold-CO fuel; the model's cold start (if "
              "any) is the FTP's at 20-30 degC, with no dependence on temperature",
    "cd_udds": "charge-depleting test of a plug-in hybrid; the model is charge-sustaining",
    "cd_hwfet": "charge-depleting test of a plug-in hybrid; the model is charge-sustaining",
}


#: cycles whose speeds a road load without its B term is fitted over when no plan is named
CERTIFICATION_CYCLES = ("udds", "hwfet", "us06")


def road_load_without_b(a: float, b: float, c: float,
                        cycles: tuple[str, ...] = CERTIFICATION_CYCLES
                        ) -> tuple[float, float, float]:
    """Road-load coefficients with B >= 0 that reproduce ``A + B v + C v^2``.

    A vehicle file's road load has B >= 0, while a fifth of the list's target rows have a
    negative B (the coast-down fit's linear term). Setting B to 0 keeps A and C and raises
    the force at every speed: the tractive energy of a HWFET by 12 % (median of those rows,
    up to 38 %). Instead, with B < 0, A' and C' of ``A' + C' v^2`` are fitted by least
    squares on the force at the speeds of ``cycles`` (their 1 s samples while moving, each
    weighted by its speed: the road-load work), A' and C' kept >= 0.

    Parameters
    ----------
    a, b, c : float
        Target coefficients [N, N/(m/s), N/(m/s)^2].
    cycles : tuple of str
        Package cycle names whose speeds the fit covers (the procedure's runs).

    Returns
    -------
    (float, float, float)
        ``(a, b, c)`` unchanged when ``b >= 0``, else ``(A', 0, C')``.
    """
    import numpy as np

    from vehval.cycles import load_cycle

    if not b < 0:
        return a, b, c
    v = np.concatenate([load_cycle(name).resampled(1.0).speed_mps for name in cycles])
    v = v[v > 0.5]
    w, force = v, a + b * v + c * v ** 2
    x = np.column_stack([np.ones_like(v), v ** 2]) * np.sqrt(w)[:, None]
    a2, c2 = np.linalg.lstsq(x, force * np.sqrt(w), rcond=None)[0]
    if a2 < 0:
        a2, c2 = 0.0, float(np.sum(w * v ** 2 * force) / np.sum(w * v ** 4))
    elif c2 < 0:
        a2, c2 = float(np.sum(w * force) / np.sum(w)), 0.0
    return float(a2), 0.0, float(max(c2, 0.0))


def fuel_family(fuel: str) -> str:
    """``gasoline``, ``diesel``, ``e85`` or ``other`` of a listed test fuel description or
    a fuel-table name (``gasoline_e10``, ``diesel``, ``biodiesel_b20``...)."""
    up = fuel.upper()
    if is_gasoline(fuel):
        return "gasoline"
    if "DIESEL" in up:
        return "diesel"
    if "E85" in up or "ETHANOL" in up:
        return "e85"
    return "other"


def is_gasoline(fuel: str) -> bool:
    """Whether a listed test fuel description is a gasoline (Tier 2 certification, CARB,
    E10...; an empty description counts as one). E85 is not: its description names the
    gasoline it is blended with ("E85 (85% Ethanol 15% EPA Unleaded Gasoline)"), but a
    gallon holds about 30 % less energy."""
    up = fuel.upper()
    return not up.strip() or ("GASOLINE" in up and "E85" not in up and "ETHANOL" not in up)


def procedure_key(test: EpaTest) -> str:
    """Short key of a test's procedure (``ftp75``, ``hwfet``, ``us06``, ``sc03``...)."""
    return _CODES.get(test.procedure_code, f"code{test.procedure_code}")


def plan_for(test: EpaTest, fuel: str = "gasoline") -> tuple[Procedure | None, str]:
    """The simulation plan of a test, or (None, reason it cannot be run).

    ``fuel`` is the vehicle's fuel (a fuel-table name, e.g. ``diesel``): a test on another
    fuel family is not run (its mpg counts gallons of another fuel)."""
    key = procedure_key(test)
    if key in UNRUNNABLE:
        return None, UNRUNNABLE[key]
    if key not in RUNNABLE:
        return None, (f"procedure code {test.procedure_code} ('{test.procedure}') is not an "
                      "FTP-75, HWFET or US06 test")
    want = fuel_family(fuel)
    if fuel_family(test.fuel) != want:
        return None, (f"test fuel '{test.fuel}' is not gasoline" if want == "gasoline" else
                      f"test fuel '{test.fuel}' is not the vehicle's fuel ({fuel})")
    if test.fe_unit and test.fe_unit != "MPG":
        return None, f"fuel economy unit '{test.fe_unit}' is not MPG"
    for name, value in (("equivalent test weight", test.mass_kg),
                        ("target coefficient A", test.target_a_n),
                        ("target coefficient B", test.target_b_n_per_mps),
                        ("target coefficient C", test.target_c_n_per_mps2)):
        if math.isnan(value):
            return None, f"the list gives no {name} for this test"
    return RUNNABLE[key], ""
