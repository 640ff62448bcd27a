"""`vehval results`: import, QA and the results stage of one test; writes results.json."""

from __future__ import annotations

import json
from pathlib import Path

import typer

from vehval.cli.app import app
from vehval.cli.options import bounded
from vehval.constants import MILE_M, MPH_M_PER_S
from vehval.errors import InputFileError, VehvalError


def hot_start_bag1(files: list[Path], template) -> dict[str, float]:
    """Fuel mass [kg], distance [m] and CO2 [kg] of bag 1 of a hot-start UDDS test."""
    from vehval.io.importer import import_test
    from vehval.results import results_from_template

    for f in files:
        if not f.exists():
            raise InputFileError(f"{f}: file not found (--hot-start): check the path")
    hot = results_from_template(import_test(files, template), template)
    if hot.conditions.get("start") == "cold":
        raise VehvalError(f"--hot-start {files[0]}: the test starts cold "
                          f"({hot.conditions.get('start_basis')}): its bag 1 cannot stand in "
                          "for the FTP bag 3 (hot start after the 10 min soak, 40 CFR 86.137); "
                          "give the hot-start UDDS run after the cold one")
    bag1 = next((p for p in hot.phases if p.part == "bag1" and p.run == 1), None)
    if bag1 is None or hot.cycle.split("_x")[0] not in ("udds", "ftp75"):
        raise VehvalError(f"--hot-start {files[0]}: not a UDDS test with a bag 1 (cycle "
                          f"{hot.cycle or 'not identified'}): give a hot-start UDDS test")
    vals = hot.values[bag1.name]
    return {k: v for k in ("fuel_mass_kg", "distance_m", "co2_kg")
            if (v := vals.get(k)) is not None}


def echo_results(res) -> None:
    """Headline lines: phases and composites with their expanded uncertainty."""
    def fe(scope: str) -> str:
        v = res.value(scope, "fuel_economy_mpg")
        if v is None:
            m = res.value(scope, "fuel_mass_kg")
            return "fuel economy n/a" + (f" (fuel {m * 1e3:.1f} g)" if m is not None else "")
        u = res.expanded(scope, "fuel_economy_mpg")
        lp = res.value(scope, "fuel_consumption_l_per_100km")
        return f"{v:6.2f} +- {u or 0:.2f} mpg ({lp:.2f} L/100 km)"

    typer.echo(f"{res.test_id}: cycle {res.cycle or '(not identified)'}; phases from "
               f"{res.phase_source}; fuel {res.fuel.name if res.fuel else '(not declared)'}")
    for p in res.phases:
        dq = res.drive_quality.get(p.name) or {}
        d = res.value(p.name, "distance_m") or 0.0
        extra = (f"  IWR {dq['iwr_pct']:+.1f} %, RMSSE {dq['rmsse_mps'] / MPH_M_PER_S:.2f} mph"
                 if dq.get("iwr_pct") is not None else "")
        typer.echo(f"  {p.name:18s} {d / MILE_M:6.2f} mi  {fe(p.name)}{extra}")
    typer.echo(f"  {'whole test':18s} {(res.value('test', 'distance_m') or 0) / MILE_M:6.2f} mi  "
               f"{fe('test')}")
    for c in res.composites:
        typer.echo(f"  = {c.name:16s} {fe(c.name)}  [{c.rule.split(':')[0]}]")
        for cav in getattr(c, "caveats", []):
            typer.echo(f"      ! {cav}")
    for note in res.notes:
        if note.startswith("FTP-75:"):
            typer.echo(f"  ! {note}")
    typer.echo(f"  uncertainty: {res.method.replace('_', ' ')}, k = 2; SOC: {res.soc['status']}")


@app.command("results")
def results_cmd(
    files: list[Path] = typer.Argument(..., help="Raw files of one test."),
    template: Path = typer.Option(..., "-t", "--template", help="Import template YAML."),
    vehicle: str = typer.Option(None, "--vehicle",
                                help="Vehicle file name or path (default: the template's)."),
    outdir: Path = typer.Option(..., "-o", "--outdir", help="Output directory."),
    as_json: bool = typer.Option(False, "--json", help="Print results.json on stdout."),
    monte_carlo: int = typer.Option(0, "--monte-carlo", callback=bounded("mc_results"),
                                    help="Monte Carlo draws (0: first-order propagation)."),
    hot_start: list[Path] = typer.Option(None, "--hot-start",
                                         help="Hot-start UDDS files whose bag 1 stands in for "
                                              "the FTP bag 3 of a cold-start UDDS."),
) -> None:
    """Results per phase, whole test and regulatory composites, with uncertainty (k = 2),
    SOC correction and drive quality. Writes results.json into OUTDIR (atomically)."""
    from vehval.io.atomic import atomic_dir, write_text_atomic
    from vehval.workflow import TestRun

    run = TestRun.load(files, template, vehicle)
    hot = hot_start_bag1(list(hot_start), run.template) if hot_start else None
    res = run.results(method="monte_carlo" if monte_carlo else "first_order",
                      draws=monte_carlo or 1000, hot_start_bag1=hot).results
    doc = res.to_dict()
    qa = run.qa_outcome
    written = ["results.json"]
    with atomic_dir(outdir) as stage:
        write_text_atomic(stage / "results.json", json.dumps(doc, indent=1))
        if qa is not None:  # what `vehval report OUTDIR` reads, as `vehval qa` writes it
            from vehval.io.parquet import write_test

            write_text_atomic(stage / "findings.json", json.dumps(qa.document, indent=1))
            write_test(qa.result.validated, stage / "validated.parquet")
            written += ["findings.json", "validated.parquet"]
    if as_json:
        typer.echo(json.dumps(dict(doc, outdir=str(outdir), files=written), indent=1))
        return
    echo_results(res)
    for f in res.findings:
        typer.echo(f"  {f.severity.value:7s} {f.kind.value:14s} {f.message}")
    typer.echo(f"wrote {outdir}/: {', '.join(written)}")
