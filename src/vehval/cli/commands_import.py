"""`vehval signals`: the nomenclature registry. (Import commands are added here too.)"""

from __future__ import annotations

import json

import typer

from vehval.cli import app
from vehval.nomenclature import registry


@app.command("signals")
def signals_cmd(as_json: bool = typer.Option(False, "--json", help="Print JSON.")) -> None:
    """List the standard base names with unit, category and plausible range."""
    reg = registry()
    if as_json:
        typer.echo(json.dumps({b: {"unit": s.unit, "category": s.category, "range": s.range,
                                   "description": s.description} for b, s in reg.specs.items()}))
        return
    for b, s in reg.specs.items():
        typer.echo(f"{b:22s} {s.unit:10s} {s.category:12s} {s.description}")
