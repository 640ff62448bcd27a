"""EPA validation: plans, bag bookkeeping, charge balance, skipped tests, CLI and report."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from helpers.epa_lists import row, write_list
from vehval.cli import main
from vehval.epa import plan_for, read_test_car_list
from vehval.epa.procedures import FTP75, US06
from vehval.epa.validation import (
    BALANCE_TOL,
    predict_test,
    validate_tests,
    vehicle_for_test,
)
from vehval.vehicle import load_vehicle


@pytest.fixture(scope="module")
def prius_2016():
    return load_vehicle("prius_2016")


def test_vehicle_for_test_uses_weight_and_target(prius_list, prius_2016):
    t = read_test_car_list(prius_list)[3]
    v = vehicle_for_test(prius_2016, t)
    assert v.body.mass_kg == pytest.approx(t.mass_kg)
    assert v.body.road_load_a_n == pytest.approx(24.153 * 4.4482216152605)
    assert v.engine == prius_2016.engine  # nothing else changes


def test_bags_partition_the_test(prius_list, prius_2016):
    tests = {t.test_number: t for t in read_test_car_list(prius_list)}
    for number, proc in (("T3", FTP75), ("T2", US06)):
        p = predict_test(prius_2016, tests[number], proc, dt=1.0)
        assert abs(p.soc_delta) <= BALANCE_TOL  # whole test charge balanced (J1711 basis)
        assert p.trace_n_miss == 0 or proc is US06
        assert abs(p.energy_balance_rel) < 1e-6
        rho = prius_2016.engine.fuel_density_kg_per_m3
        # bag fuel [kg] recovered from the bag mpg and distance; the bags cover every second
        assert all(math.isfinite(v) and v > 0 for v in p.bags_mpg.values())
        if proc is US06:
            assert p.bags_mpg[1] < p.bags_mpg[2]  # city part below the highway part
        assert p.distance_m > 0 and p.fuel_kg > 0 and rho > 0


def test_ftp_composite_weights(prius_list, prius_2016):
    t = next(t for t in read_test_car_list(prius_list) if t.test_number == "T3")
    p = predict_test(prius_2016, t, FTP75, dt=1.0)
    b = p.bags_mpg
    # hand check of the 0.43 / 0.57 composite from bag figures (distances of bags 1/3 and
    # 2/4 are equal on the same trace, so harmonic means by distance weights apply)
    from vehval.cycles import load_cycle

    cyc = load_cycle("udds")
    tt = np.arange(0, cyc.time_s[-1] + 1)
    v = np.interp(tt, cyc.time_s, cyc.speed_mps)
    d1, d2 = v[tt < 505].sum(), v[tt >= 505].sum()
    cold = (d1 + d2) / (d1 / b[1] + d2 / b[2])
    hot = (d1 + d2) / (d1 / b[3] + d2 / b[4])
    composite = 1 / (0.43 / cold + 0.57 / hot)
    assert p.overall_mpg == pytest.approx(composite, rel=0.02)  # simulated vs target distance


def test_bag_battery_energy_matches_the_kernel(prius_2016):
    """Battery chemical energy integrated from the recorded signals equals the kernel's own
    account of OCV x current (to 1e-4 of the fuel energy)."""
    from vehval.epa import validation as v
    from vehval.integrals import window_integral
    from vehval.sim.simulate import architecture, run_plan

    arch = architecture(prius_2016)
    grids = v._grids(prius_2016, FTP75, 1.0)
    for g, (out, ys) in zip(grids, run_plan(prius_2016, grids, 0.6)):
        e = window_integral(g.t, v._chemical_power(prius_2016, out, arch.column), ((0.0, None),),
                            step_s=1.0)
        ref = ys[arch.summary_keys.index("ess_chem_energy_j")]
        assert abs(e - ref) < 1e-4 * ys[arch.summary_keys.index("fuel_energy_j")]
        assert abs(ref) > 1e4  # the battery does work in the run


def test_udds_pairs_and_battery_share(prius_list, prius_2016):
    """Cold and hot UDDS are the bag pairs combined by distance (hand check); the battery
    share of a figure is its battery energy over its fuel energy, about 0 for the balanced
    whole test and equal and opposite to the neighbour bag's within one UDDS pair."""
    t = next(t for t in read_test_car_list(prius_list) if t.test_number == "T3")
    val = validate_tests(prius_2016, [t], dt=1.0)
    p = val.predictions[0]
    by = {c.item: c for c in val.comparisons}
    d, b = p.bag_distance_m, p.bags_mpg
    for item, (i, j) in (("bags 1+2", (1, 2)), ("bags 3+4", (3, 4))):
        c = by[item]
        assert c.predicted_mpg == pytest.approx((d[i] + d[j]) / (d[i] / b[i] + d[j] / b[j]))
        m = t.bags
        assert c.measured_mpg == pytest.approx((d[i] + d[j]) / (d[i] / m[i - 1] + d[j] / m[j - 1]))
        share = (p.bag_battery_j[i] + p.bag_battery_j[j]) / (p.bag_fuel_j[i] + p.bag_fuel_j[j])
        assert c.battery_share == pytest.approx(share)
    assert by["bags 1+2"].cold_start and by["bags 1+2"].judged  # the packaged cold model
    assert not by["bags 3+4"].cold_start
    for k in (1, 2):
        assert by[f"bag {k}"].battery_share == pytest.approx(p.bag_battery_j[k] / p.bag_fuel_j[k])
    total = sum(p.bag_battery_j.values()) / sum(p.bag_fuel_j.values())
    assert by["overall"].battery_share == pytest.approx(total)
    assert abs(total) < 0.01  # J1711: net energy change within 1 % of the fuel energy
    fuel = sum(p.bag_fuel_j.values()) / prius_2016.engine.fuel_lhv_j_per_kg
    assert fuel == pytest.approx(p.fuel_kg, rel=1e-9)


def test_unrunnable_named_skipped_counted(prius_list):
    tests = read_test_car_list(prius_list)
    prius = [t for t in tests if t.model == "PRIUS"]
    val = validate_tests("prius_2016", prius, dt=1.0)
    st = val.stats()
    assert st["n_tests_selected"] == 6 and st["n_tests_skipped"] == 2
    assert {s["procedure"] for s in val.skipped} == {"sc03", "coldco"}
    assert all(s["reason"] for s in val.skipped)
    # the packaged car models the cold start: its cold-start figures are judged
    cold = [c for c in val.comparisons if c.item == "bag 1" and c.procedure == "ftp75"]
    assert cold and all(c.judged and c.cold_start and "warm-up" in c.note for c in cold)
    assert plan_for(prius[0])[0] is not None
    # without a cold-start model they are reported but not judged (and the FTP runs hot)
    hot = load_vehicle("prius_2016").with_overrides({
        "engine.warmup_fuel_fraction": 0.0, "controller.cold_start_engine_on_s": 0.0})
    val0 = validate_tests(hot, prius, dt=1.0)
    cold0 = [c for c in val0.comparisons if c.cold_start]
    assert {c.item for c in cold0} == {"bag 1", "bags 1+2", "overall"}
    assert not any(c.judged for c in cold0)
    by = {(c.item, c.procedure): c.predicted_mpg for c in val0.comparisons}
    assert by[("bag 1", "ftp75")] > cold[0].predicted_mpg  # warm-up burns fuel in bag 1


def _no_nan(token):
    raise AssertionError(f"non-standard JSON constant {token}")


def test_cli_validate(prius_list, tmp_path, capsys):
    out = tmp_path / "out"
    rc = main(["epa", "validate", str(prius_list), "--vehicle", "prius_2016", "--tests",
               "model=PRIUS,originator=EPA", "--json", "-o", str(out)])
    assert rc == 0
    data = json.loads(capsys.readouterr().out, parse_constant=_no_nan)  # strict JSON
    assert data["stats"]["n_tests_simulated"] == 3
    items = {(c["procedure"], c["item"]) for c in data["comparisons"]}
    assert ("us06", "bag 1") in items and ("ftp75", "bag 4") in items
    assert ("hwfet", "overall") in items
    kinds = data["stats"]["per_kind"]
    assert sum(k["n"] for k in kinds.values()) == data["stats"]["n_judged"]
    hw = [c["error"] for c in data["comparisons"] if c["procedure"] == "hwfet" and c["judged"]]
    assert kinds["hwfet overall"]["mean_error"] == pytest.approx(np.mean(hw), abs=1e-5)
    html = (out / "report.html").read_text()
    assert "<svg" in html and "GTYX" not in html and "T3" in html and "By figure" in html
    assert (out / "epa_validation.csv").read_text().count("\n") == len(data["comparisons"]) + 1
    assert main(["epa", "validate", str(prius_list), "--vehicle", "prius_2016", "--tests",
                 "model=PRIUSS"]) == 2
    assert "did you mean" in capsys.readouterr().err


def test_cli_validate_metric_header_defines_the_error_in_l_per_100km(prius_list, capsys):
    # the metric header read "(pred, meas: L/100 km; err: fuel economy, pred / meas mpg - 1"
    rc = main(["--units", "metric", "epa", "validate", str(prius_list), "--vehicle",
               "prius_2016", "--tests", "model=PRIUS,originator=EPA,procedure=hwfet"])
    assert rc == 0
    header = capsys.readouterr().out.splitlines()[0]
    assert "err: fuel economy, meas / pred L/100 km - 1" in header, header
    assert "mpg" not in header, header


def test_cli_validate_nothing_runnable(prius_list, tmp_path, capsys):
    """A selection of only unrunnable procedures is refused: named, counted, nothing written."""
    out = tmp_path / "out"
    rc = main(["epa", "validate", str(prius_list), "--vehicle", "prius_2016", "--tests",
               "model=PRIUS,originator=MFR,procedure=sc03", "-o", str(out)])
    assert rc == 2
    err = capsys.readouterr().err
    assert "1 SC03" in err and "none of which the simulator can run" in err
    assert "A/C" in err and "Traceback" not in err
    assert not out.exists()


def test_conventional_vehicle(prius_list):
    """A conventional car runs its own loop: no battery to balance, HWFET equal to a plain
    simulation with the test's weight and road load, hot and cold UDDS identical (no cold
    start in the conventional model), cold-start figures not judged."""
    import dataclasses

    from vehval.sim.simulate import simulate

    # the diesel car runs the tests on its fuel
    tests = [dataclasses.replace(t, fuel="Federal Cert Diesel 7-15 PPM Sulfur")
             for t in read_test_car_list(prius_list) if t.model == "PRIUS"]
    val = validate_tests("cruze_diesel_2014", tests, dt=0.5)
    assert val.stats()["n_tests_simulated"] == 4
    by = {(c.test, c.item): c for c in val.comparisons}
    hw = next(p for p in val.predictions if p.procedure == "hwfet" and p.test.test_number == "T1")
    assert math.isnan(hw.soc_initial) and hw.soc_delta == 0.0 and hw.trace_n_miss == 0
    veh = vehicle_for_test(load_vehicle("cruze_diesel_2014"), hw.test)
    ref = simulate(veh, "hwfet", dt=0.5).summary["fuel_economy_mpg"]
    assert by[("T1", "overall")].predicted_mpg == pytest.approx(ref, rel=1e-12)
    assert by[("T3", "bag 1")].predicted_mpg == pytest.approx(by[("T3", "bag 3")].predicted_mpg,
                                                              rel=1e-12)
    assert not by[("T3", "bag 1")].judged and by[("T3", "bag 2")].judged
    assert all(abs(p.energy_balance_rel) < 1e-6 for p in val.predictions)
    assert all(c.battery_share is None for c in val.comparisons)  # no battery
    # with a warm-up model the FTP's first run starts cold and its figures are judged
    warm = load_vehicle("cruze_diesel_2014").with_overrides({
        "engine.warmup_fuel_fraction": 0.25, "engine.warmup_time_constant_s": 600.0})
    val_w = validate_tests(warm, [t for t in tests if t.test_number == "T3"], dt=0.5)
    byw = {c.item: c for c in val_w.comparisons}
    assert byw["bag 1"].judged and byw["bags 1+2"].judged and byw["overall"].judged
    assert byw["bag 3"].predicted_mpg == pytest.approx(by[("T3", "bag 3")].predicted_mpg,
                                                       rel=1e-12)  # the hot run unchanged
    # bag 1 burns x (1 + 0.25 e^(-t/600)) over its 505 s: 15-25 % more fuel than bag 3
    ratio = byw["bag 3"].predicted_mpg / byw["bag 1"].predicted_mpg
    assert 1.15 < ratio < 1.25


def test_cli_validate_names_tests_of_another_car(tmp_path, capsys):
    """A year whose only 'PRIUS' rows are a Prius c's: the partial model match is said, the
    tests are simulated and judged, and each test vehicle's mismatch is named (stdout, JSON,
    report)."""
    rows = [row(model="PRIUS c", vid="17-NP4H", number="C1", weight=2875, fe=61.4),
            row(model="PRIUS c", vid="17-NP4H", number="C2", weight=2875, fe=61.8)]
    for r in rows:
        r["Axle Ratio"], r["Test Veh Displacement (L)"] = "3.19", "1.497"
    path = write_list(tmp_path / "19tstcar.csv", rows)
    out = tmp_path / "out"
    rc = main(["epa", "validate", str(path), "--vehicle", "prius_2016", "--tests",
               "model=PRIUS", "-o", str(out)])
    assert rc == 0
    cap = capsys.readouterr()
    assert "no model is named 'PRIUS'; taken as part of a name: 'PRIUS c'" in cap.err
    assert "! 2 test(s) (C1, C2): the list gives axle ratio 3.19 (+12.5 %)" in cap.out
    data = json.loads((out / "epa_validation.json").read_text())
    assert data["stats"]["n_tests_vehicle_mismatch"] == 2
    assert all(not t["vehicle_check"]["ok"] for t in data["tests"])
    assert all(c["judged"] for c in data["comparisons"])  # still judged: the user's choice
    assert "may be another car" in (out / "report.html").read_text()


def _calibrated_on(vehicle, tests: list[str]):
    """``vehicle`` with one controller value whose provenance names ``tests``."""
    from vehval.calibration import Provenance, vehicle_with_values

    name = "controller.soc_gain_w"
    prov = Provenance(by="vehval epa calibrate", tests=tests, objective="RMS error",
                      start_value=0.1, best_value=0.05, method="grid",
                      start={name: vehicle.controller.soc_gain_w}, ranges={name: "grid 1, 2"},
                      dt=1.0, percent=True)
    return vehicle_with_values(vehicle, {name: vehicle.controller.soc_gain_w}, prov.text)


def test_in_sample_figures_counted_apart(prius_list, prius_2016, tmp_path):
    tests = [t for t in read_test_car_list(prius_list) if t.test_number in ("T1", "T4")]
    veh = _calibrated_on(prius_2016, ["T4"])
    val = validate_tests(veh, tests, dt=1.0)
    marks = {c.test: c.in_sample for c in val.comparisons}
    assert marks == {"T1": False, "T4": True}
    st, ins = val.stats(), val.stats(in_sample=True)
    assert st["n_judged"] == 1 and ins["n_judged"] == 1  # one HWFET figure each
    assert st["n_judged_held_out"] == 1 and st["n_judged_in_sample"] == 1
    t1 = next(c for c in val.comparisons if c.test == "T1")
    assert st["mean_error"] == pytest.approx(t1.error)  # the headline: held-out only
    assert st["n_tests_in_sample"] == 1
    data = val.to_dict()
    assert data["stats_in_sample"]["figures"] == "in-sample"
    assert data["calibration_tests"]["T4"] == ["controller.soc_gain_w"]
    assert [t["in_sample"] for t in data["tests"]] == [False, True]
    assert [c["in_sample"] for c in data["comparisons"]] == [False, True]
    # the same vehicle file without the provenance: nothing is in-sample
    plain = validate_tests(prius_2016, tests, dt=1.0)
    assert plain.stats()["n_judged"] == 2 and plain.stats(in_sample=True)["n_judged"] == 0


def test_in_sample_marked_in_cli_and_report(prius_list, prius_2016, tmp_path, capsys):
    import yaml

    from vehval.calibration.provenance import _plain

    veh = _calibrated_on(prius_2016, ["T4", "T9"])  # T9: a calibration test not in this run
    path = tmp_path / "cal.yaml"
    path.write_text(yaml.safe_dump(_plain(veh.model_dump(exclude_none=True)), sort_keys=False),
                    encoding="utf-8")
    out = tmp_path / "out"
    code = main(["epa", "validate", str(prius_list), "--vehicle", str(path), "--tests",
                 "number=T4", "--dt", "1", "-o", str(out)])
    assert code == 0
    text = capsys.readouterr().out
    assert "in-sample" in text and "held-out: 0/0 judged figures" in text
    assert "in-sample (the vehicle file was calibrated on these tests" in text
    html = (out / "report.html").read_text(encoding="utf-8")
    assert "In-sample, apart" in html and "square: in-sample" in html
    assert "calibrated on 1 of these tests (T4)" in html  # not T9, which did not run
    data = json.loads((out / "epa_validation.json").read_text(encoding="utf-8"))
    assert data["stats"]["n_judged"] == 0 and data["stats_in_sample"]["n_judged"] == 1


def test_unnumbered_repeat_of_a_calibration_test(prius_list, tmp_path, capsys):
    """A later list without test numbers (the 2017 columns) repeats the calibration test T4:
    alone it cannot be told held-out (unknown, not counted); with the list that numbers it,
    in either order, it is the calibration test (in-sample)."""
    import yaml

    from vehval.calibration.provenance import _plain

    t4 = row(number="", orig="", year=2017, cfg="1", code=3, desc="HWFE", fe=66.0,
             target=(24.153, 0.33502, 0.014096))
    t9 = row(number="", orig="", year=2017, vid="16-ZV9H", code=3, desc="HWFE", fe=70.0)
    later = write_list(tmp_path / "17tstcar.csv", [t4, t9])
    # a vehicle file calibrated on T4 only (prius_2016's own calibration tests are not here)
    veh = _calibrated_on(load_vehicle("prius_2004"), ["T4"])
    val = validate_tests(veh, read_test_car_list(later), dt=1.0)
    assert [c.sample_unknown for c in val.comparisons] == [True, True]
    assert not any(c.in_sample for c in val.comparisons)
    st = val.stats()
    assert st["n_judged"] == 0 and st["n_judged_held_out"] == 0
    assert st["n_judged_sample_unknown"] == 2
    assert val.to_dict()["sample_unknown_tests"] == [c.test for c in val.comparisons]
    # with the numbered list as reference: the repeat is T4, the other is held out
    every = read_test_car_list(prius_list) + read_test_car_list(later)
    val = validate_tests(veh, read_test_car_list(later), dt=1.0, reference=every)
    assert [(c.in_sample, c.sample_unknown) for c in val.comparisons] == [(True, False),
                                                                          (False, False)]
    assert list(val.repeats.values()) == ["T4"]
    # the CLI: the later list alone says why nothing is held out; both lists, in either
    # order, keep the numbered row
    path = tmp_path / "cal.yaml"
    path.write_text(yaml.safe_dump(_plain(veh.model_dump(exclude_none=True)), sort_keys=False),
                    encoding="utf-8")
    assert main(["epa", "validate", str(later), "--vehicle", str(path), "--tests",
                 "procedure=3", "--dt", "1"]) == 0
    text = capsys.readouterr().out
    assert "sample unknown: 2 test(s) without a test number" in text
    assert "held-out: 0/0 judged figures" in text
    assert main(["epa", "validate", str(later), "--vehicle", str(path), "--tests",
                 "procedure=3", "--dt", "1", "-o", str(tmp_path / "rep")]) == 0
    capsys.readouterr()
    html = (tmp_path / "rep" / "report.html").read_text(encoding="utf-8")
    assert "held-out: no judged figure." in html and "Sample unknown: 2 test(s)" in html
    for lists in ([later, prius_list], [prius_list, later]):
        assert main(["epa", "validate", *map(str, lists), "--vehicle", str(path), "--tests",
                     "vehicle=16-ZV1H,procedure=3,config=1", "--dt", "1"]) == 0
        text = capsys.readouterr().out
        assert "T4 " in text and "in-sample" in text and "unknown" not in text


def test_a_diesel_vehicle_runs_the_diesel_tests(tmp_path):
    """Every diesel row was skipped as 'not gasoline', also for the packaged diesel
    (cruze_diesel_2014): nothing of a diesel could be validated. The tests on the vehicle's
    fuel family run; the others are skipped with the reason."""
    from helpers.epa_lists import row, write_list
    from vehval.epa import read_test_car_list
    from vehval.epa.procedures import fuel_family, plan_for

    diesel = ("20", "Federal Cert Diesel 7-15 PPM Sulfur")
    rows = read_test_car_list(write_list(tmp_path / "19tstcar.csv", [
        row(model="CRUZE", number="D1", fuel=diesel, fe=70.2, weight=3500,
            target=(26.56, 0.1978, 0.01536)),
        row(model="CRUZE", number="G1", fe=50.1, weight=3500, target=(26.56, 0.1978, 0.01536)),
    ]))
    assert fuel_family("diesel") == fuel_family(diesel[1]) == "diesel"
    assert plan_for(rows[0])[0] is None and plan_for(rows[1])[0] is not None
    assert plan_for(rows[0], "diesel")[0] is not None
    assert "not the vehicle's fuel (diesel)" in plan_for(rows[1], "diesel")[1]
    val = validate_tests("cruze_diesel_2014", rows, dt=1.0)
    assert [p.test.label for p in val.predictions] == ["D1"]
    assert [s["test"] for s in val.skipped] == ["G1"]
    assert 20 < val.predictions[0].overall_mpg < 120


def test_a_negative_b_keeps_the_road_load_work(tmp_path, prius_2016):
    """A fifth of the runnable list rows have a negative target B, which a vehicle file
    cannot hold (B >= 0); B was set to 0 with A and C kept, raising the road load at every
    speed (a 2019 BMW 540i, B -0.172 lbf/mph: HWFET tractive energy +7.5 %). A' + C' v^2 is
    now fitted over the procedure's speeds: the tractive energy stays within 0.1 %."""
    from vehval.cycles import load_cycle
    from vehval.epa.procedures import road_load_without_b
    from vehval.sim.sensitivity import tractive_energy_j

    t = read_test_car_list(write_list(tmp_path / "19tstcar.csv", [
        row(number="N1", weight=4250, target=(49.20, -0.1720, 0.02102))]))[0]
    a, b, c = t.target_a_n, t.target_b_n_per_mps, t.target_c_n_per_mps2
    hwfet = load_cycle("hwfet")
    listed = tractive_energy_j(hwfet, t.mass_kg, a, b, c)
    clamped = tractive_energy_j(hwfet, t.mass_kg, a, 0.0, c)
    assert clamped / listed - 1 > 0.07  # what setting B to 0 did
    v = vehicle_for_test(prius_2016, t, ("hwfet",))
    body = v.body
    assert body.road_load_b_n_per_mps == 0.0 and body.road_load_a_n < a
    fitted = tractive_energy_j(hwfet, t.mass_kg, body.road_load_a_n, 0.0,
                               body.road_load_c_n_per_mps2)
    assert fitted / listed == pytest.approx(1.0, abs=1e-3)
    assert road_load_without_b(a, 0.3, c) == (a, 0.3, c)  # B >= 0: unchanged
    assert vehicle_for_test(prius_2016, t).body.road_load_b_n_per_mps == 0.0
