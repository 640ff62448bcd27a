"""Run the fleet (:mod:`vehval.epa.fleet`) over lists into an output folder; resumable, on Dask.

``OUTDIR`` receives:

* ``cars/*.json``: each car's row records, stored as the cars land (every
  :data:`FLUSH_CARS` cars, and when the run ends or is interrupted), under the car's digest
  (a hash of its specs, rows, step and the vehval version); a rerun loads every car stored
  and runs only the others (``force`` runs all);
* ``fleet.duckdb``: table ``fleet_rows`` (one row per list row: run, not run or failed, with
  its error and the baseline's) and table ``baseline`` (model against the ridge regression
  per procedure and scheme);
* ``fleet.json``: the summary (:func:`vehval.epa.fleet_summary.summarise` and the
  baseline, the run's counts, rows per minute);
* ``fleet.html``: the report (:mod:`vehval.report.fleet_page`).

The jobs run on a private local Dask cluster by default (the batch's TLS cluster,
:func:`vehval.batch.runner.local_cluster`), on an existing scheduler with ``scheduler``
(checked first: :func:`vehval.batch.scheduler.check_scheduler`), or in a plain loop with
``workers`` 0 or 1.
"""

from __future__ import annotations

import json
import os
import time
from pathlib import Path
from typing import Any, Callable, Sequence

from vehval.epa.fleet import ROW_COLUMNS, CarJob, plan_fleet, predict_jobs, read_fleet, relabel, training_jobs
from vehval.epa.fleet_baseline import (
    BASELINE_KEYS,
    BOOSTED_KEYS,
    RESIDUAL_KEYS,
    RESIDUAL_VERDICT_KEYS,
    cross_validate,
)
from vehval.epa.fleet_summary import summarise
from vehval.errors import ConfigError
from vehval.io.atomic import atomic_path, write_text_atomic
from vehval.jsonsafe import dumps

DB_NAME, JSON_NAME, HTML_NAME, CARS_DIR = "fleet.duckdb", "fleet.json", "fleet.html", "cars"
#: columns the baseline adds to a row record
BASELINE_COLUMNS = (*BASELINE_KEYS, *BOOSTED_KEYS, *RESIDUAL_KEYS, *RESIDUAL_VERDICT_KEYS)
_INT = {"year", "procedure_code", "gears", "cylinders", "trace_n_miss"}
_BOOL = {"judged", "list_doubtful", "in_sample"}
_TEXT = {"row_id", "list", "source", "car", "make", "model", "vehicle_id", "config",
         "test_number", "originator", "procedure", "fuel", "fuel_family", "transmission",
         "transmission_class", "aspiration", "status", "reason_code", "reason",
         "coefficients"}


def _sql_type(col: str) -> str:
    return ("BIGINT" if col in _INT else "BOOLEAN" if col in _BOOL
            else "VARCHAR" if col in _TEXT else "DOUBLE")


#: cars buffered before their records are written to the store (one file per flush: a
#: file per car would cost more in file-system work than the car's simulation)
FLUSH_CARS = 100


def _load_store(out: Path) -> dict[str, dict[str, Any]]:
    """Every car stored under ``OUTDIR/cars``: digest -> {key, records} (unreadable files
    are skipped: their cars run again)."""
    done: dict[str, dict[str, Any]] = {}
    for path in sorted((out / CARS_DIR).glob("*.json")):
        try:
            done.update(json.loads(path.read_text(encoding="utf-8")).get("cars", {}))
        except (OSError, ValueError, AttributeError):
            continue
    return done


class _Store:
    """Buffered writer of landed cars into ``OUTDIR/cars/<run>-<n>.json``."""

    def __init__(self, out: Path) -> None:
        import secrets

        self.dir, self.tag, self.n = out / CARS_DIR, secrets.token_hex(4), 0
        self.buf: dict[str, dict[str, Any]] = {}

    def add(self, job: CarJob, recs: list[dict[str, Any]]) -> None:
        self.buf[job.digest] = {"key": job.key, "records": recs}
        if len(self.buf) >= FLUSH_CARS:
            self.flush()

    def flush(self) -> None:
        if self.buf:
            self.n += 1
            write_text_atomic(self.dir / f"{self.tag}-{self.n:05d}.json",
                              dumps({"cars": self.buf}, indent=None))
            self.buf = {}


def write_duckdb(path: Path, records: Sequence[dict[str, Any]], baseline: dict[str, Any]) -> None:
    """Tables ``fleet_rows`` and ``baseline`` into a new DuckDB file (atomically)."""
    import duckdb

    cols = [*ROW_COLUMNS, *BASELINE_COLUMNS]
    with atomic_path(path) as tmp:
        tmp.unlink(missing_ok=True)  # DuckDB makes its own file
        con = duckdb.connect(str(tmp))
        try:
            con.execute("CREATE TABLE fleet_rows ("
                        + ", ".join(f'"{c}" {_sql_type(c)}' for c in cols) + ")")
            if records:  # one bulk insert (executemany costs ~10 ms a row)
                import pandas as pd

                frame = pd.DataFrame([[r.get(c) for c in cols] for r in records], columns=cols,
                                     dtype=object)  # None stays NULL (not NaN)
                con.register("fleet_frame", frame)
                con.execute("INSERT INTO fleet_rows SELECT "
                            + ", ".join(f'CAST("{c}" AS {_sql_type(c)})' for c in cols)
                            + " FROM fleet_frame")
                con.unregister("fleet_frame")
            con.execute("CREATE TABLE baseline (scheme VARCHAR, procedure VARCHAR, n BIGINT, "
                        "model_median_abs_error DOUBLE, baseline_median_abs_error DOUBLE, "
                        "model_share_within_5pct DOUBLE, baseline_share_within_5pct DOUBLE, "
                        "model_better BOOLEAN, residual_median_abs_error DOUBLE, "
                        "residual_share_within_5pct DOUBLE, boosted_median_abs_error DOUBLE, "
                        "boosted_share_within_5pct DOUBLE, residual_better BOOLEAN)")
            base = [[scheme, proc, d["model"]["n"], d["model"]["median_abs_error"],
                     d["baseline"]["median_abs_error"], d["model"]["share_within_5pct"],
                     d["baseline"]["share_within_5pct"], d["model_better"],
                     d["physics_residual"]["median_abs_error"],
                     d["physics_residual"]["share_within_5pct"],
                     d["boosted"]["median_abs_error"], d["boosted"]["share_within_5pct"],
                     d["residual_better"]]
                    for scheme, procs in baseline.items() for proc, d in procs.items()]
            if base:
                con.executemany("INSERT INTO baseline VALUES (" + ", ".join("?" * 13) + ")",
                                base)
        finally:
            con.close()


def _execute(jobs: list[CarJob], workers: int, scheduler: str | None,
             land: Callable[[CarJob, list[dict[str, Any]]], None]) -> int:
    """Run ``jobs`` (loop, local cluster or ``scheduler``); returns the workers used."""
    if not jobs:
        return 0
    if not scheduler and workers <= 1:
        predict_jobs(jobs, None, land)
        return 1
    from vehval.batch.runner import _client, shutdown

    client, cluster = _client(workers, scheduler)
    try:
        n = len(client.scheduler_info().get("workers", {}))
        predict_jobs(jobs, client, land)
    finally:
        shutdown(client, cluster)
    return n


def _coefficient_sets(files: Sequence[str | Path], cross_year: bool) -> list[Any]:
    """The coefficient sets of a run: the files given (each checked: a bad file is one line
    naming it), then with ``cross_year`` the package's fits; none: the package's file."""
    from vehval.epa import technology as tech

    sets = [tech.load_coefficients(Path(f)) for f in files]
    if cross_year:
        given = {s.digest for s in sets}
        sets += [c for c in tech.packaged_fits() if c.digest not in given]
    return sets or [tech.load_coefficients()]


def _coefficients_used(sets: Sequence[Any], jobs: Sequence[CarJob]) -> list[dict[str, Any]]:
    """Per coefficient set: its file, the lists it was fitted on and the lists it judged."""
    out = []
    for c in sets:
        judged = sorted({j.key.split("|", 1)[0] for j in jobs if j.coefficients is c})
        out.append({"file": c.where, "fit_lists": list(c.fit_lists), "fit": c.header.get("fit"),
                    "lists_judged": judged,
                    "in_sample_lists": [x for x in judged if x in c.fit_lists]})
    return out


def run_fleet(paths: Sequence[str | Path], outdir: str | Path, *, workers: int | None = None,
              scheduler: str | None = None, force: bool = False, progress: bool = False,
              report: bool = True, coefficients: Sequence[str | Path] = (),
              cross_year: bool = False) -> dict[str, Any]:
    """Predict every runnable row of the lists ``paths`` into ``outdir``; returns the summary.

    ``coefficients``: technology coefficient files (default the package's); ``cross_year``:
    add the package's fits of every list year (:data:`vehval.epa.technology.PACKAGED_FITS`).
    Each list's cars are built with a set not fitted on that list when there is one
    (:func:`vehval.epa.technology.for_list`); the rows of a list fitted on are marked
    ``in_sample``.

    Raises
    ------
    ConfigError
        No runnable row in any list (naming the reasons), a bad ``workers`` or scheduler.
    InputFileError
        A list that cannot be read (naming the file and line).
    """
    from vehval.batch.runner import check_workers
    from vehval.progress import bar as progress_bar

    if scheduler:
        from vehval.batch.scheduler import check_scheduler
        check_scheduler(scheduler)
    else:
        workers = check_workers(workers)
    coef_sets = _coefficient_sets(coefficients, cross_year)
    tests, lists = read_fleet(paths)
    plan = plan_fleet(tests, coefficients=coef_sets)
    if not plan.jobs:
        from collections import Counter

        why = Counter(r["reason_code"] for r in plan.not_run).most_common()
        raise ConfigError(f"{', '.join(lists)}: no runnable row among {plan.n_rows} (not run: "
                          + (", ".join(f"{c} {n}" for c, n in why) or "the list is empty")
                          + "): the fleet runs conventional gasoline FTP-75, HWFET and US06 "
                          "rows with road-load coefficients and a measured result")
    out = Path(outdir)
    (out / CARS_DIR).mkdir(parents=True, exist_ok=True)
    records = list(plan.not_run)
    training: list[dict[str, Any]] = []  # fit the residual only (never judged nor written)
    extra = training_jobs(plan)
    for_training = {id(j) for j in extra}
    todo: list[CarJob] = []
    n_cached = 0
    done = {} if force else _load_store(out)
    for job in [*plan.jobs, *extra]:
        cached = done.get(job.digest)
        if cached is None or cached.get("key") != job.key:
            todo.append(job)
        else:
            (training if id(job) in for_training else records).extend(
                relabel(job, cached["records"]))
            n_cached += 1
    t0 = time.perf_counter()
    with progress_bar("[bold]fleet", disable=not progress, transient=False) as pbar:
        total = plan.n_to_run + sum(len(j.tests) for j in extra)
        task = pbar.add_task("fleet", total=total,
                             completed=total - sum(len(j.tests) for j in todo))

        store = _Store(out)

        def land(job: CarJob, recs: list[dict[str, Any]]) -> None:
            store.add(job, recs)
            (training if id(job) in for_training else records).extend(recs)
            pbar.update(task, advance=len(recs))

        try:
            used = _execute(todo, workers or 0, scheduler, land)
        finally:  # an interrupted run keeps the cars it finished
            store.flush()
    elapsed = time.perf_counter() - t0
    n_new = sum(len(j.tests) for j in todo)
    # list order first: the baseline's sums then do not depend on the order cars landed in
    for recs in (records, training):
        recs.sort(key=lambda r: (r["list"], int(r["source"].rsplit(":", 1)[1])))
    # the trees' fits in as many processes as the run has workers (a plain loop: here)
    baseline = cross_validate(records, training,
                              jobs=(os.cpu_count() or 1) if scheduler else max(workers or 1, 1))
    summary = {"lists": lists, **summarise(records), "baseline": baseline,
               "run": {"n_cars": len(plan.jobs), "n_cars_training": len(extra),
                       "n_cars_cached": n_cached,
                       "n_rows_simulated": n_new, "elapsed_s": elapsed,
                       "rows_per_minute": 60.0 * n_new / elapsed if n_new and elapsed else None,
                       "workers": used, "scheduler": scheduler, "dt_s": plan.jobs[0].dt},
               "coefficients": _coefficients_used(coef_sets, plan.jobs),
               "outputs": {"duckdb": DB_NAME, "json": JSON_NAME,
                           "html": HTML_NAME if report else None}}
    write_duckdb(out / DB_NAME, records, baseline)
    if report:
        from vehval.report.fleet_page import write_fleet_report

        write_fleet_report(out / HTML_NAME, records, summary)
    write_text_atomic(out / JSON_NAME, dumps(summary))
    return summary
