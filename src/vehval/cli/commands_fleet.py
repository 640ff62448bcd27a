"""`vehval epa fleet` (every conventional row of the lists, on Dask) and `vehval epa whatif`."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Optional

import typer

from vehval.cli.commands_epa import epa_app
from vehval.cli.options import bounded, output_dir

_PATHS = "EPA Test Car List CSV files (e.g. 16tstcar.csv 19tstcar.csv) or directories."


def _pc(x: float | None) -> str:
    return "-" if x is None else f"{100 * x:+.1f} %"


def _pct(x: float | None) -> str:
    return "-" if x is None else f"{100 * x:.1f} %"


def _fleet_model_lines(fm: dict) -> list[str]:
    """The physics + learned residual out of sample, against its targets."""
    if not fm.get("n_judged"):
        return []
    worst = fm.get("worst_group_bias")
    return [f"  fleet model (physics + learned residual, {fm['scheme'].replace('_', ' ')}, "
            f"{fm['n_judged']} rows): " + ", ".join(
                f"{p} {100 * st['median_abs_error']:.2f} %" for p, st in fm["errors"].items())
            + f" median |error|, within 5 % {_pct(fm['share_within_5pct'])}; HWFET/FTP bias "
            + _pc(fm["hwfet_ftp_bias"]["mean"])
            + (f"; largest group bias {worst['group']} {worst['procedure']} "
               f"{_pc(worst['median_error'])}" if worst else "")
            + ("; consistent within the uncertainty (|En| <= 1): " + ", ".join(
                f"{p} {_pct(v['share_consistent'])}" for p, v in fm["verdicts"].items())
               if fm.get("verdicts") else "")] + _floor_line(fm.get("floor") or {})


def _floor_line(floor: dict) -> list[str]:
    """What a perfect model of the row's columns would reach (rows it cannot tell apart)."""
    per = floor.get("per_procedure") or {}
    if not per:
        return []
    return ["  the data's floor (a perfect model of the row's columns, from "
            + f"{sum(st['n_groups'] for st in per.values())} groups of rows it cannot tell "
            "apart): " + ", ".join(f"{p} {100 * st['median_abs_error']:.2f} %"
                                   for p, st in per.items())
            + f" median |error|, within 5 % {_pct(floor['share_within_5pct'])}"] + _twin_line(
        floor.get("twins") or {})


def _twin_line(twins: dict) -> list[str]:
    """The fleet model on rows with a near twin in the fit list and on the others."""
    def part(st: dict) -> str:
        return (f"{100 * st['median_abs_error']:.2f} % ({st['n']} rows)" if st.get("n")
                else "no rows")

    return ["  near twins in the fit list: " + "; ".join(
        f"{p} twin {part(t['twin'])}, model {part(t['model'])}, without a twin "
        f"{part(t['model_without_twin'])}" for p, t in twins.items())] if twins else []


def _lines(s: dict) -> list[str]:
    out = [f"{s['n_rows']} rows: {s['n_run']} run ({s['n_judged']} judged), {s['n_not_run']} "
           f"not run, {s['n_failed']} failed; {s['n_cars']} cars"]
    if s["not_run_by_reason"]:
        out.append("  not run: " + ", ".join(f"{k} {n}" for k, n in s["not_run_by_reason"].items()))
    for p, st in s["errors"].items():
        out.append(f"  {p}: n {st['n']}, median error {_pc(st['median_error'])}, median |error| "
                   f"{100 * st['median_abs_error']:.1f} %, within 5 % "
                   f"{100 * st['share_within_5pct']:.0f} %")
    for scheme, procs in (s.get("baseline") or {}).items():
        for p, d in procs.items():
            out.append(f"  baseline {scheme.replace('_', ' ')} {p}: model "
                       f"{100 * d['model']['median_abs_error']:.1f} % vs regression "
                       f"{100 * d['baseline']['median_abs_error']:.1f} % median |error|: "
                       f"{'physics' if d['model_better'] else 'regression'} better; "
                       f"boosted {_pct(d['boosted']['median_abs_error'])}, physics + "
                       f"residual {_pct(d['physics_residual']['median_abs_error'])}"
                       + (" (best)" if d["residual_better"] else ""))
    out += _fleet_model_lines(s.get("fleet_model") or {})
    for c in s.get("coefficients") or ():
        inside = ", ".join(c["in_sample_lists"]) or "none"
        out.append(f"  coefficients {c['file']} (fitted on {', '.join(c['fit_lists']) or '-'}): "
                   f"judged {', '.join(c['lists_judged']) or '-'}; in-sample lists: {inside}")
    oos = s.get("out_of_sample") or {}
    if oos.get("n_judged"):
        out.append(f"  out of sample ({oos['n_judged']} rows): " + ", ".join(
            f"{p} {100 * st['median_abs_error']:.1f} %" for p, st in oos["errors"].items())
            + f" median |error|, within 5 % {100 * oos['share_within_5pct']:.0f} %")
        if oos.get("verdicts"):
            out.append("  consistent within the uncertainty (|En| <= 1): " + ", ".join(
                f"{p} {100 * v['share_consistent']:.0f} %" for p, v in oos["verdicts"].items()))
    run = s["run"]
    if run["rows_per_minute"]:
        out.append(f"  {run['n_rows_simulated']} rows simulated in {run['elapsed_s']:.1f} s "
                   f"({run['rows_per_minute']:.0f} rows/min, {run['workers']} worker(s)); "
                   f"{run['n_cars_cached']} cars from an earlier run")
    out.append(f"  outliers: {len(s['outliers'])}")
    return out + [f"  note: {n}" for n in s["notes"]]


@epa_app.command("fleet")
def fleet_cmd(
    paths: list[Path] = typer.Argument(..., help=_PATHS),
    outdir: Path = typer.Option(..., "--outdir", "-o", callback=output_dir,
                                help="Output folder: fleet.duckdb, fleet.json, fleet.html, cars/."),
    scheduler: Optional[str] = typer.Option(None, "--scheduler", help="Address of an existing "
                                            "dask.distributed scheduler, e.g. tcp://host:8786."),
    workers: Optional[int] = typer.Option(None, "--workers", "-j", callback=bounded("workers"),
                                          help="Local Dask workers (default: CPU count; 0 or 1 "
                                          "= a plain loop in this process)."),
    force: bool = typer.Option(False, "--force", help="Run every car again (default: the "
                               "cars of an earlier run into OUTDIR are kept)."),
    report: bool = typer.Option(True, "--report/--no-report", help="Write fleet.html."),
    coefficients: Optional[list[Path]] = typer.Option(
        None, "--coefficients", help="Technology coefficients file (repeatable; default the "
        "package's). Each list is judged with a file not fitted on it when there is one."),
    cross_year: bool = typer.Option(False, "--cross-year", help="Add the package's fit of "
                                    "every list year: each list judged with another year's "
                                    "fit (out-of-sample)."),
    as_json: bool = typer.Option(False, "--json", help="Print the summary as JSON."),
) -> None:
    """Predict every conventional row of the lists; every other row listed with its reason.

    Resumable: each car's rows are stored as it lands; a rerun runs only the others."""
    from vehval.batch.fleet import run_fleet
    from vehval.cli.progress import enabled
    from vehval.jsonsafe import dumps

    summary = run_fleet(paths, outdir, workers=workers, scheduler=scheduler, force=force,
                        progress=enabled(as_json), report=report,
                        coefficients=coefficients or (), cross_year=cross_year)
    if as_json:
        typer.echo(dumps(summary), nl=False)
        return
    for line in _lines(summary):
        typer.echo(line)
    typer.echo(f"-> {Path(outdir) / 'fleet.json'}")


@epa_app.command("whatif")
def whatif_cmd(
    paths: list[Path] = typer.Argument(..., help=_PATHS),
    vehicle_id: str = typer.Option(..., "--vehicle-id", help="Test vehicle ID of the row(s)."),
    config: Optional[str] = typer.Option(None, "--config", help="Configuration number, when "
                                         "the test vehicle has several."),
    weight: Optional[str] = typer.Option(None, "--weight", help="Test weight change: -200lb, "
                                         "+90kg, -5%, or a new weight 3500lb."),
    road_load: Optional[str] = typer.Option(None, "--road-load", help="Road load A, B, C "
                                            "scaled: -5%."),
    axle: Optional[str] = typer.Option(None, "--axle", help="New axle ratio (3.2) or a change "
                                       "(-5%); N/V follows."),
    procedure: Optional[str] = typer.Option(None, "--procedure", help="Only this procedure "
                                            "(ftp75, hwfet, us06)."),
    as_json: bool = typer.Option(False, "--json", help="Print the answer as JSON."),
) -> None:
    """The same car with a changed weight, road load or axle ratio, with its interval (k = 2)."""
    from vehval.epa.fleet import read_fleet
    from vehval.epa.fleet_whatif import whatif

    tests, _ = read_fleet(paths)
    res = whatif(tests, vehicle_id, config=config, weight=weight, road_load=road_load,
                 axle=axle, procedure=procedure)
    if as_json:
        typer.echo(json.dumps(res, indent=1))
        return
    ch = ", ".join(f"{k} {v}" for k, v in res["changes"].items() if v and k in
                   ("weight", "road_load", "axle"))
    typer.echo(f"{res['car']} ({res['vehicle_id']}): {ch}")
    from vehval.cli.epa_common import _fe_display

    unit, shown, fmt = _fe_display()
    for r in res["rows"]:
        # an interval in L/100 km runs the other way round
        lo, hi = sorted(shown(v) for v in r["interval_mpg"])
        model, changed = shown(r["model_mpg"]), shown(r["model_changed_mpg"])
        typer.echo(f"  {r['row_id']} {r['procedure']}: listed {shown(r['measured_mpg']):{fmt}} "
                   f"{unit} -> {shown(r['answer_mpg']):{fmt}} {unit} [{lo:{fmt}}, {hi:{fmt}}] "
                   f"(model {model:{fmt}} -> {changed:{fmt}}, {100 * (changed / model - 1):+.1f} %)")
