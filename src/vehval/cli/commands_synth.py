"""`vehval synth`: write a virtual test (simulated run + virtual sensors + known faults)."""

from __future__ import annotations

import json
from pathlib import Path

import typer

from vehval.cli.app import app
from vehval.cli.options import bounded, output_dir


def _pairs(items: list[str], option: str) -> dict:
    from vehval.cli.options import parse_assignments

    return parse_assignments(items, option, "soc_target=0.6")


@app.command("synth")
def synth_cmd(
    vehicle: str = typer.Option("prius_2004", "--vehicle", help="Vehicle name or YAML path."),
    cycle: str = typer.Option("udds", "--cycle", help="Cycle name, 'steady:60kph:300s' or CSV path."),
    seed: int = typer.Option(7, "--seed", callback=bounded("seed"), help="Seed of every random draw (same seed, same bytes)."),
    faults: str = typer.Option("default", "--faults",
                               help="'default' (a representative mix), 'none', or a fault YAML file."),
    out: Path = typer.Option(..., "-o", "--out", callback=output_dir, help="Output directory (written atomically)."),
    control: list[str] = typer.Option([], "--control", metavar="KEY=VALUE",
                                      help="Controller parameter override (repeatable)."),
    param: list[str] = typer.Option([], "--param", metavar="KEY=VALUE",
                                    help="Vehicle parameter override, dotted key (repeatable)."),
    force: bool = typer.Option(False, "--force", help="Write into a non-empty directory that "
                                                      "is not a previous virtual test."),
    as_json: bool = typer.Option(False, "--json", help="Print the output paths as JSON."),
) -> None:
    """Simulate VEHICLE on CYCLE and write it as a virtual dyno test: a D3 facility file, an
    OBD logger file, an import template and truth.json (every injected offset and fault)."""
    from vehval.architectures import require
    from vehval.io.paths import check_outputs, vehicle_path
    from vehval.vehicle import load_vehicle

    check_outputs(outdir=out, inputs=[vehicle_path(vehicle), vehicle_path(cycle),
                                      vehicle_path(faults)])
    veh = load_vehicle(vehicle)
    made = require(veh, "synth")(veh, vehicle, cycle, seed, faults, out, _pairs(control, "--control"),
                             _pairs(param, "--param"), force)
    if as_json:
        typer.echo(json.dumps(made.document, indent=1))
        return
    for line in made.lines:
        typer.echo(line)
