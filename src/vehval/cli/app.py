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


def _units_option(value: str | None) -> str | None:
    """``--units``: checked against the display systems, then in force for the whole run
    (every screen table, report and workbook reads it through :mod:`vehval.display`)."""
    if value is None:
        return None
    import os

    from vehval.display import ENV_VAR, system

    try:
        os.environ[ENV_VAR] = system(value)
    except ValueError as exc:
        raise typer.BadParameter(str(exc)) from None
    return value


@app.callback()
def _root(units: str = typer.Option(
        None, "--units", metavar="us|metric", callback=_units_option,
        help="Units people read (screen, report, Excel): us (mph, mi, mpg first; the "
             "default) or metric (km/h, km, L/100 km first). Data files and JSON stay SI.")
        ) -> None:
    """Vehicle test data to trusted knowledge: import, QA, simulate, validate."""
