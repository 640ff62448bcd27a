"""EPA validation report: the per-test / per-bag table and a predicted-vs-measured plot.

The headline counts held-out figures only; the figures of the tests the vehicle file was
calibrated on are marked in-sample in the table and the plot and summarised apart.

One self-contained HTML file (inline SVG, no script; template ``epa.html.j2``), plus ``epa_validation.json`` (the
:meth:`~vehval.epa.validation.EpaValidation.to_dict` contract) and ``epa_validation.csv``.
"""

from __future__ import annotations

import csv
import io
import math
from pathlib import Path
from typing import Any

from vehval import jsonsafe
from vehval.display import as_unit
from vehval.epa.consistency import group_mismatches
from vehval.epa.validation import TOLERANCE, EpaValidation
from vehval.report.page import render_page

_COLORS = {"ftp75": "#1f77b4", "hwfet": "#2ca02c", "us06": "#d62728"}


def table_rows(val: EpaValidation) -> list[dict]:
    """One dict per compared figure (the CSV rows; U_meas's precision as its basis text)."""
    rows = []
    for c in val.comparisons:
        d = c.to_dict()
        prec = d.pop("precision", None) or {}
        d["u_meas_basis"] = prec.get("basis")
        rows.append(d)
    return rows


def verdict_text(val: EpaValidation) -> str:
    """The set verdict of the held-out figures as a sentence (or why there is none), and the
    verdict over every test, in-sample included, when some are in-sample."""
    text = _verdict_sentence(val.set_verdict, val.set_verdict_note,
                             "held-out, one figure per test")
    if val.set_verdict_all is not None:
        text += " " + _verdict_sentence(val.set_verdict_all, val.set_verdict_all_note,
                                        "all tests, in-sample included, not a prediction")
    return text.strip()


def _verdict_sentence(sv: dict | None, note: str, what: str) -> str:
    if sv is None:
        return f"Set verdict: none ({note})." if note else ""
    from vehval.uncertainty import verdict_text

    text = verdict_text(sv, what)
    return text[0].upper() + text[1:] + "."


def scatter_plot(val: EpaValidation, size: int = 420) -> dict | None:
    """Predicted vs measured fuel economy [mpg]: the geometry of the SVG scatter with the
    1:1 and ±5 % lines (drawn by ``epa.html.j2``); None without a figure.

    Judged figures are filled, figures not judged (cold start without a cold-start
    model, or a test whose listed figures disagree) open; held-out figures are circles,
    in-sample ones (a calibration test of the vehicle file) squares. Coordinates are [px]
    strings, every label is text (escaped by the template).
    """
    pts = [(c.measured_mpg, c.predicted_mpg, c) for c in val.comparisons]
    if not pts:
        return None
    lo = min(min(p[0], p[1]) for p in pts) * 0.9
    hi = max(max(p[0], p[1]) for p in pts) * 1.05
    m = 50

    def sx(x):
        return m + (x - lo) / (hi - lo) * (size - 2 * m)

    def sy(y):
        return size - m - (y - lo) / (hi - lo) * (size - 2 * m)

    lines = [{"x1": f"{sx(lo):.1f}", "y1": f"{sy(lo * k):.1f}", "x2": f"{sx(hi):.1f}",
              "y2": f"{sy(hi * k):.1f}", "dash": dash}
             for k, dash in ((1.0, ""), (1 + TOLERANCE, "4,3"), (1 - TOLERANCE, "4,3"))]
    step = 10 if hi - lo < 120 else 20
    ticks, v = [], (int(lo) // step + 1) * step
    while v < hi:
        ticks.append({"value": v, "x": f"{sx(v):.1f}", "y": f"{sy(v) + 4:.1f}"})
        v += step
    points = []
    for x, y, c in pts:
        col = _COLORS.get(c.procedure, "#555")
        points.append({"cx": f"{sx(x):.1f}", "cy": f"{sy(y):.1f}", "stroke": col,
                       "x": f"{sx(x) - 3.5:.1f}", "y": f"{sy(y) - 3.5:.1f}",
                       "fill": col if c.judged else "none", "in_sample": c.in_sample,
                       "title": f"{c.test} {c.procedure} {c.item}: predicted {c.predicted_mpg:.1f}, "
                                f"measured {c.measured_mpg:.1f} mpg ({as_unit(c.error, '%'):+.1f} %"
                                f"{', in-sample' if c.in_sample else ''})"})
    legend = [{"label": label, "color": _COLORS[key], "cy": m + 14 + 14 * i, "ty": m + 18 + 14 * i}
              for i, (label, key) in enumerate((("FTP-75", "ftp75"), ("HWFET", "hwfet"),
                                               ("US06", "us06")))]
    return {"size": size, "m": m, "inner": size - 2 * m, "half": size / 2, "lines": lines,
            "ticks": ticks, "points": points, "legend": legend, "tick_y": size - m + 14,
            "tick_x": m - 6, "xlabel_y": size - 12}


def share_text(x: float | None) -> str:
    """A battery share [-] as signed percent with one decimal ("-" without a battery)."""
    return "-" if x is None else f"{round(as_unit(x, '%'), 1) + 0.0:+.1f}"  # + 0.0: no "-0.0"


def _figures_text(st: dict) -> str:
    """``n of N judged figures within 5 % (...); mean error ...`` of one stats dict."""
    if not st["n_judged"]:
        return "no judged figure."
    return (f"{st['n_within_tolerance']} of {st['n_judged']} judged figures within "
            f"{as_unit(st['tolerance'], '%'):.0f} % ({st['n_within_3pct']} within 3 %); mean error "
            f"{as_unit(st['mean_error'] or 0, '%'):+.1f} %, mean |error| "
            f"{as_unit(st['mean_abs_error'] or 0, '%'):.1f} %.")


def render_html(val: EpaValidation) -> str:
    """The whole report page (``epa.html.j2``): every text of the list is escaped there."""
    st = val.stats()
    corr = st["spread_correlation"]
    rows, classes = [], []
    for c in val.comparisons:
        ok = abs(c.error) <= TOLERANCE
        classes.append("" if not c.judged else ("ok" if ok else "bad"))
        rows.append([c.test, c.originator, c.procedure, c.item, f"{c.predicted_mpg:.1f}",
                     f"{c.measured_mpg:.1f}", f"{as_unit(c.error, '%'):+.1f}",
                     "-" if c.en is None or not math.isfinite(c.en)
                     else f"{c.en:+.2f}" + ("?" if c.uninformative else ""),
                     share_text(c.battery_share),
                     "in-sample" if c.in_sample else ("unknown" if c.sample_unknown
                                                      else "held-out"),
                     "yes" if c.judged else "no", c.note])
    r_kind = corr["per_kind"]
    kinds = [[k, v["n"], v["n_within_tolerance"], f"{as_unit(v['mean_error'], '%'):+.1f}",
              f"{as_unit(v['mean_abs_error'], '%'):.1f}", f"{as_unit(v['max_abs_error'], '%'):.1f}",
              "-" if r_kind.get(k) is None else f"{r_kind[k]:.3f}"]
             for k, v in st["per_kind"].items()]
    skipped = [f"{s['test']} ({s['description']}): {s['reason']}" for s in val.skipped]
    pooled = corr["pooled"]
    groups = group_mismatches((p.test.label, p.vehicle_check) for p in val.predictions)
    mismatch = [f"{len(labels)} test(s) ({', '.join(labels)}): {note}. Their errors judge the "
                "vehicle file on a car it may not describe." for note, labels in groups.items()]
    tol = f"{as_unit(TOLERANCE, '%'):.0f}"
    summary = (f"{st['n_tests_simulated']} tests simulated, {st['n_tests_skipped']} skipped;\n"
               f"held-out: {_figures_text(st)}\n"
               "Correlation of predicted and measured held-out judged figures: r = "
               f"{'-' if pooled is None else f'{pooled:.3f}'}.")
    in_sample = ""
    if st["n_judged_in_sample"]:
        ins = val.stats(in_sample=True)
        here = {p.test.label for p in val.predictions}  # the file may name tests not run
        in_sample = (f"In-sample, apart: the vehicle file was calibrated on "
                     f"{ins['n_tests_in_sample']} of these tests "
                     f"({', '.join(sorted(t for t in val.calibrated if t in here))}); their "
                     "figures are not a "
                     f"prediction: {_figures_text(ins)}")
    if val.sample_unknown:
        in_sample += (f" Sample unknown: {len(val.sample_unknown)} test(s) without a test number "
                      f"({st['n_judged_sample_unknown']} judged figures) may be calibration "
                      "tests of the vehicle file, which are not all in the lists read; they are "
                      "counted neither as held-out nor as in-sample (read the list that numbers "
                      "them too).")
    return render_page("epa.html.j2", title=f"vehval EPA validation: {val.vehicle}", css="epa.css",
                       vehicle=val.vehicle, summary=summary, in_sample=in_sample,
                       mismatch=mismatch,
                       plot=scatter_plot(val), tol=tol, kinds=kinds, rows=rows,
                       row_classes=classes, skipped=skipped, verdict=verdict_text(val))


def write_epa_report(val: EpaValidation, outdir: str | Path) -> list[str]:
    """Write report.html, epa_validation.json and epa_validation.csv atomically."""
    return _write_outputs(outdir, render_html(val), jsonsafe.dumps(val), table_rows(val))


def _write_outputs(outdir: str | Path, html: str, doc_json: str,
                   rows: list[dict[str, Any]]) -> list[str]:
    """report.html, epa_validation.json and epa_validation.csv (``rows``) into ``outdir``,
    atomically; returns their names."""
    from vehval.io.atomic import atomic_dir

    buf = io.StringIO()
    if rows:
        w = csv.DictWriter(buf, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    with atomic_dir(Path(outdir)) as stage:
        (stage / "report.html").write_text(html, encoding="utf-8")
        (stage / "epa_validation.json").write_text(doc_json, encoding="utf-8")
        (stage / "epa_validation.csv").write_text(buf.getvalue(), encoding="utf-8")
    return ["report.html", "epa_validation.json", "epa_validation.csv"]


def write_bev_report(doc: dict[str, Any], outdir: str | Path) -> list[str]:
    """The outputs of `epa validate` of a battery-electric vehicle
    (:func:`vehval.epa.bev.validate_bev`): report.html, epa_validation.json and
    epa_validation.csv, atomically."""
    from vehval.epa.bev import shown_figure, validation_text
    from vehval.report.document import h1, para, render_document, table

    rows = [{"row": j["row"], "cycle": j["cycle"], "unit": j["unit"], "listed": j["listed"],
             "simulated": j["simulated"], "error_pct": as_unit(j["error"], "%"), "en": j["en"],
             "in_sample": j["in_sample"]} for j in doc["rows"]]
    cells = []
    for j in doc["rows"]:
        listed, unit = shown_figure(j["listed"], j["unit"])
        sim, _ = shown_figure(j["simulated"], j["unit"])
        cells.append([j["row"], j["cycle"], f"{listed:.1f}", f"{sim:.1f}", unit,
                      f"{as_unit(j['error'], '%'):+.1f}", f"{j['en']:+.2f}"])
    summary = validation_text({**doc, "rows": []}).strip()
    blocks = [h1(f"vehval EPA validation: {doc['vehicle']} (battery-electric)"),
              para("Each electricity row simulated on its own test weight and road load and "
                   "judged by its normalised error En (|En| <= 1: consistent; U_model "
                   f"{as_unit(doc['u_model_rel'], '%'):.0f} %, k = 2)."),
              table(["row", "cycle", "listed", "simulated", "unit", "error [%]", "En"], cells)]
    if summary:
        blocks.append(para(summary))
    html = render_document(blocks, title=f"vehval EPA validation: {doc['vehicle']}",
                           css="simple.css")
    return _write_outputs(outdir, html, jsonsafe.dumps(doc), rows)
