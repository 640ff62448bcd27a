"""Hostile EPA Test Car Lists: a damaged row or an impossible value is one line naming the
file, the line, the column and the value; the rest of a fleet run goes on (small lists
written in tmp_path)."""

from __future__ import annotations

import pytest

from helpers.epa_lists import GAS as GAS_ROW
from helpers.epa_lists import HEADER, camry_rows, write_list
from vehval.cli import main
from vehval.epa import read_test_car_list
from vehval.epa.fleet import plan_fleet, predict_jobs, read_fleet
from vehval.errors import InputFileError


def _car(vid: str) -> list[dict]:
    rows = camry_rows(vid=vid)
    for r in rows:
        r["Test Number"] = f"{vid}-{r['Test Number']}"
    return rows


def test_a_list_cut_mid_row_is_refused_naming_the_line(tmp_path, capsys):
    path = write_list(tmp_path / "19tstcar.csv", _car("A1") + _car("A2"), header=HEADER)
    data = path.read_bytes()
    path.write_bytes(data[: data.rindex(b"\r\n", 0, len(data) - 2) + 40])  # last row cut
    with pytest.raises(InputFileError, match=r"line 5: \d+ fields, the header has \d+: the "
                                             r"row is cut short"):
        read_test_car_list(path)
    assert main(["epa", "tests", str(path), "--model", "SEDAN XLE"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "19tstcar.csv: line 5" in err[0]


@pytest.mark.parametrize("column,text", [("Equivalent Test Weight (lbs.)", "heavy"),
                                         ("RND_ADJ_FE", "n/a"), ("Axle Ratio", "3,5")])
def test_a_text_in_a_numeric_column_is_refused_naming_it(tmp_path, capsys, column, text):
    rows = _car("A1")
    rows[1][column] = text
    path = write_list(tmp_path / "19tstcar.csv", rows, header=HEADER)
    with pytest.raises(InputFileError, match=f"line 3: '{text}' in column "):
        read_test_car_list(path)
    out = tmp_path / "o"
    assert main(["epa", "fleet", str(path), "-o", str(out), "--workers", "1"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"'{text}' in column '{column}' is not a number" in err[0]
    assert not (out / "fleet.json").exists()


def test_a_weight_and_axle_ratio_swapped_are_one_car_not_run(tmp_path):
    bad = _car("B1")
    for r in bad:  # the two columns' values swapped: 2.8 lb, axle ratio 3625
        r["Equivalent Test Weight (lbs.)"], r["Axle Ratio"] = r["Axle Ratio"], "3625"
    path = write_list(tmp_path / "19tstcar.csv", _car("A1") + bad, header=HEADER)
    tests, _ = read_fleet([path])
    plan = plan_fleet(tests)
    records = [*plan.not_run, *predict_jobs(plan.jobs)]  # an internal error before
    by = {r["source"]: r for r in records}
    assert [by[f"19tstcar.csv:{n}"]["status"] for n in (2, 3)] == ["run", "run"]
    for n in (4, 5):
        r = by[f"19tstcar.csv:{n}"]
        assert (r["status"], r["reason_code"]) == ("not_run", "specs_not_usable")
        assert "equivalent test weight 2.8 lb as listed ('Equivalent Test Weight (lbs.)')" \
            in r["reason"] and "\n" not in r["reason"]


@pytest.mark.parametrize("selector", ["model=SEDAN XLE,model=OTHER", "model=SEDAN XLE,OTHER",
                                      "year=2019,year=2016"])
def test_a_selector_key_given_twice_is_refused_not_overridden(tmp_path, selector):
    from vehval.epa import apply_selector
    from vehval.errors import ConfigError

    tests = read_test_car_list(write_list(tmp_path / "19tstcar.csv", _car("A1"), header=HEADER))
    with pytest.raises(ConfigError, match="given twice"):  # the last value was taken
        apply_selector(tests, selector)
    assert len(apply_selector(tests, "model=SEDAN XLE,model=sedan xle".upper())) == 2


def test_epa_vehicle_builds_a_car_tested_on_diesel_only(tmp_path, capsys):
    """`epa vehicle` built every car on gasoline: a diesel car was refused, its message
    saying the model from specs is a compression-ignition engine for a car's diesel tests."""
    from vehval.vehicle import load_vehicle

    rows = _car("D1")
    for r in rows:
        r.update({"Test Fuel Type Cd": "19",
                  "Test Fuel Type Description": "Federal Cert Diesel 7-15 PPM Sulfur"})
    path = write_list(tmp_path / "19tstcar.csv", rows, header=HEADER)
    out = tmp_path / "d1.yaml"
    assert main(["epa", "vehicle", str(path), "--make", "MAKER", "--model", "SEDAN XLE",
                 "--year", "2019", "-o", str(out)]) == 0, capsys.readouterr().err
    assert load_vehicle(str(out)).engine.fuel == "diesel"


def test_not_run_reasons_name_a_battery_electric_car(tmp_path):
    """A car with electricity rows only is named battery-electric (it read 'a hybrid or
    plug-in hybrid (other test)'); a plug-in hybrid's rows stay a hybrid's."""
    from helpers.epa_lists import row

    ev = ("95", "Electricity")
    rows = [row(model="LEAF", make="NISSAN", vid="EV1", number=n, code=c, fuel=ev, fe=f)
            for n, c, f in (("E1", 21, 120.0), ("E2", 3, 100.0))]
    rows += [row(model="X PLUG-IN HYBRID", make="MAKER", vid="PH1", number=n, code=c, fuel=fuel, fe=f)
             for n, c, fuel, f in (("P1", 21, ev, 90.0), ("P2", 21, GAS_ROW, 40.0))]
    tests, _ = read_fleet([write_list(tmp_path / "19tstcar.csv", rows, header=HEADER)])
    why = {r["source"].rsplit(":", 1)[1]: r["reason"] for r in plan_fleet(tests).not_run}
    assert "a battery-electric car (electricity test)" in why["2"]
    assert "a battery-electric car (electricity test)" in why["3"]
    assert "a hybrid or plug-in hybrid (electricity test)" in why["4"]
    assert "a hybrid or plug-in hybrid (gasoline test)" in why["5"]


@pytest.mark.parametrize("soc0,label", [(float("nan"), "HWFET"), (0.6, "HWFET (J1711 balanced)")])
def test_only_a_car_with_a_battery_has_a_j1711_balanced_figure(tmp_path, soc0, label):
    """A conventional car's whole-test figure was labelled '(J1711 balanced)'."""
    from vehval.epa.procedures import plan_for
    from vehval.epa.validation import TestPrediction, _compare

    t = read_test_car_list(write_list(tmp_path / "19tstcar.csv", _car("A1"), header=HEADER))[1]
    proc, _ = plan_for(t)
    pred = TestPrediction(test=t, procedure=proc.key, overall_mpg=57.0, bags_mpg={1: 57.0},
                          bag_distance_m={1: 16500.0}, bag_fuel_j={1: 3.0e7},
                          bag_battery_j={1: 0.0}, soc_initial=soc0, soc_delta=0.0,
                          trace_n_miss=0, energy_balance_rel=0.0, distance_m=16500.0,
                          fuel_kg=0.7, engine_on_fraction=1.0)
    names = [c.name for c in _compare(pred, proc, cold_model=False) if c.item == "overall"]
    assert names == [label]
