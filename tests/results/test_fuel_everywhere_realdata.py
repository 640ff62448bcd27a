"""One Cruze D3 test, one fuel, one set of figures: every command states the same ones.

The template is the one ``vehval template init`` proposes for the file, with only its
``# fuel: diesel`` placeholder line uncommented. Then ``results``, ``batch`` (catalog),
``validate``, ``identify`` + ``predict``, ``qa`` + ``report`` must all use diesel (the fuel
table's property set) and state the same whole-test fuel mass, distance and fuel economy, to
the last digit: each figure has one owner (the results stage, through
:mod:`vehval.fuels.quantities`). Skips without the shared real data.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import duckdb
import pytest
import yaml

from helpers.data import REAL
from vehval.fuels import table_fuel

HERE = Path(__file__).resolve().parent
CRUZE = REAL / "d3_2014_chevrolet_cruze_diesel" / "61410004 Test Data.txt"
KEYS = ("distance_m", "fuel_mass_kg", "fuel_economy_mpg")

pytestmark = [pytest.mark.realdata, pytest.mark.slow,
              pytest.mark.skipif(not CRUZE.is_file(), reason="real D3 Cruze data not available")]


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """Every command run once on the test (in-process CLI); their outputs by name."""
    from vehval.cli import main

    tmp = tmp_path_factory.mktemp("cruze_fuel")

    def cli(*args):
        code = main([str(a) for a in args])
        assert code == 0, args

    tpl = tmp / "t.yaml"
    cli("template", "init", CRUZE, "-o", tpl)
    text = tpl.read_text(encoding="utf-8")
    assert "# fuel: diesel\n" in text
    tpl.write_text(text.replace("# fuel: diesel\n", "fuel: diesel\n"), encoding="utf-8")
    data = tmp / "tests"
    data.mkdir()
    shutil.copy(CRUZE, data / CRUZE.name)      # batch reads a directory of tests
    cli("results", CRUZE, "-t", tpl, "-o", tmp / "results")
    cli("batch", data, "-t", tpl, "-o", tmp / "batch", "-j", "0", "--no-report", "-q")
    cli("validate", CRUZE, "-t", tpl, "--vehicle", "prius_2004", "-o", tmp / "validate")
    cli("identify", CRUZE, "-t", tpl, "--architecture", "conventional", "-o", tmp / "car.yaml")
    pred = tmp / "predict.json"
    import contextlib
    import io
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        cli("predict", tmp / "car.yaml", CRUZE, "-t", tpl, "--json")
    pred.write_text(buf.getvalue(), encoding="utf-8")
    cli("qa", CRUZE, "-t", tpl, "-o", tmp / "qa")
    cli("report", tmp / "qa", "-o", tmp / "report.html")
    return tmp


def _results(runs: Path) -> dict:
    return json.loads((runs / "results" / "results.json").read_text(encoding="utf-8"))


def test_results_uses_the_declared_diesel(runs):
    doc = _results(runs)
    diesel = table_fuel("diesel")
    assert doc["fuel"]["name"] == "diesel"
    assert doc["fuel"]["density_kg_per_m3"] == diesel.density_kg_per_m3
    assert doc["fuel"]["lhv_j_per_kg"] == diesel.lhv_j_per_kg
    vals = doc["test_total"]["values"]
    assert all(vals[k] and vals[k] > 0 for k in KEYS)


def test_batch_catalog_states_the_same_figures(runs):
    ref = _results(runs)["test_total"]["values"]
    with duckdb.connect(str(runs / "batch" / "catalog.duckdb"), read_only=True) as con:
        row = con.execute("SELECT distance_m, fuel_mass_kg, fuel_economy_mpg, fuel "
                          "FROM tests").fetchall()
        scope = con.execute("SELECT distance_m, fuel_mass_kg, fuel_economy_mpg FROM "
                            "phase_results WHERE scope = 'test'").fetchall()
    assert len(row) == 1 and row[0][3] == "diesel"
    assert tuple(row[0][:3]) == tuple(ref[k] for k in KEYS)
    assert tuple(scope[0]) == tuple(ref[k] for k in KEYS)


def test_validate_states_the_same_figures_and_fuel(runs):
    # validate runs QA against the Prius model it validates: QA holds the Cruze's fuel rate
    # beyond that engine's limit (an error), so the QA gate withholds the fuel figures; the
    # results stage under the same QA states exactly what validate states
    from vehval.workflow import TestRun

    run = TestRun.load([CRUZE], runs / "t.yaml", "prius_2004")
    ref = run.results().results.to_dict()["test_total"]["values"]
    doc = json.loads((runs / "validate" / "metrics.json").read_text(encoding="utf-8"))
    t = doc["tests"][0]
    assert {k: t["measured"][k] for k in KEYS} == {k: ref[k] for k in KEYS}
    assert t["measured"]["distance_m"] == _results(runs)["test_total"]["values"]["distance_m"]
    assert t["measured"]["fuel"] == "diesel"
    diesel = table_fuel("diesel")
    assert t["conditions"]["fuel_density_kg_per_m3"] == diesel.density_kg_per_m3
    assert t["conditions"]["fuel_lhv_j_per_kg"] == diesel.lhv_j_per_kg


def test_identify_names_the_fuel_and_predict_states_the_same_fuel(runs):
    car = yaml.safe_load((runs / "car.yaml").read_text(encoding="utf-8"))
    assert car["engine"]["fuel"] == "diesel"
    ref = _results(runs)["test_total"]["values"]
    pred = json.loads((runs / "predict.json").read_text(encoding="utf-8"))
    p = pred[0] if isinstance(pred, list) else pred["tests"][0]
    assert p["results_fuel_g"] == 1e3 * ref["fuel_mass_kg"]


def test_qa_calculates_fuel_power_and_the_report_states_the_same(runs):
    ref = _results(runs)
    qa_doc = json.loads((runs / "qa" / "results.json").read_text(encoding="utf-8"))
    assert {k: qa_doc["test_total"]["values"][k] for k in KEYS} == {
        k: ref["test_total"]["values"][k] for k in KEYS}
    findings = json.loads((runs / "qa" / "findings.json").read_text(encoding="utf-8"))
    calc = findings["calculations"]
    assert calc["parameters"]["fuel_lhv_j_per_kg"] == {"value": 42.8e6,
                                                       "from": "template fuel diesel"}
    assert "fuel_pwr_calc" in calc["computed"]
    html = (runs / "report.html").read_text(encoding="utf-8")
    v = ref["test_total"]["values"]
    u = ref["test_total"]["uncertainty"]["fuel_economy_mpg"]["U"]
    assert f"{v['fuel_economy_mpg']:.2f} ± {u:.2f}" in html
    assert "diesel (851.0 kg/m³, 42.80 MJ/kg)" in html
