"""HTML report of an identification: fits, the fuel map with its measured points, and the
measured vs simulated engine speed and fuel rate of every predicted test.

One self-contained file (plotly.js inlined, works offline), written atomically.
"""

from __future__ import annotations

import html
from pathlib import Path

import numpy as np
import plotly.graph_objects as go

from vehval.identify.warmup import start_label
from vehval.io.atomic import write_text_atomic
from vehval.report.safety import CSP_META

MAX_POINTS = 4000
RPM = 30.0 / np.pi


def _thin(n: int) -> slice:
    return slice(None, None, max(n // MAX_POINTS, 1))


def fuel_map_figure(idf) -> go.Figure:
    """Fitted Willans lines at five engine speeds over the measured (delay-aligned) points."""
    fm = idf.fuel_map
    pts = fm.points
    ok = np.isfinite(pts["fuel"])
    sl = _thin(int(ok.sum()))
    fig = go.Figure()
    fig.add_trace(go.Scattergl(
        x=pts["p"][ok][sl] / 1e3, y=pts["fuel"][ok][sl] * 1e3, mode="markers",
        marker={"size": 3, "color": pts["w"][ok][sl] * RPM, "colorscale": "Viridis",
                "colorbar": {"title": "rpm"}, "opacity": 0.5}, name="measured (delay-aligned)"))
    p = np.linspace(0.0, fm.power_range_w[1], 60)
    for rpm in np.linspace(fm.speed_range_rad_s[0] * RPM, fm.speed_range_rad_s[1] * RPM, 5):
        fig.add_trace(go.Scatter(x=p / 1e3, y=fm.rate(np.full_like(p, rpm / RPM), p) * 1e3,
                                 mode="lines", name=f"fitted map, {rpm:.0f} rpm"))
    fig.update_layout(title="Engine fuel map: fitted Willans lines and measured points",
                      xaxis_title="engine power [kW]", yaxis_title="fuel rate [g/s]", height=480)
    return fig


def trace_figure(pred: dict) -> go.Figure:
    """Engine speed and fuel rate, measured vs simulated, of one predicted test."""
    from plotly.subplots import make_subplots
    s = pred["sim"].test
    t = s["eng_spd_out_simu"].time
    tr = pred["trace"]
    m = tr.t >= 0
    tm = tr.t[m] - tr.t[m][0]
    sl = _thin(t.size)
    fig = make_subplots(rows=2, cols=1, shared_xaxes=True, vertical_spacing=0.06)
    fig.add_trace(go.Scattergl(x=tm[sl], y=tr.w_eng[m][sl] * RPM, name="engine speed, test",
                               line={"width": 1}), row=1, col=1)
    fig.add_trace(go.Scattergl(x=t[sl], y=s["eng_spd_out_simu"].values[sl] * RPM,
                               name="engine speed, model", line={"width": 1}), row=1, col=1)
    fig.add_trace(go.Scattergl(x=tm[sl], y=tr.fuel[m][sl] * 1e3, name="fuel rate, test",
                               line={"width": 1}), row=2, col=1)
    fig.add_trace(go.Scattergl(x=t[sl], y=s["fuel_rate_simu"].values[sl] * 1e3,
                               name="fuel rate, model", line={"width": 1}), row=2, col=1)
    fig.update_yaxes(title_text="rpm", row=1, col=1)
    fig.update_yaxes(title_text="g/s", row=2, col=1)
    fig.update_xaxes(title_text="time [s]", row=2, col=1)
    fig.update_layout(title=f"{pred['test']} ({pred['cycle']}): fuel {pred['fuel_measured_g']:.0f} g "
                            f"measured, {pred['fuel_predicted_g']:.0f} g predicted "
                            f"({100 * pred['error_rel']:+.1f} %)", height=560)
    return fig


def _table(rows: list[list], head: list[str]) -> str:
    h = "".join(f"<th>{html.escape(x)}</th>" for x in head)
    b = "".join("<tr>" + "".join(f"<td>{html.escape(str(c))}</td>" for c in r) + "</tr>"
                for r in rows)
    return f"<table><tr>{h}</tr>{b}</table>"


def write_identification_report(idf, preds: list[dict], path: str | Path) -> Path:
    """Write the report of ``idf`` with the predictions ``preds`` (from ``predict_trace``,
    each carrying its ``trace``) to ``path``."""
    rl = idf.road_load
    parts = ["<h1>Identification of " + html.escape(idf.vehicle.name) + "</h1>",
             "<p>Tests: " + html.escape(", ".join(t.test_id for t in idf.traces)) + "</p>",
             "<h2>Road load</h2>",
             _table([[k, f"{v:.4g}", f"±{rl.ci95[k]:.3g}", rl.template.get(k, "")]
                     for k, v in rl.values.items()],
                    ["coefficient", "identified", "95 % CI", "template"]),
             f"<p>R² {rl.r2:.4f}, RMSE {rl.rmse_n:.1f} N, force lag {rl.lag_s:+.2f} s</p>",
             "<h2>Gears</h2>",
             _table([[c["gear"], f"{c['identified']:.4f}",
                      "" if c["data_median"] is None else f"{c['data_median']:.4f}",
                      c["locked_samples"]] for c in idf.gear_ratio_check],
                    ["gear", "ratio (engine/wheel)", "median of locked samples", "samples"]),
             "<h2>Fuel map</h2>"]
    figs = [fuel_map_figure(idf)]
    fm = idf.fuel_map
    parts.append(f"<p>R² {fm.r2:.3f} (10 Hz), {fm.r2_5s:.3f} (5 s means); meter delay "
                 f"{fm.delay_s:.1f} s, lag {fm.tau_s:.1f} s; idle {fm.idle_fuel_kg_s * 1e3:.3f} "
                 f"g/s; overrun {fm.overrun_fuel_kg_s * 1e3:.3f} g/s above "
                 f"{fm.fuel_cut_speed_rad_s * RPM:.0f} rpm</p>")
    if idf.drag is not None:
        parts.append(f"<h2>Driveline drag</h2><p>{idf.drag.force_n:.1f} N + "
                     f"{idf.drag.force_n_per_mps:.3f} N/(m/s): {html.escape(idf.drag.note)}</p>")
    if idf.ac is not None:
        parts.append(f"<h2>A/C load</h2><p>{idf.ac['ac_power_w']:.0f} W from "
                     f"{html.escape(idf.ac['test'])}, phases "
                     f"{', '.join(map(str, idf.ac['phases']))} (measured "
                     f"{idf.ac['fuel_measured_g']:.1f} g; model without A/C "
                     f"{idf.ac['fuel_model_without_ac_g']:.1f} g)</p>")
    if idf.warmup is not None:
        w = idf.warmup
        rows = "".join(f"<li>phase {p['phase']}: cold {p['cold_g']:.1f} g, hot {p['hot_g']:.1f} g, "
                       f"fitted excess {p['fitted_excess_g']:.1f} g</li>" for p in w.phases)
        parts.append(f"<h2>Warm-up fuel</h2><p>+{100 * w.fraction:.1f} % at the start, time "
                     f"constant {w.time_constant_s:.0f} s: {html.escape(w.provenance())}"
                     f"{'; ' + html.escape(w.note) if w.note else ''}</p><ul>{rows}</ul>")
    parts.append("<h2>Predictions</h2>")
    parts.append(_table([[p["test"], p["cycle"], f"{p['amb_temp_c']:.1f}",
                          f"{p['fuel_measured_g']:.1f}", f"{p['fuel_predicted_g']:.1f}",
                          f"{100 * p['error_rel']:+.2f}", "on" if p.get("ac_on") else "off"]
                         for p in preds],
                        ["test", "cycle", "cell °C", "measured g", "predicted g", "error %",
                         "A/C"]))
    figs += [trace_figure(p) for p in preds]
    body = "\n".join(parts)
    return _write_page(path, "vehval identification", body, figs)


def write_prediction_report(vehicle_name: str, preds: list[dict], path: str | Path) -> Path:
    """Write the prediction table and the engine speed / fuel rate overlays of ``preds``
    (from ``predict_trace``) to ``path`` (one self-contained HTML file)."""
    rows = []
    for p in preds:
        ac = ("on" if p.get("ac_on") else "off") + f" ({p.get('ac_reason', '')})"
        start = f"{start_label(p)} ({p.get('cold_reason', '')})"
        rows.append([p["test"], p["cycle"], f"{p['amb_temp_c']:.1f}", ac, start, "test",
                     f"{p['fuel_measured_g']:.1f}", f"{p['fuel_predicted_g']:.1f}",
                     f"{100 * p['error_rel']:+.2f}"])
        for ph in p["phases"]:
            u = ph.get("results_fuel_U_g")
            rows.append(["", "", "", "", "", ph.get("results_name", f"phase {ph['phase']}"),
                         f"{ph['measured_g']:.1f}" + (f" ± {u:.1f}" if u else ""),
                         f"{ph['predicted_g']:.1f}", f"{100 * ph['error_rel']:+.2f}"])
    body = (f"<h1>Predictions of {html.escape(vehicle_name)}</h1>"
            + _table(rows, ["test", "cycle", "cell °C", "A/C", "start", "scope",
                            "measured g (U, k = 2)",
                            "predicted g", "error %"]))
    return _write_page(path, "vehval predictions", body, [trace_figure(p) for p in preds])


def _write_page(path: str | Path, title: str, body: str, figs: list) -> Path:
    """One self-contained HTML page: ``body`` then the plotly figures (plotly.js once)."""
    divs = "\n".join(f.to_html(full_html=False, include_plotlyjs=(i == 0))
                     for i, f in enumerate(figs))
    doc = ("<!DOCTYPE html><html><head><meta charset='utf-8'>" + CSP_META
           + f"<title>{html.escape(title)}</title><style>body{{font-family:sans-serif;"
           "margin:2em}table{border-collapse:collapse}td,th{border:1px solid #ccc;"
           f"padding:2px 8px}}</style></head><body>{body}\n{divs}</body></html>")
    path = Path(path)
    write_text_atomic(path, doc)
    return path
