"""`vehval cycles`: list and inspect the drive cycles shipped with the package."""

from __future__ import annotations

import json

import typer

from vehval.cli.app import app

cycles_app = typer.Typer(help="Drive cycles: regulatory speed traces and steady runs.",
                         no_args_is_help=True)
app.add_typer(cycles_app, name="cycles")


@cycles_app.command("list")
def list_cmd(as_json: bool = typer.Option(False, "--json", help="Print JSON.")) -> None:
    """List the package drive cycles: regulation, duration, distance, max and mean speed."""
    from vehval.cycles import list_cycles, load_cycle

    rows = [load_cycle(n).summary() for n in list_cycles()]
    if as_json:
        typer.echo(json.dumps(rows, indent=1))
        return
    from vehval.cli.table import render
    from vehval.constants import KMH_M_PER_S
    from vehval.display import unit_for

    dist, spd = unit_for("m"), unit_for("m/s")
    cols = ["name", "duration [s]", f"distance [{dist.label}]", f"max [{spd.label}]",
            f"mean [{spd.label}]", "regulation"]
    typer.echo(render(cols, [[r["name"], f"{r['duration_s']:g}",
                              f"{dist.convert(1000 * r['distance_km']):.2f}",
                              f"{spd.convert(r['max_speed_kph'] * KMH_M_PER_S):.1f}",
                              f"{spd.convert(r['mean_speed_kph'] * KMH_M_PER_S):.1f}",
                              r["regulation"]] for r in rows],
                      shrink=["regulation"], title="vehval drive cycles"))


@cycles_app.command("show")
def show_cmd(name: str = typer.Argument(..., help="Cycle name, alias, 'steady:60kph:300s' "
                                                  "or CSV path."),
             as_json: bool = typer.Option(False, "--json", help="Print JSON.")) -> None:
    """Show one cycle's figures, regulation and source."""
    from vehval.cycles import load_cycle

    info = load_cycle(name).summary()
    if as_json:
        typer.echo(json.dumps(info, indent=1))
        return
    from vehval.constants import KMH_M_PER_S
    from vehval.display import unit_for

    dist, spd = unit_for("m"), unit_for("m/s")
    shown = {"distance_km": (f"distance [{dist.label}]",
                             lambda v: f"{dist.convert(1000 * v):.3f}"),
             "max_speed_kph": (f"max speed [{spd.label}]",
                               lambda v: f"{spd.convert(v * KMH_M_PER_S):.1f}"),
             "mean_speed_kph": (f"mean speed [{spd.label}]",
                                lambda v: f"{spd.convert(v * KMH_M_PER_S):.1f}")}
    labels = {"duration_s": "duration [s]", "dt_s": "time step [s]",
              "idle_fraction": "idle fraction [-]"}
    for key, value in info.items():
        if value == "":
            continue
        if key in shown and isinstance(value, (int, float)):
            label, fmt = shown[key]
            typer.echo(f"{label + ':':20s} {fmt(value)}")
        else:
            typer.echo(f"{labels.get(key, key) + ':':20s} {value}")
