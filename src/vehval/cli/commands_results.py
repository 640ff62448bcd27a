"""`vehval results`: import, QA and the results stage of one test; writes results.json."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import typer

from vehval.cli.app import app
from vehval.cli.options import bounded, output_dir
from vehval.errors import InputFileError, VehvalError


def hot_start_bag1(files: list[Path], template) -> dict[str, float]:
    """Fuel mass [kg], distance [m] and CO2 [kg] of bag 1 of a hot-start UDDS test."""
    from vehval.io.importer import import_test
    from vehval.results import results_from_template

    for f in files:
        if not f.exists():
            raise InputFileError(f"{f}: file not found (--hot-start): check the path")
    hot = results_from_template(import_test(files, template), template)
    if hot.conditions.get("start") == "cold":
        raise VehvalError(f"--hot-start {files[0]}: the test starts cold "
                          f"({hot.conditions.get('start_basis')}): its bag 1 cannot stand in "
                          "for the FTP bag 3 (hot start after the 10 min soak, 40 CFR 86.137); "
                          "give the hot-start UDDS run after the cold one")
    bag1 = next((p for p in hot.phases if p.part == "bag1" and p.run == 1), None)
    if bag1 is None or hot.cycle.split("_x")[0] not in ("udds", "ftp75"):
        raise VehvalError(f"--hot-start {files[0]}: not a UDDS test with a bag 1 (cycle "
                          f"{hot.cycle or 'not identified'}): give a hot-start UDDS test")
    vals = hot.values[bag1.name]
    return {k: v for k in ("fuel_mass_kg", "distance_m", "co2_kg")
            if (v := vals.get(k)) is not None}


def _hot_start_not_the_test(files: list[Path], hot: list[Path]) -> None:
    """Refuse a ``--hot-start`` file that is one of the test's own files (the same file by
    device and inode): its bag 1 is this test's, not the hot start after the soak."""
    from vehval.io.paths import shared_file

    same = shared_file(files, hot)
    if same is not None:
        raise VehvalError(f"--hot-start {same[1]}: is a file of the test itself: give the "
                          "hot-start UDDS run after the soak, another test")


def headline_lines(doc: dict) -> list[str]:
    """The headline of a results.json document (:meth:`vehval.results.headline.Headline.lines`):
    its figure with U and caveats, or why it is withheld."""
    from vehval.results.headline import headline_of

    h = headline_of(doc)
    return h.lines() if h is not None else ["headline test: fuel economy n/a"]


def _fuel_declared(fuel) -> str:
    """The declared fuel as the figures use it: name, density, heating value."""
    if fuel is None:
        return "(not declared)"
    rho, lhv = fuel.density_kg_per_m3, fuel.lhv_j_per_kg
    props = ", ".join(([f"{rho:g} kg/m3"] if rho else []) + ([f"{lhv / 1e6:.1f} MJ/kg"] if lhv else []))
    origin = getattr(fuel, "origin", "declared")
    return f"{fuel.name} ({props}; {origin}: not checkable from the data)" if props else fuel.name


def _method_text(res) -> str:
    """The propagation that gave the stated U; a Monte Carlo with its own sampling error."""
    if res.method != "monte_carlo" or not res.draws:
        return res.method.replace("_", " ")
    n = int(res.draws)
    return (f"monte carlo ({n} draws: U itself uncertain by about "
            f"{100 / (2 * (n - 1)) ** 0.5:.2g} %)")


def withheld_exit(doc: dict) -> None:
    """Exit code 4 when a figure of a results.json document was withheld (not forced)."""
    from vehval.results.gate import EXIT_WITHHELD

    if doc.get("withheld_count") and not doc.get("forced"):
        raise typer.Exit(EXIT_WITHHELD)


def _fe_text(res: Any, scope: str) -> str:
    """The fuel economy of ``scope`` as the screen states it (withheld, n/a, or mpg and
    L/100 km in the reading order of ``--units``)."""
    from vehval.display import system as display_system

    v = res.value(scope, "fuel_economy_mpg")
    held = res.withheld.get(scope)
    if held and "fuel_economy_mpg" in held["quantities"] and not res.forced:
        return f"fuel economy withheld ({', '.join(held['signals'])})"
    if v is None:
        m = res.value(scope, "fuel_mass_kg")
        return "fuel economy n/a" + (f" (fuel {m * 1e3:.1f} g)" if m is not None else "")
    u = res.expanded(scope, "fuel_economy_mpg")
    lp = res.value(scope, "fuel_consumption_l_per_100km")
    ul = res.expanded(scope, "fuel_consumption_l_per_100km")
    mpg = f"{v:6.2f} +- {u or 0:.2f} mpg"
    if lp is None:
        return mpg
    lkm = f"{lp:.2f} +- {ul or 0:.2f} L/100 km" if ul is not None else f"{lp:.2f} L/100 km"
    return f"{mpg} ({lkm})" if display_system() == "us" else f"{lkm} ({mpg.strip()})"


def echo_results(res) -> None:
    """Headline lines: phases and composites with their expanded uncertainty."""
    from vehval.display import unit_for

    dist_u, spd_u = unit_for("m"), unit_for("m/s")

    def dist(scope: str) -> str:
        d = res.value(scope, "distance_m")
        if d is not None:
            return f"{dist_u.convert(d):6.2f} {dist_u.label}"
        held = "distance_m" in (res.withheld.get(scope) or {}).get("quantities", [])
        return f"{'withheld' if held else 'n/a':>{7 + len(dist_u.label)}s}"

    typer.echo(f"{res.test_id}: cycle {res.cycle or '(not identified)'}; phases from "
               f"{res.phase_source}; fuel {_fuel_declared(res.fuel)}")
    for line in headline_lines(res.to_dict()):
        typer.echo(f"  {line}")
    # a car that burns no fuel: its figures are the SAE J1634 ones below, no fuel economy
    electric = res.j1634 is not None and res.value("test", "fuel_mass_kg") is None

    def fe_or_none(scope: str) -> str:
        return "" if electric else _fe_text(res, scope)

    for p in res.phases:
        dq = res.drive_quality.get(p.name) or {}
        extra = (f"  IWR {dq['iwr_pct']:+.1f} %, RMSSE {spd_u.convert(dq['rmsse_mps']):.2f} "
                 f"{spd_u.label}" if dq.get("iwr_pct") is not None else "")
        typer.echo(f"  {p.name:18s} {dist(p.name)}  {fe_or_none(p.name)}{extra}".rstrip())
    typer.echo(f"  {'whole test':18s} {dist('test')}  {fe_or_none('test')}".rstrip())
    for c in [] if electric else res.composites:
        typer.echo(f"  = {c.name:16s} {_fe_text(res, c.name)}  [{c.rule.split(':')[0]}]")
        for cav in getattr(c, "caveats", []):
            typer.echo(f"      ! {cav}")
    for note in res.notes:
        if note.startswith("FTP-75:"):
            typer.echo(f"  ! {note}")
    typer.echo(_j1634_text(res) + f"  uncertainty: {_method_text(res)}, k = 2"
               + ("" if electric else f"; SOC: {res.soc['status']}"))
    if res.withheld:
        typer.echo(f"  {len(res.withheld)} figure(s) "
                   + ("stated despite QA errors (--force)" if res.forced else
                      "withheld for QA errors (exit code 4)"))
        for reason, fix in _withheld_reasons(res.withheld):
            typer.echo(f"    withheld because: {reason}")
            typer.echo(f"    fix: {fix}")


def _withheld_reasons(withheld: dict) -> list[tuple[str, str]]:
    """Each distinct (reason, fix) of the withheld figures, in scope order: the screen names
    why every figure was withheld, also those the headline does not show."""
    seen: dict[str, str] = {}
    for entry in withheld.values():
        seen.setdefault(entry["reason"], entry.get("fix") or "")
    return list(seen.items())


@app.command("results")
def results_cmd(
    files: list[Path] = typer.Argument(..., help="Raw files of one test."),
    template: Path = typer.Option(..., "-t", "--template", help="Import template YAML."),
    vehicle: str = typer.Option(None, "--vehicle",
                                help="Vehicle file name or path (default: the template's)."),
    outdir: Path = typer.Option(..., "-o", "--outdir", callback=output_dir, help="Output directory."),
    as_json: bool = typer.Option(False, "--json", help="Print results.json on stdout."),
    monte_carlo: int = typer.Option(0, "--monte-carlo", callback=bounded("mc_results"),
                                    help="Monte Carlo draws (0: first-order propagation)."),
    hot_start: list[Path] = typer.Option(None, "--hot-start",
                                         help="Hot-start UDDS files whose bag 1 stands in for "
                                              "the FTP bag 3 of a cold-start UDDS."),
    force: bool = typer.Option(False, "--force",
                               help="State figures QA errors would withhold, under a banner "
                                    "(exit 0 instead of 4)."),
) -> None:
    """Results per phase, whole test and regulatory composites, with uncertainty (k = 2),
    SOC correction and drive quality. Writes results.json into OUTDIR (atomically).
    Exit code 4: computed, but a figure was withheld for a QA error on its signals."""
    from vehval.io.atomic import atomic_dir, write_text_atomic
    from vehval.io.paths import check_outputs, vehicle_path
    from vehval.workflow import TestRun

    check_outputs(outdir=outdir, inputs=[*files, template, vehicle_path(vehicle), *(hot_start or [])],
                  writes=["results.json", "findings.json", "validated.parquet"])
    _hot_start_not_the_test(files, hot_start or [])
    run = TestRun.load(files, template, vehicle)
    hot = hot_start_bag1(list(hot_start), run.template) if hot_start else None
    res = run.results(method="monte_carlo" if monte_carlo else "first_order",
                      draws=monte_carlo or 1000, hot_start_bag1=hot, force=force).results
    doc = res.to_dict()
    qa = run.qa_outcome
    written = ["results.json"]
    with atomic_dir(outdir) as stage:
        write_text_atomic(stage / "results.json", json.dumps(doc, indent=1))
        if qa is not None:  # what `vehval report OUTDIR` reads, as `vehval qa` writes it
            from vehval.io.parquet import write_test

            write_text_atomic(stage / "findings.json", json.dumps(qa.document, indent=1))
            write_test(qa.result.validated, stage / "validated.parquet")
            written += ["findings.json", "validated.parquet"]
    if as_json:
        typer.echo(json.dumps(dict(doc, outdir=str(outdir), files=written), indent=1))
        withheld_exit(doc)
        return
    echo_results(res)
    for f in res.findings:
        typer.echo(f"  {f.severity.value:7s} {f.kind.value:14s} {f.message}")
    typer.echo(f"wrote {outdir}/: {', '.join(written)}")
    withheld_exit(doc)


def _j1634_text(res) -> str:
    """SAE J1634 figures of a battery-electric test (AC energy per distance in the display
    units, kWh/100 mi or kWh/100 km, and MPGe per scope), one line each, newline-terminated;
    '' for any other test."""
    from vehval.display import system

    j = getattr(res, "j1634", None)
    if not j:
        return ""
    per = ("ac_kwh_per_100mi", "kWh/100 mi") if system() == "us" else \
        ("ac_kwh_per_100km", "kWh/100 km")
    basis = (f"charger efficiency {j['charger_efficiency']:g}"
             + (" (assumed)" if j["charger_efficiency_assumed"] else ""))
    lines = [f"  SAE J1634 (AC energy: {basis}):"]
    for scope, f in j["scopes"].items():
        lines.append(f"    {scope:16s} DC {f['dc_energy_kwh']:.3f} kWh  AC "
                     f"{f[per[0]]:.1f} {per[1]}  {f['mpge']:.1f} MPGe")
    return "\n".join(lines) + "\n"

