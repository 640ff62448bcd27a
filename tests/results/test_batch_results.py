"""Batch: results.json per test, the catalog's phase_results table and the index grouping."""

import json

import numpy as np
import pytest
import yaml

from vehval.batch import run_batch
from vehval.catalog import SCHEMA_VERSION, open_catalog, results_variability

from .helpers import true_signals

TEMPLATE = {"template_version": 1, "files": [{"match": "*.csv", "source": "dyno", "channels": {
    "Speed": {"name": "veh_spd_test", "unit": "mph"},
    "Fuel": {"name": "fuel_rate_test", "unit": "g/s"},
    "Phase": {"name": "test_phase_test"},
    "Cell": {"name": "amb_temp_test", "unit": "degC"}}}]}


def _write(root, n=2, fuel="diesel"):
    t, s = true_signals()
    for i in range(n):
        d = root / f"u{i}"
        d.mkdir(parents=True)
        cols = np.column_stack([t, s["veh_spd"] / 0.44704, s["fuel_rate"] * 1e3 * (1 + 0.01 * i),
                                s["test_phase"], np.full(t.size, 24.0)])
        np.savetxt(d / "run.csv", cols, delimiter=",", fmt="%.6f",
                   header="Time[s],Speed[mph],Fuel[g/s],Phase,Cell[degC]", comments="")
    tpl = dict(TEMPLATE, **({"fuel": fuel} if fuel else {}))
    p = root / "t.yaml"
    p.write_text(yaml.safe_dump(tpl))
    return p


def test_batch_writes_phase_results_and_groups_them(tmp_path):
    inp, out = tmp_path / "in", tmp_path / "out"
    tpl = _write(inp)
    s = run_batch(inp, tpl, out, steps=["qa"], workers=0, report=False, progress=False)
    assert s.n_ok == 2
    doc = json.loads((out / "tests" / "u0" / "results.json").read_text())
    assert [p["name"] for p in doc["phases"]] == ["bag1", "bag2"]
    with open_catalog(out / "catalog.duckdb", read_only=True) as cat:
        assert cat.query("SELECT version FROM schema_info")[1] == [(SCHEMA_VERSION,)] == [(5,)]
        _, rows = cat.query("SELECT test_id, scope, kind, fuel_economy_mpg, fuel_economy_u_mpg "
                            "FROM phase_results WHERE run_id = ? ORDER BY 1, 3, 2", [s.run_id])
        scopes = {(r[0], r[1], r[2]) for r in rows}
        assert ("u0", "bag1", "phase") in scopes and ("u0", "udds", "composite") in scopes
        assert all(r[3] > 0 and r[4] > 0 for r in rows)
        _, trow = cat.query("SELECT fuel, cell_temp_c, fuel_economy_mpg FROM tests "
                            "WHERE test_id = 'u0' AND run_id = ?", [s.run_id])
        assert trow[0][0] == "diesel" and trow[0][1] == pytest.approx(24.0)
        whole = [r for r in rows if r[0] == "u0" and r[2] == "test"][0]
        assert trow[0][2] == pytest.approx(whole[3], rel=1e-9)   # same figure both places
        var = results_variability(cat)
    udds = [v for v in var if v["scope"] == "udds"][0]
    assert udds["n"] == 2 and udds["temperature_band"] == "standard (10-30 degC)"
    assert udds["cv"] == pytest.approx(0.01 / np.sqrt(2) / 1.005, rel=0.05)  # 1 % apart
    html = (out / "index.html").read_text()
    assert "Fuel economy by cycle and test conditions" in html and "fe_phase" in html


def test_batch_without_fuel_gives_no_fuel_economy(tmp_path):
    inp, out = tmp_path / "in", tmp_path / "out"
    tpl = _write(inp, n=1, fuel=None)
    s = run_batch(inp, tpl, out, steps=["qa"], workers=0, report=False, progress=False)
    with open_catalog(out / "catalog.duckdb", read_only=True) as cat:
        _, rows = cat.query("SELECT fuel_economy_mpg, fuel_mass_kg FROM tests WHERE run_id = ?",
                            [s.run_id])
    assert rows[0][0] is None and rows[0][1] > 0         # never a silent gasoline density


def test_batch_headline_withheld_reason_conditions_and_exit_code(tmp_path, cli):
    """A batch of three UDDS tests: one at 24 degC, one at 35 degC, one whose fuel channel
    reads zero throughout (QA error): the catalog's headline equals results.json's, the
    zero-fuel test's headline is withheld with its reason, the two cells are separate
    groups of `catalog summary`, no SOC chart for a car without a battery, and exit 4."""
    inp, out = tmp_path / "in", tmp_path / "out"
    tpl = _write(inp, n=3)
    for i, (cell, zero_fuel) in enumerate(((24.0, False), (35.0, False), (24.0, True))):
        f = inp / f"u{i}" / "run.csv"
        data = np.loadtxt(f, delimiter=",", skiprows=1)
        data[:, 4] = cell
        if zero_fuel:
            data[:, 2] = 0.0
        np.savetxt(f, data, delimiter=",", fmt="%.6f",
                   header="Time[s],Speed[mph],Fuel[g/s],Phase,Cell[degC]", comments="")
    code, _, err = cli("batch", inp, "-t", tpl, "-o", out, "--workers", "0", "-q")
    assert code == 4, err
    assert "withheld u2: headline udds (fuel_rate_test)" in err
    doc = json.loads((out / "tests" / "u0" / "results.json").read_text())
    assert doc["headline"]["name"] == "udds" and doc["withheld_count"] == 0
    with open_catalog(out / "catalog.duckdb", read_only=True) as cat:
        _, rows = cat.query("SELECT test_id, headline_name, headline_mpg, withheld_reason, ac "
                            "FROM latest_tests ORDER BY test_id")
        summary = cat.summary()
    by_id = {r[0]: r for r in rows}
    assert by_id["u0"][1] == "udds"
    assert by_id["u0"][2] == pytest.approx(doc["headline"]["fuel_economy_mpg"], rel=1e-12)
    assert by_id["u0"][3] is None and by_id["u0"][4] == "off" and by_id["u1"][4] == "on"
    assert by_id["u2"][2] is None and "fuel_rate_test" in by_id["u2"][3]
    groups = {(s["cycle"], s["start"], s["temperature_band"], s["ac"])
              for s in summary if s["metric"] == "headline_mpg"}
    assert len(groups) == 2                          # 24 degC / A/C off and 35 degC / A/C on
    head = [s for s in summary if s["metric"] == "headline_mpg"]
    assert sum(s["n"] for s in head) == 2            # the withheld headline is not counted
    html = (out / "index.html").read_text()
    assert "fe_soc" not in html and "withheld" in html
    code, text, _ = cli("catalog", "summary", "--db", out / "catalog.duckdb")
    assert code == 0 and "hot (> 30 degC)" in text and "headline_mpg" in text


def test_batch_an_idle_record_has_no_headline_in_the_catalog(tmp_path, cli):
    """A 9.8 s idle record beside a UDDS: its headline is none, the reason in the catalog's
    withheld_reason, headline_mpg NULL; the run is ok (no QA error: exit 0)."""
    inp, out = tmp_path / "in", tmp_path / "out"
    tpl = _write(inp, n=1)
    t = np.arange(0.0, 9.8, 0.1)
    d = inp / "idle"
    d.mkdir()
    rng = np.random.default_rng(0)        # a standing car: the speed sensor's noise only
    cols = np.column_stack([t, np.abs(rng.normal(0.0, 0.002, t.size)),
                            0.12 + 0.02 * np.sin(t), np.zeros(t.size), np.full(t.size, 24.0)])
    np.savetxt(d / "run.csv", cols, delimiter=",", fmt="%.6f",
               header="Time[s],Speed[mph],Fuel[g/s],Phase,Cell[degC]", comments="")
    code, _, err = cli("batch", inp, "-t", tpl, "-o", out, "--workers", "0", "-q")
    assert code == 0, err
    assert "no headline idle: distance 0.0 m: no fuel-economy headline" in err
    with open_catalog(out / "catalog.duckdb", read_only=True) as cat:
        _, rows = cat.query("SELECT test_id, status, headline_mpg, headline_u_mpg, "
                            "withheld_reason, fuel_economy_mpg FROM latest_tests ORDER BY 1")
    by_id = {r[0]: r for r in rows}
    assert by_id["idle"][1] == "ok" and by_id["idle"][2] is None and by_id["idle"][3] is None
    assert by_id["idle"][4].startswith("distance 0.0 m: no fuel-economy headline")
    assert by_id["u0"][2] is not None and by_id["u0"][4] is None
    html = (out / "index.html").read_text()   # no headline is not a QA error's "withheld"
    row = html[html.index(">idle<"):].split("</tr>")[0]
    assert "no headline" in row and "withheld" not in row
