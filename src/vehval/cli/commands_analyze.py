"""`vehval analyze`: control-strategy analysis of a test -> control.json."""

from __future__ import annotations

import json
from pathlib import Path

import typer

from vehval.cli.app import app


@app.command("analyze")
def analyze_cmd(
    files: list[Path] = typer.Argument(..., help="Raw files of one test."),
    template: Path = typer.Option(..., "-t", "--template", help="Import template (YAML)."),
    vehicle: str = typer.Option(None, "--vehicle", help="Vehicle name or file (fixed controller "
                                "parameters, fuel map, battery limits)."),
    outdir: Path = typer.Option(..., "-o", "--outdir", help="Directory for control.json."),
    qa: bool = typer.Option(True, "--qa/--no-qa", help="Align and compute _calc signals with the QA first."),
    as_json: bool = typer.Option(False, "--json", help="Print control.json."),
) -> None:
    """Estimate the engine on/off rule, SOC regulation, modes and braking split of a test."""
    from vehval.io.atomic import write_text_atomic
    from vehval.io.paths import check_outputs, vehicle_path
    from vehval.workflow import TestRun

    check_outputs(outdir=outdir, writes=["control.json"],
                  inputs=[*files, template, vehicle_path(vehicle)])
    run = TestRun.load(files, template, vehicle, use_qa=qa)
    outcome = run.analyze()
    for note in outcome.notes:
        typer.echo(f"note: {note}", err=True)
    result = outcome.result
    text = json.dumps(result.to_dict(), indent=1) + "\n"
    outdir.mkdir(parents=True, exist_ok=True)
    write_text_atomic(outdir / "control.json", text)
    if as_json:
        typer.echo(text, nl=False)
        return
    from vehval.analysis.summary import judged_conventional

    c = result.controller
    agree = result.rule_agreement
    if judged_conventional(result.findings):  # the analysis' own decision, not a second rule
        # the engine on/off rule, SOC regulation and modes are the hybrid's control strategy
        typer.echo(f"wrote {outdir / 'control.json'}: a conventional vehicle (its vehicle file "
                   "says so, or no battery, motor or generator signal and the engine runs "
                   "whenever the car moves): no hybrid control strategy to estimate")
        return
    typer.echo(f"wrote {outdir / 'control.json'}: {len(c)} controller parameter(s) estimated, "
               f"rule agreement {f'{agree:.1%} of steps' if agree is not None else 'n/a'}")
    if not c:  # say why nothing was estimated (the reasons are in control.json too)
        for f in result.findings:
            if f.get("kind") == "warning" and f.get("signal") in ("engine state", "wheel power"):
                typer.echo(f"  {f['message']}")
        on = (result.engine or {}).get("on_share")
        if on is not None and (result.engine or {}).get("starts") == 0:
            typer.echo(f"  the engine state never changes: {'on' if on > 0.5 else 'off'} over "
                       "the whole test")
        if result.soc_regulation.get("why"):
            typer.echo(f"  SOC regulation not fitted: {result.soc_regulation['why']}")
    for k, v in c.items():
        u = result.uncertainty.get(k, {})
        rng = f"  [{u['low']:g}, {u['high']:g}]" if u.get("low") is not None and u.get("high") is not None else ""
        typer.echo(f"  {k} = {v:g}{rng}")
    for k, b in result.rule.get("bounds", {}).items():
        side = (f">= {b['low']:g}" if b.get("low") is not None and b.get("high") is None else
                f"<= {b['high']:g}" if b.get("high") is not None and b.get("low") is None else
                "not identifiable")
        typer.echo(f"  {k}: bound only ({side}): {b.get('why', '')}")
