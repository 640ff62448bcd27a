"""One batch task: import a test, run the requested steps, write its outputs atomically.

:func:`process_test` runs in a Dask worker process (or in the driver for ``--workers 0``).
It never raises for a problem of the test itself: the error is returned in the result, so
one bad test never stops the others. The result dict is also written, last, as
``OUTDIR/tests/<test_id>/result.json``: its presence marks the test as complete.
"""

from __future__ import annotations

import importlib
import json
import math
import shutil
import time
import traceback
from datetime import datetime, timezone
from functools import lru_cache
from pathlib import Path
from typing import Any, Callable

from vehval.errors import ConfigError, VehvalError
from vehval.io.atomic import atomic_dir, write_text_atomic

RESULT_NAME = "result.json"
RESULT_SCHEMA = 1

#: Step name -> (module, function). Order of execution is the order here.
STEPS: dict[str, tuple[str, str]] = {
    "qa": ("vehval.qa.pipeline", "run_qa"),
    "analyze": ("vehval.analysis", "analyze"),
    "validate": ("vehval.validate", "validate_test"),
}
#: Output file of each step.
STEP_OUTPUT = {"qa": "findings.json", "analyze": "control.json", "validate": "validation.json"}
_REPORT = ("vehval.report", "build_reports")
#: Directory of OUTDIR holding the one plotly.js copy the test reports share.
ASSETS_DIR = "assets"


def _resolve(module: str, func: str, what: str) -> Callable:
    try:
        mod = importlib.import_module(module)
    except ModuleNotFoundError as exc:
        if exc.name and (module == exc.name or module.startswith(exc.name + ".")):
            raise ConfigError(f"{what} is not available in this version (no module {module})") from None
        raise
    fn = getattr(mod, func, None)
    if fn is None:
        raise ConfigError(f"{what} is not available in this version ({module}.{func} is missing)")
    return fn


def step_function(step: str) -> Callable:
    """The library function of a batch step; :class:`ConfigError` when unknown or absent."""
    if step not in STEPS:
        raise ConfigError(f"unknown step '{step}': choose from {', '.join(STEPS)}")
    return _resolve(*STEPS[step], what=f"step '{step}'")


def check_steps(steps: list[str], report: bool) -> None:
    """Fail early, in the driver, when a requested step or the report is not available."""
    for s in steps:
        step_function(s)
    if report:
        _resolve(*_REPORT, what="the HTML report (use --no-report)")


def jsonable(value: Any) -> Any:
    """A JSON-safe copy: NaN/inf -> None, numpy -> Python, dataclasses/objects -> dict/str."""
    if hasattr(value, "to_dict") and callable(value.to_dict) and not isinstance(value, dict):
        value = value.to_dict()
    if isinstance(value, dict):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple, set)):
        return [jsonable(v) for v in value]
    if hasattr(value, "tolist") and not isinstance(value, (str, bytes)):
        return jsonable(value.tolist())
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, (str, int, bool)) or value is None:
        return value
    if hasattr(value, "value") and isinstance(getattr(value, "value"), (str, int)):  # Enum
        return value.value
    if isinstance(value, Path):
        return str(value)
    return str(value)


def dump_json(value: Any) -> str:
    return json.dumps(jsonable(value), indent=1, sort_keys=False, allow_nan=False)


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


def _compact_findings(qa_dict: dict) -> list[dict]:
    keep = ("signal", "kind", "severity", "start_s", "end_s", "message")
    return [{k: f.get(k) for k in keep} for f in qa_dict.get("findings") or [] if isinstance(f, dict)]


def _by_severity(findings: list[dict]) -> dict[str, int]:
    out: dict[str, int] = {}
    for f in findings:
        sev = str(f.get("severity") or "unknown")
        out[sev] = out.get(sev, 0) + 1
    return out


def _selected(qa_dict: dict) -> dict[str, str]:
    """Base name -> kept full name, from the QA selection when it states it."""
    from vehval.nomenclature import registry

    sel = qa_dict.get("selection") or {}
    kept = sel.get("kept") or {}
    out: dict[str, str] = {}
    for name in (kept if isinstance(kept, (dict, list)) else []):
        try:
            parsed = registry().parse(str(name))
        except Exception:  # noqa: BLE001 - a name QA kept but the registry rejects: ignore
            continue
        if parsed.origin == "test":
            out.setdefault(parsed.base, str(name))
    return out


#: Scalar model-vs-test errors of validation.json kept in the catalog (relative errors).
VALIDATION_ERRORS = ("fuel_error", "soc_delta_error", "soc_final_error")


def _validation_summary(val: dict) -> dict:
    """Scalars of validation.json for the catalog, with ``errors`` = the relative errors."""
    out = {k: v for k, v in val.items() if isinstance(v, (int, float, str, bool)) or v is None}
    errors = val.get("errors") if isinstance(val.get("errors"), dict) else {
        k: val.get(k) for k in VALIDATION_ERRORS if k in val}
    if errors:
        out["errors"] = errors
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
    from vehval.io.importer import import_test

    template = _template(job["template"], job.get("template_hash", ""))
    vehicle = _vehicle(job.get("vehicle"), job.get("vehicle_hash", ""))
    test = import_test([Path(f) for f in job["files"]], template, test_id=job["test_id"])
    if not test.meta.test_id:
        test.meta.test_id = job["test_id"]
    result["vehicle"] = job.get("vehicle_name") or test.meta.vehicle or None
    result["cycle"] = test.meta.cycle or job.get("cycle") or None
    outputs: dict[str, Any] = {}
    report_parts: dict[str, Any] = {}
    qa = None
    work = test  # what the later steps see: the QA-validated test once QA ran
    for step in job["steps"]:
        fn = step_function(step)
        if step == "qa":
            qa = fn(test, vehicle, template)
            work = getattr(qa, "validated", None) or test
            out = jsonable(qa)
        elif step == "analyze":
            if qa is not None:
                from vehval.analysis.inputs import after_qa
                res = fn(after_qa(qa, test)[0], vehicle)
            else:
                res = fn(work, vehicle)
            out = jsonable(res)
            report_parts["control"] = out
        else:
            if vehicle is None:
                raise ConfigError("step 'validate' needs a vehicle model: pass --vehicle or set "
                                  f"'vehicle:' in {Path(job['template']).name}")
            res = fn(work, vehicle)
            out = jsonable(res)
            report_parts["validation"] = (jsonable(res.payload()) if hasattr(res, "payload")
                                          else out)
        outputs[step] = out
        write_text_atomic(stage / STEP_OUTPUT[step], dump_json(out))
    qa_dict = outputs.get("qa") or {}
    result["metrics"] = test_metrics(test, _selected(qa_dict) if qa_dict else None)
    if qa_dict:
        result["findings"] = _compact_findings(qa_dict)
        result["findings_by_severity"] = _by_severity(result["findings"])
        result["qa_summary"] = qa_dict.get("summary")
    if "validate" in outputs and isinstance(outputs["validate"], dict):
        result["validation"] = _validation_summary(outputs["validate"])
    if job.get("report"):
        build = _resolve(*_REPORT, what="the HTML report (use --no-report)")
        from vehval.report import write_plotly_asset

        # one plotly.js for the whole batch (OUTDIR/assets/), not 4.8 MB in every report;
        # written here rather than by the driver so a remote worker's plotly version is used
        asset = write_plotly_asset(Path(job["outdir"]) / ASSETS_DIR)
        build(stage, work, qa, template=template, vehicle=vehicle,
              control=report_parts.get("control"), validation=report_parts.get("validation"),
              title=f"vehval test {job['test_id']}",
              plotly_js=f"../../{ASSETS_DIR}/{asset.name}")  # from tests/<test_id>/


def process_test(job: dict) -> dict:
    """Process one test of a batch and write its outputs.

    Parameters
    ----------
    job : dict
        ``test_id``, ``files`` (paths), ``file_hashes``, ``input_hash``, ``run_id``,
        ``template`` (path), ``vehicle`` (name or path, or None), ``steps``, ``report``
        (bool), ``outdir``.

    Returns
    -------
    dict
        The content of ``result.json``: status ``ok`` or ``failed`` with ``error``,
        ``error_type`` and ``error_kind`` (``user`` for a :class:`VehvalError`, ``internal``
        otherwise), metrics, compact findings, timing and provenance.
    """
    from vehval import __version__

    t_start = time.perf_counter()
    test_dir = Path(job["outdir"]) / "tests" / job["test_id"]
    (test_dir / RESULT_NAME).unlink(missing_ok=True)
    result: dict[str, Any] = {
        "result_schema": RESULT_SCHEMA, "test_id": job["test_id"], "run_id": job["run_id"],
        "status": "ok", "error": None, "error_type": None, "error_kind": None,
        "input_hash": job["input_hash"], "file_hashes": job.get("file_hashes", {}),
        "files": [str(f) for f in job["files"]], "vehicle": job.get("vehicle_name"),
        "cycle": None, "steps": list(job["steps"]), "vehval_version": __version__,
        "started": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        "metrics": {}, "findings": [], "findings_by_severity": {}, "qa_summary": None,
        "validation": None, "outputs": [],
    }
    try:
        with atomic_dir(test_dir) as stage:
            _run_steps(job, stage, result)
            outputs = sorted(str(p.relative_to(stage)) for p in stage.rglob("*") if p.is_file())
        result["outputs"] = outputs
        _clear_stale(test_dir, keep=set(outputs) | {p.split("/")[0] for p in outputs} | {RESULT_NAME})
    except VehvalError as exc:
        result.update(status="failed", error=str(exc), error_type=type(exc).__name__, error_kind="user")
    except Exception as exc:  # noqa: BLE001 - a bug must not stop the batch; it is recorded
        result.update(status="failed", error=f"{type(exc).__name__}: {exc}",
                      error_type=type(exc).__name__, error_kind="internal",
                      traceback=traceback.format_exc(limit=8))
    if result["status"] == "failed":
        _clear_stale(test_dir, keep={RESULT_NAME})
        result["outputs"] = []
    result["elapsed_s"] = time.perf_counter() - t_start
    write_text_atomic(test_dir / RESULT_NAME, dump_json(result))
    return jsonable(result)
