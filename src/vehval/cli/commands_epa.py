"""`vehval epa calibrate|vehicle`: calibration against the EPA Test Car List and a vehicle
from its listed specification (`epa list|tests`: commands_epa_list; `epa validate`:
commands_epa_validate, registered first: the order of `vehval epa --help`)."""

from __future__ import annotations

from pathlib import Path

import typer

from vehval.cli import commands_epa_list, commands_epa_validate  # noqa: F401 - registered first
from vehval.cli.epa_common import _PATHS_HELP, _echo_mismatches, _selected, epa_app
from vehval.cli.options import bounded, output_file

__all__ = ["epa_app"]


def _parse_param(text: str) -> tuple[str, list[float]]:
    from vehval.errors import ConfigError

    name, sep, values = text.partition("=")
    try:
        vals = [float(v) for v in values.split(",") if v.strip()]
    except ValueError:
        vals = []
    if not sep or not name.strip() or not vals:
        raise ConfigError(f"--param '{text}': write NAME=v1,v2,... with numbers, e.g. "
                          "controller.soc_gain_w=10000,20000,40000")
    return name.strip(), vals


@epa_app.command("calibrate")
def calibrate_cmd(
    paths: list[Path] = typer.Argument(..., help=_PATHS_HELP),
    vehicle: str = typer.Option(..., "--vehicle", help="Vehicle name or YAML path to start "
                                "from."),
    tests: str = typer.Option(..., "--tests", help="Calibration tests, e.g. "
                              "model=PRIUS,year=2016,originator=MFR (judge the model on "
                              "others with `vehval epa validate`)."),
    param: list[str] = typer.Option(..., "--param", help="NAME=v1,v2,... candidate values of "
                                    "a parameter (dotted name; a bare name is "
                                    "controller.NAME); repeat for several."),
    refine: int = typer.Option(2, "--refine", callback=bounded("refine"), help="Rounds of coordinate "
                               "refinement after the grid."),
    dt: float = typer.Option(0.2, "--dt", callback=bounded("dt"), help="Simulation step [s]."),
    workers: int = typer.Option(0, "--workers", callback=bounded("workers"), help="Processes evaluating "
                                "settings in parallel (0: one per CPU, at most 8; the result "
                                "does not depend on it)."),
    as_json: bool = typer.Option(False, "--json", help="Print the calibration JSON."),
    output: Path | None = typer.Option(None, "-o", "--output", callback=output_file,
                                       help="Write the calibrated "
                                       "vehicle YAML here (values carry their provenance)."),
    long_run: bool = typer.Option(False, "--long-run", help="Run a calibration estimated "
                                  "to take more than 15 min (refused without it)."),
) -> None:
    """Choose unpublished parameters (controller thresholds, gains) on a set of EPA tests.

    At most 1,000 grid settings; the estimated run time is stated on stderr before a run
    of 10 s or more."""
    from vehval import jsonsafe
    from vehval.epa.calibrate import LONG_RUN_S, calibrate_on_tests, grid_from_pairs
    from vehval.epa.consistency import check_vehicle_match
    from vehval.io.paths import check_outputs, vehicle_path
    from vehval.vehicle import load_vehicle

    if output is not None:
        check_outputs(outfile=output, inputs=[*paths, vehicle_path(vehicle)])
    grid = grid_from_pairs([_parse_param(p) for p in param])
    selected, veh = _selected(paths, tests, dt), load_vehicle(vehicle)
    _echo_mismatches([(t.label, check_vehicle_match(t, veh)) for t in selected], err=True)
    cal = calibrate_on_tests(veh, selected, grid, dt=dt, refine_rounds=refine,
                             workers=workers, max_seconds=None if long_run else LONG_RUN_S,
                             notify=lambda text: typer.echo(text, err=True))
    if output is not None:
        cal.write_vehicle(output)
    if as_json:
        typer.echo(jsonsafe.dumps(cal), nl=False)
        return
    start = cal.vehicle.parameters()
    for name, value in cal.best.items():
        typer.echo(f"{name:40s} {start[name]:>12g} -> {value:<12g}")
    typer.echo(f"{len(cal.tests)} tests, {len(cal.evaluations)} settings evaluated; RMS error "
               f"of the judged figures {100 * cal.start_rms:.1f} % -> {100 * cal.best_rms:.1f} "
               f"% (max {100 * cal.best_max:.1f} %)")
    if output is not None:
        typer.echo(f"wrote {output}")


def _narrow(rows: list, vehicle_id: str | None, config: str | None) -> list:
    """The rows of one test vehicle and configuration; an ID or number that matches none
    is refused with the ones there are."""
    from vehval.errors import ConfigError

    for value, attr, opt in ((vehicle_id, "vehicle_id", "--vehicle-id"),
                             (config, "config", "--config")):
        if value is None:
            continue
        sel = [t for t in rows if getattr(t, attr).upper() == value.strip().upper()]
        if not sel:
            there = ", ".join(sorted({getattr(t, attr) or "''" for t in rows}))
            raise ConfigError(f"{opt} {value}: no selected row has it (there are: {there})")
        rows = sel
    return rows


def _bev_from_rows(rows: list, output: Path, as_json: bool) -> bool:
    """Electricity rows: write a battery-electric vehicle from the row and generic maps
    (vehval.epa.bev); False for any other rows."""
    from vehval import jsonsafe
    from vehval.calibration.provenance import write_vehicle_yaml
    from vehval.epa.bev import is_bev_row, vehicle_from_rows

    if not (rows and all(is_bev_row(r) for r in rows)):
        return False
    bev = vehicle_from_rows(rows)
    write_vehicle_yaml(bev, output, "vehval epa vehicle")
    typer.echo(jsonsafe.dumps({"vehicle": bev.name, "architecture": bev.architecture})
               if as_json else f"battery-electric {bev.name} from {rows[0].source} and "
               f"generic maps\nwrote {output}", nl=not as_json)
    return True


@epa_app.command("vehicle")
def vehicle_cmd(
    paths: list[Path] = typer.Argument(..., help=_PATHS_HELP),
    make: str = typer.Option(..., "--make", help="Make, e.g. TOYOTA."),
    model: str = typer.Option(..., "--model", help="Model name as listed, e.g. "
                              "'CAMRY XLE/XSE' (one test-vehicle configuration)."),
    year: int = typer.Option(..., "--year", callback=bounded("year"), help="Model year."),
    vehicle_id: str | None = typer.Option(None, "--vehicle-id", help="Test vehicle ID, "
                                          "when the model has several configurations."),
    config: str | None = typer.Option(None, "--config", help="Test vehicle configuration "
                                      "number (the list's 'cfg'), when one test vehicle "
                                      "has several."),
    calibrate: list[Path] = typer.Option([], "--calibrate", help="A dyno test (one file: "
                                         "vehicle speed and fuel rate) to fit the fuel "
                                         "model on; repeatable."),
    predict: list[Path] = typer.Option([], "--predict", help="A held-out dyno test to "
                                       "predict (not also a --calibrate test); repeatable."),
    template: Path | None = typer.Option(None, "-t", "--template", help="Import template "
                                         "of the dyno test files."),
    splits: int = typer.Option(0, "--splits", callback=bounded("splits"), help="Also fit on "
                               "every N of all the given tests and predict the others "
                               "(0: no)."),
    dt: float = typer.Option(0.5, "--dt", callback=bounded("dt"), help="Simulation step [s]."),
    as_json: bool = typer.Option(False, "--json", help="Print the result JSON."),
    output: Path = typer.Option(..., "-o", "--output", callback=output_file,
                                help="Write the vehicle YAML here."),
    force: bool = typer.Option(False, "--force", help="Use dyno tests whose speed or fuel "
                               "unit QA doubts (the hint is still printed)."),
) -> None:
    """A conventional vehicle from its EPA Test Car List specification, its fuel model
    calibrated on dyno tests with speed and fuel only."""
    from vehval import jsonsafe
    from vehval.calibration.provenance import write_vehicle_yaml
    from vehval.cli.epa_inputs import check_roles, unit_hints
    from vehval.epa import read_lists, select_tests
    from vehval.epa.dyno_vehicle import DynoTest, dyno_vehicle, uncalibrated_note
    from vehval.epa.procedures import fuel_family
    from vehval.epa.specs import ENGINE_FUELS, model_fuel_lhv, specs_from_tests
    from vehval.epa.specs_fit import dyno_run, efficiency_note
    from vehval.errors import ConfigError
    from vehval.io.paths import check_outputs
    from vehval.vehicle.maps import peak_brake_efficiency
    from vehval.workflow import TestRun

    check_outputs(outfile=output, inputs=[*paths, *calibrate, *predict, template])
    rows = _narrow(select_tests(read_lists(paths), make, model, year), vehicle_id, config)
    if _bev_from_rows(rows, output, as_json):
        return
    fams = {fuel_family(t.fuel) for t in rows} & set(ENGINE_FUELS)  # gasoline first, else
    specs = specs_from_tests(rows, "gasoline" if "gasoline" in fams or len(fams) != 1
                             else fams.pop())  # the one fuel (a diesel car was refused)
    check_roles(calibrate, predict)
    files = [*calibrate, *predict]
    if files and template is None:
        raise ConfigError("give the import template of the dyno tests with -t")
    dyno = []
    for f in files:
        loaded = TestRun.load([f], template, use_qa=False)
        hints = unit_hints(f, loaded.test, loaded.template, force)
        dyno.append(DynoTest(dyno_run(loaded.test, loaded.test.meta.test_id or f.stem,
                                      model_lhv_j_per_kg=model_fuel_lhv()),
                             f in calibrate, hints))
    built = dyno_vehicle(specs, dyno, dt, splits)
    fit, veh, pred = built.fit, built.vehicle, built.predictions
    write_vehicle_yaml(veh, output, "vehval epa vehicle")
    doc = built.to_dict()
    if as_json:
        typer.echo(jsonsafe.dumps(doc), nl=False)
        return
    tests_doc, split_rows = doc["tests"], built.splits
    from vehval.display import format_value

    typer.echo(f"{specs.make} {specs.model} {specs.year} ({specs.vehicle_id}): "
               f"{format_value(specs.mass_kg, 'kg')}, {specs.displacement_l:g} L, "
               f"{specs.rated_power_w / 1e3:.0f} kW, {specs.gears}-speed, axle "
               f"{specs.axle_ratio:g}, N/V {specs.n_v_ratio:g}")
    if fit is None:
        typer.echo(f"{uncalibrated_note(specs)}: expect a median error of about 5 % on the "
                   "FTP-75 and 3-5 % on the HWFET and US06 against the list's figures, "
                   "beyond 10 % for some cars (docs/validation.md); give dyno tests with "
                   "--calibrate")
    if fit is not None:
        idle = "-" if fit.idle_fuel_g_per_s is None else f"{fit.idle_fuel_g_per_s:.3f}"
        brake = peak_brake_efficiency(veh.engine)
        typer.echo(f"fitted on {', '.join(fit.tests)}: indicated efficiency "
                   f"{100 * fit.indicated_efficiency:.1f} %, friction scale "
                   f"{fit.friction_scale:.3f}, "
                   f"idle {idle} g/s; best brake efficiency {100 * brake[0]:.1f} % "
                   f"({brake[1]:.0f} rpm, {brake[2]:.0f} N·m)")
        if efficiency_note(veh):
            typer.echo(f"! {efficiency_note(veh)}")
    for row in tests_doc:
        err = "-" if row["error"] is None else f"{100 * row['error']:+.1f} %"
        typer.echo(f"{row['test'][:24]:24s} {'in-sample' if row['in_sample'] else 'held-out':9s}"
                   f" fuel error {err:>8}  ({row['note']})")
    for note in dict.fromkeys(r["fuel_note"] for r in tests_doc if r["fuel_note"]):
        typer.echo(f"test fuel: {note}")
    for f, t in zip(files, dyno):
        for h in t.unit_hints:
            typer.echo(f"! {f}: {h['message']} ({h['fix']}; used with --force)")
    if predict:
        worst = max(abs(e) for e in pred.values())
        typer.echo(f"held-out: {len(pred)} test{'s' if len(pred) != 1 else ''}, largest "
                   f"|fuel error| {100 * worst:.1f} %")
    for sp in split_rows:
        errs = ", ".join(f"{k} {100 * v:+.1f} %" for k, v in sp["held_out_errors"].items())
        typer.echo(f"split: fit on {', '.join(sp['calibration'])} -> {errs}")
    typer.echo(f"wrote {output}")
