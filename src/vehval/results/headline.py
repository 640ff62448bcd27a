"""The headline of a test: the one place its sentence is formed.

The command line (``vehval results``, ``vehval report``), the report's banner and the
workbench's page all state the same headline from a ``results.json`` document: the
regulatory figure of the test's cycle with its expanded uncertainty U (k = 2) (fuel economy
for a car that burns fuel; SAE J1634 MPGe and kWh per distance for a battery-electric test), the
regulation clause it follows, every caveat (start condition, cell temperature, SAE J1711
status, substitutes, no identified cycle), and, when a model comparison ran, its verdict with
the fuel mass's normalised error En. The figure is written in the user's unit system
(:mod:`vehval.display`: ``us`` puts mpg (MPGe, kWh/100 mi) first, ``metric`` L/100 km
(kWh/100 km)).

:func:`headline_of` builds a :class:`Headline` from the document; its :meth:`Headline.lines`
(command line), :meth:`Headline.banner` (report) and :meth:`Headline.to_dict` (page, JSON)
are the only renderings.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

__all__ = ["MIN_HEADLINE_DISTANCE_M", "NOT_A_HEADLINE", "Headline", "electric_figures",
           "headline_of", "j1711_caveat", "not_a_headline"]

#: Least distance of a fuel-economy headline [m]: a record that drives less (an idle
#: record, a file cut at the start) has a fuel economy of the speed sensor's offset, not a
#: figure (the shortest regulatory phase drives about 5.8 km, UDDS bag 1; a short drive
#: of a few hundred metres still has a figure, judged by its U).
MIN_HEADLINE_DISTANCE_M = 100.0
#: ``rule`` of the headline's ``withheld`` entry when the figure is no headline (not a QA
#: error: :func:`not_a_headline`).
NOT_A_HEADLINE = "not_a_headline"

#: SAE J1711 statuses that qualify the figure (the others stand it unqualified).
_J1711_CAVEAT = ("beyond_tolerance_uncorrected", "corrected", "undetermined")


def _num(x: Any) -> float | None:
    return float(x) if isinstance(x, (int, float)) and not isinstance(x, bool) \
        and math.isfinite(float(x)) else None


def j1711_caveat(soc: dict | None) -> str | None:
    """The caveat of a results document's SAE J1711 status (None: none, or within tolerance)."""
    soc = soc or {}
    status = soc.get("status")
    if status not in _J1711_CAVEAT:
        return None
    return f"SAE J1711 {str(status).replace('_', ' ')}: {soc.get('message', '')}".rstrip(": ")


def not_a_headline(mpg: float | None, u_mpg: float | None,
                   distance_m: float | None) -> dict[str, Any] | None:
    """The headline's ``withheld`` entry when its fuel economy is no headline, else None: a
    distance below :data:`MIN_HEADLINE_DISTANCE_M` (``distance 0.1 m: no fuel-economy
    headline ...``), or an expanded uncertainty U (k = 2) as large as the value itself (the
    figure says nothing). The values stay in their scope (``test_total``, the composite);
    ``--force`` does not state it (it is no QA error).

    Parameters
    ----------
    mpg, u_mpg : float or None
        The headline's fuel economy and its U (k = 2) [mile/US gal].
    distance_m : float or None
        The headline scope's distance [m] (None for a composite, which has none).
    """
    mpg, u, d = _num(mpg), _num(u_mpg), _num(distance_m)
    if mpg is None:
        return None
    if d is not None and d < MIN_HEADLINE_DISTANCE_M:
        reason = (f"distance {d:.1f} m: no fuel-economy headline (it needs at least "
                  f"{MIN_HEADLINE_DISTANCE_M:g} m driven)")
    elif u is not None and u >= abs(mpg):
        reason = (f"U {u:.3g} mpg exceeds the value {mpg:.3g} mpg: no fuel-economy headline "
                  "(the figure says nothing)")
    else:
        return None
    return {"quantities": ["fuel_economy_mpg", "fuel_consumption_l_per_100km"], "signals": [],
            "reason": reason, "rule": NOT_A_HEADLINE, "findings": [],
            "fix": "a fuel-economy headline needs a drive: check that the file holds the "
                   "whole test (speed channel, unit, the record not cut short)"}


@dataclass
class Headline:
    """The structured headline of one test.

    Attributes
    ----------
    kind : str
        ``headline`` (a figure stated), ``withheld`` (QA errors: no figure), ``forced``
        (stated despite QA errors, ``--force``) or ``none`` (no fuel economy nor J1634 figure).
    scope : str
        The composite (``udds``, ``hwfet``...) or ``test``.
    mpg, u_mpg : float or None
        Fuel economy [mile/US gal] and its U (k = 2).
    l_per_100km, u_l_per_100km : float or None
        Fuel consumption [L/100 km] and its U (k = 2).
    rule : str
        The regulation clause the figure follows.
    caveats : list of str
        Every departure from the procedure's conditions, each naming its clause.
    j1711 : str or None
        The SAE J1711 status of a test with a battery (``within_tolerance``...), else None.
    withheld : dict or None
        ``signals``, ``reason``, ``fix`` when the figure is withheld (or forced).
    withheld_count : int
        Figures of the document withheld for QA errors.
    forced : bool
        The document states figures despite QA errors (``--force``).
    model : dict or None
        The model comparison's ``verdict``, ``en`` (normalised error of the fuel mass) and
        ``error_pct`` when a comparison ran.
    system : str
        The unit system the text is written in (``us`` or ``metric``).
    electric : dict or None
        SAE J1634 figures of a test without fuel economy (a battery-electric test):
        ``mpge``, ``kwh_per_100mi``, ``kwh_per_100km`` (AC, wall), each with ``u_<name>``
        (U, k = 2, from the DC energy's relative U; None when the results give none),
        ``scope`` (the J1634 scope) and ``basis`` (how the AC energy was obtained).
    """

    kind: str
    scope: str
    mpg: float | None = None
    u_mpg: float | None = None
    l_per_100km: float | None = None
    u_l_per_100km: float | None = None
    rule: str = ""
    caveats: list[str] = field(default_factory=list)
    j1711: str | None = None
    withheld: dict | None = None
    withheld_count: int = 0
    model: dict | None = None
    system: str = "us"
    forced: bool = False
    electric: dict | None = None

    @property
    def shown(self) -> str:
        """The scope as a reader names it (``whole test`` for ``test``)."""
        return "whole test" if self.scope == "test" else self.scope

    def figure(self, pm: str = "±") -> str:
        """``"24.60 ± 0.30 mpg (9.56 ± 0.12 L/100 km)"``, L/100 km first in ``metric``;
        ``"fuel economy n/a"`` without a figure. ``pm`` is the plus-minus sign. A
        battery-electric test: ``"183.3 ± 1.7 MPGe (18.39 ± 0.17 kWh/100 mi)"`` (``us``) or
        ``"11.42 ± 0.11 kWh/100 km (183.3 ± 1.7 MPGe)"`` (``metric``)."""
        def one(v: float, u: float | None, unit: str, nd: int = 2) -> str:
            return f"{v:.{nd}f} {pm} {u:.{nd}f} {unit}" if u is not None else f"{v:.{nd}f} {unit}"

        if self.mpg is None and self.electric:
            e = self.electric
            mpge = one(e["mpge"], e.get("u_mpge"), "MPGe", 1)
            if self.system == "metric":
                return f"{one(e['kwh_per_100km'], e.get('u_kwh_per_100km'), 'kWh/100 km')} ({mpge})"
            return f"{mpge} ({one(e['kwh_per_100mi'], e.get('u_kwh_per_100mi'), 'kWh/100 mi')})"
        if self.mpg is None:
            return "fuel economy n/a"

        first = one(self.mpg, self.u_mpg if self.u_mpg is not None else 0.0, "mpg")
        if self.l_per_100km is None:
            return first
        second = one(self.l_per_100km, self.u_l_per_100km, "L/100 km")
        if self.system == "metric":
            first, second = second, first
        return f"{first} ({second})"

    def verdict_text(self) -> str | None:
        """The model comparison's verdict sentence, with En where it exists."""
        m = self.model or {}
        if not m.get("verdict"):
            return None
        en, err = _num(m.get("en")), _num(m.get("error_pct"))
        parts = [f"model {m['verdict']}"]
        if en is not None:
            parts.append(f"En = {en:+.2f}")
        if err is not None:
            parts.append(f"{m.get('quantity') or 'fuel'} {err:+.1f} % against the test")
        return ", ".join(parts)

    # ------------------------------------------------------------------ renderings
    def lines(self) -> list[str]:
        """The command line's headline lines (ASCII ``+-``)."""
        held = self.withheld or {}
        if self.kind == "withheld" and held.get("rule") == NOT_A_HEADLINE:
            return [f"headline {self.scope}: {held.get('reason', '')}",
                    f"  fix: {held.get('fix', '')}"]
        if self.kind == "withheld":
            return [f"headline {self.scope}: WITHHELD ({', '.join(held.get('signals') or [])}): "
                    f"{held.get('reason', '')}", f"  fix: {held.get('fix', '')}",
                    "  (--force states it anyway, under a banner)"]
        if self.kind == "none":
            return [f"headline {self.scope}: fuel economy n/a"]
        line = f"headline {self.scope}: {self.figure('+-')}"
        if self.kind == "forced":
            return [f"STATED DESPITE QA ERRORS (--force): {line}",
                    f"  withheld reason: {held.get('reason', '')}", f"  fix: {held.get('fix', '')}"]
        out = [line] + [f"  ! caveat: {c}" for c in self.caveats]
        if (v := self.verdict_text()) is not None:
            out.append(f"  {v}")
        return out

    def banner(self) -> dict:
        """The report's banner: ``{"kind", "title", "lines"}``."""
        held = self.withheld or {}
        n = self.withheld_count
        if self.kind == "withheld" and held.get("rule") == NOT_A_HEADLINE:
            return {"kind": "withheld", "title": f"Headline {self.shown}: none",
                    "lines": [f"Reason: {held.get('reason', '')}", f"Fix: {held.get('fix', '')}"]}
        if self.kind == "withheld":
            return {"kind": "withheld", "title": f"Headline {self.shown}: withheld",
                    "lines": [f"Signals: {', '.join(held.get('signals') or [])}",
                              f"Reason: {held.get('reason', '')}", f"Fix: {held.get('fix', '')}",
                              f"{n} figure(s) withheld in this report; `--force` states them "
                              "under a banner."]}
        if self.kind == "forced" or (self.forced and n):
            lines = [f"{n} figure(s) computed from signals with QA errors are stated anyway "
                     "(--force); do not use them as test results."]
            if held:
                lines += [f"Reason: {held.get('reason', '')}", f"Fix: {held.get('fix', '')}"]
            return {"kind": "forced",
                    "title": f"Stated despite QA errors: {self.shown} {self.figure()}",
                    "lines": lines}
        lines = [self.rule] if self.rule else []
        lines += [f"Caveat: {c}" for c in self.caveats]
        if self.j1711 == "within_tolerance":
            lines.append("SAE J1711: battery energy change within tolerance, uncorrected")
        if (v := self.verdict_text()) is not None:
            lines.append(v[0].upper() + v[1:])
        if n:
            lines.append(f"{n} other figure(s) withheld for QA errors: see the results section.")
        return {"kind": "headline", "title": f"{self.shown}: {self.figure()}", "lines": lines}

    def to_dict(self) -> dict:
        """The page's headline (JSON): the numbers, the texts and every caveat."""
        return {"kind": self.kind, "name": self.scope, "shown": self.shown,
                "fuel_economy_mpg": self.mpg, "fuel_economy_u_mpg": self.u_mpg,
                "fuel_consumption_l_per_100km": self.l_per_100km,
                "fuel_consumption_u_l_per_100km": self.u_l_per_100km,
                "electric": dict(self.electric) if self.electric else None,
                "figure": self.figure(), "rule": self.rule, "caveats": list(self.caveats),
                "j1711": self.j1711, "withheld": self.withheld,
                "withheld_count": self.withheld_count, "model": self.model,
                "verdict": self.verdict_text(), "system": self.system,
                "banner": self.banner()}


def _u_l_per_100km(doc: dict, scope: str) -> float | None:
    """U (k = 2) of the scope's L/100 km in the document (composites, phases or test)."""
    blocks = [c for c in doc.get("composites") or [] if c.get("name") == scope]
    blocks += [p for p in doc.get("phases") or [] if p.get("name") == scope]
    if scope == "test":
        blocks.append(doc.get("test_total") or {})
    for b in blocks:
        u = _num(((b.get("uncertainty") or {}).get("fuel_consumption_l_per_100km") or {}).get("U"))
        if u is not None:
            return u
    return None


def electric_figures(doc: dict, scope: str) -> dict | None:
    """The SAE J1634 figures of ``scope`` in a results document (``scope`` when J1634 has it,
    else the whole test), with U (k = 2) from the DC energy's relative U; None without J1634
    figures (:attr:`Headline.electric`)."""
    j = doc.get("j1634") or {}
    scopes = j.get("scopes") or {}
    key = scope if scope in scopes else "test"
    s = scopes.get(key) or {}
    vals = {n: _num(s.get(n)) for n in ("mpge", "ac_kwh_per_100mi", "ac_kwh_per_100km")}
    if any(v is None for v in vals.values()):
        return None
    rel = _num(s.get("U_rel_dc_energy"))
    out: dict[str, Any] = {"scope": key, "basis": str(s.get("ac_basis") or ""),
                           "charger_efficiency": _num(j.get("charger_efficiency"))}
    for name, v in (("mpge", vals["mpge"]), ("kwh_per_100mi", vals["ac_kwh_per_100mi"]),
                    ("kwh_per_100km", vals["ac_kwh_per_100km"])):
        out[name] = v
        out[f"u_{name}"] = None if rel is None else abs(rel * v)  # type: ignore[operator]
    return out


def headline_of(doc: dict | None, *, model: dict | None = None,
                system_name: str | None = None) -> Headline | None:
    """The headline of a ``results.json`` document (None when there is none).

    Parameters
    ----------
    doc : dict
        The results document (:meth:`vehval.results.TestResults.to_dict`).
    model : dict, optional
        The model comparison's normalised error of the fuel mass (``verdict``, ``en``,
        ``error_pct``), when one ran.
    system_name : str, optional
        ``us`` or ``metric`` (default: the user's, :func:`vehval.display.system`).
    """
    from vehval.display import system

    if not doc:
        return None
    h = doc.get("headline") or {}
    scope = str(h.get("name") or "test")
    held = h.get("withheld") or None
    mpg = _num(h.get("fuel_economy_mpg"))
    soc = doc.get("soc_correction") or {}
    caveats = [str(c) for c in h.get("caveats") or []]
    if (j := j1711_caveat(soc)) is not None and j not in caveats:
        caveats.append(j)
    electric = electric_figures(doc, scope) if mpg is None and not held else None
    rule = str(h.get("rule") or "")
    status = soc.get("status")
    if electric is not None:   # SAE J1711 corrects a hybrid's fuel: not a BEV's energy
        caveats = [c for c in caveats if c != j] if j else caveats
        status = None
        scope = electric["scope"]   # J1634 per phase and whole test, not per composite
        rule = (f"SAE J1634 ({'whole test' if electric['scope'] == 'test' else electric['scope']}):"
                f" AC energy {electric['basis']}; MPGe at 33.705 kWh per gallon equivalent")
    kind = ("withheld" if held and not h.get("forced") else "forced" if held else
            "headline" if mpg is not None or electric is not None else "none")
    return Headline(kind=kind, scope=scope, mpg=mpg, u_mpg=_num(h.get("fuel_economy_u_mpg")),
                    l_per_100km=_num(h.get("fuel_consumption_l_per_100km")),
                    u_l_per_100km=_u_l_per_100km(doc, scope), rule=rule, electric=electric,
                    caveats=caveats,
                    j1711=status if status not in (None, "not_applicable") else None,
                    withheld=held, withheld_count=int(doc.get("withheld_count") or 0),
                    forced=bool(doc.get("forced")),
                    model=dict(model) if model else None, system=system(system_name))
