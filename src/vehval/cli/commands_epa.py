"""`vehval epa list|tests|validate|calibrate`: the EPA Test Car List, validation and
calibration against it."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import typer

from vehval.cli.app import app
from vehval.cli.options import bounded, output_dir, output_file

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
    from vehval.display import unit_for

    # the display units (us: lb, lbf, lbf/mph, lbf/mph², as the list itself; metric: kg, N,
    # N/(km/h), N/(km/h)²); --json stays SI
    mu, fu, vu = unit_for("kg"), unit_for("N"), unit_for("m/s")
    fe = _fe_display()
    per = vu.label if "/" not in vu.label else f"({vu.label})"
    b_k, c_k = fu.factor / vu.factor, fu.factor / vu.factor ** 2
    # the test and vehicle IDs whole: they are what --tests number=/vehicle= and
    # --vehicle-id take
    wt = max([14, *(len(t.label) for t in tests)])
    wv = max([9, *(len(t.vehicle_id) for t in tests)])
    typer.echo(f"{'test':{wt}s} {'vehicle':{wv}s} {'cfg':>3} {'orig':4s} {'proc':7s} "
               f"{'trans':5s} {'fuel':6s} "
               f"{f'ETW {mu.label}':>7} {'N/V':>5} {'axle':>5} {f'A {fu.label}':>7} "
               f"{f'B {fu.label}/{per}':>11} {f'C {fu.label}/{per}²':>12} {'FE':>6}  "
               f"bags 1-4 (FE, bags: {fe[0]})")
    for t, chk in zip(tests, checks):
        bags = " ".join(f"{_fmt(fe[1](b_), fe[2]):>6}" for b_ in t.bags) + (
            "" if chk.ok else "  !") + ("  AD" if t.analytically_derived else "")
        typer.echo(f"{t.label:{wt}s} {t.vehicle_id:{wv}s} {t.config[:3]:>3} "
                   f"{(t.originator or '?')[:4]:4s} {procedure_key(t)[:7]:7s} "
                   f"{_trans_text(t):5s} {_fuel_text(t):6s} "
                   f"{_fmt(float(mu.convert(t.mass_kg)), '.0f'):>7} {_fmt(t.n_v_ratio):>5} "
                   f"{_fmt(t.axle_ratio, '.2f'):>5} {_fmt(float(fu.convert(t.target_a_n)), '.2f'):>7} "
                   f"{_fmt(b_k * t.target_b_n_per_mps, '.4f'):>11} "
                   f"{_fmt(c_k * t.target_c_n_per_mps2, '.5f'):>12} {_fmt(fe[1](t.fe), fe[2]):>6}  {bags}")
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


@epa_app.command("validate")
def validate_cmd(
    paths: list[Path] = typer.Argument(..., help=_PATHS_HELP),
    vehicle: str = typer.Option(..., "--vehicle", help="Vehicle name or YAML path (one file "
                                "for every test)."),
    tests: str = typer.Option(..., "--tests", help="Test selector, e.g. "
                              "model=PRIUS,year=2016,originator=EPA (keys: make, model, year, "
                              "vehicle, originator, procedure, number, config)."),
    dt: float = typer.Option(0.2, "--dt", callback=bounded("dt"), help="Simulation step [s] (0.2 s: within 0.3 % "
                             "of 0.1 s on US06)."),
    as_json: bool = typer.Option(False, "--json", help="Print the validation JSON."),
    outdir: Path | None = typer.Option(None, "-o", "--output", callback=output_dir,
                                       help="Directory for report.html, epa_validation.json "
                                            "and epa_validation.csv."),
    model_u: str = typer.Option("linear", "--model-uncertainty",
                                help="U_model of the normalised error: linear (the parameter "
                                     "ranges one at a time), monte_carlo, or none (U_model = 0)."),
    draws: int = typer.Option(200, "--draws", callback=bounded("mc_sensitivity"),
                              help="Monte Carlo draws (at least 100)."),
) -> None:
    """Simulate each selected EPA test with its own weight and road load; compare per bag.

    Each figure gets its normalised error En (|En| <= 1: consistent) and the held-out
    figures a set verdict (docs/validation.md)."""
    from vehval import jsonsafe
    from vehval.cli.progress import bar
    from vehval.epa.validation import validate_tests
    from vehval.io.paths import check_outputs, vehicle_path
    from vehval.report.epa import share_text
    if outdir is not None:
        check_outputs(outdir=outdir, inputs=[*paths, vehicle_path(vehicle)],
                      writes=["report.html", "epa_validation.json", "epa_validation.csv"])
    with bar("epa validate: simulating tests", as_json=as_json):
        every: list = []
        val = validate_tests(vehicle, _selected(paths, tests, dt, every), dt=dt, reference=every,
                             model_uncertainty=model_u.replace("-", "_"), draws=draws)
    if not val.predictions:
        from collections import Counter

        from vehval.errors import InputFileError

        by_reason: dict[str, Counter] = {}
        for sk in val.skipped:
            by_reason.setdefault(sk["reason"], Counter())[sk["description"]] += 1
        kinds = "; ".join(", ".join(f"{n} {d}" for d, n in c.items()) + f": {why}"
                          for why, c in by_reason.items())
        runnable = {"ftp75", "hwfet", "us06"}
        hint = ("select FTP-75, HWFET or US06 tests, e.g. add procedure=ftp75"
                if any(sk["procedure"] not in runnable for sk in val.skipped) else
                "select tests the list states on gasoline with their weight and road load")
        raise InputFileError(
            f"the selector '{tests}' matches {len(val.skipped)} test(s), none of which the "
            f"simulator can run ({kinds}); {hint}")
    written = []
    if outdir is not None:
        from vehval.report.epa import write_epa_report

        written = write_epa_report(val, outdir)
    if as_json:
        typer.echo(jsonsafe.dumps(val), nl=False)
        return
    fe = _fe_display()
    wt = max([14, *(len(c.test) for c in val.comparisons)])
    typer.echo(f"{'test':{wt}s} {'by':4s} {'proc':6s} {'figure':8s} {'pred':>6} {'meas':>6} "
               f"{'err %':>6} {'En':>6} {'batt %':>6} {'sample':9s} judged   (pred, meas: "
               f"{fe[0]}; err: fuel economy, pred / meas mpg - 1; En: normalised error)")
    for c in val.comparisons:
        batt = share_text(c.battery_share)
        typer.echo(f"{c.test:{wt}s} {c.originator[:4]:4s} {c.procedure:6s} {c.item:8s} "
                   f"{_fmt(fe[1](c.predicted_mpg), fe[2]):>6} "
                   f"{_fmt(fe[1](c.measured_mpg), fe[2]):>6} {100 * c.error:+6.1f} "
                   f"{_en_text(c):>6} {batt:>6} {_sample_text(c):9s} {_judged_text(c)}")
    st = val.stats()
    for p in val.predictions:
        if p.list_check is not None and not p.list_check.ok:
            typer.echo(f"! {p.test.label} ({p.test.source}): {p.list_check.note}; its figures "
                       "are listed, not judged")
    _echo_mismatches([(p.test.label, p.vehicle_check) for p in val.predictions])
    derived = [p.test.label for p in val.predictions if p.test.analytically_derived]
    if derived:
        typer.echo(f"! {len(derived)} test(s) ({', '.join(derived[:3])}"
                   f"{' ...' if len(derived) > 3 else ''}) the list marks as analytically "
                   "derived (figures computed from another test, not measured): simulated, "
                   "not judged")
    for s in val.skipped:
        typer.echo(f"skipped {s['test']} ({s['description']}): {s['reason']}")
    typer.echo(f"{st['n_tests_simulated']} tests simulated, {st['n_tests_skipped']} skipped, "
               f"{st['n_tests_in_sample']} of them calibration tests of the vehicle file")
    _echo_repeats(val)
    typer.echo("held-out: " + _stats_text(st))
    if st["n_judged_in_sample"]:
        typer.echo("in-sample (the vehicle file was calibrated on these tests; not a "
                   "prediction): " + _stats_text(val.stats(in_sample=True)))
    for line in _verdict_lines(val):
        typer.echo(line)
    if any(c.battery_share is not None for c in val.comparisons):
        typer.echo("batt %: battery energy spent in the figure / its fuel energy, in the "
                   "model (J1711 balances the whole test, not each bag)")
    if written and outdir is not None:
        typer.echo(f"wrote {', '.join(str(outdir / w) for w in written)}")


def _en_text(c) -> str:
    """``+0.42``, ``+0.42?`` when uninformative, ``-`` without an En."""
    if c.en is None or not math.isfinite(c.en):
        return "-"
    return f"{c.en:+.2f}" + ("?" if c.uninformative else "")


def _verdict_lines(val) -> list[str]:
    """The uncertainties behind En and the set verdict of the held-out figures."""
    out = [f"note: {n}" for n in val.notes]
    for proc, f in sorted(val.model_uncertainty.items()):
        if f is not None and f["method"] != "none":
            extra = (f", {f['n_draws']} draws, sampling error {100 * f['sampling_error_rel']:.0f}"
                     " % of U" if f["n_draws"] else "")
            out.append(f"U_model {proc} ({f['figure']}): {100 * f['U_rel']:.2f} % (k = 2, "
                       f"{f['method'].replace('_', ' ')}{extra})")
    bases = sorted({c.precision["basis"] for c in val.comparisons if c.precision})
    out += [f"U_meas: {b}" for b in bases]
    if any(c.uninformative for c in val.comparisons):
        out.append("En?: uninformative, the combined U exceeds 10 % of the measured figure")
    out += _set_verdict_line(val.set_verdict, val.set_verdict_note,
                             "held-out, one figure per test")
    if val.set_verdict_all is not None or val.set_verdict_all_note:
        out += _set_verdict_line(val.set_verdict_all, val.set_verdict_all_note,
                                 "all tests, in-sample included, not a prediction")
    return out


def _set_verdict_line(sv: dict | None, note: str, what: str) -> list[str]:
    """One set verdict on screen (and, for a set judged against s_R, the bias against s_r)."""
    if sv is None:
        return [f"set verdict ({what}): none ({note})"]
    from vehval.uncertainty import verdict_text

    out = [verdict_text(sv, what)]
    if sv.get("different_source"):
        out.append(f"  against s_r alone (one lab's repeats) the scatter explains "
                   f"{sv['bias_limit_s_r_pct']:.2f} %: the mean error is "
                   f"{'beyond' if sv['beyond_s_r'] else 'within'} it")
    out += [f"  {n}" for n in sv["notes"]]
    return out


def _sample_text(c) -> str:
    return "in-sample" if c.in_sample else ("unknown" if c.sample_unknown else "held-out")


def _echo_repeats(val) -> None:
    """Tests without a number: which repeat a calibration test, which cannot be told."""
    if val.repeats:
        pairs = ", ".join(f"{k} = {v}" for k, v in list(val.repeats.items())[:3])
        typer.echo(f"{len(val.repeats)} test(s) without a test number repeat a calibration "
                   f"test of the vehicle file (same vehicle, procedure, weight, road load and "
                   f"figures; {pairs}{' ...' if len(val.repeats) > 3 else ''}): in-sample")
    if val.sample_unknown:
        n_fig = val.stats()["n_judged_sample_unknown"]
        typer.echo(f"sample unknown: {len(val.sample_unknown)} test(s) without a test number "
                   f"({n_fig} judged figures) may be calibration tests of the vehicle file, "
                   "which are not all in the lists given: not counted as held-out; give the "
                   "list that numbers them too (e.g. the previous model year's) to tell")


def _stats_text(st: dict) -> str:
    """``n/N judged figures within 5 %; mean error ...; r = ...`` of one stats dict."""
    r, mean = st["spread_correlation"]["pooled"], st["mean_error"]
    return (f"{st['n_within_tolerance']}/{st['n_judged']} judged figures within "
            f"{100 * st['tolerance']:.0f} %; mean error "
            f"{'-' if mean is None else f'{100 * mean:+.1f} %'}"
            f"; r = {'-' if r is None else f'{r:.3f}'}")


def _echo_mismatches(checks, err: bool = False) -> None:
    """One '!' line per distinct note of the tests whose driveline differs from the vehicle
    file's (``checks``: (test label, VehicleCheck or None) pairs)."""
    from vehval.epa.consistency import group_mismatches

    for note, labels in group_mismatches(checks).items():
        shown = ", ".join(labels[:3]) + (" ..." if len(labels) > 3 else "")
        typer.echo(f"! {len(labels)} test(s) ({shown}): {note}", err=err)


def _judged_text(c) -> str:
    if c.judged:
        return "yes"
    if c.analytically_derived:
        return "no (derived)"
    return "no (list doubtful)" if c.list_doubtful else "no (cold start)"


def _parse_param(text: str) -> tuple[str, list[float]]:
    from vehval.errors import ConfigError

    name, sep, values = text.partition("=")
    try:
        vals = [float(v) for v in values.split(",") if v.strip()]
    except ValueError:
        vals = []
    if not sep or not name.strip() or not vals:
        raise ConfigError(f"--param '{text}': write NAME=v1,v2,... with numbers, e.g. "
                          "controller.soc_gain_w=10000,20000,40000")
    return name.strip(), vals


@epa_app.command("calibrate")
def calibrate_cmd(
    paths: list[Path] = typer.Argument(..., help=_PATHS_HELP),
    vehicle: str = typer.Option(..., "--vehicle", help="Vehicle name or YAML path to start "
                                "from."),
    tests: str = typer.Option(..., "--tests", help="Calibration tests, e.g. "
                              "model=PRIUS,year=2016,originator=MFR (judge the model on "
                              "others with `vehval epa validate`)."),
    param: list[str] = typer.Option(..., "--param", help="NAME=v1,v2,... candidate values of "
                                    "a parameter (dotted name; a bare name is "
                                    "controller.NAME); repeat for several."),
    refine: int = typer.Option(2, "--refine", callback=bounded("refine"), help="Rounds of coordinate "
                               "refinement after the grid."),
    dt: float = typer.Option(0.2, "--dt", callback=bounded("dt"), help="Simulation step [s]."),
    workers: int = typer.Option(0, "--workers", callback=bounded("workers"), help="Processes evaluating "
                                "settings in parallel (0: one per CPU, at most 8; the result "
                                "does not depend on it)."),
    as_json: bool = typer.Option(False, "--json", help="Print the calibration JSON."),
    output: Path | None = typer.Option(None, "-o", "--output", callback=output_file,
                                       help="Write the calibrated "
                                       "vehicle YAML here (values carry their provenance)."),
    long_run: bool = typer.Option(False, "--long-run", help="Run a calibration estimated "
                                  "to take more than 15 min (refused without it)."),
) -> None:
    """Choose unpublished parameters (controller thresholds, gains) on a set of EPA tests.

    At most 1,000 grid settings; the estimated run time is stated on stderr before a run
    of 10 s or more."""
    from vehval import jsonsafe
    from vehval.epa.calibrate import LONG_RUN_S, calibrate_on_tests, grid_from_pairs
    from vehval.epa.consistency import check_vehicle_match
    from vehval.io.paths import check_outputs, vehicle_path
    from vehval.vehicle import load_vehicle

    if output is not None:
        check_outputs(outfile=output, inputs=[*paths, vehicle_path(vehicle)])
    grid = grid_from_pairs([_parse_param(p) for p in param])
    selected, veh = _selected(paths, tests, dt), load_vehicle(vehicle)
    _echo_mismatches([(t.label, check_vehicle_match(t, veh)) for t in selected], err=True)
    cal = calibrate_on_tests(veh, selected, grid, dt=dt, refine_rounds=refine,
                             workers=workers, max_seconds=None if long_run else LONG_RUN_S,
                             notify=lambda text: typer.echo(text, err=True))
    if output is not None:
        cal.write_vehicle(output)
    if as_json:
        typer.echo(jsonsafe.dumps(cal), nl=False)
        return
    start = cal.vehicle.parameters()
    for name, value in cal.best.items():
        typer.echo(f"{name:40s} {start[name]:>12g} -> {value:<12g}")
    typer.echo(f"{len(cal.tests)} tests, {len(cal.evaluations)} settings evaluated; RMS error "
               f"of the judged figures {100 * cal.start_rms:.1f} % -> {100 * cal.best_rms:.1f} "
               f"% (max {100 * cal.best_max:.1f} %)")
    if output is not None:
        typer.echo(f"wrote {output}")


def _uncalibrated(specs: Any = None) -> str:
    """What a vehicle built without calibration tests is: the generic technology
    coefficients of its engine and gearbox (:mod:`vehval.epa.technology`)."""
    from vehval.epa import technology as tech
    from vehval.epa.specs import INDICATED_EFFICIENCY

    head = "fuel model not calibrated (no --calibrate test)"
    if specs is None:
        return f"{head}: the generic technology coefficients"
    c = tech.load_coefficients()
    e = tech.engine_values(c, specs.engine_technology, specs.rated_power_w,
                           specs.displacement_l, None, None, INDICATED_EFFICIENCY)
    return (f"{head}: the generic technology coefficients ({c.where}) of a "
            f"{specs.engine_technology.replace('_', ' ')} engine and a "
            f"{specs.family.replace('_', ' ')} gearbox: indicated efficiency "
            f"{100 * e['indicated_efficiency'][0]:.0f} %, friction scale "
            f"{e['friction_scale'][0]:.2g} x Heywood, idle fuel {e['idle_factor'][0]:.2g} x "
            f"the map, part-load pumping {e['pumping_bar'][0]:.2g} bar")


def _narrow(rows: list, vehicle_id: str | None, config: str | None) -> list:
    """The rows of one test vehicle and configuration; an ID or number that matches none
    is refused with the ones there are."""
    from vehval.errors import ConfigError

    for value, attr, opt in ((vehicle_id, "vehicle_id", "--vehicle-id"),
                             (config, "config", "--config")):
        if value is None:
            continue
        sel = [t for t in rows if getattr(t, attr).upper() == value.strip().upper()]
        if not sel:
            there = ", ".join(sorted({getattr(t, attr) or "''" for t in rows}))
            raise ConfigError(f"{opt} {value}: no selected row has it (there are: {there})")
        rows = sel
    return rows


@epa_app.command("vehicle")
def vehicle_cmd(
    paths: list[Path] = typer.Argument(..., help=_PATHS_HELP),
    make: str = typer.Option(..., "--make", help="Make, e.g. TOYOTA."),
    model: str = typer.Option(..., "--model", help="Model name as listed, e.g. "
                              "'CAMRY XLE/XSE' (one test-vehicle configuration)."),
    year: int = typer.Option(..., "--year", callback=bounded("year"), help="Model year."),
    vehicle_id: str | None = typer.Option(None, "--vehicle-id", help="Test vehicle ID, "
                                          "when the model has several configurations."),
    config: str | None = typer.Option(None, "--config", help="Test vehicle configuration "
                                      "number (the list's 'cfg'), when one test vehicle "
                                      "has several."),
    calibrate: list[Path] = typer.Option([], "--calibrate", help="A dyno test (one file: "
                                         "vehicle speed and fuel rate) to fit the fuel "
                                         "model on; repeatable."),
    predict: list[Path] = typer.Option([], "--predict", help="A held-out dyno test to "
                                       "predict (not also a --calibrate test); repeatable."),
    template: Path | None = typer.Option(None, "-t", "--template", help="Import template "
                                         "of the dyno test files."),
    splits: int = typer.Option(0, "--splits", callback=bounded("splits"), help="Also fit on "
                               "every N of all the given tests and predict the others "
                               "(0: no)."),
    dt: float = typer.Option(0.5, "--dt", callback=bounded("dt"), help="Simulation step [s]."),
    as_json: bool = typer.Option(False, "--json", help="Print the result JSON."),
    output: Path = typer.Option(..., "-o", "--output", callback=output_file,
                                help="Write the vehicle YAML here."),
    force: bool = typer.Option(False, "--force", help="Use dyno tests whose speed or fuel "
                               "unit QA doubts (the hint is still printed)."),
) -> None:
    """A conventional vehicle from its EPA Test Car List specification, its fuel model
    calibrated on dyno tests with speed and fuel only."""
    from vehval import jsonsafe
    from vehval.calibration.provenance import write_vehicle_yaml
    from vehval.cli.epa_inputs import check_roles, unit_hints
    from vehval.epa import read_lists, select_tests
    from vehval.epa.specs import model_fuel_lhv, specs_from_tests, vehicle_from_specs
    from vehval.epa.specs_fit import (
        all_splits,
        calibrate_specs,
        cold_note,
        dyno_run,
        efficiency_note,
        predict_runs,
    )
    from vehval.errors import ConfigError
    from vehval.io.paths import check_outputs
    from vehval.vehicle.maps import peak_brake_efficiency

    check_outputs(outfile=output, inputs=[*paths, *calibrate, *predict, template])
    rows = select_tests(read_lists(paths), make, model, year)
    rows = _narrow(rows, vehicle_id, config)
    specs = specs_from_tests(rows)
    check_roles(calibrate, predict)
    files = [*calibrate, *predict]
    if files and template is None:
        raise ConfigError("give the import template of the dyno tests with -t")
    runs, hints = {}, {}
    for f in files:
        from vehval.workflow import TestRun

        loaded = TestRun.load([f], template, use_qa=False)
        test = loaded.test
        hints[f] = unit_hints(f, test, loaded.template, force)
        runs[f] = dyno_run(test, test.meta.test_id or f.stem,
                           model_lhv_j_per_kg=model_fuel_lhv())
    cal = [runs[f] for f in calibrate]
    held = [runs[f] for f in predict]
    fit = calibrate_specs(specs, cal, dt) if cal else None
    veh = fit.vehicle() if fit is not None else vehicle_from_specs(
        specs, note=f"; {_uncalibrated(specs)}")
    pred = predict_runs(fit.model() if fit else veh, held, dt) if held else {}
    split_rows = all_splits(specs, list(runs.values()), splits, dt) if splits else []
    write_vehicle_yaml(veh, output, "vehval epa vehicle")
    tests_doc: list[dict[str, Any]] = [{"test": r.test_id, "in_sample": f in calibrate,
                  "fuel_measured_kg": r.fuel_kg, "distance_m": r.distance_m,
                  "cold_start": r.cold, "note": cold_note(r), "fuel_note": r.fuel_note,
                  "unit_hints": hints[f],
                  "error": (fit.errors.get(r.test_id) if f in calibrate and fit
                            else pred.get(r.test_id))} for f, r in runs.items()]
    doc = {"vehicle": veh.name, "specs": specs.to_dict(),
           "calibration": fit.to_dict() if fit else None,
           "tests": tests_doc,
           "splits": split_rows}
    if as_json:
        typer.echo(jsonsafe.dumps(doc), nl=False)
        return
    from vehval.display import format_value

    typer.echo(f"{specs.make} {specs.model} {specs.year} ({specs.vehicle_id}): "
               f"{format_value(specs.mass_kg, 'kg')}, {specs.displacement_l:g} L, "
               f"{specs.rated_power_w / 1e3:.0f} kW, {specs.gears}-speed, axle "
               f"{specs.axle_ratio:g}, N/V {specs.n_v_ratio:g}")
    if fit is None:
        typer.echo(f"{_uncalibrated(specs)}: expect a median error of about 5 % on the "
                   "FTP-75 and 3-5 % on the HWFET and US06 against the list's figures, "
                   "beyond 10 % for some cars (docs/validation.md); give dyno tests with "
                   "--calibrate")
    if fit is not None:
        idle = "-" if fit.idle_fuel_g_per_s is None else f"{fit.idle_fuel_g_per_s:.3f}"
        brake = peak_brake_efficiency(veh.engine)
        typer.echo(f"fitted on {', '.join(fit.tests)}: indicated efficiency "
                   f"{100 * fit.indicated_efficiency:.1f} %, friction scale "
                   f"{fit.friction_scale:.3f}, "
                   f"idle {idle} g/s; best brake efficiency {100 * brake[0]:.1f} % "
                   f"({brake[1]:.0f} rpm, {brake[2]:.0f} N·m)")
        if efficiency_note(veh):
            typer.echo(f"! {efficiency_note(veh)}")
    for row in tests_doc:
        err = "-" if row["error"] is None else f"{100 * row['error']:+.1f} %"
        typer.echo(f"{row['test'][:24]:24s} {'in-sample' if row['in_sample'] else 'held-out':9s}"
                   f" fuel error {err:>8}  ({row['note']})")
    for note in dict.fromkeys(r["fuel_note"] for r in tests_doc if r["fuel_note"]):
        typer.echo(f"test fuel: {note}")
    for f, found in hints.items():
        for h in found:
            typer.echo(f"! {f}: {h['message']} ({h['fix']}; used with --force)")
    if held:
        worst = max(abs(e) for e in pred.values())
        typer.echo(f"held-out: {len(pred)} tests, largest |fuel error| {100 * worst:.1f} %")
    for sp in split_rows:
        errs = ", ".join(f"{k} {100 * v:+.1f} %" for k, v in sp["held_out_errors"].items())
        typer.echo(f"split: fit on {', '.join(sp['calibration'])} -> {errs}")
    typer.echo(f"wrote {output}")
