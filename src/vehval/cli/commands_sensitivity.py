"""`vehval sensitivity`: ranked effect of every uncertain vehicle parameter on fuel economy."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Optional

import typer

from vehval.cli.app import app
from vehval.cli.options import bounded


@app.command("sensitivity")
def sensitivity_cmd(
    vehicle: str = typer.Option("prius_2004", "--vehicle", help="Vehicle name or YAML path."),
    cycles: str = typer.Option("udds,hwfet,us06,japan1015,nedc", "--cycles",
                               help="Comma-separated cycle names."),
    params: Optional[str] = typer.Option(None, "--params", help="Comma-separated dotted "
                                         "parameters (default: all with an uncertainty)."),
    dt: float = typer.Option(1.0, "--dt", callback=bounded("dt"), help="Time step [s], in [0.001, 1]."),
    monte_carlo: int = typer.Option(0, "--monte-carlo", callback=bounded("mc_sensitivity"),
                                    help="Monte Carlo draws (0: none)."),
    seed: int = typer.Option(0, "--seed", callback=bounded("seed"), help="Seed of the Monte Carlo draws."),
    as_json: bool = typer.Option(False, "--json", help="Print the result as one JSON object."),
    outdir: Optional[Path] = typer.Option(None, "-o", "--output",
                                          help="Directory for sensitivity.json and .html."),
) -> None:
    """Rank the vehicle's uncertain parameters by their effect on fuel economy (tornado)."""
    from vehval.errors import ConfigError
    from vehval.jsonsafe import clean
    from vehval.sim.sensitivity import sensitivity

    names = [c.strip() for c in cycles.split(",") if c.strip()]
    if not names:
        raise ConfigError("--cycles: give at least one cycle name, e.g. udds,hwfet")
    if monte_carlo < 0:
        raise ConfigError(f"--monte-carlo must be >= 0, got {monte_carlo}")
    plist = [p.strip() for p in params.split(",") if p.strip()] if params else None
    from vehval.cli.progress import bar
    with bar("sensitivity: simulating", as_json=as_json):
        res = clean(sensitivity(vehicle, names, plist, dt=dt, monte_carlo=monte_carlo, seed=seed))
    if outdir is not None:
        from vehval.io.atomic import atomic_dir
        from vehval.report.page import plotly_asset_name, write_plotly_asset
        from vehval.report.sensitivity_page import render_sensitivity_page

        with atomic_dir(outdir) as stage:
            (stage / "sensitivity.json").write_text(json.dumps(res, indent=1), encoding="utf-8")
            write_plotly_asset(stage)
            (stage / "sensitivity.html").write_text(render_sensitivity_page(res, plotly_asset_name()),
                                                    encoding="utf-8")
    if as_json:
        typer.echo(json.dumps(res))
        return
    base = ", ".join(f"{c} {b['mpg']:.1f}" for c, b in res["base"].items())
    typer.echo(f"{res['vehicle']}: base {base} mpg (dt = {res['dt_s']:g} s)")
    typer.echo(f"  {'parameter':44s} {'swing %':>8s}  low/high % per cycle")
    for r in res["parameters"]:
        per = "  ".join(f"{r['cycles'][c]['low_pct']:+.1f}/{r['cycles'][c]['high_pct']:+.1f}"
                        for c in names)
        typer.echo(f"  {r['key']:44s} {r['swing_pct']:8.2f}  {per}")
    for c, m in res.get("monte_carlo", {}).items():
        typer.echo(f"  Monte Carlo {c}: {m['p5']:.1f} / {m['p50']:.1f} / {m['p95']:.1f} mpg "
                   f"(5/50/95 %, n = {m['n']})")
    if outdir is not None:
        typer.echo(f"  wrote {outdir / 'sensitivity.json'} and {outdir / 'sensitivity.html'}")
