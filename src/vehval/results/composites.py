"""Regulatory composites: which phases make a test's reported result, and how they weigh.

A composite is a weighted sum of groups of phases: its fuel per distance is
``sum_k w_k (fuel of group k) / (distance of group k)``, which is the harmonic weighting of
fuel economy the regulations use. Each composite cites its rule.

The FTP-75 is built from any layout that holds its bags: an FTP-75 record (bags 1-3), a
cold-start UDDS followed in the same record by a hot-start UDDS after the 10 min hot soak
(the soak is checked), or a cold-start UDDS with the bag 1 of a separate hot-start UDDS.
A composite whose test conditions are not the procedure's (cell temperature, unknown start,
a substitute bag) carries ``caveats`` naming the clause; one the layout cannot support is
not built, and a note says why.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from vehval.cycles import part_boundary_s, part_rule
from vehval.results.phases import CycleMatch, Phase
from vehval.test import Signal

__all__ = ["FTP_WEIGHTS", "HOT_BAG3_SUBSTITUTE", "SOAK_S", "Composite", "SoakCheck",
           "check_soak", "composites_for", "substitute_direction", "weighted_harmonic", "weighted_per_distance",
           "weighted_reciprocal_sum"]

#: FTP-75 weights of the cold-start (bags 1+2) and hot-start (bags 3+2, or 3+4) halves [-]
#: (40 CFR 600.113-12(g)(2)). The one place they are written: results, the EPA procedures,
#: the list checks and the predictions weigh through the functions below.
FTP_WEIGHTS = (0.43, 0.57)
_W = f"1 / ({FTP_WEIGHTS[0]:g} / FE(bags 1+2) + {FTP_WEIGHTS[1]:g} / FE(bags 3+"
FTP_RULE = (f"40 CFR 600.113-12(g)(2): FTP fuel economy = {_W}2)); the same weights apply "
            "to CO2 per distance")
FTP_4BAG_RULE = (f"40 CFR 86.144-94 / SAE J1711 four-bag FTP: {_W}4)), bag 4 the hot-start "
                 "stabilised phase")


def weighted_per_distance(terms: Any) -> Any:
    """A composite's amount per distance: ``sum_k w_k a_k / d_k``.

    ``terms`` holds (weight [-], amount of group k (fuel [kg], CO2 [kg]...), distance of
    group k [m]); amounts and distances may be arrays (one value per draw). This is the
    regulations' harmonic weighting of fuel economy, written on fuel per distance.
    """
    total: Any = 0.0
    for w, amount, distance in terms:
        total = total + w * amount / distance
    return total


def weighted_reciprocal_sum(weights: Any, figures: Any) -> Any:
    """``sum_k w_k / x_k``: the amount per distance of a composite whose groups have the
    figures ``x_k`` in distance per amount (m/kg, mile/gal)."""
    return sum(w / x for w, x in zip(weights, figures))


def weighted_harmonic(weights: Any, figures: Any) -> Any:
    """The composite figure ``1 / sum_k w_k / x_k`` of group figures ``x_k`` in distance per
    amount (the FTP-75 fuel economy from its cold and hot UDDS economies with
    :data:`FTP_WEIGHTS`)."""
    return 1.0 / weighted_reciprocal_sum(weights, figures)
#: Name of the stand-in for bag 3 when a cold-start UDDS has none.
HOT_BAG3_SUBSTITUTE = "hot-start bag 1"
#: FTP hot soak between bag 2 and bag 3: nominal, lowest and highest accepted [s].
SOAK_S = (600.0, 540.0, 660.0)
SOAK_RULE = "40 CFR 86.137: 10 min hot soak, engine off, between bag 2 and bag 3"
#: What the data of one cold-start UDDS says of the bag 2 stand-in for bag 3: nothing of its
#: direction (a hot transient bag runs richer or leaner than the stabilised bag 2 depending on
#: the vehicle: on a 2014 Cruze diesel bag 2 understates the FTP by 1 %).
SUBSTITUTE_DIRECTION = ("the figure is off by the hot transient's difference from bag 2, "
                        "whose direction this test cannot tell (a hot bag 1 can use more or "
                        "less fuel per distance than bag 2); give the hot-start UDDS run with "
                        "--hot-start to measure it")
#: Test-cell range of the FTP, HWFET and US06 [degC].
CELL_RANGE_C = (20.0, 30.0)
CELL_RULE = "40 CFR 86.130: test cell 20-30 degC (68-86 degF)"
START_RULE = "40 CFR 86.132: cold start after a 12-36 h soak at 20-30 degC"
#: Vehicle speed still read as standing during the soak [m/s].
_STANDING_MPS = 0.5
#: Fraction of the soak the engine must be off (fuel rate at most 2 % of the test mean).
_ENGINE_OFF_SHARE = 0.9
_LAST_RUN_RULES = {
    "hwfet": "40 CFR 600.111-08(b): the HWFET is run twice, the first run prepares the "
             "vehicle and the second is the test run; the result is the last run",
    "us06": part_rule("us06") + "; with two runs the first prepares and the result is "
            "the last run",
    "sc03": "40 CFR 86.160-00: SC03 result of the test run; with two runs the first "
            "prepares and the result is the last run",
    "udds": "40 CFR 86.144: UDDS (FTP-72) result over bags 1+2",
    "nedc": "UN ECE R101: combined result over the urban (ECE) and extra-urban (EUDC) parts",
    "wltc3b": "UN GTR 15 / Regulation (EU) 2017/1151 Sub-Annex 7: combined result over the "
              "four phases",
}
_COLD_UDDS_RULE = "40 CFR 86.144: UDDS (FTP-72) result over the cold-start bags 1+2"
_HOT_START_UDDS_RULE = ("40 CFR 86.144: UDDS over bags 1+2 of a hot-start run (the FTP-72 "
                        "figure needs the cold start of 40 CFR 86.132)")
_HOT_UDDS_RULE = "40 CFR 86.144: hot-start UDDS (bags 3+4 of a four-bag FTP), not an FTP figure"
#: Composites run under the FTP cell range, and those that need the cold start.
_US_CELL = ("udds", "udds_hot", "ftp75", "ftp75_4bag", "ftp75_from_udds", "hwfet", "us06",
            "us06_city", "us06_highway")
_COLD = ("ftp75", "ftp75_4bag", "ftp75_from_udds")


@dataclass
class Composite:
    """A reported result made of phases.

    Attributes
    ----------
    name : str
        ``udds``, ``ftp75``, ``hwfet``, ``us06_city``...
    rule : str
        The regulation it follows.
    groups : list of (weight, phase names)
        Phases whose fuel and distance are summed, then weighted.
    substitute : str
        What stands in for a missing phase ("" when none).
    caveats : list of str
        Where the test departs from the procedure, each naming its clause; empty when the
        figure stands unqualified.
    """

    name: str
    rule: str
    groups: list[tuple[float, list[str]]] = field(default_factory=list)
    substitute: str = ""
    caveats: list[str] = field(default_factory=list)

    def to_dict(self) -> dict:
        return {"name": self.name, "rule": self.rule, "substitute": self.substitute or None,
                "caveats": list(self.caveats),
                "groups": [{"weight": w, "phases": list(p)} for w, p in self.groups]}


@dataclass
class SoakCheck:
    """The pause between two runs of a record, against the FTP hot soak.

    Attributes
    ----------
    pause_s : float
        From the end of the first run to the start of the next [s].
    standing : bool
        The vehicle speed stayed below 0.5 m/s.
    engine_off_share : float or None
        Share of the pause with the fuel flow at most 2 % of the record's mean [-]; None
        without a fuel channel.
    """

    pause_s: float
    standing: bool
    engine_off_share: float | None

    @property
    def ok(self) -> bool:
        off = self.engine_off_share is None or self.engine_off_share >= _ENGINE_OFF_SHARE
        return SOAK_S[1] <= self.pause_s <= SOAK_S[2] and self.standing and off

    def describe(self) -> str:
        eng = ("" if self.engine_off_share is None else
               f", engine off {100 * self.engine_off_share:.0f} % of it")
        return (f"{self.pause_s / 60:.1f} min pause{'' if self.standing else ' (vehicle moving)'}"
                f"{eng}")


def _mean_in(sig: Signal, a: float, b: float) -> np.ndarray:
    m = (sig.time >= a) & (sig.time <= b) & np.isfinite(sig.values)
    return sig.values[m]


def check_soak(match: CycleMatch, speed: Signal | None, fuel: Signal | None,
               first: int = 1) -> SoakCheck | None:
    """The pause after run ``first`` of ``match`` until the next run; None without one."""
    if match.runs <= first:
        return None
    end = max(p1 + off for _, p1, off in match.windows[first - 1])
    start = min(p0 + off for p0, _, off in match.windows[first])
    pause = start - end
    if pause <= 0:
        return SoakCheck(pause, True, None)
    standing = True
    if speed is not None:
        v = _mean_in(speed, end, start)
        standing = bool(v.size == 0 or np.max(np.abs(v)) < _STANDING_MPS)
    share = None
    if fuel is not None:
        f = _mean_in(fuel, end, start)
        ok = np.isfinite(fuel.values)
        ref = float(np.mean(np.abs(fuel.values[ok]))) if ok.any() else 0.0
        if f.size:
            share = float(np.mean(np.abs(f) <= 0.02 * ref))
    return SoakCheck(pause, standing, share)


def _condition_caveats(comp: Composite, conditions: dict[str, Any] | None,
                       start_basis: str) -> None:
    cond = conditions or {}
    cell = cond.get("cell_temp_c")
    base = comp.name
    if base in _US_CELL:
        if cell is not None and not CELL_RANGE_C[0] <= cell <= CELL_RANGE_C[1]:
            kind = ("a cold-temperature test (40 CFR 86 subpart C, -7 degC)" if cell < CELL_RANGE_C[0]
                    else "a hot-cell test (as the 35 degC A/C tests, 40 CFR 86.160)")
            comp.caveats.append(f"cell {cell:.1f} degC, outside {CELL_RULE}: {kind}, not the "
                                f"{base} figure of the regulation")
    if base in _COLD or base == "udds":
        if cond.get("start") == "hot":
            why = cond.get("start_basis") or "coolant far above the cell at the start"
            comp.caveats.append(f"hot start ({why}), not the cold start after a 12-36 h "
                                f"soak of 40 CFR 86.132: a hot-start figure, not the {base} "
                                "figure of the regulation")
    if base in _COLD or (base == "udds" and start_basis):
        if cond.get("start") is None:
            comp.caveats.append("start temperature not measured (no coolant and cell "
                                f"temperature): {START_RULE} is assumed"
                                + (f" {start_basis}" if start_basis else ""))


def _by_part(phases: list[Phase], run: int) -> dict[str, str]:
    return {p.part: p.name for p in phases if p.run == run and p.part}


def composites_for(cycle: str | None, phases: list[Phase], *, cold_start: bool | None,
                   hot_bag1: bool, match: CycleMatch | None = None,
                   speed: Signal | None = None, fuel: Signal | None = None,
                   conditions: dict[str, Any] | None = None,
                   notes: list[str] | None = None) -> list[Composite]:
    """The composites a test of ``cycle`` supports with the phases it has.

    Parameters
    ----------
    cycle : str or None
        Identified cycle (``udds``, ``ftp75``...).
    phases : list of Phase
        The test's phases, labelled with run and part.
    cold_start : bool or None
        The test starts cold (None: not known).
    hot_bag1 : bool
        A hot-start UDDS bag 1 was supplied to stand in for the FTP bag 3 of a cold-start
        UDDS (``__hot_bag1__`` in the groups).
    match : CycleMatch, optional
        Where the runs lie in the record; a UDDS record of two runs is read as an FTP when
        the pause between them is the hot soak (:func:`check_soak`).
    speed, fuel : Signal, optional
        Vehicle speed [m/s] and fuel flow, for the soak check.
    conditions : dict, optional
        ``cell_temp_c`` [degC] and ``start`` of the test: departures become caveats.
    notes : list of str, optional
        Receives why a composite the layout suggests is not built.
    """
    notes = notes if notes is not None else []
    if not cycle:
        return []
    labelled = [p for p in phases if p.run > 0 and p.part]
    if not labelled:
        return []
    last = max(p.run for p in labelled)
    run = [p for p in labelled if p.run == last]
    by_part = _by_part(labelled, 1)
    out: list[Composite] = []
    start_basis = ""
    if cycle == "ftp75" and {"bag1", "bag2", "bag3"} <= set(by_part):
        out.append(Composite("ftp75", FTP_RULE, [
            (FTP_WEIGHTS[0], [by_part["bag1"], by_part["bag2"]]),
            (FTP_WEIGHTS[1], [by_part["bag3"], by_part["bag2"]])]))
        start_basis = "from the layout (bags 1-2, hot soak, bag 3)"
    elif cycle == "udds" and {"bag1", "bag2"} <= set(by_part):
        out.extend(_udds(labelled, by_part, cold_start, hot_bag1, match, speed, fuel, notes))
        if any(c.name == "ftp75" for c in out):
            start_basis = "from the layout (UDDS, hot soak, UDDS)"
    else:
        names = [p.name for p in run]
        out.append(Composite(cycle, _LAST_RUN_RULES.get(cycle, "whole cycle run"),
                             [(1.0, names)]))
        if cycle == "us06":
            for part in ("city", "highway"):
                sel = [p.name for p in run if p.part == part]
                if sel:
                    out.append(Composite(f"us06_{part}", _LAST_RUN_RULES["us06"], [(1.0, sel)]))
    for c in out:
        if c.substitute:
            c.caveats.append(f"substitute: {c.substitute}")
        _condition_caveats(c, conditions, start_basis if c.name != "udds_hot" else "")
    return out


def _udds(labelled: list[Phase], by_part: dict[str, str], cold_start: bool | None,
          hot_bag1: bool, match: CycleMatch | None, speed: Signal | None, fuel: Signal | None,
          notes: list[str]) -> list[Composite]:
    """UDDS composites: the cold UDDS, and the FTP from a second run or a substitute."""
    last = max(p.run for p in labelled)
    hot_parts = _by_part(labelled, 2) if last >= 2 else {}
    soak = check_soak(match, speed, fuel) if match is not None and last >= 2 else None
    b1, b2 = by_part["bag1"], by_part["bag2"]
    if soak is not None and {"bag1", "bag2"} <= set(hot_parts):
        if not soak.ok:
            notes.append(f"FTP-75: run 2 follows run 1 after a {soak.describe()}, not the "
                         f"{SOAK_RULE} (9-11 min accepted): not read as its bag 3; the UDDS "
                         "figure is the last run")
        elif cold_start is False:
            notes.append("FTP-75: the record starts hot (coolant far above the cell): "
                         f"{START_RULE} not met, no FTP composite")
        else:
            h1, h2 = hot_parts["bag1"], hot_parts["bag2"]
            soak_text = f"hot soak {soak.describe()} ({SOAK_RULE})"
            return [
                Composite("udds", _COLD_UDDS_RULE, [(1.0, [b1, b2])]),
                Composite("udds_hot", _HOT_UDDS_RULE, [(1.0, [h1, h2])]),
                Composite("ftp75", FTP_RULE + f"; bag 3 = run 2 bag 1 after the {soak_text}",
                          [(FTP_WEIGHTS[0], [b1, b2]), (FTP_WEIGHTS[1], [h1, b2])]),
                Composite("ftp75_4bag", FTP_4BAG_RULE + f"; after the {soak_text}",
                          [(FTP_WEIGHTS[0], [b1, b2]), (FTP_WEIGHTS[1], [h1, h2])]),
            ]
    run = [p.name for p in labelled if p.run == last]
    if cold_start is False:
        return [Composite("udds", _HOT_START_UDDS_RULE, [(1.0, run)])]
    out = [Composite("udds", _LAST_RUN_RULES["udds"], [(1.0, run)])]
    if hot_bag1:
        sub = ("bag 3 taken from the bag 1 of a hot-start UDDS run of the same vehicle "
               f"(the FTP-75 bag 3 repeats the first {part_boundary_s('udds', 'bag1'):g} s hot)")
        g3 = ["__hot_bag1__", b2]
    else:
        sub = (f"no hot-start run given: bag 3 (hot transient) taken as the stabilised "
               f"bag 2: {SUBSTITUTE_DIRECTION}")
        g3 = [b2]
    out.append(Composite("ftp75_from_udds", FTP_RULE, [
        (FTP_WEIGHTS[0], [b1, b2]), (FTP_WEIGHTS[1], g3)], substitute=sub))
    return out


def substitute_direction(composites: list[Composite], values: dict[str, dict],
                         hot: dict[str, float] | None,
                         economy: Callable[[float], float | None]) -> list[str]:
    """With a measured hot-start bag 1 standing for bag 3: what the bag 2 stand-in would have
    given, and its direction, from the data (``FTP-75:`` notes).

    ``values``: the nominal figures per scope (``fuel_mass_kg`` [kg], ``distance_m`` [m]);
    ``hot``: the hot bag 1's ``fuel_mass_kg`` and ``distance_m``; ``economy``: fuel per
    distance [kg/m] -> fuel economy [mile/US gal] (None without a fuel density).
    """
    out: list[str] = []
    if not hot or not hot.get("distance_m"):
        return out
    for c in composites:
        if len(c.groups) != 2 or "__hot_bag1__" not in c.groups[1][1]:
            continue
        (w1, cold), (w2, _) = c.groups
        b2 = next(n for n in c.groups[1][1] if n != "__hot_bag1__")
        try:
            f = [float(values[n]["fuel_mass_kg"]) for n in cold]
            d = [float(values[n]["distance_m"]) for n in cold]
            fb2, db2 = float(values[b2]["fuel_mass_kg"]), float(values[b2]["distance_m"])
        except (KeyError, TypeError, ValueError):
            continue
        cold_term = (w1, sum(f), sum(d))
        measured = weighted_per_distance([cold_term, (w2, hot["fuel_mass_kg"] + fb2,
                                                      hot["distance_m"] + db2)])
        stand_in = weighted_per_distance([cold_term, (w2, fb2, db2)])
        if not (stand_in > 0 and measured > 0 and math.isfinite(stand_in + measured)):
            continue
        # fuel economy is distance per fuel: less fuel per distance overstates it
        word = "overstates" if stand_in < measured else "understates"
        rel = 100.0 * abs(measured / stand_in - 1.0)
        fe_sub, fe_meas = economy(stand_in), economy(measured)
        figures = (f" ({fe_sub:.2f} against {fe_meas:.2f} mpg)"
                   if fe_sub is not None and fe_meas is not None else "")
        out.append(f"FTP-75: bag 2 standing for bag 3 {word} the {c.name} fuel economy "
                   f"measured with the hot bag 1 by {rel:.1f} %{figures}")
    return out
