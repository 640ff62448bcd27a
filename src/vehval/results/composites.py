"""Regulatory composites: which phases make a test's reported result, and how they weigh.

A composite is a weighted sum of groups of phases: its fuel per distance is
``sum_k w_k (fuel of group k) / (distance of group k)``, which is the harmonic weighting of
fuel economy the regulations use. Each composite cites its rule.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from vehval.results.phases import Phase

__all__ = ["FTP_WEIGHTS", "HOT_BAG3_SUBSTITUTE", "Composite", "composites_for"]

#: FTP-75 weights of the cold-start (bags 1+2) and hot-start (bags 3+2) halves.
FTP_WEIGHTS = (0.43, 0.57)
FTP_RULE = ("40 CFR 600.113-12(g)(2): FTP fuel economy = 1 / (0.43 / FE(bags 1+2) + "
            "0.57 / FE(bags 3+2)); the same weights apply to CO2 per distance")
#: Name of the stand-in for bag 3 when a cold-start UDDS has none.
HOT_BAG3_SUBSTITUTE = "hot-start bag 1"
_LAST_RUN_RULES = {
    "hwfet": "40 CFR 600.111-08(b): the HWFET is run twice, the first run prepares the "
             "vehicle and the second is the test run; the result is the last run",
    "us06": "40 CFR 86.164-08 / 600.114-12: US06 city part (0-130 s, 496-600 s) and "
            "highway part (130-496 s); with two runs the first prepares and the result is "
            "the last run",
    "sc03": "40 CFR 86.160-00: SC03 result of the test run; with two runs the first "
            "prepares and the result is the last run",
    "udds": "40 CFR 86.144: UDDS (FTP-72) result over bags 1+2",
    "nedc": "UN ECE R101: combined result over the urban (ECE) and extra-urban (EUDC) parts",
    "wltc3b": "UN GTR 15 / Regulation (EU) 2017/1151 Sub-Annex 7: combined result over the "
              "four phases",
}


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
    """

    name: str
    rule: str
    groups: list[tuple[float, list[str]]] = field(default_factory=list)
    substitute: str = ""

    def to_dict(self) -> dict:
        return {"name": self.name, "rule": self.rule, "substitute": self.substitute or None,
                "groups": [{"weight": w, "phases": list(p)} for w, p in self.groups]}


def composites_for(cycle: str | None, phases: list[Phase], *, cold_start: bool | None,
                   hot_bag1: bool) -> list[Composite]:
    """The composites a test of ``cycle`` supports with the phases it has.

    ``hot_bag1`` says a hot-start UDDS bag 1 was supplied to stand in for the FTP bag 3 of a
    cold-start UDDS (``__hot_bag1__`` in the groups).
    """
    if not cycle:
        return []
    labelled = [p for p in phases if p.run > 0 and p.part]
    if not labelled:
        return []
    last = max(p.run for p in labelled)
    run = [p for p in labelled if p.run == last]
    by_part = {p.part: p.name for p in labelled if p.run == 1}
    out: list[Composite] = []
    if cycle == "ftp75" and {"bag1", "bag2", "bag3"} <= set(by_part):
        out.append(Composite("ftp75", FTP_RULE, [
            (FTP_WEIGHTS[0], [by_part["bag1"], by_part["bag2"]]),
            (FTP_WEIGHTS[1], [by_part["bag3"], by_part["bag2"]])]))
        return out
    names = [p.name for p in run]
    out.append(Composite(cycle, _LAST_RUN_RULES.get(cycle, "whole cycle run"), [(1.0, names)]))
    if cycle == "us06":
        for part in ("city", "highway"):
            sel = [p.name for p in run if p.part == part]
            if sel:
                out.append(Composite(f"us06_{part}", _LAST_RUN_RULES["us06"], [(1.0, sel)]))
    if cycle == "udds" and {"bag1", "bag2"} <= set(by_part) and cold_start is not False:
        if hot_bag1:
            sub = ("bag 3 taken from the bag 1 of a hot-start UDDS run of the same vehicle "
                   "(the FTP-75 bag 3 repeats the first 505 s hot)")
            g3 = ["__hot_bag1__", by_part["bag2"]]
        else:
            sub = ("no hot-start run given: bag 3 (hot transient) taken as the stabilised "
                   "bag 2, which overstates the FTP fuel economy by the hot-transient excess "
                   "(typically a few percent); give a hot-start UDDS with --hot-start")
            g3 = [by_part["bag2"]]
        out.append(Composite("ftp75_from_udds", FTP_RULE, [
            (FTP_WEIGHTS[0], [by_part["bag1"], by_part["bag2"]]), (FTP_WEIGHTS[1], g3)],
            substitute=sub))
    return out
