"""EPA Test Car List reader, selection and CLI list/tests (synthetic list files)."""

from __future__ import annotations

import json
import math

import pytest

from helpers.epa_lists import FULL_HEADER, row, write_list
from vehval.cli import main
from vehval.constants import LB_KG, LBF_N, MPH_M_PER_S
from vehval.epa import (
    apply_selector,
    plan_for,
    read_lists,
    read_test_car_list,
    select_tests,
)
from vehval.errors import ConfigError, InputFileError


def test_units_converted_to_si(prius_list):
    t = read_test_car_list(prius_list)[0]
    # hand-computed: 3375 lb, 18.272 lbf, 0.29545 lbf/mph, 0.013793 lbf/mph^2
    assert t.mass_kg == pytest.approx(3375 * 0.45359237, rel=1e-12)
    assert t.target_a_n == pytest.approx(18.272 * 4.4482216152605, rel=1e-12)
    assert t.target_b_n_per_mps == pytest.approx(0.29545 * LBF_N / MPH_M_PER_S, rel=1e-12)
    assert t.target_c_n_per_mps2 == pytest.approx(0.013793 * LBF_N / MPH_M_PER_S**2, rel=1e-12)
    # round trip: the road load at 50 mph is the same force in both unit systems
    v_mph = 50.0
    f_lbf = 18.272 + 0.29545 * v_mph + 0.013793 * v_mph**2
    v = v_mph * MPH_M_PER_S
    f_n = t.target_a_n + t.target_b_n_per_mps * v + t.target_c_n_per_mps2 * v**2
    assert f_n / LBF_N == pytest.approx(f_lbf, rel=1e-12)
    assert t.mass_kg / LB_KG == pytest.approx(3375, rel=1e-12)
    assert t.originator == "EPA" and t.procedure_code == 3 and t.fe == 71.2
    assert all(math.isnan(b) for b in t.bags)
    assert t.source == "16tstcar.csv:2"


@pytest.mark.parametrize("newline", ["\r", "\n", "\r\n"])
def test_line_endings_and_latin1(tmp_path, newline):
    path = write_list(tmp_path / "x.csv", [row(model="PRIUS Caf\u00e9")], newline=newline)
    t = read_test_car_list(path)
    assert len(t) == 1 and t[0].model == "PRIUS Caf\u00e9"


def test_reduced_column_set(tmp_path):
    # the 2017 list: 'Year' instead of 'Model Year', no test number / originator / displacement
    header = ["Year" if h == "Model Year" else h for h in FULL_HEADER
              if h not in ("Test Number", "Test Originator", "Test Veh Displacement (L)",
                           "Vehicle Manufacturer Name", "Test Veh Configuration #")]
    r = row(year=2017)
    r["Year"] = "2017"
    t = read_test_car_list(write_list(tmp_path / "17tstcar.csv", [r], header=header))[0]
    assert t.year == 2017 and t.test_number == "" and t.originator == ""
    assert math.isnan(t.displacement_l) and t.label.startswith("16-ZV1H/3@")


def test_missing_column_named(tmp_path):
    header = [h for h in FULL_HEADER if h != "Target Coef B (lbf/mph)"]
    path = write_list(tmp_path / "bad.csv", [row()], header=header)
    with pytest.raises(InputFileError, match=r"bad\.csv: line 1: missing column.*Target Coef B"):
        read_test_car_list(path)
    assert main(["epa", "list", str(path)]) == 2


def test_duplicates_across_years_kept_once(tmp_path, prius_list):
    other = tmp_path / "more"
    other.mkdir()
    write_list(other / "17tstcar.csv", [row(year=2017, number="")])
    tests = read_lists([prius_list, other])
    assert len(tests) == 8


def test_select_and_suggest(prius_list):
    tests = read_lists([prius_list.parent])
    assert len(select_tests(tests, "toyota", "prius")) == 6  # exact model only
    assert len(select_tests(tests, model="CAMRY")) == 1  # substring fallback
    with pytest.raises(InputFileError, match="unknown model 'PRIUSS'.*'PRIUS'"):
        select_tests(tests, model="PRIUSS")
    with pytest.raises(InputFileError, match="unknown make 'TOYTA'.*'TOYOTA'"):
        select_tests(tests, make="TOYTA")
    with pytest.raises(InputFileError, match="model year 2015"):
        select_tests(tests, year=2015)
    sel = apply_selector(tests, "model=PRIUS,originator=EPA")
    assert [t.test_number for t in sel] == ["T1", "T2", "T3"]
    assert [t.test_number for t in apply_selector(tests, "PRIUS,procedure=us06")] == ["T2"]
    with pytest.raises(ConfigError, match="unknown key 'colour'"):
        apply_selector(tests, "colour=red")


def test_unrunnable_procedures_named(prius_list):
    tests = {t.test_number: t for t in read_test_car_list(prius_list)}
    assert plan_for(tests["T1"])[0].key == "hwfet"
    assert plan_for(tests["T3"])[0].key == "ftp75"
    proc, why = plan_for(tests["T5"])
    assert proc is None and "A/C" in why
    proc, why = plan_for(tests["T6"])
    assert proc is None and "temperature" in why


def _no_nan(token):
    raise AssertionError(f"non-standard JSON constant {token}")


def test_cli_list_and_tests(prius_list, capsys):
    assert main(["epa", "list", str(prius_list), "--make", "TOYOTA", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert {r["model"] for r in rows} == {"PRIUS", "PRIUS c", "CAMRY HYBRID LE"}
    assert main(["epa", "tests", str(prius_list), "--model", "PRIUS", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out, parse_constant=_no_nan)
    assert len(rows) == 6 and rows[2]["bags"] == [50.7, 126.3, 62.7, 114.4]
    assert rows[0]["bags"] == [None] * 4  # empty bag columns: null (strict JSON, no NaN)
    assert rows[0]["mass_kg"] == pytest.approx(1530.874, abs=1e-3)
    assert main(["epa", "tests", str(prius_list), "--model", "PRIUS"]) == 0
    out = capsys.readouterr().out
    assert "T3" in out and "126.3" in out and "6 tests" in out
    assert main(["epa", "list", str(prius_list), "--model", "PRIUSS"]) == 2
    assert "did you mean" in capsys.readouterr().err
    assert main(["epa", "list", str(prius_list.parent / "nope.csv")]) == 2


def test_cli_tests_and_list_in_display_units(prius_list, capsys, monkeypatch):
    """The screen reads the list's own units in the us system (ETW lb, A lbf, B lbf/mph,
    C lbf/mph², as the row T4 gives them: 3375, 24.153, 0.33502, 0.014096) and kg, N,
    N/(m/s), N/(m/s)² in metric, the road-load units of every other screen (`identify`;
    it printed N/(km/h), 3.6 times smaller than identify's B of the same car); --json stays
    SI."""
    from vehval.display import ENV_VAR, keyed_unit

    monkeypatch.setenv(ENV_VAR, "us")
    assert main(["epa", "tests", str(prius_list), "--model", "PRIUS"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert "ETW lb" in out[0] and "A lbf" in out[0] and "B lbf/mph" in out[0]
    assert "C lbf/mph²" in out[0]
    t4 = next(ln for ln in out if ln.startswith("T4 ")).split()
    # transmission and fuel after the procedure ('?' when the list has no column)
    assert t4[5:13] == ["?", "gas", "3375", "20.0", "2.83", "24.15", "0.3350", "0.01410"]
    assert main(["epa", "list", str(prius_list), "--model", "PRIUS"]) == 0
    assert "ETW [lb]" in capsys.readouterr().out
    monkeypatch.setenv(ENV_VAR, "metric")
    assert main(["epa", "tests", str(prius_list), "--model", "PRIUS"]) == 0
    out = capsys.readouterr().out.splitlines()
    b_label = keyed_unit("road_load_b_n_per_mps", system_name="metric").label
    assert "ETW kg" in out[0] and f"B {b_label}" in out[0] and "B N/(m/s)" in out[0]
    assert "C N/(m/s)²" in out[0] and "km/h" not in out[0]
    t4 = next(ln for ln in out if ln.startswith("T4 ")).split()
    kg, a_n = 3375 * LB_KG, 24.153 * LBF_N
    b = 0.33502 * LBF_N / MPH_M_PER_S
    assert t4[7] == f"{kg:.0f}" and t4[10] == f"{a_n:.2f}" and t4[11] == f"{b:.4f}"
    assert main(["epa", "tests", str(prius_list), "--model", "PRIUS", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert any(d["mass_kg"] == pytest.approx(kg) for d in data)


def test_cli_list_counts_read_as_english(prius_list, capsys):
    """'1 vehicles, 1 tests' -> '1 vehicle, 1 test'."""
    assert main(["epa", "list", str(prius_list), "--model", "PRIUS c"]) == 0
    assert capsys.readouterr().out.splitlines()[-1] == "1 vehicle, 1 test"


def test_exact_model_name_says_what_it_left_out(prius_list, capsys):
    """`--model F150` selected the one Roush named exactly so and said nothing of the 12 Ford
    names containing F150; the note now names them (and the partial match still says so)."""
    from vehval.epa.select import model_note

    tests = read_lists([prius_list])
    note = model_note(tests, "prius")
    assert "exact name of a model (TOYOTA)" in note and "'PRIUS c'" in note
    assert model_note(tests, "PRIUS c") is None
    assert model_note(tests, "CAMRY").startswith("no model is named 'CAMRY'")
    assert main(["epa", "list", str(prius_list), "--model", "PRIUS"]) == 0
    err = capsys.readouterr().err
    assert err.startswith("note: 'PRIUS' is the exact name") and "'PRIUS c'" in err
    assert main(["epa", "tests", str(prius_list), "--model", "PRIUS c"]) == 0
    assert capsys.readouterr().err == ""


def test_a_carried_over_test_is_found_under_each_year(tmp_path, capsys):
    """A test the next year's list repeats (a carried-over certification) was kept once, under
    its first year only: with the 2016-2019 lists read together, 298 of the 498 models of
    2017 had no test (`--model "PRIUS v" --year 2017`: 'unknown model'). It is still kept
    once, and found under each year that lists it."""
    r16 = row(model="PRIUS v", vid="12-ZW2H", number="P1", fe=45.0, year=2016)
    r17 = {**row(model="PRIUS v", vid="12-ZW2H", number="", fe=45.0, year=2017)}
    write_list(tmp_path / "16tstcar.csv", [r16])
    write_list(tmp_path / "17tstcar.csv", [r17])
    tests = read_lists([tmp_path])
    assert len(tests) == 1 and tests[0].years == (2016, 2017)
    assert tests[0].test_number == "P1"
    sel = select_tests(tests, model="PRIUS v", year=2017)
    assert len(sel) == 1 and sel[0].year == 2017 and sel[0].test_number == "P1"
    assert main(["epa", "list", str(tmp_path), "--model", "PRIUS v", "--year", "2017"]) == 0
    assert "2017  TOYOTA       PRIUS v" in capsys.readouterr().out
    assert main(["epa", "tests", str(tmp_path), "--year", "2017", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)[0]["years"] == [2016, 2017]


def test_cli_metric_reads_fuel_consumption(prius_list, capsys, monkeypatch):
    """`--units metric` converted weight and road load but left every fuel figure in mpg
    (README: metric leads with L/100 km); `epa tests` and `epa validate` now show L/100 km
    (235.215 / mpg), --json keeps the list's mpg."""
    from vehval.display import ENV_VAR

    monkeypatch.setenv(ENV_VAR, "metric")
    assert main(["epa", "tests", str(prius_list), "--model", "PRIUS"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert "L/100 km" in out[0] and "mpg" not in out[0]
    t1 = next(ln for ln in out if ln.startswith("T1 ")).split()
    assert t1[13] == f"{235.2146 / 71.2:.2f}"
    monkeypatch.setenv(ENV_VAR, "us")
    assert main(["epa", "tests", str(prius_list), "--model", "PRIUS"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert next(ln for ln in out if ln.startswith("T1 ")).split()[13] == "71.2"
