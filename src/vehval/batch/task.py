"""One batch task: import a test, run the requested steps, write its outputs atomically.

:func:`process_test` runs in a Dask worker process (or in the driver for ``--workers 0``).
It never raises for a problem of the test itself: the error is returned in the result, so
one bad test never stops the others. The result dict is also written, last, as
``OUTDIR/tests/<test_id>/result.json``: its presence marks the test as complete, and its
``result_sha256`` (over the rest of its content) lets a resumed batch detect an edited file.
A test that runs longer than the job's ``test_timeout_s`` is recorded as failed (error kind
``timeout``) and the batch goes on; its late outputs, if it ever finishes, are discarded.
"""

from __future__ import annotations

import hashlib
import json
import shutil
import threading
import time
import traceback
from datetime import datetime, timezone
from functools import lru_cache
from pathlib import Path
from typing import Any, Callable

from vehval.batch.discover import ASSETS_DIR, file_sha256
from vehval.errors import ConfigError, InputFileError, VehvalError
from vehval.io.atomic import atomic_dir, write_text_atomic
from vehval.jsonsafe import clean as jsonable
from vehval.jsonsafe import dumps
from vehval.workflow import TestRun

RESULT_NAME = "result.json"
RESULT_SCHEMA = 1

#: Step name -> the :class:`TestRun` method it runs (in the order the job lists the steps).
STEPS: dict[str, Callable[[TestRun], Any]] = {
    "qa": TestRun.qa,
    "analyze": TestRun.analyze,
    "validate": TestRun.validate,
}
#: Output file of each step.
STEP_OUTPUT = {"qa": "findings.json", "analyze": "control.json", "validate": "validation.json"}


#: Default limit of one test's processing time [s] (``--test-timeout``).
DEFAULT_TEST_TIMEOUT_S = 600.0


def result_digest(result: dict) -> str:
    """SHA-256 of a result's canonical JSON without its own ``result_sha256`` key (hex)."""
    body = {k: v for k, v in jsonable(result).items() if k != "result_sha256"}
    text = json.dumps(body, sort_keys=True, separators=(",", ":"), allow_nan=False)
    return hashlib.sha256(text.encode()).hexdigest()


class TestTimedOut(BaseException):
    """Raised in a test's thread that passed its deadline: its outputs are not written."""

    __test__ = False  # not a pytest class


class _Deadline:
    """Who writes a test's outputs: its own thread (``claim``) or, once the deadline has
    passed, the timeout (``expire``); the lock makes the two exclusive."""

    def __init__(self) -> None:
        self.lock = threading.Lock()
        self.expired = False

    def claim(self) -> None:
        self.lock.acquire()
        if self.expired:
            self.lock.release()
            raise TestTimedOut()


def check_steps(steps: list[str], report: bool = False) -> None:
    """Fail early, in the driver, on an unknown step name."""
    for s in steps:
        if s not in STEPS:
            raise ConfigError(f"unknown step '{s}': choose from {', '.join(STEPS)}")


def dump_json(value: Any) -> str:
    return dumps(value).rstrip("\n")


@lru_cache(maxsize=8)
def _template(path: str, digest: str):
    from vehval.io.template import load_template

    return load_template(path)


@lru_cache(maxsize=8)
def _vehicle(name: str | None, digest: str):
    if not name:
        return None
    from vehval.vehicle import load_vehicle

    return load_vehicle(name)


#: The validated signals a test keeps for the catalog's overlays (``tests/ID/overlay.parquet``):
#: the best signal of each base, in SI; overlays work wherever the raw files are.
OVERLAY_FILE = "overlay.parquet"
OVERLAY_BASES = ("veh_spd", "fuel_rate", "eng_spd_out", "ess_soc", "test_phase")


def write_overlay(test: Any, path: Path) -> Path | None:
    """The overlay signals of a validated ``test`` (:data:`OVERLAY_BASES`) to ``path``
    (None when the test holds none of them)."""
    from vehval.io.parquet import write_test
    from vehval.test import Test

    sigs = [s for b in OVERLAY_BASES if (s := test.best(b, ("test", "calc"))) is not None]
    if not sigs:
        return None
    return write_test(Test(sigs, meta=test.meta), path)


def _compact_findings(qa_dict: dict, results: dict | None = None) -> list[dict]:
    """Every finding of QA and of the results stage (:func:`stage_findings`), compact."""
    from vehval.results.all_findings import stage_findings

    keep = ("signal", "kind", "severity", "start_s", "end_s", "message")
    return [{k: f.get(k) for k in keep} for f in stage_findings(qa_dict, results)]


def _by_severity(findings: list[dict]) -> dict[str, int]:
    out: dict[str, int] = {}
    for f in findings:
        sev = str(f.get("severity") or "unknown")
        out[sev] = out.get(sev, 0) + 1
    return out


def _selected(qa_dict: dict) -> list[str]:
    """Full names of the measured signals the QA selection kept (every source of a quantity
    it kept: :meth:`vehval.test.Test.best` chooses among them)."""
    from vehval.nomenclature import registry

    sel = qa_dict.get("selection") or {}
    kept = sel.get("kept") or {}
    out: list[str] = []
    for name in (kept if isinstance(kept, (dict, list)) else []):
        try:
            parsed = registry().parse(str(name))
        except Exception:  # noqa: BLE001 - a name QA kept but the registry rejects: ignore
            continue
        if parsed.origin == "test":
            out.append(str(name))
    return out


#: Scalar model-vs-test errors of validation.json kept in the catalog (relative errors).
VALIDATION_ERRORS = ("fuel_error", "soc_delta_error", "soc_final_error")


def _validation_summary(val: dict) -> dict:
    """Scalars of validation.json for the catalog, with ``errors`` = the relative errors."""
    out: dict[str, Any] = {k: v for k, v in val.items()
                           if isinstance(v, (int, float, str, bool)) or v is None}
    errors = val.get("errors") if isinstance(val.get("errors"), dict) else {
        k: val.get(k) for k in VALIDATION_ERRORS if k in val}
    if errors:
        out["errors"] = errors
    if isinstance(val.get("normalised_error"), dict):
        out["normalised_error"] = val["normalised_error"]
    return out


@lru_cache(maxsize=64)
def _u_model_rel(name: str | None, digest: str, cycle: str) -> tuple[float | None, tuple[str, ...]]:
    """Relative U_model (k = 2) of the fuel on ``cycle`` (the vehicle's parameter ranges,
    linear propagation, :func:`vehval.workflow.model_uncertainty_by_cycle`) and its notes;
    computed once per vehicle and cycle in a worker."""
    from vehval.workflow import model_uncertainty_by_cycle

    u, notes = model_uncertainty_by_cycle(_vehicle(name, digest), [cycle], "linear")
    return u.get(cycle), tuple(notes)


def _normalised_error(job: dict, run: TestRun, outcome: Any) -> dict[str, Any]:
    """The validate step's verdict by the normalised error of the fuel mass
    (:func:`vehval.workflow.fuel_normalised_error`), U_model cached per vehicle and cycle."""
    from vehval.workflow import fuel_normalised_error

    comp = outcome.validation.comparison
    u_rel, notes = _u_model_rel(job.get("vehicle"), job.get("vehicle_hash", ""), comp.cycle or "")
    return fuel_normalised_error(run.vehicle, comp, u_rel, notes)


def _validation_document(job: dict, run: TestRun, outcome: Any) -> Any:
    """validation.json: the comparison of the vehicle's architecture
    (:class:`vehval.workflow.ValidationOutcome`: the simulation on the test's conditions,
    a conventional car's fuel prediction, a battery-electric car's traces, DC energy and
    SAE J1634 figures); the simulation on the test's conditions and a conventional car's
    fuel prediction (the En ``vehval predict`` states) add the normalised error of the fuel
    mass (the battery-electric comparison carries its own verdicts)."""
    from vehval.validate.validation import Validation

    comp = outcome.comparison
    out = jsonable(comp)
    if isinstance(out, dict) and isinstance(comp, Validation):
        out["normalised_error"] = jsonable(_normalised_error(job, run, outcome))
    elif isinstance(out, dict) and callable(getattr(comp, "normalised_error", None)):
        # a conventional car's prediction (vehval.identify.comparison.PredictionComparison)
        out["normalised_error"] = jsonable(comp.normalised_error())
    return out


def _clear_stale(test_dir: Path, keep: set[str]) -> None:
    if not test_dir.is_dir():
        return
    for p in test_dir.iterdir():
        if p.name in keep or p.name.startswith("."):
            continue
        if p.is_dir():
            shutil.rmtree(p, ignore_errors=True)
        else:
            p.unlink(missing_ok=True)


def _run_steps(job: dict, stage: Path, result: dict) -> None:
    from vehval.batch.metrics import test_metrics

    template = _template(job["template"], job.get("template_hash", ""))
    vehicle = _vehicle(job.get("vehicle"), job.get("vehicle_hash", ""))
    if "validate" in job["steps"] and vehicle is None:
        raise ConfigError("step 'validate' needs a vehicle model: pass --vehicle or set "
                          f"'vehicle:' in {Path(job['template']).name}")
    if not job["files"]:            # a folder of nothing readable (skipped entries listed)
        from vehval.batch.discover import template_patterns
        pats = ", ".join(p or "*" for p in template_patterns(template)) or "none"
        raise InputFileError(f"{job['test_id']}: no regular file of the test folder matches "
                             f"the template's file patterns ({pats}): nothing to import")
    # the later steps see QA's validated test when QA is one of the steps
    run = TestRun.load([Path(f) for f in job["files"]], template, vehicle,
                       test_id=job["test_id"], use_qa="qa" in job["steps"])
    test = run.test
    if not test.meta.test_id:
        test.meta.test_id = job["test_id"]
    result["vehicle"] = (job.get("vehicle_name") or test.meta.vehicle
                         or getattr(template, "vehicle_name", None) or None)
    result["cycle"] = test.meta.cycle or job.get("cycle") or None
    outputs: dict[str, Any] = {}
    report_parts: dict[str, Any] = {}
    # the results stage (after QA when QA is a step): validation verdicts use its uncertainty
    res = run.results().results
    for step in job["steps"]:
        outcome = STEPS[step](run)
        out = (_validation_document(job, run, outcome) if step == "validate"
               else jsonable(outcome.result))
        if step == "analyze":
            report_parts["control"] = out
        elif step == "validate":
            report_parts["validation"] = jsonable(outcome.payload())
        outputs[step] = out
        write_text_atomic(stage / STEP_OUTPUT[step], dump_json(out))
    qa_dict = outputs.get("qa") or {}
    write_overlay(run.validated, stage / OVERLAY_FILE)
    res_doc = res.to_dict()
    write_text_atomic(stage / "results.json", dump_json(res_doc))
    result["results"] = results_summary(res)
    result["metrics"] = test_metrics(test, _selected(qa_dict) if qa_dict else None, fuel=res.fuel,
                                     results=res)
    if qa_dict:
        result["findings"] = _compact_findings(qa_dict, res_doc)
        result["findings_by_severity"] = _by_severity(result["findings"])
        result["qa_summary"] = qa_dict.get("summary")
    if "validate" in outputs and isinstance(outputs["validate"], dict):
        result["validation"] = _validation_summary(outputs["validate"])
    if job.get("report"):
        from vehval.report import write_plotly_asset

        # one plotly.js for the whole batch (OUTDIR/assets/), not 4.8 MB in every report;
        # written here rather than by the driver so a remote worker's plotly version is used
        asset = write_plotly_asset(Path(job["outdir"]) / ASSETS_DIR)
        run.report(stage, control=report_parts.get("control"),
                   validation=report_parts.get("validation"),
                   title=f"vehval test {job['test_id']}",
                   plotly_js=f"../../{ASSETS_DIR}/{asset.name}")  # from tests/<test_id>/


#: Per-phase quantities of results.json kept in the catalog's ``phase_results`` table.
PHASE_FIELDS = ("duration_s", "distance_m", "fuel_mass_kg", "fuel_economy_mpg",
                "fuel_consumption_l_per_100km", "co2_g_per_km", "ess_energy_net_j")


def results_summary(res: Any) -> dict:
    """The catalog's view of a test's results: conditions and one row per phase, whole test
    and composite (``scope``, ``kind``, figures [SI/mpg], fuel economy U (k = 2), drive
    quality)."""
    rows = []
    scopes = ([(p.name, "phase", p.part, p.run) for p in res.phases] + [("test", "test", "", 0)]
              + [(c.name, "composite", "", 0) for c in res.composites])
    for name, kind, part, run in scopes:
        vals = res.values.get(name, {})
        dq = res.drive_quality.get(name) or {}
        row = {"scope": name, "kind": kind, "part": part or None, "run": run or None,
               **{k: vals.get(k) for k in PHASE_FIELDS},
               "fuel_economy_u_mpg": res.expanded(name, "fuel_economy_mpg"),
               "iwr_pct": dq.get("iwr_pct"), "rmsse_mps": dq.get("rmsse_mps"),
               "withheld_reason": (res.withheld.get(name) or {}).get("reason")}
        rows.append(row)
    return {"phase_source": res.phase_source, "fuel": res.fuel.name if res.fuel else None,
            "cell_temp_c": res.conditions.get("cell_temp_c"), "start": res.conditions.get("start"),
            "ac": res.conditions.get("ac"), "headline": (head := res.headline()),
            "electric": _electric(res, head), "battery_share": _battery_share(res),
            "withheld_count": len(res.withheld), "forced": res.forced, "rows": rows}


def _electric(res: Any, head: dict) -> dict | None:
    """The SAE J1634 figures the headline states for a test without fuel economy (a
    battery-electric test; :func:`vehval.results.headline.electric_figures`), else None."""
    from vehval.results.headline import electric_figures

    if head.get("fuel_economy_mpg") is not None or not res.j1634:
        return None
    return electric_figures({"j1634": res.j1634}, str(head.get("name") or "test"))


def _battery_share(res: Any) -> float | None:
    """The whole test's net battery energy over its fuel energy (SAE J1711 NEC ratio of the
    results' SOC check), None where the results give none (no battery, no fuel)."""
    scopes = (res.soc or {}).get("scopes") or {}
    v = (scopes.get("test") or {}).get("nec_ratio")
    return float(v) if isinstance(v, (int, float)) else None


def process_test(job: dict) -> dict:
    """Process one test of a batch and write its outputs.

    Parameters
    ----------
    job : dict
        ``test_id``, ``files`` (paths), ``file_hashes``, ``input_hash``, ``run_id``,
        ``template`` (path), ``vehicle`` (name or path, or None), ``steps``, ``report``
        (bool), ``outdir``, optional ``test_timeout_s`` [s] (None or 0: no limit).

    Returns
    -------
    dict
        The content of ``result.json``: status ``ok`` or ``failed`` with ``error``,
        ``error_type`` and ``error_kind`` (``user`` for a :class:`VehvalError`, ``timeout``
        for a test stopped at ``test_timeout_s``, ``internal`` otherwise), metrics, compact
        findings, timing, provenance and ``result_sha256``.
    """
    timeout = job.get("test_timeout_s")
    deadline = _Deadline()
    if not timeout:
        return _process(job, deadline)
    box: dict[str, Any] = {}

    def work() -> None:
        try:
            box["result"] = _process(job, deadline)
        except BaseException as exc:  # noqa: BLE001 - handed to the calling thread
            box["error"] = exc

    # Python cannot stop a thread: a test past its deadline is left to run on (a daemon
    # thread, ended with the process), and its outputs are refused by the deadline
    th = threading.Thread(target=work, name=f"vehval-test-{job['test_id']}", daemon=True)
    t_start = time.perf_counter()
    th.start()
    th.join(timeout)
    if th.is_alive():
        got = deadline.lock.acquire(timeout=60.0)   # the test may be writing its outputs now
        try:
            if got and "result" in box:             # it finished meanwhile
                return box["result"]
            deadline.expired = True
            return _timed_out(job, timeout, time.perf_counter() - t_start)
        finally:
            if got:
                deadline.lock.release()
    if "error" in box:
        raise box["error"]
    return box["result"]


def _new_result(job: dict) -> dict[str, Any]:
    from vehval import __version__

    return {
        "result_schema": RESULT_SCHEMA, "test_id": job["test_id"], "run_id": job["run_id"],
        "status": "ok", "error": None, "error_type": None, "error_kind": None,
        "input_hash": job["input_hash"], "file_hashes": job.get("file_hashes", {}),
        "files": [str(f) for f in job["files"]], "vehicle": job.get("vehicle_name"),
        "cycle": None, "steps": list(job["steps"]), "vehval_version": __version__,
        "started": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        "metrics": {}, "findings": [], "findings_by_severity": {}, "qa_summary": None,
        "validation": None, "results": None, "outputs": [],
    }


def _write_result(test_dir: Path, result: dict) -> dict:
    result = jsonable(result)
    result["result_sha256"] = result_digest(result)
    write_text_atomic(test_dir / RESULT_NAME, dump_json(result))
    return result


def _timed_out(job: dict, timeout: float, elapsed: float) -> dict:
    """The failed result of a test stopped at its deadline (written as its result.json)."""
    test_dir = Path(job["outdir"]) / "tests" / job["test_id"]
    result = _new_result(job)
    result.update(status="failed", error_type="TestTimedOut", error_kind="timeout",
                  error=f"the test ran longer than the {timeout:g} s test timeout and was "
                        "stopped (raise --test-timeout if it is only slow)",
                  outputs=[], output_hashes={}, elapsed_s=elapsed)
    _clear_stale(test_dir, keep={RESULT_NAME})
    return _write_result(test_dir, result)


def _process(job: dict, deadline: _Deadline) -> dict:
    t_start = time.perf_counter()
    test_dir = Path(job["outdir"]) / "tests" / job["test_id"]
    (test_dir / RESULT_NAME).unlink(missing_ok=True)
    result = _new_result(job)
    claimed = False
    try:
        try:
            with atomic_dir(test_dir) as stage:
                _run_steps(job, stage, result)
                outputs = sorted(str(p.relative_to(stage)) for p in stage.rglob("*")
                                 if p.is_file())
                hashes = {o: file_sha256(stage / o) for o in outputs}
                deadline.claim()            # past the deadline: TestTimedOut, nothing kept
                claimed = True
            result["outputs"] = outputs
            result["output_hashes"] = hashes
            _clear_stale(test_dir, keep=set(outputs) | {p.split("/")[0] for p in outputs}
                         | {RESULT_NAME})
        except VehvalError as exc:
            result.update(status="failed", error=str(exc), error_type=type(exc).__name__,
                          error_kind="user")
        except Exception as exc:  # noqa: BLE001 - a bug must not stop the batch; it is recorded
            result.update(status="failed", error=f"{type(exc).__name__}: {exc}",
                          error_type=type(exc).__name__, error_kind="internal",
                          traceback=traceback.format_exc(limit=8))
        if not claimed:
            deadline.claim()
            claimed = True
        if result["status"] == "failed":
            _clear_stale(test_dir, keep={RESULT_NAME})
            result["outputs"] = []
            result["output_hashes"] = {}
        result["elapsed_s"] = time.perf_counter() - t_start
        return _write_result(test_dir, result)
    finally:
        if claimed:
            deadline.lock.release()
