"""`vehval validate` and `vehval calibrate`: the model against test data.

Test grouping (see :mod:`vehval.workflow`): each directory is one test, each
``.parquet`` file is one validated test, loose files together are one test, and
``--test A,B`` (repeatable) groups files explicitly.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import typer

from vehval.cli.app import app
from vehval.cli.options import bounded, output_dir
from vehval.errors import ConfigError
from vehval.io.paths import check_outputs, sanitize_id, vehicle_path


def _pct(value, digits: int, unit: str = " %") -> str:
    """A percentage for the terminal; ``n/a`` when the test cannot give it (no fuel, no SOC)."""
    if value is None or not math.isfinite(float(value)):
        return "n/a"
    return f"{float(value):.{digits}f}{unit}"


def _cycle(cycle: str | None, rung: str | None = None) -> str:
    """``udds, high_transient``; ``no cycle identified`` instead of an empty name."""
    name = cycle or "no cycle identified"
    return f"{name}, {rung}" if rung and cycle else name


def _params(text: str | None) -> list[str]:
    if not text:
        return []
    return [p.strip() for p in text.split(",") if p.strip()]


def _tolerances(fuel_tol: float, soc_tol: float, soc_points: float | None):
    from vehval.validate.ladder import Tolerances

    return Tolerances.from_mapping({"fuel_pct": fuel_tol, "soc_pct": soc_tol, "soc_points": soc_points})


@app.command("validate")
def validate_cmd(
    files: list[Path] = typer.Argument(None, help="Test directories, validated .parquet tests or the raw files of one test."),
    template: Path = typer.Option(None, "-t", "--template", help="Import template (default: template.yaml of each test directory)."),
    vehicle: str = typer.Option("prius_2004", "--vehicle", help="Vehicle name or YAML path."),
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
    from vehval.workflow import runs_from_args, validate_runs

    if not files and not test_group:
        raise ConfigError("no test given: name test directories or files, or use --test A,B")
    check_outputs(outdir=output, inputs=[*(files or []), template, vehicle_path(vehicle)],
                  writes=["validation.json", "metrics.json", "report.html", "tables.xlsx"])
    runs = runs_from_args(files or [], test_group, template, vehicle, use_qa=not no_qa)
    from vehval.cli.progress import bar
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
        if report:
            from vehval.report import results_beside

            for run, v in zip(runs, suite.validations):
                tid = v.validation.comparison.test_id
                sub = stage if len(runs) == 1 else stage / sanitize_id(tid)
                # a validated test from `vehval qa` / `analyze`: its findings and control.json
                found = results_beside(run.origin) if run.qa_outcome is None else {}
                run.report(sub, qa=found.get("findings"), control=found.get("control"),
                           validation=v.payload(), title=f"Validation report: {tid}")
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
    from vehval.io.atomic import atomic_dir
    from vehval.jsonsafe import dumps
    from vehval.validate.calibration import calibrate
    from vehval.vehicle import load_vehicle
    from vehval.workflow import TestRun, runs_from_args

    if not files and not test_group:
        raise ConfigError("no tuning test given: name test directories or files, or use --test A,B")
    check_outputs(outdir=output, inputs=[*(files or []), template, vehicle_path(vehicle), start],
                  writes=["calibration.json", "vehicle_calibrated.yaml"])
    veh = load_vehicle(vehicle)
    if veh.architecture == "conventional":
        _calibrate_conventional(veh, files, test_group, holdout, template, params, output,
                                as_json)
        return
    names = _params(params)
    start_values = None
    if start is not None:       # checked before any test is read: finite, inside the bounds
        from vehval.safe_yaml import read_json
        from vehval.validate.calibration import check_start
        from vehval.validate.calibration import start_values as parse_start
        from vehval.validate.conditions import full_name
        start_values = read_json(start)
        full = [full_name(n) for n in names]
        check_start(veh, parse_start(start_values, full), full)
    tests = [r.validated for r in runs_from_args(files or [], test_group, template, veh,
                                                 use_qa=not no_qa)]
    hold = [TestRun.from_paths([Path(x.strip()) for x in h.split(",") if x.strip()], template, veh,
                               use_qa=not no_qa).validated for h in holdout]
    from vehval import progress
    from vehval.cli.progress import bar
    with bar("calibrate: generations (at most)", as_json=as_json):
        progress.add(maxiter)
        res = calibrate(tests, veh, names, start=start_values, holdout_tests=hold, dt=dt,
                        popsize=popsize, maxiter=maxiter, seed=seed, mode=mode,
                        smooth_hz=smooth_hz, progress=lambda _i, _j: progress.advance())
    doc = res.to_dict()
    with atomic_dir(output) as stage:
        (stage / "calibration.json").write_text(json.dumps(doc, indent=1) + "\n", encoding="utf-8")
        res.write_vehicle(stage / "vehicle_calibrated.yaml")
    if as_json:
        typer.echo(dumps(doc), nl=False)
        return
    for note in res.notes:
        typer.echo(f"note: {note}")
    for n in res.parameters:
        typer.echo(f"{n}: {res.start[n]:.6g} -> {res.best[n]:.6g}")
    for row in res.rows():
        typer.echo(f"{row[0]} ({_cycle(row[1])}): fuel error {_pct(row[2], 2, '')} -> "
                   f"{_pct(row[3], 2)}, SOC error {_pct(row[4], 2, '')} -> {_pct(row[5], 2)}")
    for tid in res.holdout:
        en = res.after.get(tid, {}).get("en")
        if en is not None:
            typer.echo(f"{tid} (held out): fuel En after calibration {en:+.2f} "
                       f"({'consistent' if abs(en) <= 1 else 'inconsistent'}; U_model = 0)")
    sv, why = res.holdout_verdict()
    if res.holdout:
        typer.echo("held-out set verdict: " + (f"{sv['verdict']} (n = {sv['n']}, mean fuel "
                   f"error {sv['mean_error_pct']:+.2f} %)" if sv else f"none ({why})"))
    typer.echo(f"objective {res.objective_start:.4g} -> {res.objective_best:.4g} "
               f"({res.n_simulations} simulations, {res.elapsed_s:.1f} s)")
    typer.echo(res.tables()[1]["note"])
    typer.echo(f"wrote {output / 'calibration.json'} and {output / 'vehicle_calibrated.yaml'}")


def _calibrate_conventional(veh, files, test_group, holdout, template, params, output,
                            as_json) -> None:
    """Conventional car: every file (or --test group) is one test; fuel is the objective."""
    from vehval.identify.calibrate import DEFAULT_PARAMS, calibrate_conventional
    from vehval.identify.traces import trace_from_test
    from vehval.io.atomic import atomic_dir
    from vehval.jsonsafe import dumps
    from vehval.workflow import TestRun

    if template is None:
        raise ConfigError("calibrate: give the import template with -t for a conventional car")
    groups = [[f] for f in (files or [])] + [[Path(x.strip()) for x in g.split(",") if x.strip()]
                                            for g in test_group]
    hybrid_default = "controller.engine_on_power_w"
    names = (list(DEFAULT_PARAMS) if params.startswith(hybrid_default)
             else [p.strip() for p in params.split(",") if p.strip()])
    tune = [trace_from_test(TestRun.load(g, template, use_qa=False).test) for g in groups]
    hold = [trace_from_test(TestRun.load([Path(x.strip()) for x in h.split(",") if x.strip()],
                                         template, use_qa=False).test) for h in holdout]
    from vehval.cli.progress import bar
    with bar("calibrate: tuning the fuel model", as_json=as_json):
        res = calibrate_conventional(veh, tune, names, hold)
    doc = res.to_dict()
    with atomic_dir(output) as stage:
        (stage / "calibration.json").write_text(dumps(doc) + "\n", encoding="utf-8")
        res.write_vehicle(stage / "vehicle_calibrated.yaml")
    if as_json:
        typer.echo(dumps(doc), nl=False)
        return
    from vehval.identify.calibrate import _bounds
    for n in res.parameters:
        lo, hi = _bounds(n, res.start[n])
        edge = next((f"{name} bound {b:.6g}" for name, b in (("lower", lo), ("upper", hi))
                     if abs(res.best[n] - b) <= 1e-3 * max(hi - lo, 1e-12)), None)
        typer.echo(f"{n}: {res.start[n]:.6g} -> {res.best[n]:.6g}"
                   + (f"  (at its {edge}: not identified, the fuel data push it beyond its "
                      "range)" if edge else ""))
    for row in res.tests:
        typer.echo(f"{row['test']} ({row['role']}{', in sample' if row['role'] == 'tune' else ''})"
                   f": fuel error {100 * row['error_rel_before']:+.2f}"
                   f" -> {100 * row['error_rel_after']:+.2f} %")
    # the summary line of the power-split calibration: held-out and in-sample apart
    from vehval.validate.calibration import _sample_note
    stats: dict[str, dict] = {}
    for role in ("holdout", "tune"):
        rows = [r for r in res.tests if r["role"] == role]
        b, a = (100 * sum(abs(r[k]) for r in rows) / len(rows) if rows else None
                for k in ("error_rel_before", "error_rel_after"))
        stats[role] = {"n_tests": len(rows), "fuel_pct_before": b, "fuel_pct_after": a}
    hb, ha = stats["holdout"]["fuel_pct_before"], stats["holdout"]["fuel_pct_after"]
    worse = hb is not None and ha is not None and ha > hb
    typer.echo(_sample_note(stats["holdout"], stats["tune"])
               + ("; the held-out tests got worse: the tuning overfits its tests" if worse else ""))
    typer.echo(f"objective {res.objective_start:.4g} -> {res.objective_best:.4g} "
               f"({res.n_simulations} simulations, {res.elapsed_s:.1f} s)")
    typer.echo(f"wrote {output / 'calibration.json'} and {output / 'vehicle_calibrated.yaml'}")
