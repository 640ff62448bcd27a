"""The batch index page: one self-contained HTML file linking every test report.

Links are relative (``tests/<id>/report.html``) so the output directory can be moved or
served as is. plotly.js is embedded once, so the page works offline.
"""

from __future__ import annotations

import html
import json
from pathlib import Path

from vehval.catalog import Catalog, results_variability
from vehval.io.atomic import write_text_atomic
from vehval.report.safety import CSP_META

_COLS = [("distance_m", "distance [km]", 1e-3, "{:.2f}"),
         ("fuel_mass_kg", "fuel [kg]", 1.0, "{:.3f}"),
         ("fuel_economy_mpg", "fuel economy [mpg]", 1.0, "{:.1f}"),
         ("soc_change", "ΔSOC [%]", 100.0, "{:+.2f}"),
         ("ess_energy_j", "battery energy [kWh]", 1 / 3.6e6, "{:+.3f}"),
         ("eng_energy_j", "engine energy [kWh]", 1 / 3.6e6, "{:.3f}")]

_CSS = """body{font-family:system-ui,sans-serif;margin:1.5em;color:#222}
table{border-collapse:collapse;margin:.5em 0 1.5em}td,th{border:1px solid #ccc;padding:3px 8px;
font-size:13px}th{background:#f3f3f3}td.num{text-align:right;font-variant-numeric:tabular-nums}
.ok{color:#17702d}.failed{color:#b00020;font-weight:bold}.skipped{color:#666}
td.err{max-width:40em;font-size:12px;color:#b00020}"""


def _fmt(v, scale: float, pattern: str) -> str:
    if v is None:
        return ""
    try:
        return pattern.format(float(v) * scale)
    except (TypeError, ValueError):
        return html.escape(str(v))


def render_index(catalog: Catalog, run_id: str) -> str:
    """HTML of the index page of run ``run_id`` (tests of the run + variability tables)."""
    import plotly.graph_objects as go
    from plotly.offline import get_plotlyjs

    cols = ["test_id", "status", "error", "vehicle", "cycle", "outputs", "source_run_id",
            "n_findings_by_severity"] + [c[0] for c in _COLS]
    names, rows = catalog.query(f"SELECT {', '.join(cols)} FROM tests WHERE run_id = ? "
                                "ORDER BY test_id", [run_id])
    recs = [dict(zip(names, r)) for r in rows]
    _, run = catalog.query("SELECT started, vehval_version, n_ok, n_failed, n_skipped FROM runs "
                           "WHERE run_id = ?", [run_id])
    started, version, n_ok, n_failed, n_skipped = run[0] if run else (None, "", 0, 0, 0)
    body = [f"<h1>vehval batch {html.escape(run_id)}</h1>",
            f"<p>started {html.escape(str(started))} · vehval {html.escape(str(version))} · "
            f"<span class=ok>{n_ok} ok</span> · <span class=failed>{n_failed} failed</span> · "
            f"<span class=skipped>{n_skipped} unchanged (skipped)</span></p>", "<h2>Tests</h2>",
            "<table><tr><th>test</th><th>status</th><th>vehicle</th><th>cycle</th><th>findings</th>"
            + "".join(f"<th>{html.escape(c[1])}</th>" for c in _COLS) + "<th>error</th></tr>"]
    for r in recs:
        tid = html.escape(r["test_id"])
        outs = r["outputs"] or []
        link = f'<a href="tests/{tid}/report.html">{tid}</a>' if "report.html" in outs else tid
        sev = json.loads(r["n_findings_by_severity"]) if r["n_findings_by_severity"] else {}
        sev_txt = ", ".join(f"{v} {k}" for k, v in sorted(sev.items()))
        body.append(
            f"<tr><td>{link}</td><td class={html.escape(r['status'])}>{html.escape(r['status'])}</td>"
            f"<td>{html.escape(r['vehicle'] or '')}</td><td>{html.escape(r['cycle'] or '')}</td>"
            f"<td>{html.escape(sev_txt)}</td>"
            + "".join(f"<td class=num>{_fmt(r[c], s, p)}</td>" for c, _, s, p in _COLS)
            + f"<td class=err>{html.escape(r['error'] or '')}</td></tr>")
    body.append("</table>")
    var = catalog.summary()
    body.append("<h2>Test-to-test variability (latest result of every test)</h2>")
    if var:
        body.append("<table><tr><th>vehicle</th><th>cycle</th><th>metric</th><th>n</th><th>mean</th>"
                    "<th>std</th><th>CV [%]</th><th>min</th><th>max</th></tr>")
        for v in var:
            cv = "" if v["cv"] is None else f"{100 * v['cv']:.2f}"
            body.append(f"<tr><td>{html.escape(v['vehicle'])}</td><td>{html.escape(v['cycle'])}</td>"
                        f"<td>{v['metric']}</td><td class=num>{v['n']}</td>"
                        + "".join(f"<td class=num>{_fmt(v[k], 1.0, '{:.5g}')}</td>"
                                  for k in ("mean", "std"))
                        + f"<td class=num>{cv}</td>"
                        + "".join(f"<td class=num>{_fmt(v[k], 1.0, '{:.5g}')}</td>"
                                  for k in ("min", "max")) + "</tr>")
        body.append("</table>")
    else:
        body.append("<p>No successful test yet.</p>")
    body += _results_tables(catalog)
    fe_plot = _phase_plot(catalog, run_id, go)
    fig = go.Figure()
    groups: dict[tuple, list[dict]] = {}
    for r in recs:
        if r["fuel_economy_mpg"] is not None and r["soc_change"] is not None:
            groups.setdefault((r["vehicle"] or "", r["cycle"] or ""), []).append(r)
    for (veh, cyc), rs in sorted(groups.items()):
        fig.add_trace(go.Scatter(x=[100 * r["soc_change"] for r in rs],
                                 y=[r["fuel_economy_mpg"] for r in rs], mode="markers",
                                 text=[r["test_id"] for r in rs], name=f"{veh} {cyc}".strip()))
    fig.update_layout(title="Fuel economy against battery SOC change, per test",
                      xaxis_title="ΔSOC [%]", yaxis_title="fuel economy [mpg]", height=450,
                      margin=dict(l=60, r=20, t=50, b=50))
    plot = fig.to_html(full_html=False, include_plotlyjs=False, div_id="fe_soc")
    return ("<!DOCTYPE html><html><head><meta charset='utf-8'>" + CSP_META + "<title>vehval batch "
            f"{html.escape(run_id)}</title><style>{_CSS}</style>"
            f"<script type='text/javascript'>{get_plotlyjs()}</script></head><body>"
            + "\n".join(body) + fe_plot + "<h2>Fuel economy vs SOC change</h2>" + plot
            + "</body></html>")


def _results_tables(catalog: Catalog) -> list[str]:
    """Fuel economy variability by cycle and test conditions (cell temperature band, cold or
    hot start), per result scope, from the catalog's ``phase_results``."""
    var = results_variability(catalog)
    out = ["<h2>Fuel economy by cycle and test conditions (latest result of every test)</h2>"]
    if not var:
        return out + ["<p>No per-phase results (no fuel declared, or no successful test).</p>"]
    out.append("<table><tr><th>vehicle</th><th>cycle</th><th>cell temperature</th><th>start</th>"
               "<th>result</th><th>n</th><th>mean [mpg]</th><th>std [mpg]</th><th>CV [%]</th>"
               "<th>mean U (k = 2) [mpg]</th></tr>")
    for v in var:
        cv = "" if v["cv"] is None else f"{100 * v['cv']:.2f}"
        label = v["scope"] if v["kind"] != "test" else "whole test"
        out.append("<tr>" + "".join(f"<td>{html.escape(str(v[k]))}</td>" for k in
                                    ("vehicle", "cycle", "temperature_band", "start"))
                   + f"<td>{html.escape(label)} ({v['kind']})</td><td class=num>{v['n']}</td>"
                   + "".join(f"<td class=num>{_fmt(v[k], 1.0, '{:.2f}')}</td>"
                             for k in ("mean", "std"))
                   + f"<td class=num>{cv}</td><td class=num>{_fmt(v['mean_u'], 1.0, '{:.2f}')}</td></tr>")
    out.append("</table>")
    return out


def _phase_plot(catalog: Catalog, run_id: str, go) -> str:
    """Fuel economy per test and per phase (error bars: U, k = 2) of run ``run_id``."""
    names, rows = catalog.query(
        "SELECT test_id, scope, kind, fuel_economy_mpg, fuel_economy_u_mpg FROM phase_results "
        "WHERE run_id = ? AND fuel_economy_mpg IS NOT NULL AND kind IN ('phase', 'test') "
        "ORDER BY test_id", [run_id])
    if not rows:
        return ""
    fig = go.Figure()
    by_scope: dict[str, list[tuple]] = {}
    for tid, scope, kind, fe, u in rows:
        by_scope.setdefault("whole test" if kind == "test" else scope, []).append((tid, fe, u))
    for scope, pts in by_scope.items():
        fig.add_trace(go.Scatter(x=[p[0] for p in pts], y=[p[1] for p in pts], mode="markers",
                                 name=scope, error_y={"type": "data", "visible": True,
                                                      "array": [p[2] or 0.0 for p in pts]},
                                 marker={"size": 10 if scope == "whole test" else 7}))
    fig.update_layout(title="Fuel economy per test and per phase (± U, k = 2)",
                      xaxis_title="test", yaxis_title="fuel economy [mpg]", height=450,
                      margin=dict(l=60, r=20, t=50, b=80))
    return ("<h2>Fuel economy per test and per phase</h2>"
            + fig.to_html(full_html=False, include_plotlyjs=False, div_id="fe_phase"))


def write_index(path: str | Path, catalog: Catalog, run_id: str) -> Path:
    """Write the index page of run ``run_id`` atomically; returns its path."""
    write_text_atomic(path, render_index(catalog, run_id))
    return Path(path)
