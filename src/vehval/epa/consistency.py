"""Does a listed test agree with itself? The lab's bag results, combined as the lab combines
them, must give the listed whole-test figure.

The EPA Test Car List states a whole-test fuel economy and the bag values it comes from:
FTP-75 composite = 0.43 x cold UDDS + 0.57 x hot UDDS by fuel per distance (cold UDDS =
bags 1 + 2, hot UDDS = bags 3 + 4, or 3 + 2 in a 3-bag test); US06 = its city and highway
parts by distance. Bags are weighted by the schedule's own bag distances. On the 2016-2019
lists half the tests agree within 0.13 % and 99 % within 1.8 %; a larger gap, or a figure
no car reaches (a placeholder such as 10000 mpg), marks a row whose figures cannot be
trusted to judge a model. :func:`check_listed_figures` is the one place that decides it.

Is a listed specification value possible? :func:`impossible_values` names a listed axle
ratio, N/V, test weight, displacement or rated power of zero or less (a placeholder: a
2016-2019 list row may read 0 where the value was not entered), as the list gives it.

Does a listed test describe the car of the vehicle file? :func:`check_vehicle_match`
compares the list's axle ratio and engine displacement with the vehicle file's final drive
ratio and displacement: a model name can cover another car (a year's "PRIUS" rows may be a
Prius c's), whose figures then judge the file on a car it does not describe.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cache

from vehval.constants import LB_KG
from vehval.epa.procedures import FTP75, US06, procedure_key
from vehval.epa.reader import HP_W, EpaTest
from vehval.fuels import combine_mpg
from vehval.results.composites import FTP_WEIGHTS, weighted_harmonic

#: largest accepted |recombined / listed - 1| [-]
TOLERANCE = 0.025
#: fuel economy a listed figure must lie within to be plausible [mpg]
PLAUSIBLE_MPG = (3.0, 1000.0)
#: largest accepted |listed / vehicle file - 1| of the axle ratio (listed to 0.01) and of
#: the displacement (listed to 1 cm^3) [-]
AXLE_RATIO_TOLERANCE = 0.02
DISPLACEMENT_TOLERANCE = 0.03


#: specification values that must be positive: field -> (name, list column, SI per list unit)
POSITIVE_SPECS = {"mass_kg": ("equivalent test weight", "Equivalent Test Weight (lbs.)", LB_KG),
                  "axle_ratio": ("axle ratio", "Axle Ratio", 1.0),
                  "n_v_ratio": ("N/V", "N/V Ratio", 1.0),
                  "displacement_l": ("displacement", "Test Veh Displacement (L)", 1.0),
                  "rated_power_w": ("rated power", "Rated Horsepower", HP_W)}


def impossible_values(test: EpaTest, keys: tuple[str, ...] = tuple(POSITIVE_SPECS)) -> dict[str, str]:
    """Listed specification values of zero or less (placeholders, not values).

    Returns
    -------
    dict
        Field (``axle_ratio``...) -> ``axle ratio 0 as listed ('Axle Ratio'): a placeholder
        or impossible value, not an axle ratio`` (the value in the list's unit). An empty
        cell (NaN) is not named here: it is absent, not impossible.
    """
    out = {}
    for key in keys:
        name, col, si = POSITIVE_SPECS[key]
        v = float(getattr(test, key))
        if math.isfinite(v) and v <= 0:
            out[key] = (f"{name} {v / si:g} as listed ('{col}'): a placeholder or impossible "
                        f"value, not {'an' if name[0] in 'aeiou' else 'a'} {name}")
    return out


@dataclass(frozen=True)
class ListCheck:
    """Result of :func:`check_listed_figures` (recombined figure in the list's unit)."""

    ok: bool
    recombined: float | None
    rel_diff: float | None  # recombined / listed - 1 [-]
    note: str

    def to_dict(self) -> dict:
        return {"ok": self.ok, "recombined": self.recombined, "rel_diff": self.rel_diff,
                "note": self.note}


@cache
def _bag_distances(key: str) -> dict[int, float]:
    """Schedule distance of each bag of a procedure [m] (the package cycle's own trace)."""
    import numpy as np

    from vehval.cycles import load_cycle

    proc = {"ftp75": FTP75, "us06": US06}[key]
    out = {}
    for bag in proc.bags:
        cyc = load_cycle(proc.runs[bag.run])
        t = np.arange(0.0, cyc.time_s[-1] + 0.05, 0.1)
        v = np.interp(t, cyc.time_s, cyc.speed_mps)
        d = 0.0
        for a, b in bag.windows:
            d += float(np.sum(v[(t >= a) & (t < (b if b is not None else np.inf))])) * 0.1
        out[bag.number] = d
    return out


def _harmonic(d: dict[int, float], values: dict[int, float]) -> float:
    """Distance-weighted combination of bag fuel economies (:func:`vehval.fuels.combine_mpg`)."""
    return combine_mpg([d[k] for k in values], list(values.values()))


def recombine(test: EpaTest) -> float | None:
    """The whole-test figure the lab's combination of the listed bags gives (None when the
    procedure has no bags or a bag needed is missing or not positive)."""
    key = procedure_key(test)
    b = {k + 1: v for k, v in enumerate(test.bags) if not math.isnan(v)}
    if any(v <= 0 for v in b.values()):
        return None
    if key == "us06" and {1, 2} <= set(b):
        d = _bag_distances("us06")
        return _harmonic(d, {1: b[1], 2: b[2]})
    if key == "ftp75" and {1, 2, 3} <= set(b):
        d = _bag_distances("ftp75")
        cold = _harmonic(d, {1: b[1], 2: b[2]})
        # no bag 4 listed: bag 2 stands for it (same driving), as the lab combines them
        hot = (_harmonic(d, {3: b[3], 4: b[4]}) if 4 in b else
               combine_mpg([d[3], d[2]], [b[3], b[2]]))
        return float(weighted_harmonic(FTP_WEIGHTS, (cold, hot)))
    return None


def check_listed_figures(test: EpaTest) -> ListCheck:
    """Whether a test's listed figures are plausible and agree with each other."""
    lo, hi = PLAUSIBLE_MPG
    if test.fe_unit.upper() not in ("", "MPG"):
        return ListCheck(True, None, None, f"not checked: unit {test.fe_unit}")
    if math.isnan(test.fe):
        return ListCheck(True, None, None, "no whole-test figure listed")
    if not lo <= test.fe <= hi:
        return ListCheck(False, None, None,
                         f"listed whole-test figure {test.fe:g} mpg is outside {lo:g}-{hi:g} "
                         "mpg: a placeholder or a typing error in the list")
    bad = [f"bag {k + 1} {v:g}" for k, v in enumerate(test.bags)
           if not math.isnan(v) and not lo <= v <= hi]
    if bad:
        return ListCheck(False, None, None, f"listed {', '.join(bad)} mpg not plausible")
    rec = recombine(test)
    if rec is None:
        return ListCheck(True, None, None, "no bags to recombine")
    diff = rec / test.fe - 1.0
    if abs(diff) > TOLERANCE:
        return ListCheck(False, rec, diff,
                         f"the listed bags recombine to {rec:.1f} mpg, the listed whole-test "
                         f"figure is {test.fe:g} mpg ({100 * diff:+.1f} %): a typing error in "
                         "the list, or a correction (e.g. a hybrid's charge correction) applied "
                         "to one and not the other")
    return ListCheck(True, rec, diff, f"bags recombine to the whole-test figure "
                                      f"({100 * diff:+.2f} %)")


@dataclass(frozen=True)
class VehicleCheck:
    """Result of :func:`check_vehicle_match`: ``ok`` False when a listed figure of the
    driveline differs from the vehicle file's; ``note`` says which and by how much."""

    ok: bool
    note: str

    def to_dict(self) -> dict:
        return {"ok": self.ok, "note": self.note}


def check_vehicle_match(test: EpaTest, vehicle) -> VehicleCheck:
    """Whether the list's axle ratio and displacement of ``test`` match ``vehicle``.

    The final drive ratio [-] is compared when the vehicle file states one (a ratio of 1
    means its gear ratios are engine-to-wheel, the final drive lumped in: not compared);
    the displacement [L] when both state it.
    """
    listed, own, checked = [], [], []
    fd = float(vehicle.driveline.final_drive_ratio)
    if fd != 1.0 and test.axle_ratio == test.axle_ratio and test.axle_ratio > 0:
        checked.append("axle ratio")
        d = test.axle_ratio / fd - 1.0
        if abs(d) > AXLE_RATIO_TOLERANCE:
            listed.append(f"axle ratio {test.axle_ratio:g} ({100 * d:+.1f} %)")
            own.append(f"final drive ratio {fd:g}")
    disp = vehicle.engine.displacement_l
    if disp and test.displacement_l == test.displacement_l and test.displacement_l > 0:
        checked.append("displacement")
        d = test.displacement_l / disp - 1.0
        if abs(d) > DISPLACEMENT_TOLERANCE:
            listed.append(f"displacement {test.displacement_l:g} L ({100 * d:+.1f} %)")
            own.append(f"{disp:g} L")
    if listed:
        return VehicleCheck(False, f"the list gives {' and '.join(listed)} where "
                                   f"{vehicle.name} has {' and '.join(own)}: {test.model} "
                                   f"test vehicle {test.vehicle_id} may be another car or "
                                   "driveline")
    if not checked:
        return VehicleCheck(True, "not checked: no axle ratio or displacement to compare")
    return VehicleCheck(True, f"{' and '.join(checked)} match the vehicle file")


def group_mismatches(checks) -> dict[str, list[str]]:
    """Test labels whose :class:`VehicleCheck` failed, grouped by its note (one group per
    test vehicle and difference); ``checks`` are (label, VehicleCheck or None) pairs."""
    groups: dict[str, list[str]] = {}
    for label, chk in checks:
        if chk is not None and not chk.ok:
            groups.setdefault(chk.note, []).append(label)
    return groups
