"""`vehval results` and `vehval qa` writing results.json; the Cruze D3 acceptance figures."""

import json
from pathlib import Path

import pytest

from helpers.data import CRUZE

from .helpers import cli_files

HERE = Path(__file__).resolve().parent
CRUZE_TEMPLATE = HERE.parents[0] / "qa" / "templates" / "cruze.yaml"



def test_results_cli_writes_results_json(tmp_path, cli):
    raw, tpl = cli_files(tmp_path)
    code, out, err = cli("results", raw, "-t", tpl, "-o", tmp_path / "out", "--json")
    assert code == 0, err
    doc = json.loads(out)
    on_disk = json.loads((tmp_path / "out" / "results.json").read_text())
    assert doc["results_version"] == on_disk["results_version"] == 1
    assert [p["name"] for p in doc["phases"]] == ["bag1", "bag2"]
    fe = doc["test_total"]["values"]["fuel_economy_mpg"]
    u = doc["test_total"]["uncertainty"]["fuel_economy_mpg"]
    assert fe > 0 and 0 < u["U"] < 0.1 * fe and u["k"] == 2 and u["method"] == "first_order"
    assert doc["fuel"]["name"] == "diesel"


def test_results_cli_monte_carlo_and_text(tmp_path, cli):
    raw, tpl = cli_files(tmp_path)
    code, out, err = cli("results", raw, "-t", tpl, "-o", tmp_path / "o", "--monte-carlo", 200)
    assert code == 0, err
    assert "mpg" in out and "monte carlo" in out and "= udds" in out


def test_qa_writes_results_json_next_to_findings(tmp_path, cli):
    raw, tpl = cli_files(tmp_path, fuel=None)
    code, out, err = cli("qa", raw, "-t", tpl, "-o", tmp_path / "q")
    assert code == 0, err
    doc = json.loads((tmp_path / "q" / "results.json").read_text())
    assert doc["test_total"]["values"]["fuel_economy_mpg"] is None   # no fuel: no mpg
    assert any("no fuel declared" in f["message"] for f in doc["findings"])
    assert "no fuel declared" in out


def test_unknown_fuel_is_one_clear_line_and_no_output(tmp_path, cli):
    raw, tpl = cli_files(tmp_path, fuel="unobtainium")
    code, _out, err = cli("results", raw, "-t", tpl, "-o", tmp_path / "x")
    assert code == 2
    assert "unknown fuel 'unobtainium'" in err and "diesel" in err and "Traceback" not in err
    assert not (tmp_path / "x").exists()


#: Facility figures of the D3 master summary [mpg] and the composite that reports them.
FACILITY = {"61410013": ("udds", 34.0), "61410015": ("hwfet", 54.5), "61410016": ("us06", 37.0),
            "61410005": ("nedc", 37.7), "61410004": ("wltc3b", 41.2), "61410026": ("sc03", 26.7)}


@pytest.fixture(scope="module")
def cruze_template(tmp_path_factory):
    text = CRUZE_TEMPLATE.read_text()
    text = text.replace("  fuel_density_kg_per_m3: 851\n", "").replace(
        "  fuel_lhv_j_per_kg: 42.8e6\n", "") + "fuel: diesel\n"
    p = tmp_path_factory.mktemp("tpl") / "cruze_diesel.yaml"
    p.write_text(text)
    from vehval.io.template import load_template
    return load_template(p)


def _cruze(tid, tpl, **kw):
    from vehval.io.importer import import_test
    from vehval.results import results_from_template
    return results_from_template(import_test([CRUZE / f"{tid} Test Data.txt"], tpl), tpl, **kw)


@pytest.mark.realdata
@pytest.mark.skipif(not CRUZE.is_dir(), reason="real data not available")
@pytest.mark.parametrize("tid", sorted(FACILITY))
def test_cruze_results_within_two_percent_of_the_facility(tid, cruze_template):
    comp, facility = FACILITY[tid]
    res = _cruze(tid, cruze_template)
    ours = res.value(comp, "fuel_economy_mpg")
    u = res.expanded(comp, "fuel_economy_mpg")
    dq = res.drive_quality["test"]
    print(f"\n{tid} {comp}: {ours:.2f} +- {u:.2f} mpg vs facility {facility} "
          f"({100 * (ours / facility - 1):+.2f} %); IWR {dq['iwr_pct']:+.2f} %, RMSSE "
          f"{dq['rmsse_mph']:.2f} mph, ER {dq['er_pct']:+.2f} %")
    assert ours == pytest.approx(facility, rel=0.02)
    assert all(res.drive_quality[p.name] is not None for p in res.phases)


@pytest.mark.realdata
@pytest.mark.skipif(not CRUZE.is_dir(), reason="real data not available")
def test_cruze_cold_udds_bags_and_ftp_weighting(cruze_template):
    hot = _cruze("61410013", cruze_template)
    bag1_hot = {k: hot.values["bag1"][k] for k in ("fuel_mass_kg", "distance_m", "co2_kg")}
    res = _cruze("61410012", cruze_template, hot_start_bag1=bag1_hot)
    assert res.conditions["start"] == "cold" and hot.conditions["start"] == "hot"
    b1, b2 = res.value("bag1", "fuel_economy_mpg"), res.value("bag2", "fuel_economy_mpg")
    ftp = res.value("ftp75_from_udds", "fuel_economy_mpg")
    print(f"\n61410012 cold UDDS: bag 1 {b1:.2f}, bag 2 {b2:.2f}, UDDS "
          f"{res.value('udds', 'fuel_economy_mpg'):.2f} (facility 30.9), FTP-style {ftp:.2f} mpg")
    assert b1 < b2                                  # the cold bag costs fuel
    assert res.value("udds", "fuel_economy_mpg") == pytest.approx(30.9, rel=0.02)
    assert b1 < ftp < hot.value("udds", "fuel_economy_mpg")


def test_report_shows_results_first(tmp_path, cli):
    raw, tpl = cli_files(tmp_path)
    code, out, err = cli("qa", raw, "-t", tpl, "-o", tmp_path / "r", "--report")
    assert code == 0, err
    html = (tmp_path / "r" / "report.html").read_text()
    i = html.find("Test results")
    assert 0 < i < html.find("QA findings") and "Results per phase" in html
    assert "Regulatory composites" in html and "± " in html and "Drive quality (SAE J2951)" in html
    # time traces in engineering units, data SI: vehicle speed in mph, fuel rate in g/s
    assert "veh_spd [mph]" in html and "fuel_rate [g/s]" in html and "veh_spd [m/s]" not in html
    # `vehval report` on the output directory reads results.json again
    code, out, err = cli("report", tmp_path / "r", "-o", tmp_path / "again.html", "--no-excel")
    assert code == 0, err
    assert "Results per phase" in (tmp_path / "again.html").read_text()


def test_display_units_round_trip():
    from vehval.constants import MPH_M_PER_S
    from vehval.display import unit_for
    assert unit_for("m/s", system_name="us").factor == pytest.approx(1 / MPH_M_PER_S)
    rpm = unit_for("rad/s")
    assert rpm.label == "rpm" and 104.71975511965977 * rpm.factor == pytest.approx(1000.0)
    assert unit_for("N*m").label == "N·m" and unit_for("N*m").factor == 1.0
