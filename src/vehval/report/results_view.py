"""The report's first section: the test results as a laboratory reports them.

Built from ``results.json`` (:meth:`vehval.results.TestResults.to_dict`). Data stay SI in
the document; this view shows engineering units (mi, mph, mpg, L/100 km, g/km, kWh) and
every value with its expanded uncertainty (k = 2).
"""

from __future__ import annotations

from typing import Any

from vehval.constants import KMH_M_PER_S, KWH_J, MILE_M, MPH_M_PER_S
from vehval.display import as_unit
from vehval.figures import layout_figure
from vehval.report.figures import FigSpec
from vehval.report.sections import Section
from vehval.report.tables import Table

__all__ = ["PlusMinus", "results_section"]


class PlusMinus(str):
    """A ``value ± U`` cell: text on the page; the workbook writes the two numbers
    (:func:`vehval.report.excel.results_tables`), as shown (rounded to the printed digits)."""

    value: float
    u: float | None

    def __new__(cls, value: float, u: float | None, nd: int) -> "PlusMinus":
        out = super().__new__(cls, f"{value:.{nd}f}" + (f" ± {u:.{nd}f}" if u is not None else ""))
        out.value, out.u = round(value, nd), None if u is None else round(u, nd)
        return out

#: Column header and unit label of the two fuel figures.
_HEAD = {"fuel_economy_mpg": "fuel economy [mpg]",
         "fuel_consumption_l_per_100km": "consumption [L/100 km]"}
_LABEL = {"fuel_economy_mpg": "mpg", "fuel_consumption_l_per_100km": "L/100 km"}


def _r(x: Any, nd: int) -> Any:
    return None if x is None else round(float(x), nd)


def _held(block: dict, key: str) -> dict | None:
    """The block's withheld entry when it covers ``key``."""
    w = block.get("withheld") or {}
    return w if key in (w.get("quantities") or []) else None


def _pm(block: dict, key: str, scale: float = 1.0, nd: int = 2) -> str:
    v = (block.get("values") or {}).get(key)
    held = _held(block, key)
    if v is None:
        return "withheld" if held else "—"
    u = (block.get("uncertainty") or {}).get(key)
    if held:                              # stated despite QA errors: the text says so
        return f"{v * scale:.{nd}f}" + (f" ± {u['U'] * scale:.{nd}f}" if u else "") + " (forced)"
    return PlusMinus(v * scale, u["U"] * scale if u else None, nd)


def _num_or_held(block: dict, key: str, value: Any) -> Any:
    """A number, or "withheld" for a withheld quantity."""
    return "withheld" if value is None and _held(block, key) else value


def _offset(signal: str, value_si: Any) -> Any:
    """A channel's accuracy offset in its display unit (``2e-06`` kg/s -> ``0.002 g/s``)."""
    from vehval.display import format_delta
    from vehval.errors import SignalError
    from vehval.nomenclature import registry

    if not isinstance(value_si, (int, float)) or isinstance(value_si, bool):
        return value_si
    try:
        unit = registry().spec_of(signal).unit
    except (SignalError, KeyError):
        return value_si                  # not a standard name: the SI number as stored
    return format_delta(float(value_si), unit, signal=signal)


def _metric() -> bool:
    """True when the display system is metric (km, km/h, L/100 km first)."""
    from vehval.display import system

    return system() == "metric"


def _fuel_keys() -> list[str]:
    """The two fuel figures in the display system's reading order."""
    keys = ["fuel_economy_mpg", "fuel_consumption_l_per_100km"]
    return keys[::-1] if _metric() else keys


def _electric(doc: dict) -> dict:
    """The SAE J1634 scopes of a test (``{}`` when it has none)."""
    return (doc.get("j1634") or {}).get("scopes") or {}


def _burns_fuel(doc: dict) -> bool:
    """False for a battery-electric test: J1634 figures and no fuel figure anywhere."""
    if not (doc.get("j1634") or {}).get("scopes"):
        return True
    blocks = [*(doc.get("phases") or []), doc.get("test_total") or {}, *(doc.get("composites") or [])]
    return any((b.get("values") or {}).get(k) is not None or _held(b, k)
               for b in blocks for k in ("fuel_mass_kg", "fuel_economy_mpg"))


def _has_battery(doc: dict) -> bool:
    """True when some scope has a battery net energy (no battery column for a conventional car)."""
    return any((b.get("values") or {}).get("ess_energy_net_j") is not None
               for b in [*(doc.get("phases") or []), doc.get("test_total") or {}])


def _electric_cells(scope: dict | None) -> list[str]:
    """MPGe and the AC consumption of a J1634 scope, each ± U (k = 2) as the headline states
    them (:func:`vehval.results.headline.electric_figures`)."""
    if not scope:
        return ["—", "—"]
    rel = scope.get("U_rel_dc_energy")
    kwh = scope.get("ac_kwh_per_100km" if _metric() else "ac_kwh_per_100mi")

    def pm(v: Any, nd: int) -> str:
        return "—" if v is None else PlusMinus(v, None if rel is None else abs(rel * v), nd)
    return [pm(scope.get("mpge"), 1), pm(kwh, 2)]


def _row(name: str, block: dict, electric: dict | None, battery: bool, scope: str) -> list:
    """One results row; ``electric``: the J1634 scopes of a battery-electric test (None for
    a car that burns fuel); ``battery``: the battery column is shown."""
    v = block.get("values") or {}
    dq = block.get("drive_quality") or {}
    d = v.get("distance_m")
    dist_m, spd_mps = (1e3, KMH_M_PER_S) if _metric() else (MILE_M, MPH_M_PER_S)
    rmsse = dq.get("rmsse_mps") if _metric() else dq.get("rmsse_mph")
    if _metric() and rmsse is not None:
        rmsse = rmsse / KMH_M_PER_S
    row = [name, _num_or_held(block, "distance_m", _r(d / dist_m if d is not None else None, 3)),
           _r(v.get("duration_s"), 1),
           _r((v.get("mean_speed_mps") or 0) / spd_mps, 2) if v.get("mean_speed_mps") else None,
           _r((v.get("max_speed_mps") or 0) / spd_mps, 2) if v.get("max_speed_mps") else None]
    if electric is None:
        row += [_r(as_unit(v["fuel_mass_kg"], "g"), 1) if v.get("fuel_mass_kg") is not None else
                _num_or_held(block, "fuel_mass_kg", None),
                *(_pm(block, k) for k in _fuel_keys()), _pm(block, "co2_g_per_km", nd=1)]
    else:
        row += _electric_cells(electric.get(scope))
    if battery:
        row.append(_r(v["ess_energy_net_j"] / KWH_J, 4) if v.get("ess_energy_net_j") is not None
                   else None)
    return row + [_r(dq.get("iwr_pct"), 2), _r(rmsse, 3), dq.get("violations")]


def _dq_row(name: str, dq: dict | None) -> list:
    dq = dq or {}
    return [name] + [_r(dq.get(k), 2) for k in ("er_pct", "dr_pct", "eer_pct", "ascr_pct",
                                                 "iwr_pct")] + [
        _r(dq.get("rmsse_mph"), 3), dq.get("violations"), _r(dq.get("violation_s"), 1),
        {True: "yes", False: "NO", None: "—"}[dq.get("within_tolerance")]]


def _electric_headline(doc: dict) -> str:
    """The headline of a battery-electric test, as the banner states it."""
    from vehval.results.headline import headline_of

    h = headline_of(doc)
    return "—" if h is None else f"{h.shown}: {h.figure()}"


def results_section(doc: dict) -> Section:
    """The results section (first in the report) from a ``results.json`` document."""
    fuel = doc.get("fuel") or {}
    cond = doc.get("conditions") or {}
    unc = doc.get("uncertainty") or {}
    sec = Section("results", "Test results",
                  intro=("Results per phase, for the whole test and as the regulatory composites, "
                         "each with its expanded uncertainty (k = 2, about 95 %) propagated from the "
                         "declared sensor accuracies. Drive quality per SAE J2951."))
    hl = doc.get("headline") or {}
    blocks = {c.get("name"): c for c in doc.get("composites") or []}
    head = blocks.get(hl.get("name")) if hl.get("kind") == "composite" else None
    hblock = head or doc.get("test_total") or {}
    fuel_car = _burns_fuel(doc)
    sec.facts = [
        ("Cycle", str((doc.get("test") or {}).get("cycle") or "not identified")),
        ("Headline", f"{'whole test' if head is None else head['name']}: "
                     + ", ".join(f"{_pm(hblock, k)} {_LABEL[k]}" for k in _fuel_keys())
                     + (f" (caveat: {'; '.join(head['caveats'])})"
                        if head and head.get("caveats") else "")) if fuel_car else
        ("Headline (SAE J1634)", _electric_headline(doc)),
        ("Fuel", f"{fuel.get('name')} ({fuel.get('density_kg_per_m3')} kg/m³, "
                 f"{as_unit(fuel.get('lhv_j_per_kg') or 0, 'MJ'):.2f} MJ/kg)" if fuel else
         "not declared: no volume-based result"),
        ("Phases from", str(doc.get("phase_source"))),
        ("Conditions", ("cell temperature not measured" if cond.get("cell_temp_c") is None
                        else f"cell {cond['cell_temp_c']:.1f} °C")
                       + f", {cond.get('start') or 'unknown'} start"),
        ("Uncertainty", f"{str(unc.get('method', '')).replace('_', ' ')}, k = 2"
                        + (f", {unc['draws']} draws" if unc.get("draws") else "")),
        ("SOC correction (SAE J1711)", str((doc.get("soc_correction") or {}).get("message", "—"))),
    ]
    if not fuel_car:     # no fuel, no SAE J1711 (it corrects a hybrid's fuel, not a BEV's energy)
        sec.facts = [f for f in sec.facts if f[0] not in ("Fuel", "SOC correction (SAE J1711)")]
    dist, spd = ("km", "km/h") if _metric() else ("mi", "mph")
    fuel_cols = [_HEAD[k] for k in _fuel_keys()]
    electric, battery = (None if fuel_car else _electric(doc)), _has_battery(doc)
    cols = ["phase", f"distance [{dist}]", "duration [s]", f"mean speed [{spd}]",
            f"max speed [{spd}]",
            *(["fuel [g]", *fuel_cols, "CO2 [g/km]"] if fuel_car else
              ["MPGe", f"AC energy [kWh/100 {dist}]"]),
            *(["battery net [kWh]"] if battery else []),
            "IWR [%]", f"RMSSE [{spd}]", "violations"]
    rows = [_row(p["name"], p, electric, battery, p["name"]) for p in doc.get("phases") or []]
    rows.append(_row("whole test", doc.get("test_total") or {}, electric, battery, "test"))
    sec.tables.append(Table("Results per phase", cols, rows, key="results-phases",
                            note="value ± expanded uncertainty U (k = 2)"))
    crow = [[c["name"], *(_pm(c, k) for k in _fuel_keys()),
             _pm(c, "co2_g_per_km", nd=1), c.get("rule"), c.get("substitute") or "",
             "; ".join(x for x in c.get("caveats") or []       # the substitute has its column
                       if x != f"substitute: {c.get('substitute')}") or "none"]
            for c in doc.get("composites") or []]
    if crow and fuel_car:      # J1634 has the phases and the whole test, not the composites
        sec.tables.append(Table("Regulatory composites", ["composite", *fuel_cols,
                                "CO2 [g/km]", "rule", "substitute", "caveats"],
                                crow, key="results-composites",
                                note="a caveat names a departure from the procedure's conditions "
                                     "(clause cited): the figure is not the regulatory one"))
    dq_rows = [_dq_row(p["name"], p.get("drive_quality")) for p in doc.get("phases") or []]
    if any(r[1:] != [None] * 6 + [None, None, "—"] for r in dq_rows):
        sec.tables.append(Table(
            "Drive quality (SAE J2951)", ["phase", "ER [%]", "DR [%]", "EER [%]", "ASCR [%]",
                                          "IWR [%]", "RMSSE [mph]", "violations", "violation [s]",
                                          "within tolerance"], dq_rows, key="results-dq",
            note="tolerances of 40 CFR 1066.425(j): IWR -2.0..+4.0 %, RMSSE <= 0.8 mph; "
                 "violations: outside +-2 mph / +-1 s of the trace"))
    budget = []
    src = head or doc.get("test_total") or {}
    for key in ("fuel_economy_mpg", "co2_g_per_km"):
        u = (src.get("uncertainty") or {}).get(key)
        for c in (u or {}).get("contributors", []):
            budget.append([key, c["parameter"], _r(as_unit(c["share"], "%"), 1),
                           "assumed (class default)" if c.get("assumed") else "declared"])
    if budget:
        sec.tables.append(Table(f"Largest uncertainty contributors ({src.get('name', 'whole test')})",
                                ["result", "input", "share of variance [%]", "accuracy"], budget,
                                key="results-budget"))
    acc = unc.get("accuracy") or {}
    if acc:
        sec.tables.append(Table("Channel accuracies", ["signal", "reading [%]", "offset", "basis"],
                                [[k, a.get("reading_pct"), _offset(k, a.get("offset_si")),
                                  a.get("basis")] for k, a in acc.items()],
                                key="results-accuracy"))
    names = [p["name"] for p in doc.get("phases") or []]
    lead = _fuel_keys()[0]
    what = "Fuel consumption" if lead.startswith("fuel_consumption") else "Fuel economy"
    fe = [(p.get("values") or {}).get(lead) for p in doc.get("phases") or []]
    if any(v is not None for v in fe):
        err = [((p.get("uncertainty") or {}).get(lead) or {}).get("U")
               for p in doc.get("phases") or []]
        fig = layout_figure([{"type": "bar", "x": names, "y": fe, "name": what.lower(),
                              "error_y": {"type": "data", "array": err, "visible": True}}],
                            title=f"{what} per phase (± U, k = 2)", ylabel=_LABEL[lead],
                            height=360)
        sec.figures.append(FigSpec(f"{what} per phase", fig))
    held = [[p.get("name") or "whole test", ", ".join(w.get("quantities") or []),
             ", ".join(w.get("signals") or []), w.get("reason"), w.get("fix"),
             "yes" if w.get("forced") else "no"]
            for p in [*(doc.get("phases") or []), dict(doc.get("test_total") or {}, name="whole test"),
                      *(doc.get("composites") or [])] if (w := p.get("withheld"))]
    if held:
        sec.tables.insert(0, Table("Withheld for QA errors", ["figure", "quantities", "signals",
                                   "reason", "fix", "stated (--force)"], held,
                                   key="results-withheld",
                                   note="a figure computed from a signal QA holds an error on "
                                        "is not stated (docs/results.md)"))
    sec.notes = [f.get("message") for f in doc.get("findings") or []] + list(doc.get("notes") or [])
    return sec
