"""Batch driver: discover tests, skip unchanged ones, run the rest on Dask, fill the catalog.

The driver alone writes the catalog (workers return their results), so DuckDB never sees
two writers. Each test's outputs are written by the task itself under
``OUTDIR/tests/<test_id>/`` with ``result.json`` last, so an interrupted batch resumes: a
rerun skips every test whose ``result.json`` carries the same input hash.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import logging
import os
import re
import secrets
import sys
import warnings
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import Any, Callable

from vehval.batch.discover import (
    ASSETS_DIR,
    CATALOG_NAME,
    INDEX_NAME,
    OUTPUT_NAMES,
    SET_VERDICT_NAME,
    TESTS_DIR,
    TestSpec,
    discover_tests,
    file_sha256,
    folder_inputs,
    hash_spec,
    settings_hash,
)
from vehval.batch.task import (
    DEFAULT_TEST_TIMEOUT_S,
    RESULT_NAME,
    check_steps,
    jsonable,
    process_test,
    result_digest,
)
from vehval.catalog import open_catalog
from vehval.errors import ConfigError, VehvalError
from vehval.io.atomic import sweep_debris
from vehval.io.paths import inside

#: Local worker processes allowed per CPU: each is a process with its own imports and
#: memory; past a few per CPU they only wait for the CPUs (and thousands never start).
MAX_WORKERS_PER_CPU = 4
#: Temporaries of earlier vehval versions (``.<name>.<8 random>.tmp``, no process id).
_LEGACY_TMP = re.compile(r"^\..+\.[a-z0-9_]{8}\.tmp$")


@dataclass
class BatchSummary:
    """What a batch run did."""

    run_id: str
    outdir: Path
    n_ok: int = 0
    n_failed: int = 0
    n_skipped: int = 0
    status: str = "done"
    results: list[dict] = field(default_factory=list)
    #: (path, reason) of input entries not taken as tests (symlink loops, unreadable...).
    skipped_inputs: list[tuple[str, str]] = field(default_factory=list)
    #: (path, reason) of entries skipped as expected (the output folder inside DIR).
    notes: list[tuple[str, str]] = field(default_factory=list)
    #: Debris of interrupted runs removed at the start (staging folders, temporaries).
    n_debris_removed: int = 0
    #: Tests of earlier runs whose files are all gone (deleted or renamed), recorded as
    #: ``removed`` in this run (:meth:`vehval.catalog.Catalog.mark_removed`).
    removed: list[str] = field(default_factory=list)
    #: Set verdicts over the validated tests, one per vehicle
    #: (:func:`vehval.batch.verdicts.batch_set_verdicts`); empty without a validate step.
    set_verdicts: list[dict] = field(default_factory=list)

    @property
    def n_tests(self) -> int:
        return self.n_ok + self.n_failed + self.n_skipped


def check_workers(workers: int | None) -> int:
    """The number of local workers: ``workers`` when sane, else a :class:`ConfigError`.

    None means the CPU count; 0 a plain loop in this process; more than
    :data:`MAX_WORKERS_PER_CPU` per CPU is refused."""
    cpus = os.cpu_count() or 1
    if workers is None:
        return cpus
    top = MAX_WORKERS_PER_CPU * cpus
    if workers < 0:
        raise ConfigError(f"--workers {workers}: give 0 (a plain loop in this process) or a "
                          f"number of worker processes from 1 to {top}")
    if workers > top:
        raise ConfigError(f"--workers {workers}: at most {top} ({MAX_WORKERS_PER_CPU} x the "
                          f"{cpus} CPUs here): each worker is a process with its own memory and "
                          "imports, and more than that only wait for the CPUs")
    return workers


def check_test_timeout(seconds: float | None) -> float | None:
    """``--test-timeout``: a positive number of seconds, or None / 0 for no limit."""
    if seconds is None or seconds == 0:
        return None
    if not (0 < seconds < float("inf")):
        raise ConfigError(f"--test-timeout {seconds}: give a positive number of seconds "
                          "(0: no limit)")
    return float(seconds)


def remove_debris(out: Path) -> int:
    """Remove what interrupted runs left in ``out``: staging folders and temporaries of dead
    processes (``tests/``, ``assets/``, the index) and temporaries of earlier versions.
    Called with the catalog open, so no other batch is writing ``out``; returns the count."""
    removed = sweep_debris(out, depth=2)
    for d in (out, out / ASSETS_DIR, *sorted((out / TESTS_DIR).glob("*"))):
        if d.is_dir() and not d.is_symlink():
            for f in d.iterdir():
                if _LEGACY_TMP.match(f.name) and ".vehval-" not in f.name and f.is_file() and not f.is_symlink():
                    f.unlink(missing_ok=True)
                    removed.append(f)
    return len(removed)


def new_run_id() -> str:
    """A sortable, unique run id: UTC time plus 6 random hex digits."""
    return datetime.now(timezone.utc).strftime("%Y%m%dT%H%M%S") + "-" + secrets.token_hex(3)


def _load_settings(template: str | Path, vehicle: str | None) -> tuple[Any, dict]:
    from vehval.io.template import load_template

    tpath = Path(template)
    tmpl = load_template(tpath)
    veh_name = vehicle or getattr(tmpl, "vehicle", None)
    veh_digest = ""
    if veh_name:
        from vehval.vehicle import load_vehicle

        veh = load_vehicle(veh_name)
        dump = veh.model_dump_json() if hasattr(veh, "model_dump_json") else repr(veh)
        veh_digest = hashlib.sha256(dump.encode()).hexdigest()
    tmpl_digest = hashlib.sha256(tpath.read_bytes()).hexdigest() if tpath.is_file() else \
        hashlib.sha256(repr(tmpl).encode()).hexdigest()
    return tmpl, {"template": str(tpath.resolve()) if tpath.exists() else str(template),
                  "template_hash": tmpl_digest, "vehicle": str(veh_name) if veh_name else None,
                  "vehicle_hash": veh_digest}


def _cached(outdir: Path, spec: TestSpec) -> dict | None:
    """The previous result of ``spec`` when it is complete and its inputs are unchanged."""
    path = outdir / TESTS_DIR / spec.test_id / RESULT_NAME
    try:
        res = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if not isinstance(res, dict) or res.get("input_hash") != spec.input_hash:
        return None
    # the file itself must be as written: an edited metric or status means a rerun
    if res.get("result_sha256") != result_digest(res):
        return None
    # the recorded outputs must still be there, unchanged (a deleted report.html or a
    # corrupted findings.json means the test runs again)
    hashes = res.get("output_hashes")
    if not isinstance(hashes, dict) or set(hashes) != set(res.get("outputs") or []):
        return None
    for rel, digest in hashes.items():
        f = path.parent / rel
        if not inside(f, path.parent) or not f.is_file():
            return None
        try:
            if file_sha256(f) != digest:
                return None
        except VehvalError:
            return None
    if res.get("status") == "ok" or (res.get("status") == "failed" and res.get("error_kind") == "user"):
        return res  # an internal error may be transient (a killed worker...): retried
    return None


def _lost(job: dict, exc: BaseException) -> dict:
    """Result for a task that never returned (worker died, cancelled...)."""
    return jsonable({"test_id": job["test_id"], "run_id": job["run_id"], "status": "failed",
                     "error": f"{type(exc).__name__}: {exc}", "error_type": type(exc).__name__,
                     "error_kind": "internal", "input_hash": job["input_hash"],
                     "file_hashes": job["file_hashes"], "files": job["files"],
                     "vehicle": job.get("vehicle_name"), "cycle": job.get("cycle"),
                     "metrics": {}, "findings": []})


#: Loggers that report a worker's connection closing while the local cluster stops.
SHUTDOWN_LOGGERS = ("distributed", "asyncio", "tornado")


def shutdown(client: Any, cluster: Any = None) -> None:
    """Close the Dask client and the local cluster, quietly.

    When the scheduler stops while a worker still sends a heartbeat, distributed logs (or
    raises) ``CommClosedError``: harmless once every result is in, but it printed a traceback
    after about one run in twenty. The loggers stay at CRITICAL from here on (the process is
    ending the batch), and a connection error raised by ``close`` is ignored.
    """
    from distributed.comm.core import CommClosedError

    for name in SHUTDOWN_LOGGERS:
        logging.getLogger(name).setLevel(logging.CRITICAL)
    for close in (getattr(client, "close", None), getattr(cluster, "close", None)):
        if close is None:
            continue
        try:
            close()
        except (CommClosedError, OSError, TimeoutError):
            pass


#: Dask settings of the private cluster's workers when no dashboard is asked for: the
#: workers' statistical profiler (a stack sample every 10 ms, shown only on the dashboard)
#: costs about 10 % of a fleet run's simulation time on 2 workers; as environment variables
#: for workers started by hand (docs/fleet.md)
THROUGHPUT_CONFIG = {"distributed.worker.profile.enabled": False}
THROUGHPUT_ENV = {"DASK_DISTRIBUTED__WORKER__PROFILE__ENABLED": "False"}


def local_cluster(workers: int, *, dashboard: bool = False):
    """A private local Dask cluster: TLS on loopback with temporary credentials.

    The scheduler and workers listen on 127.0.0.1 over ``tls://``; every connection must
    present a certificate signed by a certificate authority created for this cluster only
    (``distributed.Security.temporary()``: in memory, never written to disk), so another user
    or process on the machine cannot submit work to it or read its results. The dashboard
    (an HTTP server) is started only when ``dashboard`` is true, on a free loopback port.
    Returns ``(client, cluster)``.
    """
    import dask
    from distributed import Client, LocalCluster, Security

    security = Security.temporary()
    # the scheduler always runs a small HTTP server: bind it to loopback on a free port and,
    # without --dashboard, give it no route at all (no /info, /health, /metrics)
    routes: dict[str, Any] = ({} if dashboard else
                              {"distributed.scheduler.http.routes": [], **THROUGHPUT_CONFIG})
    with warnings.catch_warnings(), dask.config.set(routes):
        warnings.filterwarnings("ignore", message="Port 8787 is already in use")
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                               protocol="tls://", security=security, host="127.0.0.1",
                               dashboard_address="127.0.0.1:0",
                               scheduler_kwargs={"dashboard": dashboard},
                               silence_logs=logging.ERROR)
    return Client(cluster, security=security), cluster


def _client(workers: int, scheduler: str | None, dashboard: bool = False):
    """A Dask client on ``scheduler`` or on a new private local cluster; returns (client, cluster)."""
    from distributed import Client

    if scheduler:
        try:
            return Client(scheduler, timeout="15s"), None
        except (OSError, TimeoutError, ValueError, MemoryError) as exc:
            raise VehvalError(f"cannot connect to the Dask scheduler at '{scheduler}': {exc} "
                              "(check the address, e.g. tcp://127.0.0.1:8786)") from None
    return local_cluster(workers, dashboard=dashboard)


def _checked_options(workers: int | None, scheduler: str | None, test_timeout_s: float | None,
                     steps: list[str] | tuple[str, ...],
                     report: bool) -> tuple[int | None, float | None, list[str]]:
    """Workers, time limit [s] and steps of a batch, checked before anything is written."""
    if not scheduler:
        workers = check_workers(workers)
    else:                       # before anything is written: a server that is not Dask's
        from vehval.batch.scheduler import check_scheduler
        check_scheduler(scheduler)
    test_timeout_s = check_test_timeout(test_timeout_s)
    steps = [s.strip() for s in steps if s and s.strip()]
    if len(set(steps)) != len(steps):
        raise ConfigError(f"a step is repeated in --steps: {','.join(steps)}")
    check_steps(steps, report)
    return workers, test_timeout_s, steps


def _own_outputs(target: str | Path, out: Path, tmpl: Any) -> tuple[list[Path], list[tuple[str, str]]]:
    """The batch's own outputs (never tests, even with OUTDIR inside or equal to DIR) and
    the notes of checking that OUTDIR is no test (a later batch of DIR with another OUTDIR
    skips them too: :func:`vehval.batch.discover.earlier_output`)."""
    own = [out / name for name in OUTPUT_NAMES]
    notes: list[tuple[str, str]] = []
    if not (Path(target).is_dir() and inside(target, out)):
        own.append(out)
        _check_outdir_not_a_test(target, out, tmpl, own, notes)
    return own, notes


def _discover(target: str | Path, tmpl: Any, own: list[Path], digest: str,
              notes: list[tuple[str, str]]) -> tuple[list[TestSpec], list[tuple[Path, str]]]:
    """The batch's tests (hashed) and the inputs skipped; an earlier batch's output is added
    to ``notes`` (not a test, not an error)."""
    skipped: list[tuple[Path, str]] = []
    earlier: list[tuple[Path, str]] = []
    specs = [hash_spec(s, digest)
             for s in discover_tests(target, tmpl, exclude=own, skipped=skipped, notes=earlier)]
    notes += [(str(p), why) for p, why in earlier]
    return specs, skipped


def run_batch(target: str | Path, template: str | Path, outdir: str | Path, *,
              vehicle: str | None = None, steps: list[str] | tuple[str, ...] = ("qa",),
              workers: int | None = None, scheduler: str | None = None, report: bool = True,
              force: bool = False, progress: bool = True, cycle: str | None = None,
              on_result: Callable[[dict], None] | None = None,
              dashboard: bool = False,
              test_timeout_s: float | None = DEFAULT_TEST_TIMEOUT_S) -> BatchSummary:
    """Run many tests at once.

    Parameters
    ----------
    target : str or Path
        Directory of tests or glob (see :func:`vehval.batch.discover.discover_tests`).
    template : str or Path
        Import template YAML.
    outdir : str or Path
        Output directory: ``tests/<id>/``, ``catalog.duckdb``, ``index.html``. With a
        remote scheduler it must be reachable by the workers at the same path.
    vehicle : str, optional
        Vehicle name or file; default the template's ``vehicle``.
    steps : sequence of str
        Steps after import, among ``qa``, ``analyze``, ``validate``.
    workers : int, optional
        Local worker processes (default: CPU count); 0 runs a plain loop in this process;
        at most :data:`MAX_WORKERS_PER_CPU` per CPU.
    scheduler : str, optional
        Address of an existing ``dask.distributed`` scheduler (``workers`` is then unused).
    report : bool
        Build each test's HTML report.
    force : bool
        Recompute every test even when unchanged.
    progress : bool
        Show a progress bar.
    cycle : str, optional
        Cycle name recorded for tests whose metadata names none (the importer does not
        know the cycle of a raw file).
    on_result : callable, optional
        Called with each result dict as it lands (driver side).
    dashboard : bool
        Start the Dask dashboard of the local cluster (loopback, free port; its address is
        printed). Off by default: the cluster then opens no HTTP port at all.
    test_timeout_s : float, optional
        Limit of one test's processing time [s] (default 600; None or 0: none). A test past
        it is recorded as failed (error kind ``timeout``) and the batch goes on.

    Returns
    -------
    BatchSummary
        Counts, results, and the input entries skipped with their reasons.
    """
    workers, test_timeout_s, steps = _checked_options(workers, scheduler, test_timeout_s,
                                                      steps, report)
    tmpl, settings = _load_settings(template, vehicle)
    if "validate" in steps and not settings["vehicle"]:
        raise ConfigError("step 'validate' needs a vehicle model: pass --vehicle or set "
                          f"'vehicle:' in the template {template}")
    from vehval import __version__

    settings.update(steps=steps, report=bool(report), cycle=cycle, vehval_version=__version__)
    digest = settings_hash(settings)
    out = Path(outdir).resolve()
    own, notes = _own_outputs(target, out, tmpl)
    specs, skipped = _discover(target, tmpl, own, digest, notes)
    out.mkdir(parents=True, exist_ok=True)
    run_id = new_run_id()
    summary = BatchSummary(run_id=run_id, outdir=out, notes=notes,
                           skipped_inputs=[(str(p), why) for p, why in skipped])
    veh_name = getattr(tmpl, "vehicle", None) if not vehicle else vehicle
    catalog = open_catalog(out / CATALOG_NAME)
    try:
        # the catalog is open (DuckDB's lock): no other batch writes OUTDIR, so what a killed
        # run left (staging folders, temporaries) is debris
        summary.n_debris_removed = remove_debris(out)
        catalog.start_run(run_id, {**settings, "target": str(target), "outdir": str(out),
                                   "workers": workers, "scheduler": scheduler, "force": force,
                                   "test_timeout_s": test_timeout_s,
                                   "skipped_inputs": [{"path": p, "reason": r}
                                                      for p, r in summary.skipped_inputs]})
        summary.removed = catalog.mark_removed(run_id, {s.test_id for s in specs})
        jobs = _plan(catalog, run_id, specs, out, force, summary,
                     {"run_id": run_id, "outdir": str(out), "steps": steps,
                      "report": bool(report), "vehicle_name": veh_name,
                      "test_timeout_s": test_timeout_s, **settings})

        def record(res: dict) -> None:
            catalog.add_result(run_id, res)
            if res.get("status") == "ok":
                summary.n_ok += 1
            else:
                summary.n_failed += 1
            summary.results.append({**res, "batch_status": res.get("status")})
            if on_result is not None:
                on_result(res)

        try:
            _execute(jobs, record, workers, scheduler, progress, len(specs), summary.n_skipped,
                     dashboard)
        except BaseException as exc:  # record how the run ended, then let it propagate
            summary.status = "interrupted" if isinstance(exc, KeyboardInterrupt) else "failed"
            with contextlib.suppress(Exception):    # never hide why the run stopped
                catalog.finish_run(run_id, summary.status)
            raise
        if "validate" in steps:
            _set_verdicts(catalog, run_id, summary)
        catalog.finish_run(run_id, "done")
        from vehval.batch.index import write_index

        write_index(out / INDEX_NAME, catalog, run_id)
    finally:
        catalog.close()
    return summary


def _plan(catalog: Any, run_id: str, specs: list[TestSpec], out: Path, force: bool,
          summary: BatchSummary, common: dict) -> list[dict]:
    """Record the unchanged tests as ``skipped`` (unless ``force``); return the jobs of the
    others (``common`` holds the keys every job shares)."""
    jobs = []
    for spec in specs:
        cached = None if force else _cached(out, spec)
        if cached is not None:
            catalog.add_result(run_id, cached, status="skipped")
            summary.n_skipped += 1
            summary.results.append({**cached, "batch_status": "skipped"})
            continue
        jobs.append({"test_id": spec.test_id, "files": [str(f) for f in spec.files],
                     "file_hashes": spec.file_hashes, "input_hash": spec.input_hash, **common})
    return jobs


def _set_verdicts(catalog: Any, run_id: str, summary: BatchSummary) -> None:
    """The set verdicts over the run's validated tests: in the summary, the catalog's
    ``set_verdicts`` table and ``OUTDIR/set_verdict.json``."""
    from vehval.batch.verdicts import batch_set_verdicts
    from vehval.io.atomic import write_text_atomic
    from vehval.jsonsafe import dumps

    summary.set_verdicts = batch_set_verdicts(summary.results)
    catalog.add_set_verdicts(run_id, summary.set_verdicts)
    write_text_atomic(summary.outdir / SET_VERDICT_NAME,
                      dumps({"run_id": run_id, "set_verdicts": summary.set_verdicts}))


def _check_outdir_not_a_test(target: str | Path, out: Path, tmpl: Any, own: list[Path],
                             notes: list[tuple[str, str]]) -> None:
    """An output folder that is one of DIR's test folders would silently drop that test:
    refuse it when it holds input files, else note it as skipped (the output folder)."""
    root = Path(target)
    if not root.is_dir():
        return
    root = root.resolve()
    if out == root or not inside(out, root) or out.parent != root:
        return
    if out.is_dir():
        files = folder_inputs(out, tmpl, root, [o for o in own if o != out])
        if files:
            raise ConfigError(f"output folder {out} is test folder '{out.name}' of {root} "
                              f"(it holds {len(files)} input file(s) such as {files[0].name}): "
                              "choose an output folder outside the input folder or a new one")
    notes.append((str(out), "the batch's output folder"))


def _execute(jobs: list[dict], record: Callable[[dict], None], workers: int | None,
             scheduler: str | None, progress: bool, total: int, done: int,
             dashboard: bool = False) -> None:
    from vehval.progress import bar as progress_bar

    bar = progress_bar("[bold]batch", extra=("{task.fields[last]}",), disable=not progress,
                       transient=False)
    with bar:
        task = bar.add_task("batch", total=total, completed=done, last="")

        def land(res: dict) -> None:
            record(res)
            mark = "ok" if res.get("status") == "ok" else "FAILED"
            bar.update(task, advance=1, last=f"{res['test_id']} {mark}")

        if not jobs:
            return
        if workers is None:
            workers = check_workers(None)
        # a plain loop when asked, or when a local cluster cannot pay off (a single test:
        # starting workers and their cold imports cost more than the test itself)
        if not scheduler and (workers <= 0 or len(jobs) == 1):
            for job in jobs:
                land(process_test(job))
            return
        from distributed import as_completed

        client, cluster = _client(workers, scheduler, dashboard)
        if dashboard and getattr(client, "dashboard_link", None):
            print(f"Dask dashboard: {client.dashboard_link}", file=sys.stderr)
        try:
            futs = {client.submit(process_test, job, key=f"vehval-{job['run_id']}-{job['test_id']}",
                                  pure=False): job for job in jobs}
            for fut in as_completed(list(futs)):
                try:
                    res = fut.result()
                except Exception as exc:  # noqa: BLE001 - a lost task is recorded, not fatal
                    res = _lost(futs[fut], exc)
                land(res)
        except BaseException:
            for f in futs if "futs" in locals() else ():
                f.cancel()
            raise
        finally:
            shutdown(client, cluster)
