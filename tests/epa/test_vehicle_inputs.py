"""`epa vehicle`: a dyno file's role (fitted on or predicted) and its units."""

from __future__ import annotations

import json

import pytest

from helpers.epa_lists import HEADER, camry_rows, write_list, write_sim_d3
from vehval.cli import main
from vehval.epa import read_test_car_list
from vehval.epa.specs import specs_from_tests, vehicle_from_specs

TEMPLATE = ("template_version: 1\nfuel: gasoline_e0\nfiles:\n- source: dyno\n"
            "  format: d3\n  time: {{column: Time}}\n  channels:\n"
            "    Eng_FuelFlow_Direct_DI: {{name: fuel_rate_test, unit: {fuel}}}\n"
            "    Dyno_Spd: {{name: veh_spd_test, unit: mph}}\n")


@pytest.fixture
def sedan(tmp_path):
    lists = write_list(tmp_path / "19tstcar.csv", camry_rows(), header=HEADER)
    truth = vehicle_from_specs(specs_from_tests(read_test_car_list(lists)), 0.43, 1.1,
                               cold_start=False)
    for name, cyc in (("t1", "udds"), ("t3", "hwfet")):
        write_sim_d3(tmp_path / f"{name} Test Data.txt", truth, cyc)
    base = ["epa", "vehicle", str(lists), "--make", "MAKER", "--model", "SEDAN XLE",
            "--year", "2019", "--dt", "1"]
    return tmp_path, base


def _template(tmp_path, fuel_unit="ccps"):
    path = tmp_path / f"t_{fuel_unit.replace('/', '_')}.yaml"
    path.write_text(TEMPLATE.format(fuel=fuel_unit), encoding="utf-8")
    return path


def test_a_predicted_file_that_is_also_a_calibration_file_is_refused(sedan, capsys):
    """It was reported "held-out" although the fuel model was fitted on it."""
    tmp, base = sedan
    t1, out = tmp / "t1 Test Data.txt", tmp / "car.yaml"
    tmpl = _template(tmp)
    for other in (str(t1), str(tmp / "." / "t1 Test Data.txt")):  # the same file, spelt anew
        rc = main([*base, "--calibrate", str(t1), "--predict", other, "-t", str(tmpl),
                   "-o", str(out)])
        assert rc == 2
        err = capsys.readouterr().err
        assert "given to both --calibrate and --predict" in err and "t1 Test Data.txt" in err
        assert len(err.strip().splitlines()) == 1 and not out.exists()
    assert main([*base, "--calibrate", str(t1), "--calibrate", str(t1), "-t", str(tmpl),
                 "-o", str(out)]) == 2
    assert "given twice to --calibrate" in capsys.readouterr().err
    # distinct files: one in-sample, one held-out
    assert main([*base, "--calibrate", str(t1), "--predict", str(tmp / "t3 Test Data.txt"),
                 "-t", str(tmpl), "-o", str(out), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert [t["in_sample"] for t in doc["tests"]] == [True, False]
    assert all(t["unit_hints"] == [] for t in doc["tests"])


def test_a_dyno_fuel_unit_qa_doubts_gives_the_results_hint(sedan, capsys):
    """A fuel channel declared in the wrong unit (mL/min for cc/s: 60 x too little) was fitted
    without a word; the results stage's unit hint now refuses it (--force: used, named)."""
    tmp, base = sedan
    t1, out = tmp / "t1 Test Data.txt", tmp / "car.yaml"
    tmpl = _template(tmp, "mL/min")
    args = [*base, "--calibrate", str(t1), "-t", str(tmpl), "-o", str(out)]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert "t1 Test Data.txt: fuel_rate_test" in err and "--force" in err
    assert len(err.strip().splitlines()) == 1 and not out.exists()
    # --force goes past the hint to the fit, which then finds no engine that burns 60 x less
    assert main([*args, "--force"]) == 2
    err = capsys.readouterr().err
    assert "--force uses it anyway" not in err and "indicated efficiency" in err
