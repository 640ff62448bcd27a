"""`vehval epa repeatability`: repeatability s_r and reproducibility s_R measured on the EPA
Test Car Lists, per list, powertrain family and procedure."""

from __future__ import annotations

import math
from pathlib import Path

import typer

from vehval.cli.epa_common import epa_app
from vehval.cli.options import bounded


def _pct(p, width: int = 18) -> str:
    """``s [lo-hi]`` in per cent, or ``-``."""
    if p is None:
        return f"{'-':>{width}s}"
    return f"{100 * p.s:5.2f} [{100 * p.ci_low:.2f}-{100 * p.ci_high:.2f}]".rjust(width)


def _n(p, available: int) -> str:
    """Count used (and left out as outliers); for a refusal the count there was."""
    if p is None:
        return f"{available} (< 3: refused)" if available else "0"
    return f"{p.dof}" + (f" ({p.excluded} out)" if p.excluded else "")


def _offset(p) -> str:
    if p is None or not math.isfinite(p.offset):
        return "-"
    return f"{100 * p.offset:+.2f} [{100 * p.offset_ci[0]:+.2f}, {100 * p.offset_ci[1]:+.2f}]"


def precision_tables(paths: list[Path], confidence: float = 0.95,
                     pooled: bool = False) -> list[dict]:
    """Per list file (or, ``pooled``, over all of them): name, years, row counts and the
    :class:`~vehval.epa.precision.CellPrecision` of each family and procedure."""
    from vehval.epa import read_test_car_list
    from vehval.epa.precision import collect, estimate
    from vehval.epa.reader import find_list_files

    files = find_list_files(paths)
    per = [(f.name, read_test_car_list(f)) for f in files]
    if pooled:
        per = [(" + ".join(n for n, _ in per), [t for _, ts in per for t in ts])]
    out = []
    for name, tests in per:
        s = collect(tests)
        out.append({"list": name, "years": sorted({t.year for t in tests}),
                    "rows": s.dedup.to_dict() if s.dedup else {},
                    "cells": estimate(s, confidence)})
    return out


@epa_app.command("repeatability")
def repeatability_cmd(
    paths: list[Path] = typer.Argument(..., help="EPA Test Car List CSV files (e.g. "
                                       "16tstcar.csv) or directories holding them."),
    confidence: float = typer.Option(0.95, "--confidence", callback=bounded("confidence"),
                                     help="Level of the intervals (0.5-0.999)."),
    pooled: bool = typer.Option(False, "--pooled", help="One estimate over every list given "
                                "(test numbers de-duplicated across them)."),
    as_json: bool = typer.Option(False, "--json", help="Print JSON (figures in per cent)."),
) -> None:
    """Repeatability s_r (same lab, car, setting) and reproducibility s_R (EPA lab against
    manufacturer at one setting; strict and at the vehicle level), per list, powertrain
    family and procedure, with counts and chi-square intervals (docs/validation.md)."""
    tables = precision_tables(paths, confidence, pooled)
    if as_json:
        from vehval import jsonsafe

        typer.echo(jsonsafe.dumps({"confidence": confidence, "lists": [
            {**t, "cells": [c.to_dict() for c in t["cells"]]} for t in tables]}), nl=False)
        return
    lvl = f"{100 * confidence:g} %"
    for t in tables:
        r = t["rows"]
        typer.echo(f"{t['list']} (model year {', '.join(map(str, t['years']))}): "
                   f"{r.get('kept', 0)} rows used; left out: {r.get('duplicates', 0)} "
                   f"duplicate test numbers, {r.get('inconsistent', 0)} inconsistent, "
                   f"{r.get('no_result', 0)} without result, {r.get('unnumbered', 0)} "
                   "without test number")
        typer.echo(f"| family | procedure | s_r % [{lvl}] | pairs | s_R % [{lvl}] | settings "
                   f"| s_R vehicle % [{lvl}] | settings | EPA - MFR (vehicle) % |")
        typer.echo("|---|---|---|---|---|---|---|---|---|")
        for c in t["cells"]:
            n_r, n_R, n_Rv = c.counts
            typer.echo(f"| {c.family} | {c.procedure} | {_pct(c.s_r).strip()} | {_n(c.s_r, n_r)} "
                       f"| {_pct(c.s_R).strip()} | {_n(c.s_R, n_R)} "
                       f"| {_pct(c.s_R_vehicle).strip()} | {_n(c.s_R_vehicle, n_Rv)} "
                       f"| {_offset(c.s_R_vehicle)} |")
        typer.echo("")
    typer.echo("s_r: pooled over groups of same-lab repeats; "
               "s_R: EPA lab against manufacturer, one pair per setting; relative to the "
               "figure (RND_ADJ_FE).")
