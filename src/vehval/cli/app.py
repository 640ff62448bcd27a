"""The Typer application every command module registers on (imported by :mod:`vehval.cli`)."""

from __future__ import annotations

import typer

app = typer.Typer(
    name="vehval",
    help="Vehicle test data to trusted knowledge: import, QA, simulate, validate.",
    no_args_is_help=True,
    add_completion=False,
    rich_markup_mode=None,  # units in help texts are written "[s]": not rich markup
    pretty_exceptions_enable=False,
)


@app.callback()
def _root() -> None:
    """Vehicle test data to trusted knowledge: import, QA, simulate, validate."""
