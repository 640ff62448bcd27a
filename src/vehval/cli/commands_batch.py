"""`vehval batch` (many tests on Dask) and `vehval catalog query|summary` (the results catalog)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Optional

import typer

from vehval.cli.app import app
from vehval.cli.options import bounded, output_dir

catalog_app = typer.Typer(help="Query the results catalog (OUTDIR/catalog.duckdb).",
                          no_args_is_help=True)
app.add_typer(catalog_app, name="catalog")


@app.command("batch")
def batch_cmd(
    target: str = typer.Argument(..., help="Directory of tests (one subdirectory per test, or one "
                                 "file per test for a single-file template) or a quoted glob."),
    template: Path = typer.Option(..., "--template", "-t", help="Import template YAML."),
    outdir: Path = typer.Option(..., "--outdir", "-o", callback=output_dir, help="Output directory."),
    vehicle: Optional[str] = typer.Option(None, "--vehicle", help="Vehicle name or file "
                                          "(default: the template's vehicle)."),
    steps: str = typer.Option("qa", "--steps", help="Comma-separated steps: qa,analyze,validate "
                              "(empty for import only)."),
    workers: Optional[int] = typer.Option(None, "--workers", "-j", callback=bounded("workers"), help="Local worker processes "
                                          "(default: CPU count; 0 = plain loop, no Dask; at "
                                          "most 4 x CPU count)."),
    scheduler: Optional[str] = typer.Option(None, "--scheduler", help="Address of an existing "
                                            "dask.distributed scheduler, e.g. tcp://host:8786."),
    report: bool = typer.Option(True, "--report/--no-report", help="Build each test's HTML report."),
    cycle: Optional[str] = typer.Option(None, "--cycle", help="Cycle name recorded in the catalog "
                                        "for tests whose metadata names none."),
    force: bool = typer.Option(False, "--force", help="Recompute unchanged tests too."),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress bar."),
    dashboard: bool = typer.Option(False, "--dashboard", help="Start the Dask dashboard of the "
                                   "local cluster (loopback, free port; off by default)."),
    test_timeout: float = typer.Option(600.0, "--test-timeout", callback=bounded("test_timeout"), help="Stop waiting for a test "
                                       "after this many seconds: it is recorded as failed and "
                                       "the batch goes on (0 = no limit)."),
) -> None:
    """Process many tests at once; rerun to resume: unchanged tests are skipped.

    Exit code 1: a test failed or an input was skipped; 4: every test ran but at least one
    headline was withheld for QA errors."""
    from vehval.batch import run_batch
    from vehval.io.paths import check_outputs, vehicle_path
    from vehval.io.template import check_cycle_name

    if cycle is not None:
        check_cycle_name(cycle, "--cycle")

    check_outputs(outdir=outdir, inputs=[template, vehicle_path(vehicle)],
                  writes=["index.html", "catalog.duckdb"])

    res = run_batch(target, template, outdir, vehicle=vehicle, steps=steps.split(","),
                    workers=workers, scheduler=scheduler, report=report, force=force,
                    progress=not quiet, cycle=cycle, dashboard=dashboard,
                    test_timeout_s=test_timeout)
    skipped = (f", {len(res.skipped_inputs)} input(s) skipped" if res.skipped_inputs else "")
    removed = f", {len(res.removed)} removed" if res.removed else ""
    typer.echo(f"run {res.run_id}: {res.n_ok} ok, {res.n_failed} failed, {res.n_skipped} unchanged"
               f"{removed}{skipped} -> {res.outdir / 'index.html'}")
    from vehval.batch.verdicts import verdict_line

    for row in res.set_verdicts:
        typer.echo(verdict_line(row))
    for path, why in res.notes:
        typer.echo(f"  not a test: {path} ({why})", err=True)
    for tid in res.removed:
        typer.echo(f"  removed {tid}: none of its files exists any more (deleted or renamed)",
                   err=True)
    for path, why in res.skipped_inputs:
        typer.echo(f"  skipped {path}: {why}", err=True)
    failed = [r for r in res.results if r.get("status") == "failed"]
    for r in failed:
        when = " (unchanged since an earlier run)" if r.get("batch_status") == "skipped" else ""
        typer.echo(f"  failed {r['test_id']}{when}: {r.get('error')}", err=True)
    from vehval.results.headline import NOT_A_HEADLINE

    held = []
    for r in res.results:
        head = (r.get("results") or {}).get("headline") or {}
        w = head.get("withheld")
        if r.get("status") == "failed" or not w or head.get("forced"):
            continue
        if w.get("rule") == NOT_A_HEADLINE:     # no figure to state, not a QA error
            typer.echo(f"  no headline {r['test_id']}: {w.get('reason')}", err=True)
            continue
        held.append(r)
        typer.echo(f"  withheld {r['test_id']}: headline {head.get('name')} "
                   f"({', '.join(w.get('signals') or [])}): {w.get('fix')}", err=True)
    if failed or res.skipped_inputs:
        raise typer.Exit(1)
    if held:
        from vehval.results.gate import EXIT_WITHHELD

        raise typer.Exit(EXIT_WITHHELD)


def _db(db: Optional[Path]) -> Path:
    return db if db is not None else Path("catalog.duckdb")


@catalog_app.command("query")
def catalog_query(
    sql: str = typer.Argument(..., help="SQL on tables runs, tests, findings, schema_info, "
                              "view latest_tests."),
    db: Optional[Path] = typer.Option(None, "--db", help="Catalog file (default ./catalog.duckdb)."),
    as_json: bool = typer.Option(False, "--json", help="Print a JSON list of row objects."),
    limit: int = typer.Option(10_000, "--limit", callback=bounded("query_rows"), help="Print at most this many rows (a line on "
                              "stderr says when more exist)."),
    timeout: float = typer.Option(30.0, "--timeout", callback=bounded("query_timeout"), help="Stop the query after this many "
                                  "seconds."),
) -> None:
    """Run one read-only SQL statement (SELECT or EXPLAIN) on the catalog and print the rows.

    No file, network or extension access; 2 GB memory budget."""
    from vehval.catalog import open_catalog

    with open_catalog(_db(db), read_only=True, timeout_s=timeout) as cat:
        res = cat.user_query(sql, limit=limit, timeout_s=timeout)
    if res.truncated:
        typer.echo(f"vehval: showing the first {limit} rows; the query returns more "
                   "(narrow it or raise --limit)", err=True)
    if as_json:
        from vehval.batch.task import jsonable

        typer.echo(json.dumps([jsonable(dict(zip(res.columns, r))) for r in res.rows], indent=1,
                              default=str))
        return
    _print_table(res.columns, [[_cell(v) for v in r] for r in res.rows])


def _cell(v, digits: int = 6) -> str:
    if v is None:
        return ""
    if isinstance(v, float):
        return f"{v:.{digits}g}"
    return str(v)


def _print_table(cols: list[str], rows: list[list[str]], group_by: tuple[str, ...] = ()) -> None:
    from vehval.cli.table import render

    typer.echo(render(cols, rows, group_by=group_by))


@catalog_app.command("summary")
def catalog_summary(
    db: Optional[Path] = typer.Option(None, "--db", help="Catalog file (default ./catalog.duckdb)."),
    as_json: bool = typer.Option(False, "--json", help="Print JSON."),
    timeout: float = typer.Option(30.0, "--timeout", callback=bounded("query_timeout"), help="Stop after this many seconds."),
) -> None:
    """Test-to-test variability per vehicle, cycle and test conditions (start, cell
    temperature band, A/C): n, mean, std, CV of the headline and the key metrics."""
    from vehval.catalog import open_catalog
    from vehval.errors import VehvalError

    if not (0 < timeout < float("inf")):
        raise VehvalError(f"--timeout {timeout}: give a positive number of seconds")
    from vehval.catalog import SUMMARY_METRICS, SUMMARY_METRICS_METRIC
    from vehval.display import system

    # the JSON keeps the documented metrics; the table reads in the display units
    shown = SUMMARY_METRICS_METRIC if system() == "metric" and not as_json else SUMMARY_METRICS
    with open_catalog(_db(db), read_only=True, timeout_s=timeout) as cat:
        rows = cat.summary(shown)
        from vehval.batch.verdicts import stored_set_verdicts

        verdicts = stored_set_verdicts(cat)
    if as_json:
        typer.echo(json.dumps(rows, indent=1))
        return
    from vehval.display import keyed_metric

    cols = ["vehicle", "cycle", "start", "cell", "a/c", "metric", "unit", "n", "mean", "std",
            "cv [%]", "min", "max"]
    table = []
    for r in rows:
        # the catalog is SI (fuel_energy_j 5.4e+07): shown in display units (53.9 MJ)
        name, unit = keyed_metric(r["metric"], magnitude=r["mean"])
        if unit is not None and unit.label in ("L/100 km", "kWh/100 km"):
            name = name.removesuffix("_l_per_100km").removesuffix("_kwh_per_100km")
        f, off = (unit.factor, unit.offset) if unit is not None else (1.0, 0.0)
        table.append([r["vehicle"], r["cycle"], r["start"], r["temperature_band"], r["ac"],
                      name, unit.label if unit is not None else "", str(r["n"]),
                      _cell(None if r["mean"] is None else r["mean"] * f + off, 5),
                      _cell(None if r["std"] is None else r["std"] * f, 4),
                      "" if r["cv"] is None else f"{100 * r['cv']:.2f}",
                      _cell(None if r["min"] is None else r["min"] * f + off, 5),
                      _cell(None if r["max"] is None else r["max"] * f + off, 5)])
    _print_table(cols, table, group_by=("vehicle", "cycle", "start", "cell", "a/c"))
    from vehval.batch.verdicts import verdict_line

    for row in verdicts:
        typer.echo(f"run {row['run_id']}: {verdict_line(row)}")
