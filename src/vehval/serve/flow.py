"""The lab flow of the workbench beyond one test's QA: the report of a test, and model and test
for every architecture the tool simulates.

* **Report** (``POST /api/report``): the static HTML report ``vehval report`` writes from the
  test's QA outputs, written atomically into the test's ``qa/`` folder and opened sandboxed.
* **Model and test** (``POST /api/model`` runs, ``GET /api/model`` reads what is kept): a
  car the stage registry validates by simulation (a power-split hybrid, a battery-electric car)
  named by the template is simulated and compared as its validate stage does
  (:mod:`.model_view`); a conventional car is predicted as ``vehval predict`` does, with the
  template's vehicle or, when it names none, with the car identified (as ``vehval identify``
  does) from the other tests of the folder (this one held out). The result is kept on disk in
  the workspace's state folder (:data:`STATE_DIR`) until an input changes (the test's files,
  the template, the vehicle file, the identification tests: their SHA-256).

:func:`simulate` is the one place choosing the stages by architecture.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path
from typing import Any

import numpy as np

from vehval.display import as_unit
from vehval.errors import ConfigError, InputFileError
from vehval.serve import security as sec
from vehval.serve.series import series

#: The workbench's state folder in the workspace (hidden: never listed as a test).
STATE_DIR = ".vehval-workbench"
#: Kinds of QA findings on the measured fuel that name a meter problem (a model error beside
#: one of them is labelled with it).
FUEL_QA_KINDS = ("fuel_map", "fuel_efficiency", "fuel_response", "unit_suspect", "unit",
                 "cross_check", "crosscheck")
#: Fewest other tests of a folder to identify a car from.
MIN_IDENTIFY_TESTS = 2


# --------------------------------------------------------------------------- report
def build_report(bench: Any) -> dict:
    """Write the test's ``report.html`` (the code of ``vehval report``) into its QA folder.

    Returns ``{"report": path relative to the workspace}``.
    """
    from vehval.report import write_report

    with bench.lock:
        run = bench._ensure_run()
        qa = run.qa()
        path = bench._qa_dir() / "report.html"   # never through a link out of the folder
        write_report(path, test=qa.validated, qa=bench.state.findings, template=run.template,
                     results=bench.state.results,
                     title=f"{bench._label()}: QA and results")
    return {"report": sec.relative(bench.root, path)}


# --------------------------------------------------------------------------- model plan
def _sha(paths: list[Path]) -> str:
    h = hashlib.sha256()
    for p in sorted(paths, key=str):
        h.update(f"\0{p.name}\0".encode())
        h.update(hashlib.sha256(p.read_bytes()).digest())
    return h.hexdigest()


def plan(bench: Any) -> dict:
    """What model and test will run for ``bench``: ``architecture``, ``vehicle`` (its name and
    where it comes from), ``inputs`` (files whose content keys the kept result) and, for an
    identification, ``identify_from`` (the tests' files)."""
    from vehval.io.template import load_template
    from vehval.vehicle import load_vehicle

    if not bench.saved():
        raise ConfigError("save the template first: model and test reads it")
    tmpl = load_template(bench.template_path)
    files, _ = bench.test_files(tmpl)
    if not files:
        raise InputFileError(f"{bench._label()}: no raw data file the template matches")
    inputs = [*files, bench.template_path]
    if tmpl.vehicle:
        sec.vehicle_inside(bench.root, tmpl.vehicle)
        veh = load_vehicle(tmpl.vehicle)
        vfile = getattr(veh, "_file", None)
        if vfile:
            inputs.append(Path(vfile))
        return {"architecture": veh.architecture, "vehicle": veh.name,
                "vehicle_text": f"{veh.name} ({veh.architecture}), the template's vehicle",
                "inputs": inputs, "identify_from": []}
    others = _other_tests(bench, tmpl)
    if len(others) < MIN_IDENTIFY_TESTS:
        raise ConfigError("the template names no vehicle ('vehicle: NAME' or a vehicle file) "
                          f"and the folder has {len(others)} other test(s) of this car to "
                          f"identify it from (at least {MIN_IDENTIFY_TESTS}): name the vehicle, "
                          "or put the car's tests in one folder under this template")
    where = sec.relative(bench.root, bench.folder)
    return {"architecture": "conventional", "vehicle": None,
            "vehicle_text": (f"identified from the {len(others)} other tests of {where} "
                             f"(this test held out): {', '.join(p.stem for p in others)}"),
            "inputs": inputs + others, "identify_from": others}


def _other_tests(bench: Any, tmpl: Any) -> list[Path]:
    """The data files of the folder's other tests (a folder of many tests), sorted."""
    if bench.test is None:
        return []
    from vehval.batch.discover import file_tests
    from vehval.serve.bench import pick_data

    data, _ = pick_data(sec.list_folder(bench.root, bench.folder), tmpl, most=None)
    ordered = sorted(data, key=lambda p: p.name)
    return [p for p, s in zip(ordered, file_tests(ordered, tmpl)) if s.test_id != bench.test]


def _state_file(bench: Any) -> Path:
    """The kept result's file in the state folder (refused when the folder or its ``model/``
    is a symlink or a file: nothing is read or written through a link)."""
    import os

    rel = sec.relative(bench.root, bench.folder)
    key = hashlib.sha256(f"{rel}\0{bench.test or ''}".encode()).hexdigest()[:24]
    for d in (bench.root / STATE_DIR, bench.root / STATE_DIR / "model"):
        if os.path.lexists(d) and (os.path.islink(d) or not d.is_dir()):
            raise InputFileError(f"{sec.relative(bench.root, d)}: a symlink or a file, not the "
                                 "workbench's own state folder: refused: remove it")
    return bench.root / STATE_DIR / "model" / f"{key}.json"


def kept(bench: Any) -> dict:
    """``GET /api/model``: the plan (the vehicle named) and the kept result when its inputs
    are unchanged (``result``: None otherwise); runs nothing."""
    p = plan(bench)
    out = {"vehicle_text": p["vehicle_text"], "architecture": p["architecture"], "result": None,
           "stale": False}
    path = _state_file(bench)
    real = sec.regular_file(bench.root, path, STATE_DIR) if path.exists() else None
    if real is not None:
        from vehval.safe_yaml import load_json

        doc = load_json(real.read_text(encoding="utf-8"))
        if isinstance(doc, dict) and doc.get("inputs") == _sha(p["inputs"]):
            out["result"] = doc.get("result")
        else:
            out["stale"] = True
    return out


def run_model(bench: Any) -> dict:
    """``POST /api/model``: run model and test for ``bench`` and keep the result (returned:
    ``vehicle``, ``vehicle_text``, ``tables``, ``traces``, ``notes``, ``architecture``...)."""
    from vehval.io.atomic import write_text_atomic
    from vehval.jsonsafe import clean

    with bench.lock:
        p = plan(bench)
        digest = _sha(p["inputs"])
        result = simulate(p["architecture"], bench, p)
        result["vehicle_text"] = p["vehicle_text"]
        result = clean(result)
        path = _state_file(bench)
        path.parent.mkdir(parents=True, exist_ok=True)
        write_text_atomic(path, json.dumps({"inputs": digest, "result": result}))
    return {**result, "architecture": p["architecture"]}


def simulate(architecture: str, bench: Any, p: dict) -> dict:
    """Model and test by architecture: the stage registry (vehval.architectures) says what
    each one takes: identification and prediction where it has them, else the simulation of
    the test's conditions (a stage an architecture lacks is refused in one line)."""
    from vehval.architectures import require, stages

    require(architecture, "validate")
    if stages(architecture).predict is not None:
        return _conventional(bench, p)
    return _simulated(bench, p)


# --------------------------------------------------------------------------- simulated
def _simulated(bench: Any, p: dict) -> dict:
    """The validation of the architecture (power-split, battery-electric...) through the
    outcome's generic interface (:func:`vehval.serve.model_view.model_overlay`), its traces
    in display units, QA's flagged samples blanked."""
    from vehval.display import to_display
    from vehval.serve.model_view import model_overlay

    out = model_overlay(bench)
    findings = (bench.state.findings or {}).get("findings") or []
    for tr in out["traces"]:
        for side in ("measured", "simulated"):   # SI -> display units (SOC in %)
            y, unit = to_display(np.asarray(tr[side]["y"], float), tr["unit"], signal=tr["base"])
            tr[side]["y"] = [float(v) if np.isfinite(v) else None for v in y]
        tr["unit"] = unit
        _mask_flagged(tr["measured"], tr["measured"]["name"], findings)
    fuel_qa = fuel_findings(findings)
    for t in out["tables"]:
        if fuel_qa and t.get("title", "").startswith("Verdict"):
            t["note"] = (t.get("note") or "") + " " + qa_label(fuel_qa)
    out["fuel_qa"] = fuel_qa
    out["figure"] = traces_figure(out["traces"])
    return out


def _mask_flagged(s: dict, name: str, findings: list[dict]) -> None:
    """Blank (None) the samples of trace ``s`` inside the spans QA flagged (warning or error)
    on signal ``name``; ``s["masked"]`` counts them."""
    t = np.asarray(s["t"], float)
    y = [None if not np.isfinite(v) else float(v) for v in np.asarray(s["y"], float)]
    n = 0
    for f in findings:
        if f.get("signal") != name or f.get("severity") not in ("warning", "error"):
            continue
        a, b = f.get("start_s"), f.get("end_s")
        if a is None or b is None:
            continue
        for i in np.flatnonzero((t >= a) & (t <= b)):
            if y[i] is not None:
                y[i], n = None, n + 1
    s["y"], s["masked"] = y, n


def fuel_findings(findings: list[dict]) -> list[dict]:
    """QA's warnings and errors on the measured fuel rate (meter gain, efficiency, unit)."""
    return [f for f in findings if str(f.get("signal") or "").startswith("fuel_rate")
            and f.get("severity") in ("warning", "error") and f.get("kind") in FUEL_QA_KINDS]


def qa_label(fuel_qa: list[dict]) -> str:
    """What a fuel difference is called beside QA findings on the measured fuel."""
    return ("The measured fuel has QA findings: the difference may be the meter's, not the "
            "model's: " + "; ".join(f"{f['kind']}: {f['message']}" for f in fuel_qa))


# --------------------------------------------------------------------------- conventional
def _conventional(bench: Any, p: dict) -> dict:
    """Predict the test as ``vehval predict`` does, with the template's vehicle or the car
    identified (as ``vehval identify`` does) from the folder's other tests."""
    from vehval.identify.build import identify_conventional
    from vehval.identify.checks import cold_warnings
    from vehval.identify.loading import load_traces
    from vehval.identify.predict import check_same_car, predict_trace
    from vehval.identify.verdicts import judge_rows
    from vehval.vehicle import load_vehicle

    tmpl_path = bench.template_path
    files, _ = bench.test_files(None if not bench.saved() else _tmpl(bench))
    trace = load_traces(files, tmpl_path)[0]
    notes: list[str] = []
    if p["identify_from"]:
        traces = load_traces(p["identify_from"], tmpl_path)
        idf = identify_conventional(traces, "identified_" + (bench.test or "car"))
        veh = idf.vehicle
        notes += cold_warnings(traces, idf.fuel_left_out)   # vehval identify's own warning
    else:
        veh = load_vehicle(p["vehicle"])
        check_same_car(veh, trace)
    pred = predict_trace(veh, trace)
    verdict, more = judge_rows([pred])
    notes += more
    findings = (bench.state.findings or {}).get("findings") or []
    fuel_qa = fuel_findings(findings)
    return {"vehicle": veh.name, "tables": [_fuel_table(pred, fuel_qa)],
            "normalised_error": {"en": pred.get("en"), "consistent": pred.get("consistent"),
                                 "in_sample": pred.get("in_sample")},
            "set_verdict": verdict, "fuel_qa": fuel_qa,
            "notes": notes + [f"A/C {'on' if pred['ac_on'] else 'off'}: {pred['ac_reason']}",
                              f"start: {pred['cold_reason']}"],
            "traces": (overlay := _conventional_traces(pred)),
            "figure": traces_figure(overlay)}


def _tmpl(bench: Any) -> Any:
    from vehval.io.template import load_template

    return load_template(bench.template_path)


def _verdict(row: dict, fuel_qa: list[dict]) -> str:
    if row.get("en") is None:
        return "no verdict (no measured fuel)"
    word = "consistent" if row.get("consistent") else "inconsistent"
    if row.get("uninformative"):
        word += " (uninformative: combined U over 10 % of the measured fuel)"
    if not row.get("consistent") and fuel_qa:
        word += " - measured fuel flagged by QA (" + ", ".join(f["kind"] for f in fuel_qa) + ")"
    elif not row.get("consistent"):
        word += " - model error"
    return word


def _fuel_table(pred: dict, fuel_qa: list[dict]) -> dict:
    """Fuel per phase and for the test, measured against predicted [g], with En."""
    def pct(x: Any) -> Any:
        return None if x is None or not np.isfinite(x) else as_unit(x, "%")

    rows = [[ph.get("results_name") or f"phase {ph['phase']}", ph["measured_g"],
             ph["predicted_g"], pct(ph["error_rel"]), ph.get("u_model_g"), ph.get("u_meas_g"),
             ph.get("en"), _verdict(ph, fuel_qa)] for ph in pred["phases"]]
    rows.append(["test", pred["fuel_measured_g"], pred["fuel_predicted_g"],
                 pct(pred["error_rel"]), pred.get("u_model_g"), pred.get("u_meas_g"),
                 pred.get("en"), _verdict(pred, fuel_qa)])
    note = ("En = (m_pred - m_test) / sqrt(U_model² + U_meas²); |En| ≤ 1 is consistent. "
            + ("In-sample: the vehicle was identified from this test. " if pred.get("in_sample")
               else "Held out: the vehicle was not identified from this test. "))
    if fuel_qa:
        note += qa_label(fuel_qa)
    return {"title": f"Fuel, measured against predicted ({pred['test']}, {pred['cycle']})",
            "columns": ["scope", "measured [g]", "predicted [g]", "error [%]",
                        "U_model (k = 2) [g]", "U_meas (k = 2) [g]", "En", "verdict"],
            "rows": rows, "note": note}


def traces_figure(traces: list[dict]) -> dict:
    """Measured against model, one panel per quantity in its display unit, on one linked time
    axis: the figure layer's stacked traces (:func:`vehval.report.figures.time_traces_figure`),
    as plotly JSON the page draws."""
    from vehval.report.figures import PALETTE, figure_json, time_traces_figure

    panels = [{"ylabel": f"{tr['base']} [{tr['unit']}]" if tr["unit"] else tr["base"],
               "traces": [{"name": tr[side]["name"], "t": tr[side]["t"],
                           "y": [np.nan if v is None else v for v in tr[side]["y"]],
                           "unit": tr["unit"], "color": PALETTE[k],
                           **({"dash": "dot"} if side == "simulated" else {})}
                          for k, side in enumerate(("measured", "simulated"))]}
              for tr in traces]
    fig = time_traces_figure(panels, row_height=150)
    fig["layout"]["meta"] = {"units": [tr["unit"] for tr in traces]}
    return json.loads(figure_json(fig))


def _conventional_traces(pred: dict, n: int = 2000) -> list[dict]:
    """Speed, engine speed and fuel rate, measured and predicted, on the test's time [s], in
    display units (:func:`vehval.display.to_display`)."""
    from vehval.display import to_display

    tr, s = pred["trace"], pred["sim"].test
    m = tr.t >= 0
    tm = tr.t[m] - tr.t[m][0]
    out = []
    for base, si, meas, sim_name in (("veh_spd", "m/s", tr.v[m], "veh_spd_simu"),
                                     ("eng_spd_out", "rad/s", tr.w_eng[m], "eng_spd_out_simu"),
                                     ("fuel_rate", "kg/s", tr.fuel[m], "fuel_rate_simu")):
        if sim_name not in s:
            continue
        sig = s[sim_name]
        ym, unit = to_display(meas, si, signal=base)
        ys, _ = to_display(sig.values, si, signal=base)
        out.append({"base": base, "unit": unit,
                    "measured": {"name": f"{base} (test)", **series(tm, ym, None, None, n)},
                    "simulated": {"name": f"{base} (model)", **series(sig.time, ys, None, None, n)}})
    return out
