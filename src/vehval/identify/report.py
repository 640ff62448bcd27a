"""HTML report of an identification: fits, the fuel map with its measured points, and the
measured vs simulated engine speed and fuel rate of every predicted test.

This module prepares the data and the figures; the pages are built and written by
:mod:`vehval.report.identify_page` (one self-contained file, plotly.js inlined, offline).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from vehval.constants import RPM_RAD_PER_S
from vehval.display import as_unit
from vehval.identify.warmup import start_label
from vehval.report.identify_page import write_identification_page, write_prediction_page

MAX_POINTS = 4000
RPM = 1.0 / RPM_RAD_PER_S  # [rpm] per [rad/s]


def _thin(n: int) -> slice:
    return slice(None, None, max(n // MAX_POINTS, 1))


def fuel_map_figure(idf) -> dict:
    """Fitted Willans lines at five engine speeds over the measured (delay-aligned) points
    (the figure layer's :func:`~vehval.figures.markers_figure`; power in kW, fuel in g/s)."""
    from vehval.figures import markers_figure

    fm = idf.fuel_map
    pts = fm.points
    ok = np.isfinite(pts["fuel"])
    sl = _thin(int(ok.sum()))
    series = [{"name": "measured (delay-aligned)", "x": as_unit(pts["p"][ok][sl], "kW"),
               "y": as_unit(pts["fuel"][ok][sl], "g/s"), "color": pts["w"][ok][sl] * RPM,
               "color_title": "rpm", "size": 3, "opacity": 0.5}]
    p = np.linspace(0.0, fm.power_range_w[1], 60)
    for rpm in np.linspace(fm.speed_range_rad_s[0] * RPM, fm.speed_range_rad_s[1] * RPM, 5):
        series.append({"name": f"fitted map, {rpm:.0f} rpm", "mode": "lines", "x": as_unit(p, "kW"),
                       "y": as_unit(fm.rate(np.full_like(p, rpm / RPM), p), "g/s")})
    return markers_figure(series, xlabel="engine power [kW]", ylabel="fuel rate [g/s]",
                          title="Engine fuel map: fitted Willans lines and measured points",
                          height=480)


def trace_figure(pred: dict) -> dict:
    """Engine speed and fuel rate, measured vs simulated, of one predicted test: one panel
    per unit (rpm, g/s) on one linked time axis (:func:`~vehval.figures.time_traces_figure`)."""
    from vehval.figures import PALETTE, time_traces_figure

    s = pred["sim"].test
    t = s["eng_spd_out_simu"].time
    tr = pred["trace"]
    m = tr.t >= 0
    tm = tr.t[m] - tr.t[m][0]
    panels = [
        {"ylabel": "engine speed [rpm]", "traces": [
            {"name": "engine speed, test", "t": tm, "y": tr.w_eng[m] * RPM, "unit": "rpm",
             "color": PALETTE[0]},
            {"name": "engine speed, model", "t": t, "y": s["eng_spd_out_simu"].values * RPM,
             "unit": "rpm", "color": PALETTE[1], "dash": "dot"}]},
        {"ylabel": "fuel rate [g/s]", "traces": [
            {"name": "fuel rate, test", "t": tm, "y": as_unit(tr.fuel[m], "g/s"), "unit": "g/s",
             "color": PALETTE[0]},
            {"name": "fuel rate, model", "t": t, "y": as_unit(s["fuel_rate_simu"].values, "g/s"),
             "unit": "g/s", "color": PALETTE[1], "dash": "dot"}]}]
    fig = time_traces_figure(panels, row_height=250)
    fig["layout"]["title"] = {"text": f"{pred['test']} ({pred['cycle']}): fuel "
                                      f"{pred['fuel_measured_g']:.0f} g measured, "
                                      f"{pred['fuel_predicted_g']:.0f} g predicted "
                                      f"({as_unit(pred['error_rel'], '%'):+.1f} %)"}
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
