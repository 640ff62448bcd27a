"""`vehval identify`: a conventional car from its dyno tests."""

from __future__ import annotations

import json
from pathlib import Path

import typer

from vehval.cli.app import app
from vehval.cli.options import bounded, output_file
from vehval.constants import RPM_RAD_PER_S
from vehval.errors import ConfigError


@app.command("identify")
def identify_cmd(
    files: list[Path] = typer.Argument(..., help="Raw test files (one test per file)."),
    template: Path = typer.Option(..., "-t", "--template", help="Import template."),
    architecture: str = typer.Option("conventional", "--architecture", help="Model to identify (conventional)."),
    output: Path = typer.Option(None, "-o", "--output", callback=output_file, help="Vehicle YAML to write (atomically); with --cross-validate the table as JSON."),
    name: str = typer.Option(None, "--name", help="Vehicle name (default: the output file stem)."),
    report: Path = typer.Option(None, "--report", callback=output_file, help="Also write an HTML report (fitted map with the measured points, traces)."),
    ac_test: Path = typer.Option(None, "--ac-test", help="A test run with the A/C on (not one of FILES): identifies the A/C compressor load from its phases after the first."),
    cold_test: Path = typer.Option(None, "--cold-test", help="A cold-start test (not one of FILES) on the cycle of a hot-start test among FILES: identifies the warm-up fuel (fraction and time constant) from the two tests' measured fuel. Without it, a cold start among FILES in a 20-30 °C cell, on the cycle of a warm test among them, does."),
    spec: Path = typer.Option(None, "--spec", help="Specification YAML (rated power and speed, peak torque, displacement, fuel, tyre, gears...; see docs/identification.md): values the data cannot separate."),
    rated_power_kw: float = typer.Option(None, "--rated-power-kw", callback=bounded("rated_power_kw"), help="Rated engine power [kW] (over the spec)."),
    rated_speed_rpm: float = typer.Option(None, "--rated-speed-rpm", callback=bounded("rated_speed_rpm"), help="Engine speed at rated power [rpm]."),
    peak_torque_nm: float = typer.Option(None, "--peak-torque-nm", callback=bounded("peak_torque_nm"), help="Peak engine torque [N m]."),
    displacement_l: float = typer.Option(None, "--displacement-l", callback=bounded("displacement_l"), help="Engine displacement [L]."),
    engine_fuel: str = typer.Option(None, "--engine-fuel", help="Engine type for the generic scaling: diesel or gasoline (default: from the test fuel)."),
    tyre: str = typer.Option(None, "--tyre", help="Tyre size, e.g. 225/50 R17 (wheel radius)."),
    gears: int = typer.Option(None, "--gears", callback=bounded("gears"), help="Number of forward gears (honoured; refused when the data show more)."),
    cross_validate: bool = typer.Option(False, "--cross-validate", help="Identify from all tests but one and predict that one, for each test; prints the table (and writes it as JSON with -o)."),
    pairs: bool = typer.Option(False, "--pairs", help="With --cross-validate: identify from every pair of tests of distinct cycles and predict every other test."),
    as_json: bool = typer.Option(False, "--json", help="Print the identification summary as JSON."),
) -> None:
    """Identify a conventional car (road load, gears, converter, shifts, driveline drag, fuel map,
    with --cold-test the warm-up fuel and with --ac-test the A/C load) from dyno tests."""
    from vehval.architectures import having, require

    if architecture not in having("identify"):
        raise ConfigError(f"--architecture {architecture}: identification from dyno data exists "
                          f"for {', '.join(repr(a) for a in having('identify'))} cars only")
    from vehval.identify.build import write_vehicle
    from vehval.identify.checks import check_declared, check_identification, identification_warnings
    from vehval.identify.loading import load_traces, refuse_one_test_of_several_files
    from vehval.identify.spec import load_spec
    from vehval.io.paths import check_outputs
    declared = load_spec(spec, {
        "rated_power_kw": rated_power_kw, "rated_speed_rpm": rated_speed_rpm,
        "peak_torque_nm": peak_torque_nm, "displacement_l": displacement_l,
        "fuel": engine_fuel, "tyre": tyre, "gears": gears})
    check_declared(declared)
    if pairs and not cross_validate:
        raise ConfigError("--pairs: give it with --cross-validate")
    if cross_validate:
        unused = [opt for opt, val in (("--ac-test", ac_test), ("--cold-test", cold_test),
                                       ("--report", report), ("--name", name)) if val is not None]
        if unused:
            raise ConfigError(f"--cross-validate: {', '.join(unused)} would be ignored (the "
                              "cross-validation identifies from FILES only and writes its "
                              "table); run identify without --cross-validate for them")
        _cross_validate(files, template, declared, pairs, output, as_json, spec)
        return
    if output is None:
        raise ConfigError("identify: give the vehicle file to write (-o FILE)")
    extra = [p for p in (ac_test, cold_test, spec) if p is not None]
    check_outputs(outfile=output, inputs=[*files, *extra, template])
    if report is not None:
        check_outputs(outfile=report, inputs=[*files, *extra, template, output],
                      option="--report")
    for opt, path in (("--ac-test", ac_test), ("--cold-test", cold_test)):
        if path is not None and path.resolve() in {f.resolve() for f in files}:
            raise ConfigError(f"{opt} {path}: it is also an identification test; give a "
                              "separate test run")
    refuse_one_test_of_several_files(files, template)
    traces = load_traces(files, template)
    ac_trace = load_traces([ac_test], template)[0] if ac_test is not None else None
    cold_trace = load_traces([cold_test], template)[0] if cold_test is not None else None
    from vehval.cli.progress import bar
    with bar("identify: fitting the car (road load, gears, fuel map)", as_json=as_json):
        idf = require(architecture, "identify")(traces, name or output.stem, ac_trace=ac_trace,
                                    cold_trace=cold_trace, declared=declared)
    check_identification(idf, declared, template, files)
    from vehval.io.atomic import atomic_files
    preds = None
    if report is not None:
        preds = [require(architecture, "predict")(idf.vehicle, t) for t in traces]
    # the vehicle file and the report are one unit: a run killed at any point leaves both
    # old or (once the next run completes its commit) both new, and no temporary behind
    with atomic_files([output] if report is None else [output, report]) as staged:
        write_vehicle(idf.vehicle, staged[0])
        if report is not None:
            from vehval.identify.report import write_identification_report
            write_identification_report(idf, preds, staged[1])
    for line in identification_warnings(idf, traces):
        typer.echo(f"vehval: warning: {line}", err=True)
    if as_json:
        typer.echo(json.dumps(idf.summary(), indent=2))
        return
    _print_identification(idf, output, report)


def _keyed(key: str, value_si: float, ci95_si: float | None = None) -> str:
    """``value [± ci] unit`` of a vehicle key (``mass_kg``, ``road_load_b_n_per_mps``...) in
    the display units (us: lb, lbf, lbf/mph, lbf/mph²; metric: kg, N, N/(m/s), N/(m/s)²)."""
    from vehval.display import format_keyed, keyed_unit, number

    text = format_keyed(key, value_si)
    unit = keyed_unit(key, magnitude=abs(value_si))
    if ci95_si is None or unit is None or not text.endswith(unit.label):
        return text
    shown = text[: -len(unit.label)].rstrip()
    ci = abs(ci95_si) * unit.factor
    # the interval to the value's last decimal (2 significant digits for a whole value)
    decimals = len(shown.partition(".")[2])
    half = (f"{ci:.{decimals}f}" if "e" not in shown and "\u2009" not in shown
            and decimals > 0 else number(ci, 2))
    return f"{shown} ± {half} {unit.label}"


def _drag_text(a_n: float, b_n_per_mps: float) -> str:
    """``a + b·v`` of a drag in the display units (``18.86 lbf + 0.1517 lbf/mph``)."""
    return f"{_keyed('drag_force_n', a_n)} + {_keyed('drag_force_n_per_mps', b_n_per_mps)}"


def _drag_note(drag) -> str:
    """The drag's note with its dyno losses (written in SI in the vehicle file) in the
    display units."""
    si = f"{drag.dyno_loss_a_n:.1f} N + {drag.dyno_loss_b_n_per_mps:.3f} N/(m/s)"
    return drag.note.replace(si, _drag_text(drag.dyno_loss_a_n, drag.dyno_loss_b_n_per_mps))




def _print_identification(idf, output: Path, report: Path | None) -> None:
    from vehval.vehicle.maps import peak_brake_efficiency

    rl = idf.road_load
    v, ci = rl.values, rl.ci95
    typer.echo(f"wrote {output}")
    body = idf.vehicle.body
    terms = []
    for name, k in (("A", "road_load_a_n"), ("B", "road_load_b_n_per_mps"),
                    ("C", "road_load_c_n_per_mps2"), ("mass", "mass_kg")):
        kept = float(getattr(body, k))
        terms.append(f"{name} {_keyed(k, v[k], ci.get(k))}" + (
            "" if abs(kept - v[k]) <= 1e-9 * max(abs(v[k]), 1.0) else
            f" (the vehicle file holds {_keyed(k, kept)}: a physical bound)"))
    typer.echo(f"road load (95 % intervals): {', '.join(terms)} (R^2 {rl.r2:.4f})")
    g = idf.gears
    typer.echo("gear ratios (engine/wheel): " + ", ".join(f"{r:.3f}" for r in g.ratios)
               + ("" if g.declared is None else f" ({len(g.ratios)} of the {g.declared} "
                  "declared gears)"))
    for note in g.notes:
        typer.echo(f"gears: {note}")
    fm = idf.fuel_map
    typer.echo(f"fuel map: R^2 {fm.r2:.3f} (5 s means {fm.r2_5s:.3f}), idle "
               f"{fm.idle_fuel_kg_s * 1e3:.3f} g/s, fuel cut above "
               f"{fm.fuel_cut_speed_rad_s / RPM_RAD_PER_S:.0f} rpm")
    for why in idf.fuel_left_out.values():
        typer.echo(f"fuel map: left out {why}")
    eta, rpm, nm = peak_brake_efficiency(idf.vehicle.engine)
    typer.echo(f"fuel map: peak brake efficiency {100 * eta:.1f} % at {rpm:.0f} rpm, {nm:.0f} N·m "
               "(between idle and full load)")
    if idf.drag is not None:
        typer.echo(f"driveline drag: {_drag_text(idf.drag.force_n, idf.drag.force_n_per_mps)} "
                   f"({_drag_note(idf.drag)})")
    if idf.warmup is not None:
        w = idf.warmup
        typer.echo(f"warm-up fuel: +{100 * w.fraction:.1f} % at the start, time constant "
                   f"{w.time_constant_s:.0f} s (from {w.cold_test} against {w.hot_test}, "
                   f"R^2 {w.r2:.3f}{'; ' + w.note if w.note else ''})")
    if idf.ac is not None:
        typer.echo(f"A/C load: {idf.ac['ac_power_w'] / 1e3:.2f} kW (from {idf.ac['test']}, phases "
                   f"{', '.join(map(str, idf.ac['phases']))})")
    a = idf.assumptions
    if a is not None:
        for k in a.generic():
            p = a.provenance[k]
            val = "" if p["value"] is None else (
                f" {p['value']:.4g}" if isinstance(p["value"], float) else f" {p['value']}")
            typer.echo(f"generic value: {k}{val} ({p['source']})")
    if report is not None:
        typer.echo(f"wrote {report}")


def _cross_validate(files, template, declared, pairs, output, as_json, spec) -> None:
    from vehval.identify.crossval import cross_validate, table
    from vehval.identify.loading import load_traces, refuse_one_test_of_several_files
    if len(files) < 2:
        raise ConfigError(f"--cross-validate: one test given ({files[0] if files else 'none'}); "
                          "it needs at least two (identify from some, predict the others)")
    if output is not None:
        from vehval.io.paths import check_outputs
        check_outputs(outfile=output, inputs=[*files, template] + ([spec] if spec else []))
    refuse_one_test_of_several_files(files, template)
    traces = load_traces(files, template)
    from vehval.cli.progress import bar
    with bar(f"identify: cross-validation ({'pairs' if pairs else 'leave-one-out'})",
             as_json=as_json):
        result = cross_validate(traces, pairs=pairs, declared=declared)
    if output is not None:
        from vehval.io.atomic import write_text_atomic
        write_text_atomic(output, json.dumps(result, indent=1) + "\n")
    if as_json:
        typer.echo(json.dumps(result, indent=2))
    else:
        typer.echo(table(result))
        if output is not None:
            typer.echo(f"wrote {output}")
