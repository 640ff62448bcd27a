"""`vehval epa validate`: the model against the EPA Test Car List, per bag, with the
normalised error of each figure and the set verdict of the held-out figures."""

from __future__ import annotations

import math
from pathlib import Path

import typer

from vehval.cli.epa_common import (
    _PATHS_HELP,
    _echo_mismatches,
    _fe_display,
    _fmt,
    _selected,
    epa_app,
)
from vehval.cli.options import bounded, output_dir


def _validate_bev(paths: list[Path], vehicle: str, tests: str, dt: float,
                  as_json: bool, outdir: Path | None) -> bool:
    """`epa validate` of a battery-electric vehicle: electricity rows judged in their own
    unit (vehval.epa.bev), written to ``outdir`` when given; False for any other vehicle."""
    from vehval import jsonsafe
    from vehval.epa.bev import is_bev_vehicle, validate_bev, validation_text

    if not is_bev_vehicle(vehicle):
        return False
    doc = validate_bev(vehicle, _selected(paths, tests, dt), dt)
    written: list[str] = []
    if outdir is not None:
        from vehval.report.epa import write_bev_report

        written = write_bev_report(doc, outdir)
    typer.echo(jsonsafe.dumps(doc) if as_json else validation_text(doc), nl=not as_json)
    if written and not as_json and outdir is not None:
        typer.echo(f"wrote {', '.join(str(outdir / w) for w in written)}")
    return True


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
    from vehval.epa.validation import none_runnable, validate_tests
    from vehval.io.paths import check_outputs, vehicle_path
    from vehval.report.epa import share_text
    if outdir is not None:
        check_outputs(outdir=outdir, inputs=[*paths, vehicle_path(vehicle)],
                      writes=["report.html", "epa_validation.json", "epa_validation.csv"])
    if _validate_bev(paths, vehicle, tests, dt, as_json, outdir):
        return
    with bar("epa validate: simulating tests", as_json=as_json):
        every: list = []
        val = validate_tests(vehicle, _selected(paths, tests, dt, every), dt=dt, reference=every,
                             model_uncertainty=model_u.replace("-", "_"), draws=draws)
    if not val.predictions:
        none_runnable(val, tests)
    written = []
    if outdir is not None:
        from vehval.report.epa import write_epa_report

        written = write_epa_report(val, outdir)
    if as_json:
        typer.echo(jsonsafe.dumps(val), nl=False)
        return
    fe = _fe_display()
    # the error is the fuel economy's, read in the shown unit: L/100 km is its inverse
    ratio = "pred / meas mpg" if fe[0] == "mpg" else f"meas / pred {fe[0]}"
    wt = max([14, *(len(c.test) for c in val.comparisons)])
    typer.echo(f"{'test':{wt}s} {'by':4s} {'proc':6s} {'figure':8s} {'pred':>6} {'meas':>6} "
               f"{'err %':>6} {'En':>6} {'batt %':>6} {'sample':9s} judged   (pred, meas: "
               f"{fe[0]}; err: fuel economy, {ratio} - 1; En: normalised error)")
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


def _judged_text(c) -> str:
    if c.judged:
        return "yes"
    if c.analytically_derived:
        return "no (derived)"
    return "no (list doubtful)" if c.list_doubtful else "no (cold start)"
