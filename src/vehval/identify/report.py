"""HTML report of an identification: fits, the fuel map with its measured points, and the
measured vs simulated engine speed and fuel rate of every predicted test.

This module prepares the data and the figures; the pages are built and written by
:mod:`vehval.report.identify_page` (one self-contained file, plotly.js inlined, offline).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import plotly.graph_objects as go

from vehval.constants import RPM_RAD_PER_S
from vehval.identify.warmup import start_label
from vehval.report.identify_page import write_identification_page, write_prediction_page

MAX_POINTS = 4000
RPM = 1.0 / RPM_RAD_PER_S  # [rpm] per [rad/s]


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


def identification_data(idf, preds: list[dict]) -> dict:
    """The plain data of the identification page (see
    :func:`vehval.report.identify_page.identification_blocks`)."""
    rl, fm, w = idf.road_load, idf.fuel_map, idf.warmup
    return {
        "vehicle": idf.vehicle.name, "tests": [t.test_id for t in idf.traces],
        "road_load": {"values": dict(rl.values), "ci95": dict(rl.ci95),
                      "template": dict(rl.template), "r2": rl.r2, "rmse_n": rl.rmse_n,
                      "lag_s": rl.lag_s},
        "gears": list(idf.gear_ratio_check),
        "fuel_map": {"r2": fm.r2, "r2_5s": fm.r2_5s, "delay_s": fm.delay_s, "tau_s": fm.tau_s,
                     "idle_fuel_kg_s": fm.idle_fuel_kg_s, "overrun_fuel_kg_s": fm.overrun_fuel_kg_s,
                     "fuel_cut_speed_rad_s": fm.fuel_cut_speed_rad_s},
        "drag": None if idf.drag is None else {"force_n": idf.drag.force_n,
                                               "force_n_per_mps": idf.drag.force_n_per_mps,
                                               "note": idf.drag.note},
        "ac": idf.ac,
        "warmup": None if w is None else {"fraction": w.fraction,
                                          "time_constant_s": w.time_constant_s,
                                          "provenance": w.provenance(), "note": w.note,
                                          "phases": list(w.phases)},
        "predictions": [{k: p.get(k) for k in ("test", "cycle", "amb_temp_c", "fuel_measured_g",
                                               "fuel_predicted_g", "error_rel", "ac_on",
                                               "in_sample")}
                        for p in preds],
    }


def write_identification_report(idf, preds: list[dict], path: str | Path) -> Path:
    """Write the report of ``idf`` with the predictions ``preds`` (from ``predict_trace``,
    each carrying its ``trace``) to ``path``."""
    figs = [fuel_map_figure(idf)] + [trace_figure(p) for p in preds]
    return write_identification_page(path, identification_data(idf, preds), figs)


def prediction_data(preds: list[dict]) -> list[dict]:
    """The rows of the prediction page (see
    :func:`vehval.report.identify_page.write_prediction_page`)."""
    out = []
    for p in preds:
        phases = [{"name": ph.get("results_name", f"phase {ph['phase']}"),
                   "measured_g": ph["measured_g"], "u_g": ph.get("results_fuel_U_g"),
                   "predicted_g": ph["predicted_g"], "error_rel": ph["error_rel"],
                   "in_sample": bool(ph.get("in_sample")), "en": ph.get("en"),
                   "uninformative": ph.get("uninformative")}
                  for ph in p["phases"]]
        out.append({**{k: p.get(k) for k in ("test", "cycle", "amb_temp_c", "ac_on", "ac_reason",
                                              "cold_reason", "fuel_measured_g",
                                              "fuel_predicted_g", "error_rel", "in_sample",
                                              "en", "uninformative")},
                    "ac_reason": p.get("ac_reason", ""), "cold_reason": p.get("cold_reason", ""),
                    "start": start_label(p), "phases": phases})
    return out


def write_prediction_report(vehicle_name: str, preds: list[dict], path: str | Path,
                            verdict_lines: list[str] | None = None) -> Path:
    """Write the prediction table (with each figure's normalised error En when
    :func:`vehval.identify.verdicts.judge_rows` has judged ``preds``), the set verdict's
    lines and the engine speed / fuel rate overlays of ``preds`` (from ``predict_trace``) to
    ``path`` (one self-contained HTML file)."""
    return write_prediction_page(path, vehicle_name, prediction_data(preds),
                                 [trace_figure(p) for p in preds], verdict_lines or [])
