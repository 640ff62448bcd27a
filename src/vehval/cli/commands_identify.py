"""`vehval identify` (a conventional car from its dyno tests) and `vehval predict`
(a vehicle model against measured tests, fuel per test and phase)."""

from __future__ import annotations

import json
from pathlib import Path

import typer

from vehval.cli.app import app
from vehval.cli.options import bounded, output_file
from vehval.constants import BRAKE_EFFICIENCY_RANGE, RPM_RAD_PER_S
from vehval.errors import ConfigError


def _table(rows: list[dict]) -> str:
    from vehval.display import fuel_text

    lines = [f"{'test':<22} {'cycle':<10} {'T [C]':>6} {'measured g':>11} {'predicted g':>12} "
             f"{'error %':>8}"]
    for r in rows:
        lines.append(f"{r['test']:<22} {r['cycle']:<10} {r['amb_temp_c']:>6.1f} "
                     f"{r['fuel_measured_g']:>11.1f} {r['fuel_predicted_g']:>12.1f} "
                     f"{100 * r['error_rel']:>+8.2f}{_pi(r)}{_en(r)}  A/C {'on' if r['ac_on'] else 'off'}: "
                     f"{r['ac_reason']}; {_start(r)}")
        if r.get("fuel_economy_measured_mpg") is not None:
            lines.append(f"  {'fuel economy':<38} measured "
                         f"{fuel_text(r['fuel_economy_measured_mpg'], r['fuel_consumption_measured_l_per_100km'])}"
                         f", predicted "
                         f"{fuel_text(r['fuel_economy_predicted_mpg'], r['fuel_consumption_predicted_l_per_100km'])}")
        for p in r["phases"]:
            u = p.get("results_fuel_U_g")
            unc = f"  (results stage: {p['results_fuel_g']:.1f} ± {u:.1f} g)" if u else ""
            lines.append(f"  {p.get('results_name', 'phase ' + str(p['phase'])):<38} "
                         f"{p['measured_g']:>11.1f} {p['predicted_g']:>12.1f} "
                         f"{100 * p['error_rel']:>+8.2f}{_pi(p)}{_en(p)}{unc}")
    return "\n".join(lines)


def _en(r: dict) -> str:
    """`` En +0.42`` (``?`` when uninformative) of a result row; empty without one."""
    if r.get("en") is None:
        return ""
    return f" En {r['en']:+.2f}" + ("?" if r.get("uninformative") else "")


def _verdict_lines(verdict: dict | None, notes: list[str]) -> list[str]:
    """The set verdict of the held-out tests and the notes behind En."""
    out = [f"note: {n}" for n in notes]
    if verdict is not None:
        from vehval.uncertainty import verdict_text

        out.append(verdict_text(verdict, "held-out tests"))
        out += [f"  {n}" for n in verdict["notes"]]
    return out


def _pi(r: dict) -> str:
    """`` ±x.x % (95 %), y % uncovered`` and ``in sample`` marks of a result row."""
    out = ""
    if r.get("pi95_rel") is not None:
        out += f" ±{100 * r['pi95_rel']:.1f} % (95 %), {100 * r['uncovered_share']:.0f} % uncovered"
    if r.get("in_sample"):
        out += " [in sample]"
    return out


def _start(r: dict) -> str:
    """How the test and the model started (cold, with or without warm-up fuel) and why."""
    from vehval.identify.warmup import start_label
    return f"{start_label(r)}: {r['cold_reason']}"


def _public(r: dict, vehicle=None) -> dict:
    """A prediction row without its arrays, with the fuel economy of the measured and the
    predicted fuel over the test's own distance (the test's fuel, else the vehicle's)."""
    out = {k: v for k, v in r.items() if k not in ("sim", "trace")}
    trace = r.get("trace")
    if trace is None:
        return out
    import numpy as np

    from vehval.fuels import fuel_consumption_l_per_100km, fuel_economy_mpg, fuel_volume_m3

    sel = trace.phase > 0 if np.any(trace.phase > 0) else np.ones(trace.phase.size, dtype=bool)
    dist = float(np.sum(trace.v[sel]) * trace.dt)
    dens = trace.test_fuel.density_kg_per_m3 if trace.test_fuel is not None else None
    if dens is None and vehicle is not None:
        dens = getattr(vehicle.engine, "fuel_density_kg_per_m3", None)
    out["distance_m"] = dist
    for which in ("measured", "predicted"):
        vol = fuel_volume_m3(out[f"fuel_{which}_g"] / 1e3, dens) if dens else None
        out[f"fuel_economy_{which}_mpg"] = (float(fuel_economy_mpg(dist, vol))
                                            if vol else None)
        out[f"fuel_consumption_{which}_l_per_100km"] = (
            float(fuel_consumption_l_per_100km(vol, dist)) if vol else None)
    return out


@app.command("identify")
def identify_cmd(
    files: list[Path] = typer.Argument(..., help="Raw test files (one test per file)."),
    template: Path = typer.Option(..., "-t", "--template", help="Import template."),
    architecture: str = typer.Option("conventional", "--architecture", help="Model to identify (conventional)."),
    output: Path = typer.Option(None, "-o", "--output", callback=output_file, help="Vehicle YAML to write (atomically); with --cross-validate the table as JSON."),
    name: str = typer.Option(None, "--name", help="Vehicle name (default: the output file stem)."),
    report: Path = typer.Option(None, "--report", callback=output_file, help="Also write an HTML report (fitted map with the measured points, traces)."),
    ac_test: Path = typer.Option(None, "--ac-test", help="A test run with the A/C on (not one of FILES): identifies the A/C compressor load from its phases after the first."),
    cold_test: Path = typer.Option(None, "--cold-test", help="A cold-start test (not one of FILES) on the cycle of a hot-start test among FILES: identifies the warm-up fuel (fraction and time constant) from the two tests' measured fuel."),
    spec: Path = typer.Option(None, "--spec", help="Specification YAML (rated power and speed, peak torque, displacement, fuel, tyre, gears...; see docs/identification.md): values the data cannot separate."),
    rated_power_kw: float = typer.Option(None, "--rated-power-kw", callback=bounded("rated_power_kw"), help="Rated engine power [kW] (over the spec)."),
    rated_speed_rpm: float = typer.Option(None, "--rated-speed-rpm", callback=bounded("rated_speed_rpm"), help="Engine speed at rated power [rpm]."),
    peak_torque_nm: float = typer.Option(None, "--peak-torque-nm", callback=bounded("peak_torque_nm"), help="Peak engine torque [N m]."),
    displacement_l: float = typer.Option(None, "--displacement-l", callback=bounded("displacement_l"), help="Engine displacement [L]."),
    engine_fuel: str = typer.Option(None, "--engine-fuel", help="Engine type for the generic scaling: diesel or gasoline (default: from the test fuel)."),
    tyre: str = typer.Option(None, "--tyre", help="Tyre size, e.g. 225/50 R17 (wheel radius)."),
    gears: int = typer.Option(None, "--gears", callback=bounded("gears"), help="Number of forward gears (honoured; refused when the data show more)."),
    cross_validate: bool = typer.Option(False, "--cross-validate", help="Identify from all tests but one and predict that one, for each test; prints the table (and writes it as JSON with -o)."),
    pairs: bool = typer.Option(False, "--pairs", help="With --cross-validate: identify from every pair of tests of distinct cycles and predict every other test."),
    as_json: bool = typer.Option(False, "--json", help="Print the identification summary as JSON."),
) -> None:
    """Identify a conventional car (road load, gears, converter, shifts, driveline drag, fuel map,
    with --cold-test the warm-up fuel and with --ac-test the A/C load) from dyno tests."""
    if architecture != "conventional":
        raise ConfigError(f"--architecture {architecture}: identification from dyno data exists "
                          "for 'conventional' cars only")
    from vehval.identify.build import identify_conventional, write_vehicle
    from vehval.identify.spec import load_spec
    from vehval.identify.traces import load_traces
    from vehval.io.paths import check_outputs
    declared = load_spec(spec, {
        "rated_power_kw": rated_power_kw, "rated_speed_rpm": rated_speed_rpm,
        "peak_torque_nm": peak_torque_nm, "displacement_l": displacement_l,
        "fuel": engine_fuel, "tyre": tyre, "gears": gears})
    _check_radius(declared)
    _check_power_torque(declared)
    if pairs and not cross_validate:
        raise ConfigError("--pairs: give it with --cross-validate")
    if cross_validate:
        unused = [opt for opt, val in (("--ac-test", ac_test), ("--cold-test", cold_test),
                                       ("--report", report), ("--name", name)) if val is not None]
        if unused:
            raise ConfigError(f"--cross-validate: {', '.join(unused)} would be ignored (the "
                              "cross-validation identifies from FILES only and writes its "
                              "table); run identify without --cross-validate for them")
        _cross_validate(files, template, declared, pairs, output, as_json, spec)
        return
    if output is None:
        raise ConfigError("identify: give the vehicle file to write (-o FILE)")
    extra = [p for p in (ac_test, cold_test, spec) if p is not None]
    check_outputs(outfile=output, inputs=[*files, *extra, template])
    if report is not None:
        check_outputs(outfile=report, inputs=[*files, *extra, template, output],
                      option="--report")
    for opt, path in (("--ac-test", ac_test), ("--cold-test", cold_test)):
        if path is not None and path.resolve() in {f.resolve() for f in files}:
            raise ConfigError(f"{opt} {path}: it is also an identification test; give a "
                              "separate test run")
    _refuse_one_test_of_several_files(files, template)
    traces = load_traces(files, template)
    ac_trace = load_traces([ac_test], template)[0] if ac_test is not None else None
    cold_trace = load_traces([cold_test], template)[0] if cold_test is not None else None
    from vehval.cli.progress import bar
    with bar("identify: fitting the car (road load, gears, fuel map)", as_json=as_json):
        idf = identify_conventional(traces, name or output.stem, ac_trace=ac_trace,
                                    cold_trace=cold_trace, declared=declared)
    _check_mass(idf, declared)
    _check_template_mass(idf, template)
    _check_fuel_map(idf, files)
    from vehval.io.atomic import atomic_files
    preds = None
    if report is not None:
        from vehval.identify.predict import predict_trace
        preds = [predict_trace(idf.vehicle, t) for t in traces]
    # the vehicle file and the report are one unit: a run killed at any point leaves both
    # old or (once the next run completes its commit) both new, and no temporary behind
    with atomic_files([output] if report is None else [output, report]) as staged:
        write_vehicle(idf.vehicle, staged[0])
        if report is not None:
            from vehval.identify.report import write_identification_report
            write_identification_report(idf, preds, staged[1])
    for line in _fuel_map_warnings(idf) + _cold_warnings(traces):
        typer.echo(f"vehval: warning: {line}", err=True)
    if as_json:
        typer.echo(json.dumps(idf.summary(), indent=2))
        return
    _print_identification(idf, output, report)


def _refuse_one_test_of_several_files(files: list[Path], template: Path) -> None:
    """Refuse, in one line, what identify cannot read one test per file: a hybrid (the
    template's vehicle says so, or the files are one test with battery or motor signals:
    :func:`vehval.identify.traces.hybrid_refusal`) and the files of one test of several
    files (the template has an entry per file)."""
    from vehval.errors import VehvalError
    from vehval.identify.traces import IdentificationError, hybrid_refusal
    from vehval.test import Test, TestMeta
    from vehval.workflow import TestRun, load_template_arg, load_vehicle_arg

    tpl = load_template_arg(template)
    names = [str(f) for f in files]
    refusal = hybrid_refusal(Test(meta=TestMeta(test_id=", ".join(names), files=names)),
                             load_vehicle_arg(getattr(tpl, "vehicle", None)))
    if refusal is None and len(files) > 1 and len(tpl.files) > 1:
        try:
            run = TestRun.load(files, tpl, use_qa=False)
        except VehvalError:
            return                       # not one test: each file is read as one below
        refusal = hybrid_refusal(run.test, run.vehicle) or (
            f"{', '.join(names)}: these files are one test (one per files[] entry of "
            f"{Path(template).name}); identify reads one file per test: give a template with "
            "the one entry of the file that has speed, tractive force, engine speed and fuel")
    if refusal:
        raise IdentificationError(refusal)


RADIUS_TOL = 0.10   # [-] a rolling radius is within a few % of 0.97 x the unloaded radius


def _check_radius(declared: dict) -> None:
    """A declared wheel radius far from the declared tyre's: a unit slip or another tyre (the
    radius would win silently and scale every gear ratio)."""
    if "tyre" not in declared or "wheel_radius_m" not in declared:
        return
    from vehval.identify.spec import tyre_radius_m
    tyre, r = declared["tyre"][0], float(declared["wheel_radius_m"][0])
    r_tyre = tyre_radius_m(tyre)
    if abs(r / r_tyre - 1) > RADIUS_TOL:
        raise ConfigError(
            f"identify: the declared wheel radius {r:.3f} m ({declared['wheel_radius_m'][2]}) "
            f"is {100 * (r / r_tyre - 1):+.0f} % from the rolling radius of the declared "
            f"{tyre} tyre ({r_tyre:.3f} m): give one of them, or the right one")


POWER_TOL = 0.02    # [-] rounding of published ratings


def _check_power_torque(declared: dict) -> None:
    """The torque at rated power cannot exceed the peak torque: P_rated <= T_peak · ω_rated
    (within the rounding of published ratings); beyond, a unit slip (hp as kW, lb·ft as N·m)."""
    keys = ("rated_power_kw", "rated_speed_rpm", "peak_torque_nm")
    if not all(k in declared for k in keys):
        return
    p_kw, n_rpm, t_nm = (float(declared[k][0]) for k in keys)
    t_rated = p_kw * 1e3 / (n_rpm * RPM_RAD_PER_S)
    if t_rated > (1 + POWER_TOL) * t_nm:
        raise ConfigError(
            f"identify: a rated power of {p_kw:g} kW at {n_rpm:g} rpm needs {t_rated:.0f} N·m "
            f"there, above the declared peak torque {t_nm:g} N·m: is the power in hp (1 hp = "
            "0.7457 kW) or the torque in lb·ft (1 lb·ft = 1.356 N·m)?")


def _check_mass(idf, declared: dict) -> None:
    """A declared test mass far from the identified inertia: another car's specification."""
    if "test_mass_kg" not in declared:
        return
    m_dec, m_id = float(declared["test_mass_kg"][0]), idf.road_load.values["mass_kg"]
    if abs(m_id / m_dec - 1) > 0.15:
        raise ConfigError(
            f"identify: the declared test mass {m_dec:.0f} kg ({declared['test_mass_kg'][2]}) "
            f"is far from the inertia identified from the tests ({m_id:.0f} kg): is the "
            "specification of another car?")


def _check_template_mass(idf, template: Path) -> None:
    """The template's ``test_mass_kg`` against the inertia identified from the tests.

    The template's constant is the test mass every later stage uses (a template constant
    beats the vehicle's value: :mod:`vehval.conditions`), so a wrong one is refused here
    rather than written into the vehicle's record: the ratio tells a value in lb (or
    converted from lb twice) from another car's. The band is QA's gain of the force over
    ``test_mass_kg`` x acceleration (:data:`vehval.qa.crosscheck.MASS_GAIN_BAND`)."""
    from vehval.constants import LB_KG
    from vehval.qa.crosscheck import MASS_GAIN_BAND

    m_tpl = idf.road_load.template.get("mass_kg")
    m_id = idf.road_load.values["mass_kg"]
    if m_tpl is None or not m_tpl > 0:
        return
    lo, hi = MASS_GAIN_BAND
    gain = m_id / m_tpl
    if lo <= gain <= hi:
        return
    head = (f"identify: {template}: constants.test_mass_kg {m_tpl:g} is far from the inertia "
            f"identified from the tests ({m_id:.0f} kg, {gain:.3g} x it)")
    if lo <= gain / LB_KG <= hi:
        raise ConfigError(f"{head}: it is probably in lb ({m_tpl:g} lb = {m_tpl * LB_KG:.1f} kg): "
                          f"set test_mass_kg: {m_tpl * LB_KG:.1f}")
    if lo <= gain * LB_KG <= hi:
        raise ConfigError(f"{head}: it is probably converted from lb twice: set test_mass_kg: "
                          f"{m_tpl / LB_KG:.1f}")
    raise ConfigError(f"{head}: is the template of another car? Set the test (inertia) mass "
                      "of these tests")


def _keyed(key: str, value_si: float, ci95_si: float | None = None) -> str:
    """``value [± ci] unit`` of a vehicle key (``mass_kg``, ``road_load_b_n_per_mps``...) in
    the display units (us: lb, lbf, lbf/mph, lbf/mph²; metric: kg, N, N/(m/s), N/(m/s)²)."""
    from vehval.display import format_keyed, keyed_unit, number

    text = format_keyed(key, value_si)
    unit = keyed_unit(key, magnitude=abs(value_si))
    if ci95_si is None or unit is None or not text.endswith(unit.label):
        return text
    shown = text[: -len(unit.label)].rstrip()
    ci = abs(ci95_si) * unit.factor
    # the interval to the value's last decimal (2 significant digits for a whole value)
    decimals = len(shown.partition(".")[2])
    half = (f"{ci:.{decimals}f}" if "e" not in shown and "\u2009" not in shown
            and decimals > 0 else number(ci, 2))
    return f"{shown} ± {half} {unit.label}"


def _drag_text(a_n: float, b_n_per_mps: float) -> str:
    """``a + b·v`` of a drag in the display units (``18.86 lbf + 0.1517 lbf/mph``)."""
    return f"{_keyed('drag_force_n', a_n)} + {_keyed('drag_force_n_per_mps', b_n_per_mps)}"


def _drag_note(drag) -> str:
    """The drag's note with its dyno losses (written in SI in the vehicle file) in the
    display units."""
    si = f"{drag.dyno_loss_a_n:.1f} N + {drag.dyno_loss_b_n_per_mps:.3f} N/(m/s)"
    return drag.note.replace(si, _drag_text(drag.dyno_loss_a_n, drag.dyno_loss_b_n_per_mps))


_UNIT_HINT = ("check the fuel flow's unit and the test fuel's heating value (template "
              "constants) and the fuel channel's mapping")


def _check_fuel_map(idf, files) -> None:
    """A fuel map that explains the fuel worse than its mean, or burns less fuel than the
    work it gives (brake efficiency above 100 %): a unit or mapping mistake, refused."""
    from vehval.vehicle.maps import peak_brake_efficiency

    fm = idf.fuel_map
    eta = peak_brake_efficiency(idf.vehicle.engine)[0]
    tests = ", ".join(str(f) for f in files)
    if not fm.r2_5s >= 0.0:
        raise ConfigError(
            f"identify: the fuel map does not fit the measured fuel of {tests} (R² of 5 s "
            f"means {fm.r2_5s:.2f}: worse than a constant rate); {_UNIT_HINT}")
    if not eta <= 1.0:
        raise ConfigError(
            f"identify: the fuel map of {tests} gives "
            + (f"{100 * eta:.0f} % brake efficiency (more work than the fuel's energy)"
               if eta == eta else "no fuel where the engine runs")
            + f"; {_UNIT_HINT}")


def _cold_warnings(traces) -> list[str]:
    """Identification tests that start cold: their warm-up fuel goes into the warm fuel map."""
    from vehval.identify.warmup import cold_start_state
    cold = [(t.test_id, why) for t in traces for c, why in [cold_start_state(t)] if c]
    if not cold:
        return []
    return [f"{', '.join(f'{tid} ({why})' for tid, why in cold)} "
            f"start{'s' if len(cold) == 1 else ''} cold: the warm fuel map takes in "
            f"{'its' if len(cold) == 1 else 'their'} warm-up fuel; identify from hot-start "
            "tests and give a cold start as --cold-test"]


def _fuel_map_warnings(idf) -> list[str]:
    """A peak brake efficiency outside the range of road engines, in one line."""
    from vehval.vehicle.maps import brake_efficiency_plausible, peak_brake_efficiency

    eta, rpm, nm = peak_brake_efficiency(idf.vehicle.engine)
    if brake_efficiency_plausible(eta):
        return []
    lo, hi = BRAKE_EFFICIENCY_RANGE
    return [f"the identified fuel map peaks at {100 * eta:.1f} % brake efficiency ({rpm:.0f} "
            f"rpm, {nm:.0f} N·m), outside the {100 * lo:.0f}-{100 * hi:.0f} % of road "
            f"engines: {_UNIT_HINT}"]


def _print_identification(idf, output: Path, report: Path | None) -> None:
    from vehval.vehicle.maps import peak_brake_efficiency

    rl = idf.road_load
    v, ci = rl.values, rl.ci95
    typer.echo(f"wrote {output}")
    body = idf.vehicle.body
    terms = []
    for name, k in (("A", "road_load_a_n"), ("B", "road_load_b_n_per_mps"),
                    ("C", "road_load_c_n_per_mps2"), ("mass", "mass_kg")):
        kept = float(getattr(body, k))
        terms.append(f"{name} {_keyed(k, v[k], ci.get(k))}" + (
            "" if abs(kept - v[k]) <= 1e-9 * max(abs(v[k]), 1.0) else
            f" (the vehicle file holds {_keyed(k, kept)}: a physical bound)"))
    typer.echo(f"road load (95 % intervals): {', '.join(terms)} (R^2 {rl.r2:.4f})")
    g = idf.gears
    typer.echo("gear ratios (engine/wheel): " + ", ".join(f"{r:.3f}" for r in g.ratios)
               + ("" if g.declared is None else f" ({len(g.ratios)} of the {g.declared} "
                  "declared gears)"))
    for note in g.notes:
        typer.echo(f"gears: {note}")
    fm = idf.fuel_map
    typer.echo(f"fuel map: R^2 {fm.r2:.3f} (5 s means {fm.r2_5s:.3f}), idle "
               f"{fm.idle_fuel_kg_s * 1e3:.3f} g/s, fuel cut above "
               f"{fm.fuel_cut_speed_rad_s / RPM_RAD_PER_S:.0f} rpm")
    eta, rpm, nm = peak_brake_efficiency(idf.vehicle.engine)
    typer.echo(f"fuel map: peak brake efficiency {100 * eta:.1f} % at {rpm:.0f} rpm, {nm:.0f} N·m "
               "(between idle and full load)")
    if idf.drag is not None:
        typer.echo(f"driveline drag: {_drag_text(idf.drag.force_n, idf.drag.force_n_per_mps)} "
                   f"({_drag_note(idf.drag)})")
    if idf.warmup is not None:
        w = idf.warmup
        typer.echo(f"warm-up fuel: +{100 * w.fraction:.1f} % at the start, time constant "
                   f"{w.time_constant_s:.0f} s (from {w.cold_test} against {w.hot_test}, "
                   f"R^2 {w.r2:.3f}{'; ' + w.note if w.note else ''})")
    if idf.ac is not None:
        typer.echo(f"A/C load: {idf.ac['ac_power_w'] / 1e3:.2f} kW (from {idf.ac['test']}, phases "
                   f"{', '.join(map(str, idf.ac['phases']))})")
    a = idf.assumptions
    if a is not None:
        for k in a.generic():
            p = a.provenance[k]
            val = "" if p["value"] is None else (
                f" {p['value']:.4g}" if isinstance(p["value"], float) else f" {p['value']}")
            typer.echo(f"generic value: {k}{val} ({p['source']})")
    if report is not None:
        typer.echo(f"wrote {report}")


def _cross_validate(files, template, declared, pairs, output, as_json, spec) -> None:
    from vehval.identify.crossval import cross_validate, table
    from vehval.identify.traces import load_traces
    if len(files) < 2:
        raise ConfigError(f"--cross-validate: one test given ({files[0] if files else 'none'}); "
                          "it needs at least two (identify from some, predict the others)")
    if output is not None:
        from vehval.io.paths import check_outputs
        check_outputs(outfile=output, inputs=[*files, template] + ([spec] if spec else []))
    _refuse_one_test_of_several_files(files, template)
    traces = load_traces(files, template)
    from vehval.cli.progress import bar
    with bar(f"identify: cross-validation ({'pairs' if pairs else 'leave-one-out'})",
             as_json=as_json):
        result = cross_validate(traces, pairs=pairs, declared=declared)
    if output is not None:
        from vehval.io.atomic import write_text_atomic
        write_text_atomic(output, json.dumps(result, indent=1) + "\n")
    if as_json:
        typer.echo(json.dumps(result, indent=2))
    else:
        typer.echo(table(result))
        if output is not None:
            typer.echo(f"wrote {output}")


@app.command("predict")
def predict_cmd(
    vehicle: str = typer.Argument(..., help="Vehicle name or YAML path (conventional)."),
    files: list[Path] = typer.Argument(..., help="Raw test files to predict (one test per file)."),
    template: Path = typer.Option(..., "-t", "--template", help="Import template."),
    report: Path = typer.Option(None, "--report", callback=output_file, help="Also write an HTML report (table, engine speed and fuel rate overlays)."),
    ac: str = typer.Option("auto", "--ac", help="A/C of the model: auto (on for SC03 or a cell at 30 C or more), on, off."),
    as_json: bool = typer.Option(False, "--json", help="Print the results as JSON."),
) -> None:
    """Drive each test's measured speed with the model; fuel measured vs predicted, per phase."""
    from vehval.identify.predict import predict_trace
    from vehval.identify.traces import load_traces
    from vehval.vehicle import load_vehicle
    if report is not None:
        from vehval.io.paths import check_outputs, vehicle_path
        check_outputs(outfile=report, inputs=[*files, template, vehicle_path(vehicle)],
                      option="--report")
    veh = load_vehicle(vehicle)
    if veh.architecture != "conventional":
        raise ConfigError(f"{vehicle}: predict compares fuel of conventional cars; this vehicle "
                          f"is '{veh.architecture}' (use vehval validate)")
    from vehval.identify.predict import check_same_car, poor_coverage
    traces = load_traces(files, template)
    for t in traces:
        check_same_car(veh, t)
    from vehval import progress
    from vehval.cli.progress import bar
    with bar("predict: driving each test's speed", as_json=as_json):
        progress.add(len(traces))
        preds = []
        for t in traces:
            preds.append(predict_trace(veh, t, ac=ac))
            progress.advance()
    from vehval.identify.conditions import conditions_warnings
    for line in poor_coverage(preds) + conditions_warnings(preds, veh.identification):
        typer.echo(f"vehval: warning: {line}", err=True)
    from vehval.identify.verdicts import judge_rows
    verdict, notes = judge_rows(preds)
    if report is not None:
        from vehval.identify.report import write_prediction_report
        write_prediction_report(veh.name, preds, report, verdict_lines=_verdict_lines(verdict, notes))
    rows = [_public(p, veh) for p in preds]
    for r in rows:   # the set's verdict with every row (the JSON stays a list of rows)
        r["set_verdict"] = verdict
    if as_json:
        typer.echo(json.dumps(rows, indent=2))
    else:
        typer.echo(_table(rows))
        for line in _verdict_lines(verdict, notes):
            typer.echo(line)
