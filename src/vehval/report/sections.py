"""Sections of the test report: tables and figures built from a Test and its QA result.

Each builder returns a :class:`Section`; the HTML template only lays them out. A section
whose input is missing says so in a note instead of disappearing silently.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from vehval.display import as_unit
from vehval.integrals import integral
from vehval.nomenclature import registry
from vehval.report import qa_view as qv
from vehval.report.figures import PALETTE, FigSpec, scatter_fit_figure, time_traces_figure
from vehval.report.tables import Table, rows_table, to_tables
from vehval.test import Test

MAX_FINDING_PLOTS = 40
MAX_PAIR_PLOTS = 40
PANELS_PER_FIGURE = 8


@dataclass
class Section:
    """One section of the report."""

    key: str
    title: str
    intro: str = ""
    tables: list[Table] = field(default_factory=list)
    figures: list[FigSpec] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    facts: list[tuple[str, str]] = field(default_factory=list)


def _parse(name: str):
    try:
        return registry().parse(name)
    except Exception:  # noqa: BLE001 - names outside the registry are shown as they are
        return None


def label(test: Test, name: str) -> str:
    """``name [unit]`` for axis titles."""
    unit = test[name].unit if name in test else ""
    return f"{name} [{unit}]" if unit and unit != "dimensionless" else name


def display_label(test: Test, name: str) -> tuple[str, float]:
    """``name [display unit]`` for time-trace axes, and the factor SI -> display unit
    (the one display-unit table, :mod:`vehval.display`; offsets are zero for every unit
    the nomenclature uses)."""
    if name not in test:
        return name, 1.0
    unit = _display_unit(test[name])
    return (f"{name} [{unit.label}]" if unit.label else name), unit.factor


def _display_unit(sig: Any) -> Any:
    """The display unit of a signal (kJ or MJ from its largest magnitude)."""
    from vehval.display import unit_for

    finite = sig.values[np.isfinite(sig.values)]
    return unit_for(sig.unit, signal=sig.name,
                    magnitude=float(np.max(np.abs(finite))) if finite.size else None)


def _trace(test: Test, name: str, i: int, **kw) -> dict:
    """A time trace of ``name`` in its display unit."""
    sig = test[name]
    k = display_label(test, name)[1]
    return {"name": name, "t": sig.time, "y": sig.values * k if k != 1.0 else sig.values,
            "color": PALETTE[i % len(PALETTE)], **kw}


def duration_and_distance(test: Test) -> tuple[float, float | None]:
    """Test duration [s] and distance [m] (from veh_dist, else the integral of veh_spd)."""
    t0, t1 = test.span()
    dist = None
    for base in ("veh_dist", "veh_spd"):
        s = test.best(base, ("test",))
        if s is None:
            continue
        ok = np.isfinite(s.values)
        if base == "veh_dist" and ok.any():
            dist = float(np.nanmax(s.values) - np.nanmin(s.values))
        elif ok.sum() > 1:
            dist = integral(s.time, s.values)
        if dist is not None:
            break
    return t1 - t0, dist


# ----------------------------------------------------------------------------- summary
def summary_section(test: Test, qa: dict, template: Any, title: str) -> Section:
    m = test.meta
    dur, dist = duration_and_distance(test)
    tmpl = template if isinstance(template, (str, type(None))) else getattr(template, "description", None) or type(template).__name__
    facts = [("Test", m.test_id or "—"), ("Vehicle", m.vehicle or "—"), ("Cycle", m.cycle or "—"),
             ("Duration", f"{dur:,.1f} s ({dur / 60:.1f} min)"),
             ("Distance", f"{as_unit(dist, 'km'):,.3f} km ({as_unit(dist, 'mi'):,.3f} mi)" if dist is not None else "—"),
             ("Template", str(tmpl or m.template or "—")),
             ("Signals", f"{len(test)} from sources {', '.join(s or '—' for s in test.sources)}"),
             ("Files", ", ".join(m.files) or "—")]
    findings = qv.as_rows(qa.get("findings"))
    if findings:
        counts: dict[str, int] = {}
        for r in findings:
            counts[qv.severity(r)] = counts.get(qv.severity(r), 0) + 1
        rank = {"error": 0, "warning": 1, "info": 2}
        facts.append(("QA findings", ", ".join(f"{v} {k}" for k, v in
                                               sorted(counts.items(), key=lambda kv: (rank.get(kv[0], 3), kv[0])))))
    sec = Section("summary", "Test summary", facts=facts)
    if qa.get("summary") is not None:
        sec.tables += to_tables(qa["summary"], "QA summary", key="qa-summary")
    if m.constants:
        sec.tables.append(Table("Template constants", ["constant", "value"],
                                [[k, _constant(k, v)] for k, v in m.constants.items()],
                                key="constants", note="SI in the template; shown in display units"))
    if m.notes:
        sec.notes += [str(n) for n in m.notes]
    sec.notes += [f"QA: {n}" for n in qa.get("notes") or []]
    if not qa:
        sec.notes.append("No QA result was given: the QA sections are empty.")
    return sec


def _constant(key: str, value: Any) -> Any:
    """A template constant in its display unit (the key names the SI unit)."""
    from vehval.display import format_keyed

    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return value
    return format_keyed(key, float(value))


# ----------------------------------------------------------------------------- import
def import_section(test: Test) -> Section:
    """The import mapping: each raw channel with the unit the file or template declared, its
    standard name, the SI unit stored and the unit the report shows it in; deleted channels."""
    rows = [{"standard name": s.name, "unit (SI)": s.unit,
             "shown as": _display_unit(s).label or "-", "source": s.source,
             "raw name": s.raw_name, "raw unit": s.raw_unit, "file": s.file,
             "samples": int(s.time.size), "period [s]": s.sample_period,
             "resample": s.resample, "notes": "; ".join(s.notes)}
            for s in test]
    sec = Section("import", "Import mapping",
                  intro="Raw channel name and the unit the file or template declared (raw "
                        "unit), mapped to the standard name and the SI unit stored; the "
                        "report shows each channel in its display unit (shown as).")
    sec.tables.append(rows_table("Channel mapping", rows, key="mapping"))
    deleted = [d if isinstance(d, dict) else {"channel": str(d)} for d in test.meta.deleted]
    sec.tables.append(rows_table("Deleted channels", deleted, key="deleted",
                                 columns=None if deleted else ["channel", "reason"]))
    return sec


# ----------------------------------------------------------------------------- alignment
def alignment_results(alignment: Any) -> list[dict]:
    """Per-source alignment results (``source``, ``reference``, ``offset_s``, ``applied``,
    ``pairs``...) from a list, ``{results|sources: [...]}``, ``{source: {...}}`` or
    ``{offsets_s: {source: offset}}``."""
    if isinstance(alignment, list):
        return [r for r in alignment if isinstance(r, dict)]
    if not isinstance(alignment, dict):
        return []
    for k in ("results", "sources", "per_source"):
        if isinstance(alignment.get(k), (list, dict)):
            return alignment_results(alignment[k]) if isinstance(alignment[k], list) else \
                [{"source": s, **v} for s, v in alignment[k].items() if isinstance(v, dict)]
    for k in ("offsets_s", "offsets", "applied_offsets_s"):
        v = alignment.get(k)
        if isinstance(v, dict):
            return [{"source": s, "offset_s": o, "applied": True,
                     "reference": alignment.get("reference")} for s, o in v.items()]
    if alignment and all(isinstance(v, dict) for v in alignment.values()):
        return [{"source": s, **v} for s, v in alignment.items()]
    return []


def calc_sources(qa: dict, name: str, test: Test, _seen: set | None = None) -> set[str]:
    """Acquisition sources a ``_calc`` signal was computed from (through other ``_calc``).

    Read from the QA calculation log (``calculations.computed[name].inputs``); a signal
    whose inputs are unknown counts as depending on every source of the test.
    """
    seen = _seen if _seen is not None else set()
    if name in seen:
        return set()
    seen.add(name)
    calc = qa.get("calculations")
    entry = (calc.get("computed") or {}).get(name) if isinstance(calc, dict) else None
    inputs = entry.get("inputs") if isinstance(entry, dict) else None
    if not isinstance(inputs, dict):
        return set(test.sources)
    out: set[str] = set()
    for dep in inputs.values():
        for d in dep if isinstance(dep, list) else [dep]:
            if not isinstance(d, str):
                continue
            if d.endswith("_calc"):
                out |= calc_sources(qa, d, test, seen)
            elif d in test:
                out.add(test[d].source)
    return out


def alignment_section(test: Test, qa: dict) -> Section:
    al = qa.get("alignment")
    sec = Section("alignment", "Time alignment",
                  intro="Offsets estimated between acquisition systems and removed from the data. "
                        "Each plot overlays a quantity seen by two sources before and after "
                        "the shift.")
    results = alignment_results(al)
    if not results and test.meta.offsets_s:
        results = [{"source": s, "offset_s": o, "applied": True} for s, o in test.meta.offsets_s.items()]
    if not results:
        sec.notes.append("No alignment result (a single acquisition system needs none)."
                         if al is not None else "No alignment result.")
        if isinstance(al, dict) and al:
            sec.tables += to_tables(al, "Alignment", key="alignment")
        return sec
    main = [{k: v for k, v in r.items() if k != "pairs"} for r in results]
    sec.tables.append(rows_table("Alignment by source", main, key="alignment"))
    pairs = [{"source": r.get("source"), **p} for r in results for p in qv.as_rows(r.get("pairs"))]
    if pairs:
        sec.tables.append(rows_table("Alignment pairs", pairs, key="alignment-pairs"))
    if isinstance(al, dict):
        extra = {k: v for k, v in al.items() if not isinstance(v, (list, dict))}
        if extra:
            sec.tables += to_tables(extra, "Alignment settings", key="alignment-settings")
    prefer = ("veh_spd", "eng_spd_out", "whl_spd", "mot_spd_out", "ess_curr", "fuel_rate")
    for r in results:
        src, off = r.get("source"), qv.first_number(r, ("offset_s", "offset"))
        if not isinstance(src, str) or off is None:
            continue
        applied = bool(r.get("applied", True))
        cands = sorted(qv.as_rows(r.get("pairs")), key=lambda p: -(qv.first_number(p, ("confidence",)) or 0))
        pair = next(((p["ref"], p["other"]) for p in cands
                     if p.get("ref") in test and p.get("other") in test), None)
        if pair is None:
            sigs = [s for s in test if s.source == src and _parse(s.name) and _parse(s.name).origin == "test"]
            sigs.sort(key=lambda s: prefer.index(s.base) if s.base in prefer else len(prefer))
            for s in sigs:
                # the same quantity from another source, else calculated (from other signals)
                refs = ([x for x in test.by_base(s.base, "test") if x.source != src]
                        or [x for x in test.by_base(s.base, "calc")
                            if src not in calc_sources(qa, x.name, test)])
                if refs:
                    pair = (refs[0].name, s.name)
                    break
        if pair is None:
            sec.notes.append(f"Source '{src}' offset {off:+.3f} s: no pair of signals to plot.")
            continue
        ref, other = test[pair[0]], test[pair[1]]
        if applied:
            before_t, after_t = other.time - off, other.time
            after_name = f"{other.name} after (shifted {off:+.3f} s)"
        else:
            before_t, after_t = other.time, other.time + off
            after_name = f"{other.name} with the estimated {off:+.3f} s (not applied)"
        (ref_label, kr), (oth_label, ko) = display_label(test, ref.name), display_label(test, other.name)
        panels: list[dict[str, Any]] = [{"ylabel": ref_label,
                   "traces": [{"name": f"{ref.name} (reference)", "t": ref.time, "y": ref.values * kr, "color": PALETTE[0]}]},
                  {"ylabel": oth_label,
                   "traces": [{"name": f"{other.name} before", "t": before_t, "y": other.values * ko,
                               "color": PALETTE[1], "dash": "dot"},
                              {"name": after_name, "t": after_t, "y": other.values * ko, "color": PALETTE[2]}]}]
        if ref.unit == other.unit and kr == ko:  # same quantity: overlay all three in one panel
            panels = [{"ylabel": ref_label, "traces": panels[0]["traces"] + panels[1]["traces"]}]
        fig = time_traces_figure(panels, row_height=300 if len(panels) == 1 else 200)
        sec.figures.append(FigSpec(f"Source '{src}': {other.name} against {ref.name}, "
                                   f"offset {off:+.3f} s" + ("" if applied else " (not applied)"),
                                   fig, linked=True))
    return sec


# ----------------------------------------------------------------------------- QA1
#: Finding numbers that are values of the signal, and differences of it (display units).
_VALUE_KEYS = ("value", "limit_min", "limit_max")
_DELTA_KEYS = ("deviation", "threshold", "noise_sigma")


def _finding_row(row: dict) -> dict:
    """A finding with its numbers as a person reads them: ``value = -0.001 g/s;
    fraction = 0.0144 %`` instead of ``value = -1e-06; fraction = 1.442e-04`` (SI)."""
    from vehval.display import format_delta, format_value, number

    nums, sig = row.get("numbers"), row.get("signal")
    if not isinstance(nums, dict) or not isinstance(sig, str):
        return row
    spec = _parse(sig)
    si = registry()[spec.base].unit if spec is not None else None
    parts = []
    for k, v in nums.items():
        if not isinstance(v, (int, float)) or isinstance(v, bool):
            parts.append(f"{k} = {'n/a' if v is None else v}")
        elif si is not None and k in _VALUE_KEYS:
            parts.append(f"{k} = {format_value(float(v), si, signal=sig)}")
        elif si is not None and k in _DELTA_KEYS:
            parts.append(f"{k} = {format_delta(float(v), si, signal=sig)}")
        elif k.endswith("fraction"):
            parts.append(f"{k} = {number(as_unit(float(v), '%'))} %")
        elif k.endswith("_s"):
            parts.append(f"{k} = {number(float(v))} s")
        else:
            parts.append(f"{k} = {number(float(v))}")
    return {**row, "numbers": "; ".join(parts)}


def findings_section(test: Test, qa: dict, limits: dict | None = None) -> Section:
    rows = qv.as_rows(qa.get("findings"))
    sec = Section("qa1", "QA findings",
                  intro="Every finding of the QA (alignment, level 1: range, gaps, flat/stuck, spikes, "
                        "rate, sign; levels 2 and 3: disagreement between sources or with the "
                        "calculation). Plots show each signal flagged at level 0/1 with its "
                        "plausible range (green band) and the flagged spans (red).")
    table = rows_table("QA1 findings", [_finding_row(r) for r in rows], key="findings")
    table.highlight = {i: f"sev-{qv.severity(r)}" for i, r in enumerate(rows)}
    sec.tables.append(table)
    if qa.get("checks"):
        sec.tables += to_tables(qa["checks"], "Checks run", key="checks")
    if not rows:
        sec.notes.append("No findings." if "findings" in qa else "No QA result.")
        return sec
    by_signal: dict[str, list[dict]] = {}
    for r in rows:
        if (qv.first_number(r, ("level",)) or 1) > 1:
            continue  # levels 2 and 3 are plotted in their own sections
        name = qv.finding_signal(r, test.names)
        if name:
            by_signal.setdefault(name, []).append(r)
    missing = [n for n in by_signal if n not in test]
    if missing:
        sec.notes.append("Flagged signals without data in the report (dropped by the selection; "
                         "give the imported test to plot them): " + ", ".join(missing))
    sel = qa.get("selection")
    dropped = sel["dropped"] if isinstance(sel, dict) and isinstance(sel.get("dropped"), dict) else {}
    plotted = [n for n in by_signal if n in test][:MAX_FINDING_PLOTS]
    if len(by_signal) - len(missing) > len(plotted):
        sec.notes.append(f"Plots limited to the first {MAX_FINDING_PLOTS} flagged signals.")
    for name in plotted:
        fr = by_signal[name]
        spans = [sp for r in fr for sp in qv.finding_spans(r)]
        band: tuple[float | None, ...] | None = next((qv.finding_range(r) for r in fr if qv.finding_range(r)), None)
        spec = _parse(name)
        if band is None and spec is not None:
            band = (limits or {}).get(spec.base) or registry()[spec.base].range
        checks = sorted({str(r.get("kind") or r.get("check") or r.get("test") or "?") for r in fr})
        ylab, k = display_label(test, name)
        if band is not None and k != 1.0:
            band = tuple(None if b is None else b * k for b in band)
        fig = time_traces_figure([{"ylabel": ylab, "traces": [_trace(test, name, 0)],
                                   "band": band, "spans": spans}], row_height=240)
        sec.figures.append(FigSpec(f"{name}: {', '.join(checks)}" + (" (dropped by the selection)" if name in dropped else ""),
                                   fig, linked=True))
    return sec


# ----------------------------------------------------------------------------- QA2 / QA3
def _pair_data(test: Test, a: str, b: str) -> tuple[np.ndarray, np.ndarray]:
    sa, sb = test[a], test[b]
    grid = sa.time if sa.time.size <= sb.time.size else sb.time
    return sa.at(grid), sb.at(grid)


#: Columns of Tables 2 and 3 in the row's unit (differences: converted by the factor only).
_PAIR_UNIT_KEYS = ("mean_abs_diff", "max_abs_diff", "test_range", "offset", "mean_diff",
                   "mean_ref", "u_ref", "u_other", "u_measured", "u_calculated")
#: Columns of Tables 2 and 3 that are fractions (shown in %).
_PAIR_FRACTION_KEYS = ("rel_diff", "mean_rel_diff")


def _pair_rows(rows: list[dict]) -> list[dict]:
    """Rows of Tables 2 and 3 in display units: differences in lbf or rpm instead of N or
    rad/s, relative differences in % (``rel_diff`` 0.0195 -> ``rel_diff [%]`` 1.95)."""
    from vehval.display import unit_for

    out = []
    for r in rows:
        si = r.get("unit")
        unit = None
        if isinstance(si, str):
            sig = next((r[k] for k in ("measured", "ref", "reference", "other")
                        if isinstance(r.get(k), str)), None)
            mag = next((abs(float(r[k])) for k in ("test_range", "mean_abs_diff")
                        if isinstance(r.get(k), (int, float))), None)
            unit = unit_for(si, signal=sig, magnitude=mag)
        row: dict = {}
        for k, v in r.items():
            if k in _PAIR_FRACTION_KEYS:
                row[f"{k} [%]"] = None if v is None else as_unit(float(v), "%")
            elif unit is not None and k in _PAIR_UNIT_KEYS and isinstance(v, (int, float)):
                row[k] = float(v) * unit.factor
            elif unit is not None and k == "unit":
                row[k] = unit.label
            elif k == "accuracy" and isinstance(v, dict):
                # the sensors' accuracies in one cell; the full record is in findings.json
                row["accuracy assumed"] = ", ".join(
                    n for n, a in v.items() if isinstance(a, dict) and a.get("assumed")) or "-"
            else:
                row[k] = v
        out.append(row)
    return out


def table2_section(test: Test, qa: dict) -> Section:
    rows = qv.as_rows(qa.get("table2"))
    sec = Section("qa2", "QA level 2 (Table 2): one quantity from several sources",
                  intro="Each quantity measured by more than one system: coefficient of determination, "
                        "differences and linear fit; the scatter shows the 1:1 line and the fit.")
    sec.tables.append(rows_table("Table 2", _pair_rows(rows), key="table2"))
    if not rows:
        sec.notes.append("No quantity is measured by two sources." if "table2" in qa else "No QA result.")
    for r in rows[:MAX_PAIR_PLOTS]:
        names = qv.signal_names_in(r, test.names)
        if len(names) < 2:
            continue
        a, b = names[:2]
        x, y = _pair_data(test, a, b)
        slope, icpt, r2 = qv.fit_of(r)
        (xlab, kx), (ylab, ky) = display_label(test, a), display_label(test, b)
        # the fit in display units: y' = (slope ky / kx) x' + intercept ky
        fig = scatter_fit_figure(x * kx, y * ky, xlabel=xlab, ylabel=ylab,
                                 slope=None if slope is None else slope * ky / kx,
                                 intercept=None if icpt is None else icpt * ky, r2=r2)
        sec.figures.append(FigSpec(f"{b} vs {a}", fig))
    return sec


def table3_section(test: Test, qa: dict) -> Section:
    rows = qv.as_rows(qa.get("table3"))
    sec = Section("qa3", "QA level 3 (Table 3): measured vs calculated",
                  intro="Measured signals against the same quantity calculated from the powertrain "
                        "equations out of other measured signals.")
    sec.tables.append(rows_table("Table 3", _pair_rows(rows), key="table3"))
    if not rows:
        sec.notes.append("No measured signal has a calculated counterpart." if "table3" in qa else "No QA result.")
    for r in rows[:MAX_PAIR_PLOTS]:
        names = qv.signal_names_in(r, test.names)
        meas = [n for n in names if _parse(n) and _parse(n).origin == "test"]
        calc = [n for n in names if _parse(n) and _parse(n).origin == "calc"]
        if not meas or not calc:
            continue
        fig = time_traces_figure([{"ylabel": display_label(test, meas[0])[0],
                                   "traces": [_trace(test, meas[0], 0), _trace(test, calc[0], 1)]}],
                                 row_height=260)
        _, _, r2 = qv.fit_of(r)
        sec.figures.append(FigSpec(f"{meas[0]} vs {calc[0]}" + (f" (R² = {r2:.4f})" if r2 is not None else ""),
                                   fig, linked=True))
    return sec


def calculations_section(qa: dict) -> Section:
    sec = Section("calc", "Calculations", intro="Signals calculated from the powertrain equations.")
    calc = qa.get("calculations")
    if isinstance(calc, dict) and isinstance(calc.get("parameters"), dict):
        # parameter values in display units (fuel_lhv_j_per_kg 42.8 MJ/kg, not 4.280e+07)
        calc = {**calc, "parameters": {
            k: ({**p, "value": _constant(k, p["value"])} if isinstance(p, dict) and "value" in p
                else p) for k, p in calc["parameters"].items()}}
    sec.tables += to_tables(calc, "Calculations", key="calculations") if calc is not None else []
    if calc is None:
        sec.notes.append("No calculation log.")
    return sec


def selection_section(qa: dict) -> Section:
    sec = Section("selection", "Signal selection",
                  intro="The trusted source kept for each quantity, and the reason for every drop.")
    sel = qa.get("selection")
    sec.tables += to_tables(sel, "Selection", key="selection") if sel is not None else []
    if sel is None:
        sec.notes.append("No selection result.")
    return sec


# ----------------------------------------------------------------------------- signals
def signals_section(test: Test) -> Section:
    """All signals, by component category, one panel per base name (test/calc/simu overlaid)."""
    reg = registry()
    groups: dict[str, dict[str, list[str]]] = {}
    for s in test:
        p = _parse(s.name)
        cat = reg[p.base].category if p else "other"
        base = p.base if p else s.name
        groups.setdefault(cat, {}).setdefault(base, []).append(s.name)
    order = list(reg.categories) + ["other"]
    sec = Section("signals", "Time traces",
                  intro="Every signal of the validated test, by component. Traces are decimated for "
                        "display (minimum and maximum of each of 1,200 time buckets: no extreme is "
                        "lost). Zoom one plot and every time axis follows.")
    for cat in sorted(groups, key=lambda c: order.index(c) if c in order else len(order)):
        bases = list(groups[cat].items())
        for k in range(0, len(bases), PANELS_PER_FIGURE):
            chunk = bases[k:k + PANELS_PER_FIGURE]
            panels = []
            for base, names in chunk:
                unit_suffix = display_label(test, names[0])[0][len(names[0]):]  # " [kW]" or ""
                panels.append({"ylabel": f"{base}{unit_suffix}",
                               "traces": [_trace(test, n, i) for i, n in enumerate(sorted(names))]})
            part = f" ({k // PANELS_PER_FIGURE + 1})" if len(bases) > PANELS_PER_FIGURE else ""
            sec.figures.append(FigSpec(f"{cat.capitalize()}{part}", time_traces_figure(panels),
                                       linked=True))
    return sec


def headline_banner(results: dict | None) -> dict | None:
    """What the report shows first (:meth:`vehval.results.headline.Headline.banner`): the
    headline figure of ``results.json`` with U and every caveat, or why it is withheld
    (signals, reason, fix), or that it is stated despite QA errors (``--force``).

    Returns ``{"kind": "headline" | "withheld" | "forced", "title", "lines"}`` or None when
    there are no results.
    """
    from vehval.results.headline import headline_of

    h = headline_of(results)
    return None if h is None else h.banner()
