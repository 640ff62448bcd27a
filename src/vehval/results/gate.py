"""The QA gate of the results: a figure computed from a signal QA holds an error on is withheld.

Every stated figure (phase, whole test, composite) knows the signals it was computed from
(:attr:`TestResults.inputs`): its fuel quantities depend on the fuel-rate signal, the speed
signal (distance) and, for phases and composites, the phase channel; CO2 on the CO2 channel
when measured (else on the fuel); battery energy on the battery signals. An error-severity
finding on one of those signals whose span overlaps the figure's span withholds the
dependent quantities: they become null in ``values`` and ``uncertainty`` and the scope gets
a ``withheld`` entry naming the signals, the reason and the fix. With ``force`` the values
stay, the entry says ``forced``.

The headline (:func:`headline`) is the regulatory figure of the test's cycle, which every
consumer (screen, report, batch index, catalog, Excel) reads instead of choosing its own.
"""

from __future__ import annotations

import math
from typing import Any, Iterable

from vehval.qa.findings import Finding, Kind, Severity

__all__ = ["EXIT_WITHHELD", "apply_gate", "dependencies", "headline", "withheld_count"]

#: Exit code of `results`, `qa`, `batch` and `report` when a figure was computed but withheld.
EXIT_WITHHELD = 4
#: Kinds whose finding speaks for the whole channel, whatever span it carries.
WHOLE_CHANNEL_KINDS = frozenset({Kind.ALL_ZERO, Kind.CONSTANT, Kind.UNIT, Kind.UNIT_SUSPECT,
                                 Kind.GAIN, Kind.OFFSET, Kind.SIGN_FLIP, Kind.SPARSE,
                                 Kind.FUEL_MAP, Kind.UNRECOGNISED, Kind.FUEL_EFFICIENCY})

_DIST = ("distance_m", "mean_speed_mps", "max_speed_mps")
_FUEL = ("fuel_mass_kg", "fuel_volume_m3", "fuel_energy_j")
_ECON = ("fuel_economy_mpg", "fuel_consumption_l_per_100km")
_CO2 = ("co2_kg", "co2_g_per_km")
_COMP_FUEL = ("fuel_per_distance_kg_per_m", "fuel_economy_mpg", "fuel_consumption_l_per_100km",
              "fuel_energy_per_distance_j_per_m")
#: Headline rule of a cycle without a regulatory composite.
WHOLE_TEST_RULE = "whole test (no regulatory composite for this cycle and layout)"


def dependencies(inputs: dict[str, list[str]], kind: str) -> dict[str, list[str]]:
    """Signals each quantity of a scope depends on.

    Parameters
    ----------
    inputs : dict
        Role -> signal names (``speed``, ``fuel``, ``co2``, ``ess``, ``phase``) of
        :attr:`TestResults.inputs`.
    kind : {'phase', 'test', 'composite'}
        The scope's kind: the phase channel counts for phases and composites only.

    Returns
    -------
    dict
        Quantity key -> names of the signals it was computed from.
    """
    spd, fuel = inputs.get("speed", []), inputs.get("fuel", [])
    co2 = inputs.get("co2", []) or fuel
    phase = inputs.get("phase", []) if kind != "test" else []
    if kind == "composite":
        dep = {q: spd + fuel for q in _COMP_FUEL}
        dep["co2_g_per_km"] = spd + co2
    else:
        dep = {"duration_s": []}
        dep.update({q: list(spd) for q in _DIST})
        dep.update({q: list(fuel) for q in _FUEL})
        dep.update({q: spd + fuel for q in _ECON})
        dep["co2_kg"] = list(co2)
        dep["co2_g_per_km"] = spd + co2
        dep["ess_energy_net_j"] = list(inputs.get("ess", []))
    return {q: sorted(set(s + phase)) for q, s in dep.items()}


def _span(f: Finding) -> tuple[float, float] | None:
    """The finding's span [s], or None when it speaks for the whole channel."""
    if f.kind in WHOLE_CHANNEL_KINDS:
        return None
    a, b = f.start_s, f.end_s
    if not (isinstance(a, (int, float)) and isinstance(b, (int, float))
            and math.isfinite(a) and math.isfinite(b)):
        return None
    return float(a), float(b)


def _overlaps(f: Finding, segments: list[tuple[float, float]]) -> bool:
    span = _span(f)
    if span is None or not segments:
        return True
    return any(span[0] <= b and a <= span[1] for a, b in segments)


def _fix(f: Finding) -> str:
    return f.fix or (f"check the template's unit and mapping of {f.signal} (and the sensor) "
                     "before stating this figure")


def _entry(quantities: list[str], hits: list[Finding], forced: bool) -> dict[str, Any]:
    signals = sorted({f.signal for f in hits})
    first: dict[str, Finding] = {}
    for f in hits:              # one reason and one fix per signal, the first error of each
        first.setdefault(f.signal, f)
    reason = "; ".join(f"QA error on {s} ({first[s].kind.value}): {first[s].message}"
                       for s in signals)
    fixes = list(dict.fromkeys(_fix(first[s]) for s in signals))
    return {"quantities": quantities, "signals": signals, "reason": reason,
            "fix": "; ".join(fixes),
            "findings": [{"signal": f.signal, "kind": f.kind.value, "severity": f.severity.value,
                          "message": f.message} for f in hits],
            **({"forced": True} if forced else {})}


def _scopes(res: Any) -> list[tuple[str, str, list[tuple[float, float]]]]:
    """(scope, kind, record-time segments) of every stated figure."""
    segs = {p.name: list(p.segments) for p in res.phases}
    out = [(p.name, "phase", segs[p.name]) for p in res.phases]
    out.append(("test", "test", []))
    for c in res.composites:
        cs = [s for _, names in c.groups for n in names for s in segs.get(n, [])]
        out.append((c.name, "composite", cs))
    return out


def apply_gate(res: Any, findings: Iterable[Finding | dict] = (), *,
               force: bool = False) -> Any:
    """Withhold the figures of ``res`` computed from signals QA holds an error on.

    Parameters
    ----------
    res : vehval.results.TestResults
        Computed results (changed in place and returned).
    findings : iterable of Finding or dict
        QA findings of the test (``findings.json`` entries or :class:`Finding`); the
        results stage's own findings are added.
    force : bool
        State withheld figures anyway (each entry then has ``forced``: true).

    Returns
    -------
    vehval.results.TestResults
        ``res``, with ``withheld`` per scope and ``forced`` set.
    """
    errors = [f if isinstance(f, Finding) else Finding.from_dict(f) for f in findings]
    # an error the import already repaired (a repeated time stamp dropped) leaves sound values
    errors = [f for f in errors + list(res.findings) if f.severity == Severity.ERROR
              and not (f.numbers or {}).get("repaired_at_import")]
    res.withheld = {}
    res.forced = bool(force)
    if not errors:
        return res
    _battery_dropped(res, errors)
    # a role with no signal because QA's selection dropped its only source for an error:
    # its figures are withheld for that error, not merely "n/a"
    dropped = {role: sorted({f.signal for f in errors if _is_measured(f.signal, base)})
               for role, base in _ROLE_BASE.items() if not res.inputs.get(role)}
    inputs = {**res.inputs, **{r: names for r, names in dropped.items() if names}}
    lost = {n for names in dropped.values() for n in names}
    for scope, kind, segs in _scopes(res):
        deps = dependencies(inputs, kind)
        vals = res.values.get(scope, {})
        out: list[str] = []
        hits: list[Finding] = []
        for q, sigs in deps.items():
            if vals.get(q) is None and not lost & set(sigs):
                continue                 # nothing stated, nothing to withhold
            h = [f for f in errors if f.signal in sigs and _overlaps(f, segs)]
            if h:
                out.append(q)
                hits += [f for f in h if f not in hits]
        if not out:
            continue
        res.withheld[scope] = _entry(out, hits, force)
        if not force:
            for q in out:
                vals[q] = None
                res.uncertainty.get(scope, {}).pop(q, None)
    if not force:
        _gate_soc(res)
    return res


#: Base names of the measured battery signals the SAE J1711 ratio rests on.
_BATTERY_BASES = ("ess_pwr", "ess_curr", "ess_volt")


def _battery_dropped(res: Any, errors: list[Finding]) -> None:
    """A test whose battery signal QA dropped for an error has a battery: its J1711 status
    is ``undetermined`` (naming the error), not ``not_applicable`` (no battery), so the
    headline carries the caveat instead of silently losing the SOC check."""
    soc = res.soc or {}
    if soc.get("status") != "not_applicable":
        return
    hits = [f for f in errors if any(_is_measured(f.signal, b) for b in _BATTERY_BASES)]
    if not hits:
        return
    f = hits[0]
    res.soc = {"status": "undetermined", "tolerance": soc.get("tolerance"), "method": None,
               "message": f"the battery signal {f.signal} has a QA error ({f.kind.value}: {f.message}), so the "
                          "battery's change over the test is unknown; fix the signal (sign, "
                          "unit, mapping) and rerun",
               "scopes": {}}


def _gate_soc(res: Any) -> None:
    """The J1711 ratio is battery energy over fuel energy: withheld with the fuel energy."""
    held = [w for w in res.withheld.values() if "fuel_energy_j" in w["quantities"]]
    soc = res.soc or {}
    if not held or soc.get("status") in (None, "not_applicable"):
        return
    old = soc.get("message")
    res.findings = [f for f in res.findings if not (old and f.message == old)]
    res.soc = {"status": "withheld", "tolerance": soc.get("tolerance"), "method": None,
               "message": "SOC correction (SAE J1711) withheld: it compares the battery energy "
                          "with the fuel energy, which is withheld (" + held[0]["reason"] + ")",
               "scopes": {}}


#: Role of :attr:`TestResults.inputs` -> base name of its measured signals.
_ROLE_BASE = {"speed": "veh_spd", "fuel": "fuel_rate", "co2": "co2_rate"}


def _is_measured(name: str, base: str) -> bool:
    """``name`` is a measured signal (``*_test``) of ``base`` (``fuel_rate_test``,
    ``fuel_rate_bench_test``)."""
    return name.startswith(base + "_") and name.endswith("_test")


def withheld_count(res: Any) -> int:
    """Number of scopes (phases, whole test, composites) with a withheld figure."""
    return len(res.withheld)


def headline(res: Any) -> dict[str, Any]:
    """The test's headline: the regulatory figure of its cycle.

    HWFET, US06 and SC03: the last run (the first prepares); UDDS: bags 1+2; FTP-75 (also
    a file holding the cold UDDS, the soak and the hot UDDS): the 0.43/0.57 weighting; NEDC, WLTC: the whole run; a cycle without a composite: the whole
    test, named ``test``.

    Returns
    -------
    dict
        ``name``, ``kind`` (``composite`` or ``test``), ``rule``, ``fuel_economy_mpg``
        [mile/US gal], ``fuel_economy_u_mpg`` (U, k = 2), ``fuel_consumption_l_per_100km``,
        ``withheld`` (the scope's entry or None; when the figure is no headline, a distance
        below :data:`vehval.results.headline.MIN_HEADLINE_DISTANCE_M` or U as large as the
        value, the entry of :func:`vehval.results.headline.not_a_headline` and null figures),
        ``forced`` and ``caveats`` (the
        composite's departures from the procedure's conditions, each naming its clause;
        a whole-test headline of a test with no identified cycle says so,
        :data:`NO_CYCLE_CAVEAT`).
    """
    base = (res.cycle or "").split("_x")[0]
    names = {c.name for c in res.composites}
    if base == "udds" and (res.cycle or "") != "udds" and "ftp75" in names:
        base = "ftp75"               # cold UDDS, soak, hot UDDS in one file: the FTP-75 test
    comp = next((c for c in res.composites if c.name == base), None)
    if comp is None and res.composites:
        comp = res.composites[0]
    name, kind, rule = ("test", "test", WHOLE_TEST_RULE) if comp is None else \
        (comp.name, "composite", comp.rule)
    from vehval.results.headline import not_a_headline

    held = res.withheld.get(name)
    if held is not None and not set(_ECON) & set(held["quantities"]):
        held = None                  # only figures other than the fuel economy withheld
    mpg, u_mpg = res.value(name, "fuel_economy_mpg"), res.expanded(name, "fuel_economy_mpg")
    lkm = res.value(name, "fuel_consumption_l_per_100km")
    forced = bool(held and res.forced)
    if held is None and (held := not_a_headline(mpg, u_mpg, res.value(name, "distance_m"))):
        mpg = u_mpg = lkm = None     # no headline (an idle record): the scope keeps its values
    return {"name": name, "kind": kind, "rule": rule,
            "fuel_economy_mpg": mpg, "fuel_economy_u_mpg": u_mpg,
            "fuel_consumption_l_per_100km": lkm,
            "withheld": held, "forced": forced,
            "caveats": list(getattr(comp, "caveats", None) or []) + _whole_test_caveat(res, comp)}


#: Caveat of a headline that is the whole test because no drive cycle was identified.
NO_CYCLE_CAVEAT = ("no drive cycle identified in the speed trace: this is the whole test's "
                   "figure (every second of the record), not a cycle's regulatory figure; "
                   "check the speed channel (unit, scale) or declare 'cycle:' in the template")


def _whole_test_caveat(res: Any, comp: Any) -> list[str]:
    """The caveat a whole-test headline carries when the test has no identified cycle."""
    return [NO_CYCLE_CAVEAT] if comp is None and not res.cycle else []
