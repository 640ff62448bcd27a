"""`vehval analyze`: control-strategy analysis of a test -> control.json."""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Callable

import typer

from vehval.cli.app import app
from vehval.cli.options import output_dir


@app.command("analyze")
def analyze_cmd(
    files: list[Path] = typer.Argument(..., help="Raw files of one test."),
    template: Path = typer.Option(..., "-t", "--template", help="Import template (YAML)."),
    vehicle: str = typer.Option(None, "--vehicle", help="Vehicle name or file (fixed controller "
                                "parameters, fuel map, battery limits)."),
    outdir: Path = typer.Option(..., "-o", "--outdir", callback=output_dir, help="Directory for control.json."),
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
    lines = getattr(result, "summary_lines", None)
    if lines is not None:  # an analysis that states its own summary (a parallel hybrid)
        first, *rest = lines()
        typer.echo(f"wrote {outdir / 'control.json'}: {first}")
        for line in rest:
            typer.echo(line)
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
            typer.echo(f"  SOC regulation not fitted: {_soc_why(result.soc_regulation['why'])}")
    for k, v in c.items():
        u = result.uncertainty.get(k, {})
        name, fmt = _shown(k)
        rng = (f"  [{fmt(u['low'], False)}, {fmt(u['high'])}]"
               if u.get("low") is not None and u.get("high") is not None else "")
        typer.echo(f"  {name} = {fmt(v)}{rng}")
    for k, b in result.rule.get("bounds", {}).items():
        name, fmt = _shown(k)
        low, high = b.get("low"), b.get("high")
        side = (f">= {fmt(low)}" if low is not None and high is None else
                f"<= {fmt(high)}" if high is not None and low is None else
                "not identifiable")
        typer.echo(f"  {name}: bound only ({side}): {_why(b, fmt)}")


def _shown(key: str) -> tuple[str, Callable[..., str]]:
    """A controller key as the screen names it, and the formatter of its SI values.

    ``engine_on_speed_mps`` -> ``engine_on_speed`` in mph (or km/h), ``engine_on_power_w``
    -> ``engine_on_power`` in kW, ``min_on_time_s`` in s, ``soc_target`` (a fraction) in %;
    control.json keeps the SI keys and values.
    """
    from vehval import display

    if key.startswith("soc_") and display.keyed_unit(key) is None:    # a SOC fraction
        unit: display.DisplayUnit | None = display.unit_for("dimensionless", signal="ess_soc")
        name = key
    else:
        name, unit = display.keyed_metric(key)
    if unit is None:
        return key, lambda value, labelled=True: display.number(float(value), 3)

    def fmt(value: float, labelled: bool = True) -> str:
        # three digits: the thresholds are resolved to 0.1 m/s, 100 W and one time step
        shown = display.number(float(unit.convert(float(value))), 3)
        return f"{shown} {unit.label}".rstrip() if labelled else shown

    return name, fmt


#: The analysis writes a bound's reason as ``<reason>: any value above|below <x> ...`` or
#: ``<reason>: any value in the plausible range [<lo>, <hi>] ...``, in SI.
_NUM = r"[-+0-9.eE]+"
_WHY_SIDE = re.compile(rf"^(?P<head>.*?: any value (?:above|below) )(?P<x>{_NUM})(?P<rest> .*)$")
_WHY_RANGE = re.compile(rf"^(?P<head>.*?: any value in the plausible range )"
                        rf"\[(?P<lo>{_NUM}), (?P<hi>{_NUM})\](?P<rest> .*)$")


def _why(bound: dict, fmt: Callable[..., str]) -> str:
    """The reason of a bound with its numbers in display units (control.json keeps SI)."""
    why = str(bound.get("why", ""))
    try:
        if (m := _WHY_SIDE.match(why)) is not None:
            return f"{m['head']}{fmt(float(m['x']))}{m['rest']}"
        if (m := _WHY_RANGE.match(why)) is not None:
            return (f"{m['head']}[{fmt(float(m['lo']), False)}, {fmt(float(m['hi']))}]"
                    f"{m['rest']}")
    except ValueError:
        pass
    return why


#: The SOC fit's reason writes the SOC span as a fraction (control.json); the screen in %.
_SOC_SPAN = re.compile(rf"^(?P<head>SOC spans only )(?P<x>{_NUM})(?P<rest> .*)$")


def _soc_why(why: str) -> str:
    """Why the SOC regulation was not fitted, a SOC span in % (control.json keeps the
    fraction)."""
    from vehval import display

    m = _SOC_SPAN.match(str(why))
    if m is None:
        return str(why)
    try:
        return f"{m['head']}{display.percent(float(m['x']))}{m['rest']}"
    except ValueError:
        return str(why)
