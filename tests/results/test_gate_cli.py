"""The gate end to end: a virtual test whose fuel channel is declared in mg/s instead of its
real unit. `results`, `qa` and `report` withhold the fuel figures (exit 4) and name the fuel
signal; `--force` states them under a banner (exit 0)."""

from __future__ import annotations

import json

import pytest

from vehval.cycles import Cycle, load_cycle
from vehval.synth import make_virtual_test

SHORT_S = 330.0  # the first UDDS hills: the engine runs, the unit check has data


@pytest.fixture(scope="module")
def mg_test(tmp_path_factory):
    """(files, template declaring the fuel in mg/s, template as generated)."""
    udds = load_cycle("udds")
    keep = udds.time_s <= SHORT_S
    cyc = Cycle.from_trace(udds.time_s[keep], udds.speed_mps[keep], "udds330",
                           description="first 330 s of the UDDS")
    out = make_virtual_test(vehicle="prius_2004", cycle=cyc, seed=3, faults="none",
                            outdir=tmp_path_factory.mktemp("gate") / "vt")
    text = out.template_path.read_text(encoding="utf-8")
    line = next(x for x in text.splitlines() if "name: fuel_rate_test" in x)
    unit = line.split("unit:")[1].strip(" }")
    bad = out.template_path.with_name("template_mg.yaml")
    bad.write_text(text.replace(line, line.replace(f"unit: {unit}", "unit: mg/s")),
                   encoding="utf-8")
    return [str(f) for f in out.files], bad, out.template_path


def test_results_withhold_the_fuel_figures_and_name_the_signal(mg_test, cli, tmp_path):
    files, bad, _ = mg_test
    code, out, err = cli("results", *files, "-t", bad, "-o", tmp_path / "r")
    assert code == 4, err
    assert "WITHHELD (fuel_rate_test)" in out and "fix:" in out
    doc = json.loads((tmp_path / "r" / "results.json").read_text())
    total = doc["test_total"]
    assert total["values"]["fuel_economy_mpg"] is None
    assert "fuel_economy_mpg" not in total["uncertainty"]
    assert total["withheld"]["signals"] == ["fuel_rate_test"]
    assert total["values"]["distance_m"] > 0           # the speed is fine: distance stays
    assert doc["headline"]["withheld"] and doc["withheld_count"] >= 1
    assert doc["forced"] is False


def test_force_states_them_under_a_banner_with_exit_0(mg_test, cli, tmp_path):
    files, bad, _ = mg_test
    code, out, _ = cli("results", *files, "-t", bad, "-o", tmp_path / "r", "--force")
    assert code == 0
    assert "STATED DESPITE QA ERRORS (--force)" in out
    doc = json.loads((tmp_path / "r" / "results.json").read_text())
    assert doc["forced"] is True
    assert doc["test_total"]["values"]["fuel_economy_mpg"] > 1000   # the impossible figure
    assert doc["test_total"]["withheld"]["forced"] is True


def test_the_correct_unit_states_everything_with_exit_0(mg_test, cli, tmp_path):
    files, _, good = mg_test
    code, out, _ = cli("results", *files, "-t", good, "-o", tmp_path / "r")
    assert code == 0 and "WITHHELD" not in out
    doc = json.loads((tmp_path / "r" / "results.json").read_text())
    assert doc["withheld_count"] == 0 and doc["test_total"]["withheld"] is None
    assert 20 < doc["headline"]["fuel_economy_mpg"] < 150


def test_qa_report_opens_with_the_withheld_banner_and_excel_says_withheld(mg_test, cli, tmp_path):
    files, bad, _ = mg_test
    out_dir = tmp_path / "qa"
    code, _, _ = cli("qa", *files, "-t", bad, "-o", out_dir, "--report")
    assert code == 4
    html = (out_dir / "report.html").read_text(encoding="utf-8")
    body = html[html.index("<body"):]
    first = body.index('id="headline"')
    assert first < body.index("<main>")               # before any section
    assert "headline-withheld" in body[first - 60:first]
    assert "fuel_rate_test" in body[first:first + 2000]
    # `vehval report` on the same outputs: exit 4 again
    code, out, _ = cli("report", out_dir, "--no-excel", "-o", tmp_path / "again.html")
    assert code == 4 and "WITHHELD" in out
    import openpyxl

    wb = openpyxl.load_workbook(out_dir / "tables.xlsx", read_only=True)
    assert wb.sheetnames[0] == "Results"
    cells = [c for row in wb["Results"].iter_rows(values_only=True) for c in row if c is not None]
    assert "withheld" in cells
    # no impossible figure: no fuel economy above 1000 mpg anywhere in the sheet (numbers
    # are stored as numbers, their U in a column of its own)
    mpg_cols: set[int] = set()
    judged = 0
    for row in wb["Results"].iter_rows(values_only=True):
        if row and all(isinstance(c, str) or c is None for c in row):   # a table's header
            mpg_cols = {k for k, c in enumerate(row) if isinstance(c, str) and "mpg" in c}
            continue
        judged += sum(1 for k in mpg_cols if k < len(row) and row[k] == "withheld")
        assert not any(isinstance(row[k], (int, float)) and row[k] > 1000
                       for k in mpg_cols if k < len(row)), row
    assert judged == 2                    # the fuel economy column: withheld, both rows
    assert not any(isinstance(c, str) and c[:1].isdigit() and " ± " in c for c in cells)


def test_qa_force_gives_the_stated_despite_banner(mg_test, cli, tmp_path):
    files, bad, _ = mg_test
    code, _, _ = cli("qa", *files, "-t", bad, "-o", tmp_path / "qa", "--report", "--force")
    assert code == 0
    html = (tmp_path / "qa" / "report.html").read_text(encoding="utf-8")
    assert "headline-forced" in html and "Stated despite QA errors" in html


# ---------------------------------------------------------------- the example, real data
def _cruze_template(tmp_path, fuel_unit: str):
    from helpers.data import CRUZE_TEMPLATE

    text = CRUZE_TEMPLATE.read_text()
    text = text.replace("  fuel_density_kg_per_m3: 851\n", "").replace(
        "  fuel_lhv_j_per_kg: 42.8e6\n", "") + "fuel: diesel\n"
    text = text.replace("{name: fuel_rate_test, unit: g/s}", f"{{name: fuel_rate_test, unit: {fuel_unit}}}")
    p = tmp_path / f"cruze_{fuel_unit.replace('/', '_')}.yaml"
    p.write_text(text)
    return p


@pytest.mark.realdata
def test_cruze_fuel_declared_mg_per_s_is_withheld_not_33857_mpg(cli, tmp_path, cruze_data):
    f = cruze_data / "61410013 Test Data.txt"
    code, out, _ = cli("results", f, "-t", _cruze_template(tmp_path, "mg/s"), "-o", tmp_path / "r")
    assert code == 4 and "WITHHELD (fuel_rate_test)" in out
    assert "33856" not in out and "33,857" not in out
    doc = json.loads((tmp_path / "r" / "results.json").read_text())
    assert doc["headline"]["name"] == "udds" and doc["headline"]["fuel_economy_mpg"] is None


def test_hot_start_that_is_the_test_itself_is_refused(tmp_path, capsys):
    """`results T --hot-start T` took the test's own bag 1 as the hot start, silently."""
    from vehval.cli import main

    f = tmp_path / "run.txt"
    f.write_text("Time[s],Dyno_Speed[mph]\n0,0\n1,1\n", encoding="utf-8")
    link = tmp_path / "same.txt"
    link.symlink_to(f)
    t = tmp_path / "t.yaml"
    t.write_text("files:\n  - source: dyno\n    channels:\n"
                 "      Dyno_Speed: {name: veh_spd_test, unit: mph}\n", encoding="utf-8")
    for hot in (f, link):
        rc = main(["results", str(f), "-t", str(t), "-o", str(tmp_path / "out"),
                   "--hot-start", str(hot)])
        err = capsys.readouterr().err
        assert rc == 2 and "is a file of the test itself" in err, err
    assert not (tmp_path / "out").exists()
