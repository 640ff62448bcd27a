"""`vehval epa list|tests`: the vehicles and the tests of the EPA Test Car List."""

from __future__ import annotations

from pathlib import Path

import typer

from vehval.cli.epa_common import _PATHS_HELP, _fe_display, _fmt, _load, epa_app
from vehval.cli.options import bounded


@epa_app.command("list")
def list_cmd(
    paths: list[Path] = typer.Argument(..., help=_PATHS_HELP),
    make: str | None = typer.Option(None, "--make", help="Make, e.g. TOYOTA."),
    model: str | None = typer.Option(None, "--model", help="Model name or part of it."),
    year: int | None = typer.Option(None, "--year", callback=bounded("year"), help="Model year."),
    as_json: bool = typer.Option(False, "--json", help="Print JSON."),
) -> None:
    """Vehicles (make, model, year) in the list with their test vehicles and test counts."""
    from vehval import jsonsafe
    from vehval.epa import vehicles

    tests = _load(paths, make, model, year)
    rows = vehicles(tests)
    if as_json:
        typer.echo(jsonsafe.dumps(rows), nl=False)
        return
    repeated = sum(1 for t in tests if t.duplicate_rows)
    if repeated:
        typer.echo(f"note: {repeated} test number(s) listed on several rows (duplicate rows "
                   "counted once; `vehval epa tests` names their lines)", err=True)
    from vehval.display import unit_for

    mu = unit_for("kg")
    typer.echo(f"{'year':>4}  {'make':12s} {'model':32s} {'tests':>5}  "
               f"{f'ETW [{mu.label}]':>16}  test vehicles")
    for r in rows:
        mass = "/".join(f"{mu.convert(m):.0f}" for m in r.mass_kg[:3]) + (
            "..." if len(r.mass_kg) > 3 else "")
        ids = ", ".join(r.vehicle_ids[:4]) + (" ..." if len(r.vehicle_ids) > 4 else "")
        typer.echo(f"{r.year:>4}  {r.make[:12]:12s} {r.model[:32]:32s} {r.n_tests:>5}  "
                   f"{mass:>16}  {ids}")
    n_tests = sum(r.n_tests for r in rows)
    typer.echo(f"{len(rows)} vehicle{'' if len(rows) == 1 else 's'}, "
               f"{n_tests} test{'' if n_tests == 1 else 's'}")


@epa_app.command("tests")
def tests_cmd(
    paths: list[Path] = typer.Argument(..., help=_PATHS_HELP),
    make: str | None = typer.Option(None, "--make", help="Make, e.g. TOYOTA."),
    model: str | None = typer.Option(None, "--model", help="Model name or part of it."),
    year: int | None = typer.Option(None, "--year", callback=bounded("year"), help="Model year."),
    as_json: bool = typer.Option(False, "--json", help="Print JSON (SI units, keys as the "
                                 "EpaTest fields)."),
) -> None:
    """Tests of a vehicle: weight, N/V, axle ratio, road load (display units; SI in --json),
    cycle, originator, results."""
    from vehval import jsonsafe
    from vehval.epa import procedure_key
    from vehval.epa.consistency import check_listed_figures, impossible_values

    tests = _load(paths, make, model, year)
    checks = [check_listed_figures(t) for t in tests]
    if as_json:
        typer.echo(jsonsafe.dumps([{**t.to_dict(), "procedure_key": procedure_key(t),
                                    "list_check": c.to_dict(),
                                    "impossible_values": impossible_values(t)}
                                   for t, c in zip(tests, checks)]), nl=False)
        return
    from vehval.display import keyed_unit, unit_for

    # the display units (us: lb, lbf, lbf/mph, lbf/mph², as the list itself; metric: kg, N,
    # N/(m/s), N/(m/s)², as every other road load on screen); --json stays SI
    mu, fu = unit_for("kg"), unit_for("N")
    bu, cu = keyed_unit("target_b_n_per_mps"), keyed_unit("target_c_n_per_mps2")
    assert bu is not None and cu is not None       # compound keys the display owner knows
    fe = _fe_display()
    # the test and vehicle IDs whole: they are what --tests number=/vehicle= and
    # --vehicle-id take
    wt = max([14, *(len(t.label) for t in tests)])
    wv = max([9, *(len(t.vehicle_id) for t in tests)])
    typer.echo(f"{'test':{wt}s} {'vehicle':{wv}s} {'cfg':>3} {'orig':4s} {'proc':7s} "
               f"{'trans':5s} {'fuel':6s} "
               f"{f'ETW {mu.label}':>7} {'N/V':>5} {'axle':>5} {f'A {fu.label}':>7} "
               f"{f'B {bu.label}':>11} {f'C {cu.label}':>12} {'FE':>6}  "
               f"bags 1-4 (FE, bags: {fe[0]}; elec: {_electric_unit()})")
    for t, chk in zip(tests, checks):
        # an electricity row's figures are MPGe or kWh/100 mi, never mpg
        shown = _electric_shown if _fuel_text(t) == "elec" else (
            lambda v: _fmt(fe[1](v), fe[2]))
        bags = " ".join(f"{shown(b_):>6}" for b_ in t.bags) + (
            "" if chk.ok else "  !") + ("  AD" if t.analytically_derived else "")
        typer.echo(f"{t.label:{wt}s} {t.vehicle_id:{wv}s} {t.config[:3]:>3} "
                   f"{(t.originator or '?')[:4]:4s} {procedure_key(t)[:7]:7s} "
                   f"{_trans_text(t):5s} {_fuel_text(t):6s} "
                   f"{_fmt(float(mu.convert(t.mass_kg)), '.0f'):>7} {_fmt(t.n_v_ratio):>5} "
                   f"{_fmt(t.axle_ratio, '.2f'):>5} {_fmt(float(fu.convert(t.target_a_n)), '.2f'):>7} "
                   f"{_fmt(float(bu.convert(t.target_b_n_per_mps)), '.4f'):>11} "
                   f"{_fmt(float(cu.convert(t.target_c_n_per_mps2)), '.5f'):>12} "
                   f"{shown(t.fe):>6}  {bags}")
    typer.echo(f"{len(tests)} tests (road-load target coefficients; set coefficients and SI "
               "units in --json; N/V in rpm/mph as listed)")
    for t, chk in zip(tests, checks):
        if not chk.ok:
            typer.echo(f"! {t.label} ({t.source}): {chk.note}")
        for text in impossible_values(t).values():
            typer.echo(f"! {t.label} ({t.source}): {text}")
    _echo_list_marks(tests)


def _echo_list_marks(tests: list) -> None:
    """The list's own marks: tests listed again (one line each) and the analytically
    derived ones (one line: the 'AD' of the table)."""
    for t in tests:
        if t.duplicate_note:
            typer.echo(f"note: {t.label} ({t.source}): {t.duplicate_note}")
    derived = [t for t in tests if t.analytically_derived]
    if derived:
        typer.echo(f"AD: {len(derived)} test(s) the list marks as analytically derived "
                   "('Analytically Derived FE?' Yes: figures computed from another test, "
                   "'adfe_test_number' in --json), not measured; `epa validate` does not "
                   "judge them")
    if tests and all(t.analytically_derived is None for t in tests):
        typer.echo("AD: the list has no 'Analytically Derived FE?' column (a reduced column "
                   "set): derived figures cannot be told from measured ones")


def _electric_unit() -> str:
    """The unit an electricity row's figures are shown in: as listed (MPGe; a consumption
    row kWh/100 mi) in the us system, kWh/100 km in metric."""
    from vehval.display import system

    return "MPGe or kWh/100 mi as listed" if system() == "us" else "kWh/100 km"


def _electric_shown(value: float) -> str:
    """An electricity row's figure in :func:`_electric_unit` (its unit read by
    :func:`vehval.epa.bev.figure_unit`)."""
    import math

    from vehval.epa.bev import figure_unit, shown_figure

    if value is None or not math.isfinite(value) or value <= 0:
        return _fmt(value)
    return _fmt(shown_figure(value, figure_unit(value))[0])


def _trans_text(t) -> str:
    """Transmission code and gear count as listed (``SA8``, ``M6``, ``CVT``; ``?``)."""
    code = t.transmission or "?"
    return code if code in ("CVT", "?") or t.gears <= 1 else f"{code}{t.gears}"


#: the list's test fuel descriptions, shortened (first match wins)
_FUELS = (("COLD CO", "coldCO"), ("DIESEL", "diesel"), ("E85", "E85"),
          ("ELECTRIC", "elec"), ("HYDROGEN", "H2"), ("CNG", "CNG"), ("E10", "E10"),
          ("GASOLINE", "gas"))


def _fuel_text(t) -> str:
    up = t.fuel.upper()
    return next((short for key, short in _FUELS if key in up), t.fuel[:6] or "?")
