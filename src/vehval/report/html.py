"""The self-contained HTML report of one test (and, when given, its analysis and validation).

One file, readable offline: plotly.js is embedded once, each figure is a compact JSON block
(typed arrays) drawn by a small script, and every table is plain HTML, all through the
autoescaping template ``report.html.j2`` (:mod:`vehval.report.page`). The file is written
atomically: a failed run leaves no partial report.

Many reports side by side (``vehval batch``) can instead share one local copy of plotly.js:
:func:`write_plotly_asset` writes it once, and ``plotly_js="<relative path>"`` makes a report
load it with ``<script src>`` (still offline: a relative ``file://`` path, no network).
"""

from __future__ import annotations

import datetime as _dt
from pathlib import Path
from typing import Any

from vehval.display import as_unit
from vehval.io.atomic import write_text_atomic
from vehval.report import plots
from vehval.report import sections as S
from vehval.report.figures import DEFAULT_FIG_HEIGHT_PX, FigSpec, prepare_figures
from vehval.report.page import INLINE, plotly_asset_name, plotly_src, render_page, write_plotly_asset
from vehval.report.plugins import control_section, normalise_figure, validation_section
from vehval.report.qa_view import as_dict
from vehval.report.tables import fmt_cell
from vehval.test import Test, TestMeta

__all__ = ["INLINE", "DEFAULT_FIG_HEIGHT_PX", "build_sections", "energy_tables", "plotly_asset_name",
           "render_report", "write_plotly_asset", "write_report"]


def resolve_vehicle(vehicle: Any, test: Test) -> tuple[Any, str | None]:
    """A vehicle model object from an object, a name/path, or the test's ``meta.vehicle``.

    Returns ``(vehicle or None, note)``: the note says why no vehicle is used.
    """
    if vehicle is not None and not isinstance(vehicle, (str, Path)):
        return vehicle, None
    name = vehicle or test.meta.vehicle
    if not name:
        return None, "No vehicle file given: component-map plots are skipped."
    from vehval.vehicle import load_vehicle

    try:
        return load_vehicle(name), None
    except Exception as exc:  # noqa: BLE001 - an unknown vehicle must not stop the report
        return None, f"Vehicle '{name}' could not be loaded ({exc}): component-map plots are skipped."


def engineering_section(test: Test, vehicle: Any, vehicle_note: str | None) -> S.Section:
    """Operating points on maps, histograms, Willans line and the energy flow diagram.

    The energy flow is the architecture's own audit (:mod:`vehval.report.energy_flow`);
    hybrid-only plots (MG1, MG2, battery) appear for a hybrid only.
    """
    from vehval.report import energy_flow as ef

    hybrid = ef.is_hybrid(test, vehicle)
    sec = S.Section("engineering", "Engineering plots",
                    intro="Operating points on the component maps of the vehicle file, distributions, "
                          "Willans line and the energy flow over the test.")
    if vehicle_note:
        sec.notes.append(vehicle_note)
    makers: list[tuple[str, Any]] = []
    if vehicle is not None:
        makers += [("Engine map", lambda: plots.engine_map_figure(test, vehicle))]
    if hybrid:
        makers += [("Motor map", lambda: plots.machine_map_figure(test, vehicle, "mot")),
                   ("Generator map", lambda: plots.machine_map_figure(test, vehicle, "gen")),
                   ("Battery current during braking", lambda: plots.regen_current_histogram(test))]
    makers += [("Engine power distribution", lambda: plots.engine_power_histogram(test)),
               ("Willans line", lambda: plots.willans_figure(test))]
    audit = None
    if hybrid:
        makers.append(("Energy flow", lambda: plots.sankey_figure(plots.energy_flows(test))))
    else:
        try:
            audit = ef.conventional_audit(test)
            makers.append(("Energy flow", lambda: ef.conventional_sankey(audit)))
        except plots.PlotSkipped as exc:
            sec.notes.append(f"Energy flow: skipped ({exc}).")
    for title, make in makers:
        try:
            fig = make()
        except plots.PlotSkipped as exc:
            sec.notes.append(f"{title}: skipped ({exc}).")
            continue
        fig, caption = normalise_figure(fig)  # the plot's own title becomes the caption
        sec.figures.append(FigSpec(caption or title, fig))
    sec.tables += _energy_tables(test, audit)
    return sec


def _energy_tables(test: Test, audit: Any) -> list[S.Table]:
    """The energy table of the engineering section: a conventional car's audit, else the
    energies over the test (a hybrid's, or a car without the audit's signals)."""
    from vehval.report import energy_flow as ef

    if audit is not None:
        return [S.Table("Energy audit over the test (conventional)",
                        ["item", "energy [MJ]", "share of the fuel energy [%]"],
                        ef.audit_rows(audit), key="energies")]
    flows = plots.energy_flows(test)
    return [S.Table("Energies over the test", ["quantity", "energy [MJ]"],
                    [[k, as_unit(v, "MJ")] for k, v in flows.items()], key="energies")] if flows else []


def energy_tables(test: Test, vehicle: Any = None, template: Any = None,
                  results: Any = None) -> list[S.Table]:
    """The tables of the report's energy section without its figures (the workbook's
    ``Energy`` sheet): SAE J1634 energy per phase of a battery-electric car, a conventional
    car's energy audit, a hybrid's energies over the test."""
    from vehval.report import energy_flow as ef
    from vehval.vehicle.definition import architecture_of

    veh, _ = resolve_vehicle(vehicle, test)
    if architecture_of(veh, template) == "battery_electric":
        from vehval.report.energy_bev import bev_energy_section

        return bev_energy_section(test, as_dict(results) if results is not None else None).tables
    audit = None
    if not ef.is_hybrid(test, veh):
        try:
            audit = ef.conventional_audit(test)
        except plots.PlotSkipped:
            audit = None
    return _energy_tables(test, audit)


def _energy_section(test: Test, veh: Any, vnote: str | None, template: Any,
                    results: Any) -> S.Section:
    """The engineering plots, or for a battery-electric car (vehicle file, else template)
    its SAE J1634 energy section (:mod:`vehval.report.energy_bev`)."""
    from vehval.vehicle.definition import architecture_of

    if architecture_of(veh, template) == "battery_electric":
        from vehval.report.energy_bev import bev_energy_section

        return bev_energy_section(test, as_dict(results) if results is not None else None)
    return engineering_section(test, veh, vnote)


def with_dropped(test: Test, raw: Test | None, qa: dict) -> Test:
    """The validated test plus the signals of ``raw`` that selection dropped, aligned.

    ``raw`` is the imported test before QA; its sources are shifted by the offsets the QA
    applied (``alignment[].applied``), so the dropped signals sit on the validated time
    base. The QA sections plot from this view; every other section uses ``test`` only.
    """
    if raw is None:
        return test
    extra = Test([s for s in raw if s.name not in test], TestMeta())
    if not len(extra):
        return test
    for r in S.alignment_results(qa.get("alignment")):
        off = r.get("offset_s")
        if r.get("applied") and isinstance(r.get("source"), str) and isinstance(off, (int, float)):
            extra.shift_source(r["source"], float(off))
    return Test(list(test) + list(extra), test.meta)


def _is_virtual(test: Test, template: Any) -> bool:
    """A virtual test: flagged in its metadata, or its template says so (``vehval synth``)."""
    desc = template if isinstance(template, str) else getattr(template, "description", None)
    return bool(test.meta.synthetic) or str(desc or "").lstrip().upper().startswith("VIRTUAL TEST")


def build_sections(test: Test, qa: Any = None, *, template: Any = None, vehicle: Any = None,
                   control: dict | None = None, validation: dict | None = None,
                   title: str = "", raw: Test | None = None,
                   results: Any = None) -> list[S.Section]:
    """All sections of the report, in order (see :func:`write_report`)."""
    q = as_dict(qa)
    veh, vnote = resolve_vehicle(vehicle, test)
    limits = None
    if veh is not None and hasattr(veh, "signal_limits"):
        try:
            limits = veh.signal_limits()
        except Exception:  # noqa: BLE001 - limits only draw the band
            limits = None
    qt = with_dropped(test, raw, q)
    secs = [S.summary_section(test, q, template, title), S.import_section(test),
            S.alignment_section(qt, q), S.findings_section(qt, q, limits),
            S.table2_section(qt, q), S.calculations_section(q), S.table3_section(qt, q),
            S.selection_section(q), S.signals_section(test),
            _energy_section(test, veh, vnote, template, results)]
    if results is not None:
        from vehval.report.results_view import results_section
        secs.insert(0, results_section(as_dict(results)))
    if control is not None:
        from vehval.report.energy_flow import is_hybrid
        secs.append(control_section(as_dict(control), hybrid=is_hybrid(test, veh)))
    if validation is not None:
        secs.append(validation_section(as_dict(validation)))
    return secs


def render_report(test: Test, qa: Any = None, *, template: Any = None, vehicle: Any = None,
                  control: dict | None = None, validation: dict | None = None,
                  title: str | None = None, raw: Test | None = None,
                  plotly_js: str = INLINE, results: Any = None) -> str:
    """The report as one HTML string (see :func:`write_report`)."""
    from vehval import __version__

    plotly_src(plotly_js)  # a URL or an absolute path is refused before any work
    m = test.meta
    title = title or f"Test report: {m.test_id or 'unnamed test'}"
    secs = build_sections(test, qa, template=template, vehicle=vehicle, control=control,
                          validation=validation, title=title, raw=raw, results=results)
    n = 0
    for sec in secs:
        n = prepare_figures(sec.figures, start=n)
        seen: set[str] = set()
        for t in sec.tables:
            base, k = t.key, 2
            while t.key in seen:
                t.key = f"{base}-{k}"
                k += 1
            seen.add(t.key)
    subtitle = " · ".join(x for x in (m.vehicle, m.cycle, m.test_id) if x) or "vehicle test"
    return render_page(
        "report.html.j2", title=title, css="report.css", plotly=True, plotly_js=plotly_js,
        figures=[f for sec in secs for f in sec.figures], subtitle=subtitle,
        generated=_dt.datetime.now().strftime("%Y-%m-%d %H:%M"), version=__version__,
        synthetic=_is_virtual(test, template), sections=secs, fmt=fmt_cell,
        headline=S.headline_banner(as_dict(results) if results is not None else None))


def write_report(path: str | Path, *, test: Test, qa: Any = None, template: Any = None,
                 vehicle: Any = None, control: dict | None = None, validation: dict | None = None,
                 title: str | None = None, raw: Test | None = None,
                 plotly_js: str = INLINE, results: Any = None) -> Path:
    """Write one self-contained HTML report of a test.

    Parameters
    ----------
    path : str or Path
        Output file (written atomically).
    test : Test
        The validated test (after alignment, calculation and selection).
    qa : dict or QAResult or None
        QA result (``findings.json`` structure).
    template : Template or str or None
        Import template (shown in the summary).
    vehicle : Vehicle or str or None
        Vehicle model or name/path; defaults to ``test.meta.vehicle`` when loadable.
    control : dict or AnalysisResult or None
        ``control.json`` of ``vehval analyze`` (its ``report`` entry plus figures drawn from
        the analysis), or any section payload (see :mod:`vehval.report.plugins`).
    validation : dict or None
        ``validation.json`` of ``vehval validate``: ``{"tables": [{"title", "columns",
        "rows"}], "figures": [plotly figure or {"title", "figure"}], "notes": [...]}``.
    title : str, optional
        Report title.
    raw : Test, optional
        The imported test before QA: signals that selection dropped are plotted in the QA
        sections (shifted by the applied alignment offsets).
    plotly_js : str
        ``"inline"`` (default) embeds plotly.js (~4.8 MB): the file stands alone. Otherwise
        a relative path (URL syntax, ``/`` separators) from the report to a local copy
        written by :func:`write_plotly_asset`, e.g. ``"../../assets/plotly-3.1.0.min.js"``:
        the report is then ~4.8 MB smaller but needs that file beside it. URLs and
        absolute paths are refused (:class:`ConfigError`): the report must stay offline.
    results : dict or TestResults, optional
        ``results.json`` of the results stage: shown first (results per phase and composite
        with their uncertainty, drive quality), before the QA sections.

    Returns
    -------
    Path
        The written file.
    """
    html = render_report(test, qa, template=template, vehicle=vehicle, control=control,
                         validation=validation, title=title, raw=raw, plotly_js=plotly_js,
                         results=results)
    write_text_atomic(path, html)
    return Path(path)
