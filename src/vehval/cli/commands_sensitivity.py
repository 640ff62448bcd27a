"""`vehval sensitivity`: ranked effect of every uncertain vehicle parameter on fuel economy."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Optional

import typer

from vehval.cli.app import app
from vehval.cli.options import bounded, output_dir

#: default simulation step [s]: the step of `vehval epa validate` and of the figures in the
#: docs (1 s moved the 2016 Prius's UDDS weight elasticity from -0.288 to -0.326)
DEFAULT_DT_S = 0.2


@app.command("sensitivity")
def sensitivity_cmd(
    vehicle: str = typer.Option("prius_2004", "--vehicle", help="Vehicle name or YAML path."),
    cycles: str = typer.Option("udds,hwfet,us06,japan1015,nedc", "--cycles",
                               help="Comma-separated cycle names."),
    params: Optional[str] = typer.Option(None, "--params", help="Comma-separated dotted "
                                         "parameters (default: all with an uncertainty)."),
    dt: float = typer.Option(DEFAULT_DT_S, "--dt", callback=bounded("dt"),
                             help="Time step [s], in [0.001, 1] (0.2 s as `epa validate`: "
                             "1 s moves it -3 to +2.5 % against 0.1 s, the Insight's "
                             "manual gearbox +1 to +10 %)."),
    monte_carlo: int = typer.Option(0, "--monte-carlo", callback=bounded("mc_sensitivity"),
                                    help="Monte Carlo draws (0: none)."),
    seed: int = typer.Option(0, "--seed", callback=bounded("seed"), help="Seed of the Monte Carlo draws."),
    as_json: bool = typer.Option(False, "--json", help="Print the result as one JSON object."),
    outdir: Optional[Path] = typer.Option(None, "-o", "--output", callback=output_dir,
                                          help="Directory for sensitivity.json and .html."),
    road_load: bool = typer.Option(False, "--road-load", help="Instead of the tornado: the "
                                   "fuel economy's elasticity to test weight and road load "
                                   "(A, B, C) per cycle; with --epa, between the list's "
                                   "configurations, model against list."),
    epa: Optional[list[Path]] = typer.Option(None, "--epa", help="EPA Test Car List files or "
                                             "directories (with --road-load)."),
    tests: Optional[list[str]] = typer.Option(None, "--tests", help="EPA test selector "
                                              "(repeatable), e.g. 'model=PRIUS Eco,year=2016'."),
) -> None:
    """Rank the vehicle's uncertain parameters by their effect on fuel economy (tornado)."""
    from vehval.jsonsafe import clean
    from vehval.sim.sensitivity import sensitivity

    if outdir is not None:
        from vehval.io.paths import check_outputs, vehicle_path

        check_outputs(outdir=outdir, inputs=[vehicle_path(vehicle), *(epa or [])],
                      writes=["sensitivity.json", "sensitivity.html", "road_load.json"])
    names = _names(cycles, "--cycles", "cycle name, e.g. udds,hwfet")
    if road_load or epa or tests:
        _road_load(vehicle, names, dt, epa, tests, as_json, outdir)
        return
    plist = None if params is None else _names(params, "--params", "parameter, e.g. "
                                               "body.aux_power_w (leave --params out for all)")
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
    from vehval.cli.epa_common import _fe_display

    unit, fe, fmt = _fe_display()
    shown = {c: fe(b["mpg"]) for c, b in res["base"].items()}
    base = ", ".join(f"{c} {_num(v, fmt)}" for c, v in shown.items())
    typer.echo(f"{res['vehicle']}: base {base} {unit} (dt = {res['dt_s']:g} s)")
    typer.echo(f"  {'parameter':44s} {'swing %':>8s}  low/high % per cycle (fuel economy "
               "change)")
    for r in res["parameters"]:
        per = "  ".join(f"{_num(r['cycles'][c]['low_pct'], '+.1f')}/"
                        f"{_num(r['cycles'][c]['high_pct'], '+.1f')}" for c in res["cycles"])
        typer.echo(f"  {r['key']:44s} {_num(r['swing_pct'], '8.2f')}  {per}")
    for c, m in res.get("monte_carlo", {}).items():
        ps = [fe(m[k]) for k in ("p5", "p50", "p95")]
        if ps[0] is not None and ps[2] is not None and ps[0] > ps[2]:
            ps = ps[::-1]  # a consumption falls as the economy rises: its 5 % is the mpg's 95 %
        typer.echo(f"  Monte Carlo {c}: {' / '.join(_num(v, fmt) for v in ps)} {unit} "
                   f"(5/50/95 %, n = {m['n']})")
    if outdir is not None:
        typer.echo(f"  wrote {outdir / 'sensitivity.json'} and {outdir / 'sensitivity.html'}")


def _names(text: str, option: str, example: str) -> list[str]:
    """The comma-separated names of ``option`` (stripped); ConfigError when there is none."""
    from vehval.errors import ConfigError

    names = [c.strip() for c in text.split(",") if c.strip()]
    if not names:
        raise ConfigError(f"{option}: give at least one {example}")
    return names


def _num(value: float | None, fmt: str) -> str:
    """``value`` in ``fmt``, ``n/a`` for a missing figure (an end that is no valid vehicle)."""
    return "n/a" if value is None else format(value, fmt)


def _road_load(vehicle: str, cycles: list[str], dt: float, epa: Optional[list[Path]],
               tests: Optional[list[str]], as_json: bool, outdir: Optional[Path]) -> None:
    """``--road-load``: elasticities per cycle and, with ``--epa``, model against list."""
    from vehval.errors import ConfigError
    from vehval.jsonsafe import clean
    from vehval.sim.sensitivity import configuration_pairs, load_derivatives

    if bool(epa) != bool(tests):
        raise ConfigError("--road-load against the list needs both --epa LISTS and --tests "
                          "SELECTOR (one per configuration set, e.g. --tests 'model=PRIUS Eco,"
                          "year=2016' --tests 'model=PRIUS,year=2016')")
    res: dict = {"vehicle": vehicle, "derivatives": load_derivatives(vehicle, cycles, dt=dt)}
    res["vehicle"] = res["derivatives"]["vehicle"]
    if epa and tests:
        from vehval.epa import apply_selector, read_lists
        from vehval.epa.validation import validate_tests

        listed = read_lists(epa)
        rows = []
        for sel in tests:
            chosen = apply_selector(listed, sel)
            val = validate_tests(vehicle, chosen, dt=dt)
            by_test = {p.test.label: p.test for p in val.predictions}
            for c in val.comparisons:
                if (c.item != "overall" or c.measured_mpg is None or c.list_doubtful
                        or c.analytically_derived):
                    continue
                t = by_test[c.test]
                rows.append({"procedure": c.procedure, "label": sel, "mass_kg": t.mass_kg,
                             "road_load_a_n": t.target_a_n,
                             "road_load_b_n_per_mps": t.target_b_n_per_mps,
                             "road_load_c_n_per_mps2": t.target_c_n_per_mps2,
                             "measured_mpg": c.measured_mpg, "predicted_mpg": c.predicted_mpg})
        res["pairs"] = configuration_pairs(rows)
    res = clean(res)
    if outdir is not None:
        from vehval.io.atomic import atomic_dir

        with atomic_dir(outdir) as stage:
            (stage / "road_load.json").write_text(json.dumps(res, indent=1), encoding="utf-8")
    if as_json:
        typer.echo(json.dumps(res))
        return
    _road_load_text(res)
    if outdir is not None:
        typer.echo(f"  wrote {outdir / 'road_load.json'}")


def _road_load_text(res: dict) -> None:
    """The ``--road-load`` table and pairs in the display units (``--units``)."""
    from vehval.cli.epa_common import _fe_display
    from vehval.display import format_value, unit_for

    unit, fe, fmt = _fe_display()
    weight = unit_for("kg").label  # lb or kg: the step of test weight the table states
    d = res["derivatives"]
    typer.echo(f"{res['vehicle']}: d ln fuel economy / d ln x (dt = {d['dt_s']:g} s, "
               f"+-{100 * d['rel_step']:g} %)")
    typer.echo(f"  {'cycle':10s} {unit:>8s} {'weight':>7s} {'A':>7s} {'B':>7s} {'C':>7s} "
               f"{'all':>7s} {'%/100 ' + weight:>9s}")
    for cyc, r in d["cycles"].items():
        e = r["elasticity"]
        typer.echo(f"  {cyc:10s} {_num(fe(r['mpg']), '8' + fmt)} " + " ".join(
            _num(e[k], '+7.3f') for k in (*e,)) + f" {_num(r[f'per_100_{weight}_pct'], '+9.2f')}")

    def name(p: dict, side: str) -> str:
        return (f"{p[side + '_selection']} ({format_value(p[side + '_mass_kg'], 'kg')}, "
                f"A {format_value(p[side + '_road_load_a_n'], 'N')})")
    for p in res.get("pairs", []):
        typer.echo(f"  {p['procedure']:6s} {name(p, 'config')} vs {name(p, 'reference')}: "
                   f"tractive energy {p['tractive_change_pct']:+.1f} %, fuel economy list "
                   f"{p['measured_change_pct']:+.1f} % / model {p['predicted_change_pct']:+.1f} "
                   f"% (elasticity list {p['measured_elasticity']:.2f}, model "
                   f"{p['predicted_elasticity']:.2f})")
