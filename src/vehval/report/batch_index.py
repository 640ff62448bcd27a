"""The batch index page: every test of a run linked to its report, variability tables and
two fuel-economy plots.

:mod:`vehval.batch.index` reads the catalog and hands plain rows to :func:`render_index_page`.
Links are relative (``tests/<id>/report.html``) so the output directory can be moved or
served as is; plotly.js is embedded once, so the page works offline.
"""

from __future__ import annotations

import json
from typing import Any, Sequence
from urllib.parse import quote

from vehval.display import as_unit
from vehval.figures import layout_figure
from vehval.report.document import Block, cell, figure, h1, h2, para, render_document, table
from vehval.report.figures import FigSpec

#: Result columns of the tests table: (catalog column, header, scale, format); distance and
#: fuel mass are shown in the display system's unit (:func:`_columns`).
COLUMNS = [("headline_mpg", "headline [mpg]", 1.0, "{:.2f}"),
           ("headline_mpge", "headline [MPGe]", 1.0, "{:.1f}"),
           ("distance_m", "distance [km]", 1e-3, "{:.2f}"),
           ("fuel_mass_kg", "fuel [kg]", 1.0, "{:.3f}"),
           ("fuel_economy_mpg", "whole test [mpg]", 1.0, "{:.2f}"),
           ("soc_change", "ΔSOC [%]", 100.0, "{:+.2f}"),
           ("ess_energy_j", "battery energy [kWh]", 1 / 3.6e6, "{:+.3f}"),
           ("eng_energy_j", "engine energy [kWh]", 1 / 3.6e6, "{:.3f}"),
           ("fuel_en", "En (fuel, model)", 1.0, "{:+.2f}")]


def _columns(tests: Sequence[dict] = ()) -> list[tuple[str, str, float, str]]:
    """:data:`COLUMNS` with distance and fuel mass in the display system (mi and lb for us);
    the SAE J1634 headline (MPGe) only when a test of ``tests`` has one (battery-electric)."""
    from vehval.display import unit_for

    out = []
    for col, head, scale, pattern in COLUMNS:
        if col == "headline_mpge" and all(t.get(col) is None for t in tests):
            continue
        if col in ("distance_m", "fuel_mass_kg"):
            unit = unit_for("m" if col == "distance_m" else "kg")
            head, scale = f"{head.split(' [')[0]} [{unit.label}]", unit.factor
        out.append((col, head, scale, pattern))
    return out


#: Statuses with a style of their own.
_STATUS = ("ok", "failed", "skipped")


def _fmt(v: Any, scale: float, pattern: str) -> str:
    if v is None:
        return ""
    try:
        return pattern.format(float(v) * scale)
    except (TypeError, ValueError):
        return str(v)


def _num(v: Any, scale: float = 1.0, pattern: str = "{:.5g}") -> dict:
    return cell(_fmt(v, scale, pattern), "num")


def _headline_scope(r: dict) -> str:
    """The scope the headline figure is of: a battery-electric test's J1634 scope (``test``)."""
    if r.get("headline_mpg") is None and r.get("headline_mpge") is not None:
        return r.get("headline_j1634_scope") or r.get("headline_name") or ""
    return r.get("headline_name") or ""


def _tests_table(tests: Sequence[dict]) -> Block:
    rows = []
    cols = _columns(tests)
    for r in tests:
        tid = str(r["test_id"])
        link = "tests/" + quote(tid, safe="") + "/report.html" \
            if "report.html" in (r["outputs"] or []) else None
        sev = json.loads(r["n_findings_by_severity"]) if r["n_findings_by_severity"] else {}
        status = str(r["status"])
        held = r.get("withheld_reason")
        # a reason with nothing withheld: no headline (an idle record), not a QA error
        mark = cell("withheld", "err") if r.get("withheld_count") else cell("no headline")
        vals = [mark if c == "headline_mpg" and held else _num(r.get(c), s, p)
                for c, _, s, p in cols]
        rows.append([cell(tid, href=link), cell(status, status if status in _STATUS else ""),
                     r["vehicle"] or "", r["cycle"] or "", _headline_scope(r),
                     ", ".join(f"{v} {k}" for k, v in sorted(sev.items()))]
                    + vals + [cell(r["error"] or held or "", "err")])
    return table(["test", "status", "vehicle", "cycle", "headline", "findings"]
                 + [c[1] for c in cols] + ["error / withheld because"], rows)


def _variability(var: Sequence[dict]) -> list[Block]:
    out = [h2("Test-to-test variability (latest result of every test)")]
    if not var:
        return out + [para("No successful test yet.")]
    from vehval.display import keyed_metric

    rows = []
    for v in var:
        # the catalog is SI (fuel_energy_j 5.4e+07): shown in display units (53.9 MJ)
        name, unit = keyed_metric(v["metric"], magnitude=v["mean"])
        f, off = (unit.factor, unit.offset) if unit is not None else (1.0, 0.0)

        def shown(x: Any, factor: float = f, offset: float = off) -> dict:
            return _num(None if x is None else float(x) * factor + offset)
        rows.append([v["vehicle"], v["cycle"], v.get("start", ""), v.get("temperature_band", ""),
                     v.get("ac", ""), name, unit.label if unit is not None else "",
                     _num(v["n"], pattern="{:.0f}"), shown(v["mean"]), shown(v["std"], f, 0.0),
                     cell("" if v["cv"] is None else f"{as_unit(v['cv'], '%'):.2f}", "num"),
                     shown(v["min"]), shown(v["max"])])
    return out + [table(["vehicle", "cycle", "start", "cell temperature", "A/C", "metric", "unit",
                         "n", "mean", "std", "CV [%]", "min", "max"], rows)]


def _results(var: Sequence[dict]) -> list[Block]:
    out = [h2("Fuel economy by cycle and test conditions (latest result of every test)")]
    if not var:
        return out + [para("No per-phase results (no fuel declared, or no successful test).")]
    rows = [[str(v.get(k, "")) for k in ("vehicle", "cycle", "temperature_band", "start", "ac")]
            + [f"{v['scope'] if v['kind'] != 'test' else 'whole test'} ({v['kind']})",
               _num(v["n"], pattern="{:.0f}"), _num(v["mean"], pattern="{:.2f}"),
               _num(v["std"], pattern="{:.2f}"),
               cell("" if v["cv"] is None else f"{as_unit(v['cv'], '%'):.2f}", "num"),
               _num(v["mean_u"], pattern="{:.2f}")] for v in var]
    return out + [table(["vehicle", "cycle", "cell temperature", "start", "A/C", "result", "n",
                         "mean [mpg]", "std [mpg]", "CV [%]", "mean U (k = 2) [mpg]"], rows)]


def _phase_figure(phase_rows: Sequence[tuple]) -> list[Block]:
    """Fuel economy per test and per phase (error bars: U, k = 2)."""
    if not phase_rows:
        return []
    by_scope: dict[str, list[tuple]] = {}
    for tid, scope, kind, fe, u in phase_rows:
        by_scope.setdefault("whole test" if kind == "test" else scope, []).append((tid, fe, u))
    data = [{"type": "scatter", "x": [p[0] for p in pts], "y": [p[1] for p in pts],
             "mode": "markers", "name": scope,
             "error_y": {"type": "data", "visible": True, "array": [p[2] or 0.0 for p in pts]},
             "marker": {"size": 10 if scope == "whole test" else 7}}
            for scope, pts in by_scope.items()]
    fig = layout_figure(data, xlabel="test", ylabel="fuel economy [mpg]", height=450,
                        margin={"l": 60, "r": 20, "t": 30, "b": 80})
    return [h2("Fuel economy per test and per phase"),
            figure(FigSpec("Fuel economy per test and per phase (± U, k = 2)", fig,
                           key="fe_phase"))]


def _soc_figure(tests: Sequence[dict]) -> list[Block]:
    """Headline fuel economy against SOC change; nothing when no test has a battery SOC
    (a conventional car)."""
    groups: dict[tuple, list[dict]] = {}
    for r in tests:
        fe = r.get("headline_mpg")
        if fe is not None and r.get("soc_change") is not None:
            groups.setdefault((r["vehicle"] or "", r["cycle"] or ""), []).append(r)
    if not groups:
        return []
    data = [{"type": "scatter", "x": [as_unit(r["soc_change"], "%") for r in rs],
             "y": [r["headline_mpg"] for r in rs], "mode": "markers",
             "text": [str(r["test_id"]) for r in rs], "name": f"{veh} {cyc}".strip()}
            for (veh, cyc), rs in sorted(groups.items())]
    fig = layout_figure(data, xlabel="ΔSOC [%]", ylabel="headline fuel economy [mpg]",
                        height=450, margin={"l": 60, "r": 20, "t": 30, "b": 50})
    return [h2("Fuel economy vs SOC change"),
            figure(FigSpec("Headline fuel economy against battery SOC change, per test", fig,
                           key="fe_soc"))]


def render_index_page(run: dict, tests: Sequence[dict], variability: Sequence[dict],
                      results: Sequence[dict], phase_rows: Sequence[tuple],
                      verdict_lines: Sequence[str] = ()) -> str:
    """HTML of the index page of one batch run.

    Parameters
    ----------
    run : dict
        ``run_id``, ``started``, ``vehval_version``, ``n_ok``, ``n_failed``, ``n_skipped``;
        ``removed``: ids of the tests whose files are gone (said under the counts).
    tests : sequence of dict
        The run's tests: ``test_id``, ``status``, ``error``, ``vehicle``, ``cycle``,
        ``outputs``, ``n_findings_by_severity`` (JSON text) and the :data:`COLUMNS`.
    variability : sequence of dict
        ``Catalog.summary()`` rows.
    results : sequence of dict
        ``results_variability()`` rows.
    phase_rows : sequence of tuple
        ``(test_id, scope, kind, fuel_economy_mpg, fuel_economy_u_mpg)`` of the run.
    verdict_lines : sequence of str
        The run's set verdicts of the model against its tests (one line each), shown under
        the tests table; En per test is the table's last column.
    """
    blocks = [h1(f"vehval batch {run['run_id']}"),
              para(f"started {run['started']} · vehval {run['vehval_version']} · ",
                   (f"{run['n_ok']} ok", "ok"), " · ", (f"{run['n_failed']} failed", "failed"),
                   " · ", (f"{run['n_skipped']} unchanged (skipped)", "skipped")),
              h2("Tests"), _tests_table(tests)]
    if run.get("removed"):
        blocks.insert(2, para(f"{len(run['removed'])} removed since the earlier runs (their "
                              f"files are gone: deleted or renamed; left out of the "
                              f"variability): {', '.join(run['removed'])}"))
    blocks += [para(line) for line in verdict_lines]
    blocks += _variability(variability) + _results(results)
    blocks += _phase_figure(phase_rows) + _soc_figure(tests)
    return render_document(blocks, title=f"vehval batch {run['run_id']}", css="batch.css")
