"""`vehval validate` and `vehval calibrate`: the model against test data.

Test grouping (see :mod:`vehval.workflow`): each directory is one test, each
``.parquet`` file is one validated test, loose files together are one test, and
``--test A,B`` (repeatable) groups files explicitly.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Optional

import typer

from vehval.cli.app import app
from vehval.cli.options import bounded, output_dir
from vehval.errors import ConfigError
from vehval.io.paths import check_outputs, sanitize_id, vehicle_path

#: the vehicle validated when neither --vehicle nor the test's template names one
DEFAULT_VEHICLE = "prius_2004"


def _pct(value, digits: int, unit: str = " %") -> str:
    """A percentage for the terminal; ``n/a`` when the test cannot give it (no fuel, no SOC)."""
    if value is None or not math.isfinite(float(value)):
        return "n/a"
    return f"{float(value):.{digits}f}{unit}"


def _cycle(cycle: str | None, rung: str | None = None) -> str:
    """``udds, high_transient``; ``no cycle identified`` instead of an empty name."""
    name = cycle or "no cycle identified"
    return f"{name}, {rung}" if rung and cycle else name


def _tolerances(fuel_tol: float, soc_tol: float, soc_points: float | None):
    from vehval.validate.ladder import Tolerances

    return Tolerances.from_mapping({"fuel_pct": fuel_tol, "soc_pct": soc_tol, "soc_points": soc_points})


@app.command("validate")
def validate_cmd(
    files: list[Path] = typer.Argument(None, help="Test directories, validated .parquet tests or the raw files of one test."),
    template: Path = typer.Option(None, "-t", "--template", help="Import template (default: template.yaml of each test directory)."),
    vehicle: Optional[str] = typer.Option(None, "--vehicle", help="Vehicle name or YAML path (default: the template's vehicle, else prius_2004)."),
    output: Path = typer.Option(..., "-o", "--output", callback=output_dir, help="Output directory (written atomically)."),
    test_group: list[str] = typer.Option([], "--test", metavar="A,B", help="Files (comma-separated) of one test; repeatable."),
    dt: float = typer.Option(0.1, "--dt", callback=bounded("dt"), help="Simulation step (s)."),
    window_s: float = typer.Option(2.0, "--window", callback=bounded("window"), help="Engine start/stop matching window (s)."),
    fuel_tol: float = typer.Option(5.0, "--fuel-tol", callback=bounded("tolerance_pct"), help="Ladder tolerance on the fuel error (%)."),
    soc_tol: float = typer.Option(5.0, "--soc-tol", callback=bounded("tolerance_pct"), help="Ladder tolerance on the SOC error (%) (relative error of final SOC)."),
    soc_points: float = typer.Option(None, "--soc-points", callback=bounded("soc_points"), help="Optional tolerance on the ΔSOC mismatch (SOC points)."),
    smooth_hz: float = typer.Option(None, "--smooth-hz", callback=bounded("smooth_hz"), help="Low-pass the measured speed given to the driver at this cut-off (Hz; zero phase). Default: as measured."),
    no_qa: bool = typer.Option(False, "--no-qa", help="Use the imported signals without the QA pipeline."),
    report: bool = typer.Option(False, "--report", help="Also write report.html and tables.xlsx per test."),
    as_json: bool = typer.Option(False, "--json", help="Print the results as JSON."),
    model_u: str = typer.Option("linear", "--model-uncertainty", help="U_model of the normalised error: linear (the vehicle's parameter ranges one at a time), monte_carlo, or none (U_model = 0)."),
    draws: int = typer.Option(200, "--draws", callback=bounded("mc_sensitivity"), help="Monte Carlo draws (at least 100)."),
) -> None:
    """Simulate VEHICLE on each test's own conditions and compare: writes validation.json
    (report tables and overlay figures), metrics.json and overlays_<test>.parquet. Each test's
    verdict is its normalised error (|En| <= 1: consistent); the fixed tolerances are the
    secondary check (pass / FAIL)."""
    from vehval.io.atomic import atomic_dir
    from vehval.jsonsafe import dumps
    from vehval.workflow import runs_from_args, validate_each, validate_runs

    if not files and not test_group:
        raise ConfigError("no test given: name test directories or files, or use --test A,B")
    check_outputs(outdir=output, inputs=[*(files or []), template,
                                         vehicle_path(vehicle or DEFAULT_VEHICLE)],
                  writes=["validation.json", "metrics.json", "report.html", "tables.xlsx"])
    runs = runs_from_args(files or [], test_group, template, vehicle, use_qa=not no_qa)
    for run in runs:  # no --vehicle: the template's (a QA output keeps it in its metadata)
        if run.vehicle is None:
            from vehval.vehicle import load_vehicle

            run.vehicle = load_vehicle(run.test.meta.vehicle or DEFAULT_VEHICLE)
    from vehval.architectures import stages
    from vehval.cli.progress import bar

    if not stages(runs[0].vehicle).validate_suite:      # judged test by test
        with bar("validate: simulating tests", as_json=as_json):
            each = validate_each(runs, dt=dt, window_s=window_s, smooth_hz=smooth_hz)
        _write_each(each, output, report, runs, as_json)
        return
    with bar("validate: simulating tests", as_json=as_json):
        suite = validate_runs(runs, _tolerances(fuel_tol, soc_tol, soc_points), dt=dt,
                              window_s=window_s, smooth_hz=smooth_hz,
                              model_uncertainty=model_u.replace("-", "_"), draws=draws)
    metrics, lad = suite.metrics, suite.ladder
    with atomic_dir(output) as stage:      # every output of the run, reports included
        (stage / "validation.json").write_text(dumps(suite.payload), encoding="utf-8")
        (stage / "metrics.json").write_text(dumps(metrics), encoding="utf-8")
        for v in suite.validations:
            comp = v.validation.comparison
            comp.overlays.to_parquet(stage / f"overlays_{sanitize_id(comp.test_id)}.parquet",
                                     index=False)
        if report:   # + each test's own ladder row and En verdict
            _test_reports(stage, runs, suite.validations,
                          lambda tid: [*lad.tables(tid), lad.en_table(tid)])
    if as_json:
        typer.echo(dumps(metrics), nl=False)
        return
    for v in suite.validations:
        m = v.validation.match
        if m is not None and not m.matches:
            typer.echo(f"warning: {m.message()}", err=True)
    for e in lad.entries:
        en = ("En -" if e.en is None else f"En {e.en:+.2f}{'?' if e.uninformative else ''}")
        typer.echo(f"{e.test_id} ({_cycle(e.cycle, e.rung)}): fuel {_pct(e.errors['fuel_pct'], 2)}, "
                   f"SOC {_pct(e.errors['soc_pct'], 2)}, engine state agreement "
                   f"{_pct(e.errors['engine_on_agreement_pct'], 1)}: {en} {e.verdict}; "
                   f"tolerance {'pass' if e.passed else 'FAIL'}"
                   f"{' (in-sample)' if e.in_sample else ''}"
                   f"{'' if e.passed or not e.failures else ': ' + '; '.join(e.failures)}")
    typer.echo(lad.en_summary())
    typer.echo("tolerance (secondary check): " + lad.summary())
    typer.echo(f"wrote {output / 'validation.json'} and {output / 'metrics.json'}")


def _test_reports(stage: Path, runs: list, validations: list, extra: Any) -> None:
    """report.html (and tables.xlsx) of each test, in ``stage`` or ``stage/<test>`` when
    several: its validation section plus ``extra(test id)`` tables; a validated test from
    `vehval qa` / `analyze` adds its findings and control.json."""
    from vehval.report import results_beside

    for run, v in zip(runs, validations):
        tid = str(getattr(v.comparison, "test_id", "") or run.validated.meta.test_id)
        sub = stage if len(runs) == 1 else stage / sanitize_id(tid)
        found = results_beside(run.origin) if run.qa_outcome is None else {}
        payload = dict(v.payload())
        payload["tables"] = [*payload["tables"], *extra(tid)]
        run.report(sub, qa=found.get("findings"), control=found.get("control"),
                   validation=payload, title=f"Validation report: {tid}")


def _write_each(each: Any, output: Path, report: bool, runs: list, as_json: bool) -> None:
    """The outputs and the screen of tests validated one by one (an architecture without
    the tolerance ladder): validation.json, metrics.json, a report per test."""
    from vehval.io.atomic import atomic_dir
    from vehval.jsonsafe import dumps

    with atomic_dir(output) as stage:
        (stage / "validation.json").write_text(dumps(each.payload), encoding="utf-8")
        (stage / "metrics.json").write_text(dumps(each.metrics), encoding="utf-8")
        if report:
            _test_reports(stage, runs, each.validations, lambda tid: [])
    if as_json:
        typer.echo(dumps(each.metrics), nl=False)
        return
    for line in each.lines():
        typer.echo(line)
    typer.echo(f"wrote {output / 'validation.json'} and {output / 'metrics.json'}")


@app.command("calibrate")
def calibrate_cmd(
    files: list[Path] = typer.Argument(None, help="Tests to tune on (directories, .parquet tests or raw files of one test)."),
    template: Path = typer.Option(None, "-t", "--template", help="Import template (default: template.yaml of each test directory)."),
    vehicle: str = typer.Option("prius_2004", "--vehicle", help="Vehicle name or YAML path."),
    output: Path = typer.Option(..., "-o", "--output", callback=output_dir, help="Output directory (written atomically)."),
    test_group: list[str] = typer.Option([], "--test", metavar="A,B", help="Files of one tuning test; repeatable."),
    holdout: list[str] = typer.Option([], "--holdout", metavar="DIR_OR_A,B", help="A held-out test (directory, .parquet or comma-separated files); repeatable."),
    params: str = typer.Option("controller.engine_on_power_w,controller.soc_gain_w,controller.regen_fraction_max",
                               "--params", help="Comma-separated dotted parameters to tune (bare names mean controller.<name>)."),
    start: Path = typer.Option(None, "--start", help="JSON with start values (e.g. control.json of the analysis: its 'controller' mapping)."),
    dt: float = typer.Option(1.0, "--dt", callback=bounded("dt"), help="Simulation step during the search (s)."),
    popsize: int = typer.Option(8, "--popsize", callback=bounded("popsize"), help="Differential-evolution population multiplier."),
    maxiter: int = typer.Option(40, "--maxiter", callback=bounded("maxiter"), help="Differential-evolution generations (at most; it stops earlier once converged)."),
    seed: int = typer.Option(0, "--seed", callback=bounded("seed"), help="Seed of the search."),
    mode: str = typer.Option("traces", "--mode", help="Objective of the search: traces (recorded signals, default) or batch (summaries, parallel, faster)."),
    smooth_hz: float = typer.Option(None, "--smooth-hz", callback=bounded("smooth_hz"), help="Low-pass the measured speed given to the driver at this cut-off (Hz; zero phase). Default: as measured."),
    no_qa: bool = typer.Option(False, "--no-qa", help="Use the imported signals without the QA pipeline."),
    as_json: bool = typer.Option(False, "--json", help="Print calibration.json to stdout."),
) -> None:
    """Tune vehicle parameters on several tests and check them on held-out tests: writes
    calibration.json and vehicle_calibrated.yaml (tuned values with their provenance)."""
    from vehval.architectures import require
    from vehval.cli.progress import bar
    from vehval.io.atomic import atomic_dir
    from vehval.jsonsafe import dumps
    from vehval.vehicle import load_vehicle
    from vehval.workflow import calibration_runs

    if not files and not test_group:
        raise ConfigError("no tuning test given: name test directories or files, or use --test A,B")
    check_outputs(outdir=output, inputs=[*(files or []), template, vehicle_path(vehicle), start],
                  writes=["calibration.json", "vehicle_calibrated.yaml"])
    veh = load_vehicle(vehicle)

    def load(per_file: bool, use_qa: bool) -> tuple[list, list]:
        return calibration_runs(files or [], test_group, holdout, template, veh,
                                per_file=per_file, use_qa=use_qa and not no_qa)

    opts = {"params": params, "start": start, "template": template, "dt": dt,
            "popsize": popsize, "maxiter": maxiter, "seed": seed, "mode": mode,
            "smooth_hz": smooth_hz}
    cal = require(veh, "calibrate")(veh, load, opts, lambda label: bar(label, as_json=as_json))
    with atomic_dir(output) as stage:
        cal.write(stage)
    if as_json:
        typer.echo(dumps(cal.document), nl=False)
        return
    for line in cal.lines:
        typer.echo(line)
    typer.echo(f"wrote {output / 'calibration.json'} and {output / 'vehicle_calibrated.yaml'}")
