"""The identification and prediction pages of ``vehval identify`` / ``vehval predict``.

The identify package hands plain data (numbers, names, plotly figures) to
:func:`write_identification_page` and :func:`write_prediction_page`; the pages are
:mod:`vehval.report.document` pages: every name is escaped text, plotly.js is embedded once.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Sequence

from vehval.constants import RPM_RAD_PER_S
from vehval.display import as_unit, format_keyed
from vehval.io.atomic import write_text_atomic
from vehval.report.document import Block, bullets, figure, h1, h2, para, render_document, table
from vehval.report.figures import FigSpec
from vehval.report.plugins import normalise_figure

RPM = 1.0 / RPM_RAD_PER_S  # [rpm] per [rad/s]


def _figures(figs: Sequence[Any]) -> list[Block]:
    out = []
    for f in figs:
        fig, caption = normalise_figure(f)
        out.append(figure(FigSpec(caption, fig)))
    return out


def identification_blocks(d: dict, figs: Sequence[Any]) -> list[Block]:
    """Blocks of the identification page.

    Parameters
    ----------
    d : dict
        ``vehicle`` (name), ``tests`` (ids), ``road_load`` (``values``, ``ci95``, ``template``
        per coefficient, ``r2``, ``rmse_n`` [N], ``lag_s`` [s]), ``gears`` (``gear``,
        ``identified``, ``data_median``, ``locked_samples``), ``fuel_map`` (``r2``, ``r2_5s``,
        ``delay_s``, ``tau_s`` [s], ``idle_fuel_kg_s``, ``overrun_fuel_kg_s`` [kg/s],
        ``fuel_cut_speed_rad_s`` [rad/s]), ``drag`` (``force_n`` [N], ``force_n_per_mps``
        [N/(m/s)], ``note``) or None, ``ac`` (``ac_power_w`` [W], ``test``, ``phases``,
        ``fuel_measured_g``, ``fuel_model_without_ac_g`` [g]) or None, ``warmup``
        (``fraction``, ``time_constant_s``, ``provenance``, ``note``, ``phases`` with
        ``phase``, ``cold_g``, ``hot_g``, ``fitted_excess_g``) or None, ``predictions``
        (``test``, ``cycle``, ``amb_temp_c``, ``fuel_measured_g``, ``fuel_predicted_g``,
        ``error_rel``, ``ac_on``).
    figs : sequence
        The fuel-map figure, then one trace figure per prediction (plotly figures).
    """
    rl, fm = d["road_load"], d["fuel_map"]
    out = [h1(f"Identification of {d['vehicle']}"), para("Tests: " + ", ".join(d["tests"])),
           h2("Road load"),
           table(["coefficient", "identified", "95 % CI", "template"],
                 [[k, _keyed(k, v), "±" + _keyed(k, rl["ci95"][k], 3),
                   _keyed(k, rl["template"].get(k, ""))] for k, v in rl["values"].items()]),
           para(f"R² {rl['r2']:.4f}, RMSE {_keyed('rmse_n', rl['rmse_n'])}, force lag {rl['lag_s']:+.2f} s"),
           h2("Gears"),
           table(["gear", "ratio (engine/wheel)", "median of locked samples", "samples"],
                 [[c["gear"], f"{c['identified']:.4f}",
                   "" if c["data_median"] is None else f"{c['data_median']:.4f}",
                   c["locked_samples"]] for c in d["gears"]]),
           h2("Fuel map"),
           para(f"R² {fm['r2']:.3f} (10 Hz), {fm['r2_5s']:.3f} (5 s means); meter delay "
                f"{fm['delay_s']:.1f} s, lag {fm['tau_s']:.1f} s; idle "
                f"{as_unit(fm['idle_fuel_kg_s'], 'g/s'):.3f} g/s; overrun "
                f"{as_unit(fm['overrun_fuel_kg_s'], 'g/s'):.3f}"
                f" g/s above {fm['fuel_cut_speed_rad_s'] * RPM:.0f} rpm")]
    if d.get("drag") is not None:
        dr = d["drag"]
        out += [h2("Driveline drag"),
                para(f"{_keyed('force_n', dr['force_n'])} + "
                     f"{_keyed('force_n_per_mps', dr['force_n_per_mps'])}: {dr['note']}")]
    if d.get("ac") is not None:
        ac = d["ac"]
        out += [h2("A/C load"),
                para(f"{ac['ac_power_w']:.0f} W from {ac['test']}, phases "
                     f"{', '.join(map(str, ac['phases']))} (measured {ac['fuel_measured_g']:.1f} g; "
                     f"model without A/C {ac['fuel_model_without_ac_g']:.1f} g)")]
    if d.get("warmup") is not None:
        w = d["warmup"]
        out += [h2("Warm-up fuel"),
                para(f"+{as_unit(w['fraction'], '%'):.1f} % at the start, time constant "
                     f"{w['time_constant_s']:.0f} s: {w['provenance']}"
                     + (f"; {w['note']}" if w["note"] else "")),
                bullets([f"phase {p['phase']}: cold {p['cold_g']:.1f} g, hot {p['hot_g']:.1f} g, "
                         f"fitted excess {p['fitted_excess_g']:.1f} g" for p in w["phases"]])]
    out += [h2("Predictions"),
            para("Tests marked in sample are ones the model was fitted on: their errors "
                 "are not a check of the model."),
            table(["test", "cycle", "cell °C", "measured g", "predicted g", "error %", "A/C"],
                  [[p["test"] + (" (in sample)" if p.get("in_sample") else ""), p["cycle"], f"{p['amb_temp_c']:.1f}", f"{p['fuel_measured_g']:.1f}",
                    f"{p['fuel_predicted_g']:.1f}", f"{as_unit(p['error_rel'], '%'):+.2f}",
                    "on" if p.get("ac_on") else "off"] for p in d["predictions"]])]
    return out + _figures(figs)  # every figure after the text, as plotly.js draws them


def _in_sample(row: dict) -> str:
    return " (in sample)" if row.get("in_sample") else ""


def _keyed(key: str, value: Any, digits: int = 4) -> str:
    """A number of a unit-suffixed key in the display units; anything else as given."""
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return format_keyed(key, value, digits=digits)
    return str(value)


def write_identification_page(path: str | Path, d: dict, figs: Sequence[Any]) -> Path:
    """Write the identification page (:func:`identification_blocks`) atomically."""
    html = render_document(identification_blocks(d, figs), title="vehval identification",
                           css="simple.css")
    write_text_atomic(path, html)
    return Path(path)


def _en(p: dict) -> str:
    """The normalised error of a row as the table shows it ('' when not judged)."""
    en = p.get("en")
    if en is None:
        return ""
    return f"{en:+.2f}" + (" (uninformative)" if p.get("uninformative") else "")


def write_prediction_page(path: str | Path, vehicle: str, predictions: Sequence[dict],
                          figs: Sequence[Any], verdict_lines: Sequence[str] = ()) -> Path:
    """Write the prediction page: one table row per test and per phase, then the figures.

    Parameters
    ----------
    path : str or Path
        Output file (written atomically).
    vehicle : str
        Vehicle name.
    predictions : sequence of dict
        ``test``, ``cycle``, ``amb_temp_c`` [°C], ``ac_on``, ``ac_reason``, ``start`` (start
        label), ``cold_reason``, ``fuel_measured_g``, ``fuel_predicted_g`` [g], ``error_rel``
        [-], ``in_sample``, ``en`` (normalised error, or None), ``uninformative``, ``phases``
        (``name``, ``measured_g``, ``u_g`` or None, ``predicted_g``, ``error_rel``,
        ``in_sample``, ``en``, ``uninformative``).
    figs : sequence
        One plotly figure per prediction.
    verdict_lines : sequence of str
        The set verdict and its notes, as the command prints them.
    """
    rows = []
    for p in predictions:
        ac = ("on" if p.get("ac_on") else "off") + f" ({p.get('ac_reason', '')})"
        rows.append([p["test"], p["cycle"], f"{p['amb_temp_c']:.1f}", ac,
                     f"{p['start']} ({p.get('cold_reason', '')})", "test",
                     f"{p['fuel_measured_g']:.1f}", f"{p['fuel_predicted_g']:.1f}",
                     f"{as_unit(p['error_rel'], '%'):+.2f}" + _in_sample(p), _en(p)])
        for ph in p["phases"]:
            u = ph.get("u_g")
            rows.append(["", "", "", "", "", ph["name"],
                         f"{ph['measured_g']:.1f}" + (f" ± {u:.1f}" if u else ""),
                         f"{ph['predicted_g']:.1f}", f"{as_unit(ph['error_rel'], '%'):+.2f}"
                         + _in_sample(ph), _en(ph)])
    blocks = [h1(f"Predictions of {vehicle}"),
              para("An error marked in sample is of a test (or phase) the model was fitted "
                   "on: no check of the model."),
              para("En is the normalised error (predicted - measured) / sqrt(U_model² + "
                   "U_meas²): |En| <= 1 is consistent with the data (docs/validation.md)."),
              table(["test", "cycle", "cell °C", "A/C", "start", "scope", "measured g (U, k = 2)",
                     "predicted g", "error %", "En"], rows)]
    blocks += [para(line.strip()) for line in verdict_lines if line.strip()]
    blocks += _figures(figs)
    write_text_atomic(path, render_document(blocks, title="vehval predictions", css="simple.css"))
    return Path(path)
