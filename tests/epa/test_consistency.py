"""The list's own consistency: bags recombined as the lab combines them give the listed
whole-test figure; placeholders and contradictions are named, listed and not judged."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from helpers.epa_lists import row, write_list
from vehval.cli import main
from vehval.epa import read_test_car_list
from vehval.epa.consistency import TOLERANCE, check_listed_figures, recombine
from vehval.epa.validation import validate_tests

FTP_DESC = "Federal fuel 2-day exhaust (w/can load)"


def _udds_bag_distances():
    from vehval.cycles import load_cycle

    c = load_cycle("udds")
    t = np.arange(0.0, c.time_s[-1] + 0.05, 0.1)
    v = np.interp(t, c.time_s, c.speed_mps)
    return v[t < 505].sum() * 0.1, v[t >= 505].sum() * 0.1


@pytest.fixture
def tests(tmp_path):
    rows = [
        row(number="OK4", code=21, desc=FTP_DESC, fe=78.0, bags=(50.7, 126.3, 62.7, 114.4)),
        row(number="OK3", code=21, desc=FTP_DESC, fe=30.0, bags=(27.0, 30.0, 32.0, 0)),
        row(number="US", code=90, desc="US06", fe=48.6, bags=(35.4, 54.4, "", "")),
        row(number="BAD", code=90, desc="US06", fe=60.0, bags=(35.4, 54.4, "", "")),
        row(number="PH", code=3, desc="HWFE", fe=10000),
    ]
    return {t.test_number: t for t in read_test_car_list(write_list(tmp_path / "l.csv", rows))}


def test_recombination_by_hand(tests):
    d1, d2 = _udds_bag_distances()
    b = tests["OK4"].bags
    cold = (d1 + d2) / (d1 / b[0] + d2 / b[1])
    hot = (d1 + d2) / (d1 / b[2] + d2 / b[3])
    assert recombine(tests["OK4"]) == pytest.approx(1 / (0.43 / cold + 0.57 / hot), rel=1e-3)
    # a 3-bag FTP (bag 4 listed as 0, the lists' placeholder): hot UDDS = bags 3 + 2
    t3 = tests["OK3"]
    assert math.isnan(t3.bags[3])
    b = t3.bags
    cold = (d1 + d2) / (d1 / b[0] + d2 / b[1])
    hot = (d1 + d2) / (d1 / b[2] + d2 / b[1])
    assert recombine(t3) == pytest.approx(1 / (0.43 / cold + 0.57 / hot), rel=1e-3)
    assert recombine(tests["PH"]) is None  # a HWFET has no bags


def test_checks_name_what_is_wrong(tests):
    assert check_listed_figures(tests["OK4"]).ok
    us = check_listed_figures(tests["US"])
    assert us.ok and abs(us.rel_diff) < 0.005
    bad = check_listed_figures(tests["BAD"])
    assert not bad.ok and bad.rel_diff < -TOLERANCE
    assert "recombine to 48.6 mpg" in bad.note and "60 mpg" in bad.note
    ph = check_listed_figures(tests["PH"])
    assert not ph.ok and "10000 mpg" in ph.note and "placeholder" in ph.note


def test_doubtful_tests_are_listed_not_judged(tests, tmp_path, capsys):
    val = validate_tests("prius_2016", [tests["US"], tests["BAD"], tests["PH"]], dt=1.0)
    by = {(c.test, c.item): c for c in val.comparisons}
    assert by[("US", "overall")].judged and not by[("US", "overall")].list_doubtful
    for key in (("BAD", "overall"), ("BAD", "bag 1"), ("PH", "overall")):
        assert not by[key].judged and by[key].list_doubtful
        assert by[key].note.startswith("list figures doubtful")
    assert val.stats()["n_judged"] == 3  # US06 whole, city and highway of the good test
    js = {t["test"]: t["list_check"] for t in val.to_dict()["tests"]}
    assert js["US"]["ok"] and not js["BAD"]["ok"] and js["PH"]["recombined"] is None


def test_cli_flags_doubtful_rows(tmp_path, capsys):
    path = write_list(tmp_path / "16tstcar.csv", [
        row(number="BAD", code=90, desc="US06", fe=60.0, bags=(35.4, 54.4, "", "")),
        row(number="OK", code=90, desc="US06", fe=48.6, bags=(35.4, 54.4, "", ""))])
    assert main(["epa", "tests", str(path)]) == 0
    out = capsys.readouterr().out
    assert "! BAD (16tstcar.csv:2): the listed bags recombine" in out and "! OK" not in out
    assert main(["epa", "tests", str(path), "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert [r["list_check"]["ok"] for r in rows] == [False, True]
    assert main(["epa", "validate", str(path), "--vehicle", "prius_2016", "--tests",
                 "model=PRIUS", "--dt", "1"]) == 0
    out = capsys.readouterr().out
    assert "no (list doubtful)" in out and "its figures are listed, not judged" in out


def test_vehicle_match_by_axle_ratio_and_displacement(tmp_path):
    """The list's axle ratio and displacement against the vehicle file: the 2016 Prius's
    rows match (2.83 listed to 0.01 against 2.8344: -0.16 %); a Prius c row does not."""
    import dataclasses

    from vehval.epa.consistency import check_vehicle_match, group_mismatches
    from vehval.vehicle import load_vehicle

    veh = load_vehicle("prius_2016")
    prius = read_test_car_list(write_list(tmp_path / "16tstcar.csv", [row()]))[0]
    ok = check_vehicle_match(prius, veh)
    assert ok.ok and ok.note == "axle ratio and displacement match the vehicle file"
    # +2 % is the edge of what the list's rounding explains; beyond it, a mismatch
    edge = dataclasses.replace(prius, axle_ratio=2.8344 * 1.019, displacement_l=float("nan"))
    assert check_vehicle_match(edge, veh).ok
    c = dataclasses.replace(prius, model="PRIUS c", vehicle_id="17-NP4H", axle_ratio=3.19,
                            displacement_l=1.497)
    bad = check_vehicle_match(c, veh)
    assert not bad.ok
    assert "axle ratio 3.19 (+12.5 %)" in bad.note  # 3.19 / 2.8344 - 1 = +12.55 %
    assert "displacement 1.497 L (-16.7 %)" in bad.note  # 1.497 / 1.798 - 1 = -16.74 %
    assert "17-NP4H" in bad.note
    assert group_mismatches([("A", bad), ("B", ok), ("C", bad), ("D", None)]) == {
        bad.note: ["A", "C"]}
    # nothing to compare: no axle ratio listed, no displacement in the file
    bare = dataclasses.replace(c, axle_ratio=float("nan"))
    no_disp = veh.with_overrides({"engine.displacement_l": None})
    assert check_vehicle_match(bare, no_disp).note.startswith("not checked")
    # a final drive ratio of 1 lumps the final drive into the gear ratios: not compared
    lumped = veh.with_overrides({"driveline.final_drive_ratio": 1.0,
                                 "engine.displacement_l": None})
    assert check_vehicle_match(c, lumped).ok


def test_cli_shows_an_electricity_row_in_its_own_unit(tmp_path, capsys, monkeypatch):
    """`--units metric epa tests` showed a 180.4 MPGe row as 1.3 L/100 km (mpg converted)."""
    path = write_list(tmp_path / "16tstcar.csv", [
        row(model="LEAF", number="EV", code=81, desc="Charge Depleting UDDS",
            fuel=("E", "Electricity"), fe=180.4)])
    monkeypatch.setenv("COLUMNS", "250")
    assert main(["epa", "tests", str(path)]) == 0
    out = capsys.readouterr().out
    assert "elec: MPGe or kWh/100 mi as listed" in out and " 180.4 " in out
    assert main(["--units", "metric", "epa", "tests", str(path)]) == 0
    out = capsys.readouterr().out
    kwh_100km = 33.705 / 180.4 * 100 / 1.609344  # 11.61, by hand
    assert f" {kwh_100km:.1f} " in out and "elec: kWh/100 km" in out and " 1.3 " not in out
