"""What the `vehval epa` commands share: the command group, reading and selecting list
rows with their notes, the display of a listed fuel economy, the driveline mismatch lines."""

from __future__ import annotations

import math
from pathlib import Path

import typer

from vehval.cli.app import app

epa_app = typer.Typer(help="EPA Test Car List: certification dyno results per test.",
                      no_args_is_help=True)
app.add_typer(epa_app, name="epa")

_PATHS_HELP = "EPA Test Car List CSV files (e.g. 16tstcar.csv) or directories holding them."


def _fmt(x: float | None, spec: str = ".1f") -> str:
    return "-" if x is None or (isinstance(x, float) and math.isnan(x)) else format(x, spec)


def _load(paths: list[Path], make, model, year):
    from vehval.epa import read_lists, select_tests

    every = read_lists(paths)
    selected = select_tests(every, make, model, year)
    _note_model(every, model, make, year)
    return selected


def _note_model(every: list, model: str | None, make: str | None, year) -> None:
    """Say on stderr what a model name took when it may not be what was meant: a part of
    the names (``PRIUS`` in a year that lists only ``PRIUS c``), or one exact name where
    others contain it too (``F150``: a Roush, not the 13 Ford F150 names)."""
    from vehval.epa.select import model_note

    note = model_note(every, model, make, year)
    if note:
        typer.echo(f"note: {note}", err=True)


def _fe_display():
    """(unit label, mpg -> shown value, format) of a listed fuel economy: mpg in the us
    system, L/100 km in metric (the list states mpg; --json keeps it)."""
    from vehval.display import system

    if system() == "metric":
        from vehval.fuels import (
            l_per_100km_from_volume_per_distance,
            mpg_from_volume_per_distance,
        )

        # mpg = k / (volume per distance), k the fuel quantities' own gallon per mile
        k = float(mpg_from_volume_per_distance(1.0))

        def to_l(mpg: float | None) -> float | None:
            if mpg is None or not mpg > 0:
                return None
            return float(l_per_100km_from_volume_per_distance(k / mpg))
        return "L/100 km", to_l, ".2f"
    return "mpg", (lambda mpg: mpg), ".1f"


def _selected(paths: list[Path], selector: str, dt: float, every: list | None = None):
    """Tests of the list files matching ``selector`` (refused if none; ``dt`` checked);
    ``every``, when given, receives every test read."""
    from vehval.epa import apply_selector, read_lists
    from vehval.epa.select import parse_selector
    from vehval.errors import InputFileError
    from vehval.sim.simulate import _check_dt

    _check_dt(dt)
    tests = read_lists(paths)
    if every is not None:
        every.extend(tests)
    selected = apply_selector(tests, selector)
    if not selected:
        raise InputFileError(f"the selector '{selector}' matches no test")
    sel = parse_selector(selector)
    _note_model(tests, sel.get("model"), sel.get("make"), sel.get("year"))
    return selected


def _echo_mismatches(checks, err: bool = False) -> None:
    """One '!' line per distinct note of the tests whose driveline differs from the vehicle
    file's (``checks``: (test label, VehicleCheck or None) pairs)."""
    from vehval.epa.consistency import group_mismatches

    for note, labels in group_mismatches(checks).items():
        shown = ", ".join(labels[:3]) + (" ..." if len(labels) > 3 else "")
        typer.echo(f"! {len(labels)} test(s) ({shown}): {note}", err=err)
