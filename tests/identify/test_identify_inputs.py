"""Identification refuses bad input with one clear line (library and CLI)."""

import json

import numpy as np
import pytest

from vehval.cli import main
from vehval.identify import IdentificationError, identify_conventional, trace_from_test
from vehval.test import Signal, TestMeta
from vehval.test import Test as VTest


def _test(duration_s=200.0, with_engine=True, hybrid=False) -> VTest:
    t = np.arange(0.0, duration_s, 0.1)
    v = np.clip(10 * np.sin(np.pi * t / 100.0), 0, None)
    test = VTest(meta=TestMeta(test_id="t1", files=["t1.txt"]))
    test.add(Signal.standard("veh_spd_test", t, v))
    test.add(Signal.standard("veh_frc_in_test", t, 200 + 1500 * np.gradient(v, t)))
    test.add(Signal.standard("fuel_rate_test", t, 1e-3 * (0.2 + 0.1 * v)))
    if with_engine:
        test.add(Signal.standard("eng_spd_out_test", t, 90 + 10 * v))
    if hybrid:
        test.add(Signal.standard("mot_spd_out_test", t, 30 * v))
    return test


def test_no_engine_speed_is_named():
    with pytest.raises(IdentificationError, match=r"t1.txt: no engine speed signal \(eng_spd_out_test\)"):
        trace_from_test(_test(with_engine=False))


def test_a_speed_and_fuel_only_test_is_pointed_to_the_specification_route():
    """A test of speed and fuel only (like the Camry's reduced D3 files) cannot be identified;
    the line names the flow that uses such tests. One missing signal among others does not."""
    full = _test(with_engine=False)
    only = VTest(meta=TestMeta(test_id="t1", files=["t1.txt"]))
    for name in ("veh_spd_test", "fuel_rate_test"):
        only.add(full[name])
    with pytest.raises(IdentificationError, match=r"no tractive force.*epa vehicle .* --calibrate"):
        trace_from_test(only)
    with pytest.raises(IdentificationError, match="no engine speed signal") as err:
        trace_from_test(full)
    assert "epa vehicle" not in str(err.value)


def test_hybrid_test_is_refused():
    with pytest.raises(IdentificationError, match=r"t1.txt: this is a hybrid \(it has "
                       r"mot_spd_out_test\).*vehval validate. or .vehval calibrate. with a "
                       r"power-split vehicle file"):
        trace_from_test(_test(hybrid=True))


def _two_file_test(tmp_path, hybrid: bool, vehicle: str | None = None):
    """A test of two files (dyno: speed, force, engine speed, fuel; logger: speed and the
    battery current of a hybrid, or the engine speed of a conventional car) and its template
    of two entries."""
    t = np.arange(0.0, 120.0, 0.1)
    v = np.clip(10 * np.sin(np.pi * t / 60.0), 0, None)
    (tmp_path / "run_dyno.csv").write_text("Time,Speed,Force,Engine,Fuel\n" + "".join(
        f"{a:.1f},{b:.3f},{200 + 1500 * c:.1f},{900 + 100 * b:.0f},{0.2 + 0.1 * b:.3f}\n"
        for a, b, c in zip(t, v, np.gradient(v, t))))
    other = ("Current", "ess_curr_test", "A") if hybrid else ("RPM", "eng_spd_out_obd_test", "rpm")
    (tmp_path / "run_obd.csv").write_text(f"Time,VSS,{other[0]}\n" + "".join(
        f"{a:.1f},{3.6 * b:.0f},{10 * np.sin(a) if hybrid else 900 + 100 * b:.1f}\n"
        for a, b in zip(t[::10], v[::10])))
    (tmp_path / "t.yaml").write_text(
        "template_version: 1\n" + (f"vehicle: {vehicle}\n" if vehicle else "") + "files:\n"
        "  - {match: '*_dyno.csv', source: dyno, format: csv, time: {column: Time, unit: s},\n"
        "     channels: {Speed: {name: veh_spd_test, unit: m/s},\n"
        "                Force: {name: veh_frc_in_test, unit: N},\n"
        "                Engine: {name: eng_spd_out_test, unit: rpm},\n"
        "                Fuel: {name: fuel_rate_test, unit: g/s}}}\n"
        "  - {match: '*_obd.csv', source: obd, format: csv, time: {column: Time, unit: s},\n"
        "     channels: {VSS: {name: veh_spd_obd_test, unit: km/h},\n"
        f"                {other[0]}: {{name: {other[1]}, unit: {other[2]}}}}}}}\n")
    return [tmp_path / "run_dyno.csv", tmp_path / "run_obd.csv"], tmp_path / "t.yaml"


@pytest.mark.parametrize("case", ["signals", "vehicle", "vehicle, dyno file only"])
def test_cli_refuses_a_hybrid_test_of_several_files_in_one_line(tmp_path, capsys, case):
    """The files of a hybrid test (two files, battery current in the logger's; or a template
    whose vehicle is a power-split hybrid) are refused as a hybrid, in one line naming what
    to use, not as a missing files[1] of the template."""
    files, tpl = _two_file_test(tmp_path, hybrid=True,
                                vehicle=None if case == "signals" else "prius_2004")
    given = files[:1] if case.endswith("only") else files
    out = tmp_path / "veh.yaml"
    rc = main(["identify", *map(str, given), "-t", str(tpl), "-o", str(out)])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1, err
    assert "this is a hybrid" in err[0] and "files[" not in err[0]
    assert ("it has ess_curr_test" if case == "signals" else "its vehicle prius_2004") in err[0]
    assert "`vehval validate` or `vehval calibrate` with a power-split vehicle file" in err[0]
    assert not out.exists()


def test_cli_says_identify_reads_one_file_per_test(tmp_path, capsys):
    """A conventional test of two files: identify reads one file per test, and says so."""
    files, tpl = _two_file_test(tmp_path, hybrid=False)
    rc = main(["identify", *map(str, files), "-t", str(tpl), "-o", str(tmp_path / "v.yaml")])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1, err
    assert "these files are one test" in err[0] and "one file per test" in err[0]


def test_single_short_test_says_how_much_is_missing():
    tr = trace_from_test(_test(duration_s=200.0))
    with pytest.raises(IdentificationError, match=r"only \d+ s of driving.*at least 600 s"):
        identify_conventional([tr])


def test_cli_bad_input_one_line_exit_2(tmp_path, capsys):
    raw = tmp_path / "t1.txt"
    t = np.arange(0.0, 100.0, 0.1)
    rows = ["Time[sec]\tDyno_Speed[mph]\tDyno_Tractive_Effort[N]\tFuel_Flow_Bench_Modal[g/s]"]
    rows += [f"{x:.1f}\t{5.0:.3f}\t{100.0:.1f}\t{0.5:.3f}" for x in t]
    raw.write_text("\n".join(rows) + "\n")
    tpl = tmp_path / "tpl.yaml"
    tpl.write_text(
        "template_version: 1\nfiles:\n  - match: '*.txt'\n    source: dyno\n    format: d3\n"
        "    time: {column: Time, unit: s}\n    channels:\n"
        "      Dyno_Speed: {name: veh_spd_test, unit: mph}\n"
        "      Dyno_Tractive_Effort: {name: veh_frc_in_test, unit: N}\n"
        "      Fuel_Flow_Bench_Modal: {name: fuel_rate_test, unit: g/s}\n")
    out = tmp_path / "veh.yaml"
    rc = main(["identify", str(raw), "-t", str(tpl), "-o", str(out)])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2
    assert len(err) == 1 and "no engine speed signal" in err[0]
    assert not out.exists()


def _engineless_d3(tmp_path):
    """A D3 file without engine speed and its template (identify refuses it after reading)."""
    raw = tmp_path / "t1.txt"
    t = np.arange(0.0, 100.0, 0.1)
    rows = ["Time[sec]\tDyno_Speed[mph]\tDyno_Tractive_Effort[N]\tFuel_Flow_Bench_Modal[g/s]"]
    rows += [f"{x:.1f}\t{5.0:.3f}\t{100.0:.1f}\t{0.5:.3f}" for x in t]
    raw.write_text("\n".join(rows) + "\n")
    tpl = tmp_path / "tpl.yaml"
    tpl.write_text(
        "template_version: 1\nfiles:\n  - match: '*.txt'\n    source: dyno\n    format: d3\n"
        "    time: {column: Time, unit: s}\n    channels:\n"
        "      Dyno_Speed: {name: veh_spd_test, unit: mph}\n"
        "      Dyno_Tractive_Effort: {name: veh_frc_in_test, unit: N}\n"
        "      Fuel_Flow_Bench_Modal: {name: fuel_rate_test, unit: g/s}\n")
    return raw, tpl


@pytest.mark.parametrize("tyre, says", [("999/99 R99", "width 999 mm is outside 105-395 mm"),
                                        ("225/10 R17", "aspect ratio 10 % is outside 20-95 %"),
                                        ("225/50 R40", "rim 40 in is outside 10-26 in"),
                                        ("395/95 R26", "rolling radius 0.684 m is outside")])
def test_cli_refuses_a_tyre_size_outside_road_car_tyres(tmp_path, capsys, tyre, says):
    """A tyre size that matches the pattern but no road car's (a 2 m wheel) is refused with the
    valid range, before any file is read, and nothing is written."""
    raw, tpl = _engineless_d3(tmp_path)
    out = tmp_path / "veh.yaml"
    rc = main(["identify", str(raw), "-t", str(tpl), "--tyre", tyre, "-o", str(out)])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1, err
    assert f"--tyre: tyre {tyre!r}" in err[0] and says in err[0], err
    assert not out.exists()


def test_synth_conventional_cli_writes_an_identifiable_test(tmp_path, capsys):
    out = tmp_path / "v"
    rc = main(["synth", "--vehicle", "cruze_diesel_2014", "--cycle", "ece15", "--seed", "1",
               "-o", str(out)])
    assert rc == 0
    assert "VIRTUAL" in capsys.readouterr().out
    files = sorted(out.glob("*_d3.txt"))
    assert len(files) == 1 and (out / "truth.json").is_file()
    from vehval.identify import load_traces
    tr = load_traces(files, out / "template.yaml")[0]
    assert tr.w_eng.max() > 100          # engine speed channel came through [rad/s]
    # one 195 s ECE cycle is too short to identify a fuel map: one clear refusal
    with pytest.raises(IdentificationError, match="at least 600 s"):
        identify_conventional([tr])


def test_cli_refuses_to_overwrite_an_input(tmp_path, capsys):
    raw = tmp_path / "t1.txt"
    raw.write_text("Time[sec]\tDyno_Speed[mph]\n0.0\t0.0\n0.1\t0.0\n")
    rc = main(["identify", str(raw), "-t", str(raw), "-o", str(raw)])
    assert rc == 2
    assert len(capsys.readouterr().err.strip().splitlines()) == 1
    assert raw.read_text().startswith("Time[sec]")


def test_predict_cli_table_json_and_report(tmp_path, capsys):
    out = tmp_path / "v"
    assert main(["synth", "--vehicle", "cruze_diesel_2014", "--cycle", "ece15", "--seed", "2",
                 "-o", str(out)]) == 0
    capsys.readouterr()
    f = str(next(out.glob("*_d3.txt")))
    rep = tmp_path / "pred.html"
    assert main(["predict", "cruze_diesel_2014", f, "-t", str(out / "template.yaml"),
                 "--report", str(rep), "--json"]) == 0
    import json
    rows = json.loads(capsys.readouterr().out)
    # the generating model predicts its own virtual test: fuel within 1 % (bench noise,
    # and the 1.5 s meter delay pushes the last grams past the end of the file)
    assert abs(rows[0]["error_rel"]) < 0.01
    # the ECE-15 has no bags: the virtual test marks one phase, as a lab would
    assert [p["phase"] for p in rows[0]["phases"]] == [1]
    text = rep.read_text()
    assert "engine speed, model" in text
    assert "<th>A/C</th>" in text and "off (auto: not an SC03 test" in text
    # the normalised error of each row, as the JSON gives it, and what En means
    assert "<th>En</th>" in text and f"{rows[0]['en']:+.2f}" in text
    assert "normalised error" in text


def test_power_split_analysis_refuses_a_conventional_vehicle_validate_judges_it(tmp_path,
                                                                                capsys):
    """`analyze` (the power-split control analysis) refuses the Cruze in one line; `validate`
    judges it test by test by the En of its fuel, as `predict` does (it refused it)."""
    out = tmp_path / "v"
    assert main(["synth", "--vehicle", "cruze_diesel_2014", "--cycle", "ece15", "--seed", "2",
                 "-o", str(out)]) == 0
    capsys.readouterr()
    f = str(next(out.glob("*_d3.txt")))
    args = [f, "-t", str(out / "template.yaml"), "--vehicle", "cruze_diesel_2014"]
    rc = main(["analyze", *args, "-o", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2
    assert len(err) == 1 and "is 'conventional'" in err[0] and "vehval predict" in err[0]
    assert not (tmp_path / "o").exists()
    assert main(["validate", *args, "-o", str(tmp_path / "val")]) == 0
    text = capsys.readouterr().out
    doc = json.loads((tmp_path / "val" / "metrics.json").read_text())
    v = doc["tests"][0]["verdict"]
    assert v["figure"] == "fuel_mass_g" and f"En {v['en']:+.2f} consistent" in text
    assert "held-out: 1/1 consistent" in text


def test_ac_state_rules():
    from vehval.errors import ConfigError
    from vehval.identify.predict import ac_state
    tr = trace_from_test(_test(duration_s=700.0))
    tr.cycle, tr.amb_temp_c = "udds", 23.0
    assert ac_state(tr) == (False, "auto: not an SC03 test, cell below 30 °C")
    tr.amb_temp_c = 35.1
    assert ac_state(tr)[0] and "35.1" in ac_state(tr)[1]
    tr.cycle, tr.amb_temp_c = "sc03_x2", float("nan")
    assert ac_state(tr) == (True, "SC03 (run with the A/C on)")
    assert ac_state(tr, "off") == (False, "--ac off")
    with pytest.raises(ConfigError, match="--ac maybe: give one of auto, on, off"):
        ac_state(tr, "maybe")


def test_predict_with_ac_switches_the_models_ac(tmp_path, capsys):
    out = tmp_path / "v"
    assert main(["synth", "--vehicle", "cruze_diesel_2014", "--cycle", "ece15", "--seed", "2",
                 "-o", str(out)]) == 0
    capsys.readouterr()
    f, tpl = str(next(out.glob("*_d3.txt"))), str(out / "template.yaml")
    import json
    got = {}
    for mode in ("off", "on"):
        assert main(["predict", "cruze_diesel_2014", f, "-t", tpl, "--ac", mode, "--json"]) == 0
        got[mode] = json.loads(capsys.readouterr().out)[0]
    assert not got["off"]["ac_on"] and got["on"]["ac_on"]
    # the packaged Cruze carries its identified A/C load: on burns more
    assert got["on"]["fuel_predicted_g"] > 1.05 * got["off"]["fuel_predicted_g"]
    assert main(["predict", "cruze_diesel_2014", f, "-t", tpl, "--ac", "sometimes"]) == 2
    assert "--ac sometimes" in capsys.readouterr().err


@pytest.mark.parametrize("option", ["--ac-test", "--cold-test"])
def test_extra_test_must_not_be_an_identification_test(tmp_path, capsys, option):
    raw = tmp_path / "t1.txt"
    raw.write_text("Time[sec]\tDyno_Speed[mph]\n0.0\t0.0\n0.1\t0.0\n")
    tpl = tmp_path / "tpl.yaml"
    tpl.write_text("template_version: 1\n")
    rc = main(["identify", str(raw), "-t", str(tpl), "-o", str(tmp_path / "o.yaml"),
               option, str(raw)])
    assert rc == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and option in err[0] and "also an identification test" in err[0]
    assert not (tmp_path / "o.yaml").exists()


def _simulated_trace():
    """The packaged Cruze's simulated UDDS as a trace with its wheel force and fuel."""
    from vehval.identify.traces import Trace
    from vehval.sim.simulate import simulate

    res = simulate("cruze_diesel_2014", "udds", dt=0.1)
    t = res.test["veh_spd_simu"].time
    v = res.test["veh_spd_simu"].values
    return Trace(test_id="udds", cycle="udds", t=t, v=v, a=np.gradient(v, t),
                 force=res.test["veh_frc_in_simu"].values,
                 w_eng=res.test["eng_spd_out_simu"].values,
                 fuel=res.test["fuel_rate_simu"].values, phase=np.ones_like(t),
                 constants={"fuel_density_kg_per_m3": 851.0, "fuel_lhv_j_per_kg": 42.8e6},
                 file="udds.txt")


def test_a_dead_fuel_channel_is_left_out_of_the_fuel_map_and_named():
    """A test whose fuel channel reads 0 throughout while the engine runs (a channel not
    recorded, as in one of the real Cruze files) serves road load and gears, not the fuel
    map: fitted, its zeros pulled the map toward no fuel at power and its total error was
    infinite. The map equals the one fitted without it; the provenance names it."""
    import dataclasses

    from vehval.identify.traces import dead_fuel_channel

    live = _simulated_trace()
    dead = dataclasses.replace(live, test_id="dead", file="dead.txt",
                               fuel=np.zeros_like(live.fuel))
    nan = dataclasses.replace(dead, fuel=np.full_like(live.fuel, np.nan))
    assert dead_fuel_channel(live) is None
    assert "dead: its fuel rate reads 0 throughout" in dead_fuel_channel(dead)
    assert "dead: its fuel rate has no value throughout" in dead_fuel_channel(nan)
    both = identify_conventional([live, dead], "two", drag_evidence=False)
    alone = identify_conventional([live], "one", drag_evidence=False)
    assert set(both.fuel_left_out) == {"dead"} and not alone.fuel_left_out
    assert both.fuel_map.willans == pytest.approx(alone.fuel_map.willans, rel=0.02)
    assert set(both.fuel_map.total_error_rel) == {"udds"}
    assert "left out: dead: its fuel rate" in both.vehicle.engine.sources["fuel_rate_g_per_s"]
    assert both.summary()["fuel_left_out"] == both.fuel_left_out
    roles = {r["test"]: r["role"] for r in both.conditions["tests"]}
    assert roles == {"udds": "fuel map", "dead": "road load and gears"}
    with pytest.raises(IdentificationError, match="no test with a fuel rate.*dead"):
        identify_conventional([dead], "none", drag_evidence=False)


def test_cross_validation_does_not_judge_a_test_without_fuel():
    """Held out, a dead-fuel test has nothing to judge: it is named among the skipped, and
    the summary's figures stay finite (they read nan before)."""
    import dataclasses

    from vehval.identify.crossval import cross_validate

    live = _simulated_trace()
    other = dataclasses.replace(live, test_id="udds2", file="udds2.txt")
    dead = dataclasses.replace(live, test_id="dead", file="dead.txt",
                               fuel=np.zeros_like(live.fuel))
    res = cross_validate([live, other, dead], jobs=1)
    assert {r["test"] for r in res["rows"]} == {"udds", "udds2"}
    assert any(s.startswith("dead: its fuel rate reads 0") for s in res["skipped"])
    assert np.isfinite(res["summary"]["median_abs_error"])


def test_predict_names_a_test_without_fuel_as_not_judged():
    import dataclasses

    from vehval.cli.commands_predict import _table
    from vehval.identify.predict import predict_trace
    from vehval.vehicle import load_vehicle

    live = _simulated_trace()
    dead = dataclasses.replace(live, test_id="dead", fuel=np.zeros_like(live.t))
    row = predict_trace(load_vehicle("cruze_diesel_2014"), dead)
    assert row["not_judged"].startswith("dead: its fuel rate reads 0")
    text = _table([row])
    assert "not judged: dead: its fuel rate" in text and "+nan" not in text


def test_the_warm_fuel_map_leaves_out_cold_starts_and_off_standard_cells():
    """With a standard warm test among them, a cold start (its warm-up fuel) and a test in a
    35 °C cell (its A/C) serve road load and gears, not the warm fuel map, and are named;
    with no warm test, every test with fuel fits it (as before)."""
    import dataclasses

    from vehval.identify.conditions import off_standard

    base = _simulated_trace()
    warm = dataclasses.replace(base, test_id="warm", amb_temp_c=23.0, coolant_start_c=90.0)
    cold = dataclasses.replace(base, test_id="cold", amb_temp_c=22.0, coolant_start_c=22.0,
                               fuel=base.fuel * 1.3)
    hot = dataclasses.replace(base, test_id="hot", amb_temp_c=35.0, coolant_start_c=95.0,
                              fuel=base.fuel * 1.2)
    assert off_standard(warm) is None and off_standard(base) is None  # not measured: kept
    assert off_standard(cold).startswith("cold: a cold start")
    assert off_standard(hot) == "hot: cell 35.0 °C, outside the standard 20-30 °C"
    mixed = identify_conventional([warm, cold, hot], "mixed", drag_evidence=False)
    alone = identify_conventional([warm], "warm", drag_evidence=False)
    assert set(mixed.fuel_left_out) == {"cold", "hot"}
    assert mixed.fuel_map.willans == pytest.approx(alone.fuel_map.willans, rel=0.02)
    # the cold start, on the warm test's cycle in a standard cell, gives the warm-up: the
    # identification then covers its start; the 35 °C test stays outside
    assert mixed.warmup is not None and mixed.warmup.cold_test == "cold"
    ranges = mixed.conditions
    assert ranges["amb_temp_c"] == [22.0, 23.0] and ranges["coolant_start_c"] == [22.0, 90.0]
    only_cold = identify_conventional([cold], "cold", drag_evidence=False)
    assert not only_cold.fuel_left_out


def test_a_test_outside_the_identifications_conditions_is_not_in_the_set_verdict():
    from vehval.identify.verdicts import judge_rows

    rows = [{"test": f"t{k}", "fuel_measured_g": 700.0, "fuel_predicted_g": 700.0 * (1 + e),
             "error_rel": e, "pi95_rel": 0.1, "pi95_g": [600.0, 800.0], "cycle": "udds",
             "phases": [], "in_sample": False,
             "outside_identification": {"amb_temp_c": {"value": -7.0, "range": [22, 25]}}
             if k == 3 else {}}
            for k, e in enumerate([0.01, -0.02, 0.015, -0.30])]
    verdict, notes = judge_rows(rows)
    assert verdict is not None and verdict["tests"] == ["t0", "t1", "t2"]
    assert any(n.startswith("t3: outside the identification's conditions") for n in notes)


def test_a_cold_start_among_the_tests_gives_the_warm_up_without_cold_test():
    """A cold start in a standard cell, on the cycle of a warm test given beside it, is left
    out of the warm map and identifies the warm-up (as --cold-test would); no warning that
    its warm-up went into the warm map. A cold start at -7 °C gives no warm-up."""
    import dataclasses

    from vehval.identify.checks import cold_warnings

    base = _simulated_trace()
    warm = dataclasses.replace(base, test_id="warm", amb_temp_c=23.0, coolant_start_c=90.0)
    cold = dataclasses.replace(base, test_id="cold", amb_temp_c=22.0, coolant_start_c=22.0,
                               fuel=base.fuel * (1.0 + 0.3 * np.exp(-base.t / 400.0)))
    idf = identify_conventional([warm, cold], "auto", drag_evidence=False)
    assert idf.warmup is not None and idf.warmup.cold_test == "cold"
    assert idf.vehicle.engine.warmup_fuel_fraction == pytest.approx(0.3, rel=0.05)
    assert idf.vehicle.engine.warmup_time_constant_s == pytest.approx(400.0, rel=0.1)
    assert cold_warnings([warm, cold], idf.fuel_left_out) == []
    assert cold_warnings([warm, cold]) != []  # fitted into the map, it would warn
    frozen = dataclasses.replace(cold, amb_temp_c=-7.0, coolant_start_c=-7.0)
    assert identify_conventional([warm, frozen], "frozen", drag_evidence=False).warmup is None


def test_negative_fuel_channel_is_refused_not_called_zero():
    """A fuel channel with its sign slipped (all negative while the engine turns) was taken
    for a dead channel ('reads 0 throughout') and left out, or predicted against a negative
    measured fuel; it is refused naming the file and the sign. Meter noise (a few negative
    samples) passes."""
    test = _test()
    fuel = test["fuel_rate_test"]
    test.add(type(fuel)(**{**fuel.__dict__, "values": -fuel.values}), replace_existing=True)
    with pytest.raises(IdentificationError, match=r"t1.txt: its fuel rate is negative in \d+ "
                       r"of the \d+ samples.*check the channel's sign"):
        trace_from_test(test)
    noisy = _test()
    vals = noisy["fuel_rate_test"].values
    vals[::10] = -1e-4                     # -0.1 g/s in one sample of ten
    assert trace_from_test(noisy).fuel.min() < 0


def test_a_speed_unit_slip_is_refused_not_identified(tmp_path, capsys):
    """mph declared km/h: identify wrote a 6151 lb car with ratios 1.6 x too high and only
    an efficiency warning; it refuses now, with QA's speed-scale reason (the factor)."""
    out = tmp_path / "v"
    assert main(["synth", "--vehicle", "cruze_diesel_2014", "--cycle", "udds", "--seed", "3",
                 "--faults", "none", "-o", str(out)]) == 0
    tpl = out / "template.yaml"
    bad = tmp_path / "kmh.yaml"
    bad.write_text(tpl.read_text().replace("{name: veh_spd_test, unit: mph}",
                                           "{name: veh_spd_test, unit: km/h}"))
    f = str(next(out.glob("*_d3.txt")))
    capsys.readouterr()
    rc = main(["identify", f, "-t", str(bad), "-o", str(tmp_path / "id")])
    err = capsys.readouterr().err
    assert rc == 2 and "follows udds once divided by 0.62" in err, err
    assert not (tmp_path / "id").exists()
    assert main(["identify", f, "-t", str(tpl), "-o", str(tmp_path / "ok")]) == 0
