"""`vehval predict`: a vehicle model against measured tests, fuel per test and phase."""

from __future__ import annotations

import json
from pathlib import Path

import typer

from vehval.cli.app import app
from vehval.cli.options import output_file
from vehval.errors import ConfigError


def _table(rows: list[dict]) -> str:
    from vehval.display import fuel_text

    lines = [f"{'test':<22} {'cycle':<10} {'T [C]':>6} {'measured g':>11} {'predicted g':>12} "
             f"{'error %':>8}"]
    for r in rows:
        lines.append(f"{r['test']:<22} {r['cycle']:<10} {r['amb_temp_c']:>6.1f} "
                     f"{r['fuel_measured_g']:>11.1f} {r['fuel_predicted_g']:>12.1f}"
                     + (f"  not judged: {r['not_judged']}" if r.get("not_judged") else
                        f" {100 * r['error_rel']:>+8.2f}{_pi(r)}{_en(r)}  A/C "
                        f"{'on' if r['ac_on'] else 'off'}: {r['ac_reason']}; {_start(r)}"))
        if r.get("not_judged"):
            continue
        if r.get("fuel_economy_measured_mpg") is not None:
            lines.append(f"  {'fuel economy':<38} measured "
                         f"{fuel_text(r['fuel_economy_measured_mpg'], r['fuel_consumption_measured_l_per_100km'])}"
                         f", predicted "
                         f"{fuel_text(r['fuel_economy_predicted_mpg'], r['fuel_consumption_predicted_l_per_100km'])}")
        for p in r["phases"]:
            u = p.get("results_fuel_U_g")
            unc = f"  (results stage: {p['results_fuel_g']:.1f} ± {u:.1f} g)" if u else ""
            lines.append(f"  {p.get('results_name', 'phase ' + str(p['phase'])):<38} "
                         f"{p['measured_g']:>11.1f} {p['predicted_g']:>12.1f} "
                         f"{100 * p['error_rel']:>+8.2f}{_pi(p)}{_en(p)}{unc}")
    return "\n".join(lines)


def _en(r: dict) -> str:
    """`` En +0.42`` (`` (uninformative)`` when the combined U exceeds a tenth of the
    measured figure: the comparison cannot tell) of a result row; empty without one."""
    if r.get("en") is None:
        return ""
    return f" En {r['en']:+.2f}" + (" (uninformative)" if r.get("uninformative") else "")


def _verdict_lines(verdict: dict | None, notes: list[str]) -> list[str]:
    """The set verdict of the held-out tests and the notes behind En."""
    out = [f"note: {n}" for n in notes]
    if verdict is not None:
        from vehval.uncertainty import verdict_text

        out.append(verdict_text(verdict, "held-out tests"))
        out += [f"  {n}" for n in verdict["notes"]]
    return out


def _pi(r: dict) -> str:
    """`` ±x.x % (95 %), y % uncovered`` and ``in sample`` marks of a result row."""
    out = ""
    if r.get("pi95_rel") is not None:
        out += f" ±{100 * r['pi95_rel']:.1f} % (95 %), {100 * r['uncovered_share']:.0f} % uncovered"
    if r.get("in_sample"):
        out += " [in sample]"
    return out


def _start(r: dict) -> str:
    """How the test and the model started (cold, with or without warm-up fuel) and why."""
    from vehval.identify.warmup import start_label
    return f"{start_label(r)}: {r['cold_reason']}"




@app.command("predict")
def predict_cmd(
    vehicle: str = typer.Argument(..., help="Vehicle name or YAML path (conventional)."),
    files: list[Path] = typer.Argument(..., help="Raw test files to predict (one test per file)."),
    template: Path = typer.Option(..., "-t", "--template", help="Import template."),
    report: Path = typer.Option(None, "--report", callback=output_file, help="Also write an HTML report (table, engine speed and fuel rate overlays)."),
    ac: str = typer.Option("auto", "--ac", help="A/C of the model: auto (on for SC03 or a cell at 30 C or more), on, off."),
    as_json: bool = typer.Option(False, "--json", help="Print the results as JSON."),
) -> None:
    """Drive each test's measured speed with the model; fuel measured vs predicted, per phase."""
    from vehval.identify.loading import load_traces
    from vehval.vehicle import load_vehicle
    if report is not None:
        from vehval.io.paths import check_outputs, vehicle_path
        check_outputs(outfile=report, inputs=[*files, template, vehicle_path(vehicle)],
                      option="--report")
    veh = load_vehicle(vehicle)
    from vehval.architectures import require, stages

    if stages(veh).predict is None:
        raise ConfigError(f"{vehicle}: predict compares fuel of conventional cars; this vehicle "
                          f"is '{veh.architecture}' (use vehval validate)")
    from vehval.identify.predict import check_same_car, poor_coverage, public_row
    traces = load_traces(files, template)
    for t in traces:
        check_same_car(veh, t)
    from vehval import progress
    from vehval.cli.progress import bar
    with bar("predict: driving each test's speed", as_json=as_json):
        progress.add(len(traces))
        preds = []
        for t in traces:
            preds.append(require(veh, "predict")(veh, t, ac=ac))
            progress.advance()
    from vehval.identify.conditions import conditions_warnings
    for line in poor_coverage(preds) + conditions_warnings(preds, veh.identification):
        typer.echo(f"vehval: warning: {line}", err=True)
    from vehval.identify.verdicts import judge_rows
    verdict, notes = judge_rows(preds)
    if report is not None:
        from vehval.identify.report import write_prediction_report
        write_prediction_report(veh.name, preds, report, verdict_lines=_verdict_lines(verdict, notes))
    rows = [public_row(p, veh) for p in preds]
    for r in rows:   # the set's verdict with every row (the JSON stays a list of rows)
        r["set_verdict"] = verdict
    if as_json:
        typer.echo(json.dumps(rows, indent=2))
    else:
        typer.echo(_table(rows))
        for line in _verdict_lines(verdict, notes):
            typer.echo(line)
