"""The DuckDB catalog: schema, inserts, the latest view and the variability summary."""

from __future__ import annotations

import math
import statistics

import pytest

from vehval.catalog import SCHEMA_VERSION, open_catalog
from vehval.errors import ConfigError, InputFileError, VehvalError


def _res(tid, run, mpg, soc, status="ok", cycle="udds", findings=()):
    return {"test_id": tid, "run_id": run, "status": status, "vehicle": "prius_2004",
            "cycle": cycle, "files": [f"/d/{tid}.txt"], "file_hashes": {f"{tid}.txt": "ab"},
            "input_hash": "h" + tid, "elapsed_s": 0.5, "error": None if status == "ok" else "bad",
            "metrics": {"fuel_economy_mpg": mpg, "soc_change": soc, "distance_m": float("nan")},
            "findings": list(findings), "findings_by_severity": {"warning": len(findings)}}


def test_schema_and_roundtrip(tmp_path):
    db = tmp_path / "c.duckdb"
    f = {"signal": "veh_spd_test", "kind": "spike", "severity": "warning", "start_s": 1.0,
         "end_s": 2.0, "message": "spike"}
    with open_catalog(db) as cat:
        cat.start_run("r1", {"steps": ["qa"]})
        cat.add_result("r1", _res("a", "r1", 50.0, -0.01, findings=[f, f]))
        cat.add_result("r1", _res("b", "r1", None, None, status="failed"))
        assert cat.finish_run("r1") == {"ok": 1, "failed": 1, "skipped": 0}
    with open_catalog(db, read_only=True) as cat:
        assert cat.query("SELECT version FROM schema_info")[1] == [(SCHEMA_VERSION,)]
        cols, rows = cat.query("SELECT test_id, status, fuel_economy_mpg, distance_m, files, "
                               "n_findings, n_findings_by_severity->>'warning' FROM tests ORDER BY 1")
        assert rows[0] == ("a", "ok", 50.0, None, ["/d/a.txt"], 2, "2")  # NaN stored as NULL
        assert rows[1][1] == "failed"
        assert cat.query("SELECT count(*) FROM findings WHERE test_id = 'a'")[1] == [(2,)]
        with pytest.raises(VehvalError, match="catalog query failed"):
            cat.query("SELECT nope FROM tests")


def test_summary_uses_latest_row_per_test(tmp_path):
    with open_catalog(tmp_path / "c.duckdb") as cat:
        cat.start_run("r1", {})
        for tid, mpg in (("a", 40.0), ("b", 44.0), ("c", 48.0)):
            cat.add_result("r1", _res(tid, "r1", mpg, -0.02))
        cat.add_result("r1", _res("h", "r1", 30.0, 0.0, cycle="hwfet"))
        cat.finish_run("r1")
        cat.start_run("r2", {})
        cat.add_result("r2", _res("a", "r2", 60.0, -0.02))          # a recomputed: 60 replaces 40
        cat.add_result("r2", _res("b", "r1", 44.0, -0.02), status="skipped")
        cat.add_result("r2", _res("c", "r2", None, None, status="failed"))  # now failing: left out
        cat.finish_run("r2")
        rows = {(r["cycle"], r["metric"]): r for r in cat.summary()}
    s = rows[("udds", "fuel_economy_mpg")]
    assert s["n"] == 2
    assert s["mean"] == pytest.approx(52.0, rel=1e-12)
    assert s["std"] == pytest.approx(statistics.stdev([60.0, 44.0]), rel=1e-12)
    assert s["cv"] == pytest.approx(statistics.stdev([60.0, 44.0]) / 52.0, rel=1e-12)
    h = rows[("hwfet", "soc_change")]
    assert h["n"] == 1 and h["std"] is None and h["cv"] is None
    assert not math.isnan(rows[("udds", "soc_change")]["mean"])


def test_read_only_errors(tmp_path):
    with pytest.raises(InputFileError, match="does not exist"):
        open_catalog(tmp_path / "none.duckdb", read_only=True)
    import duckdb

    con = duckdb.connect(str(tmp_path / "other.duckdb"))
    con.execute("CREATE TABLE x (a INTEGER)")
    con.close()
    with pytest.raises(ConfigError, match="not a vehval catalog"):
        open_catalog(tmp_path / "other.duckdb", read_only=True)


def test_metrics_skip_a_quantity_qa_dropped():
    """A fuel channel QA dropped as not measured gives no fuel metric, not 0 kg."""
    import numpy as np

    from vehval.batch.metrics import test_metrics
    from vehval.test import Signal, Test

    t = np.arange(0.0, 100.0, 0.1)
    test = Test([Signal.standard("veh_spd_test", t, 10.0 + 0 * t, source="dyno"),
                 Signal.standard("fuel_rate_test", t, 0 * t, source="dyno")])
    without_qa = test_metrics(test, None)
    assert without_qa["fuel_mass_kg"] == 0.0
    with_qa = test_metrics(test, {"veh_spd": "veh_spd_test"})   # fuel_rate_test dropped
    assert with_qa["fuel_mass_kg"] is None and with_qa["fuel_economy_mpg"] is None
    assert with_qa["distance_m"] == np.float64(999.0) or abs(with_qa["distance_m"] - 999.0) < 1e-6


def test_a_phase_and_a_composite_may_share_a_name(tmp_path):
    # a one-run HWFET: the phase is named "hwfet" and so is its regulatory composite
    res = _res("h", "r1", 55.0, 0.0, cycle="hwfet")
    res["results"] = {"rows": [
        {"scope": "hwfet", "kind": "phase", "fuel_economy_mpg": 55.0},
        {"scope": "test_total", "kind": "test_total", "fuel_economy_mpg": 55.0},
        {"scope": "hwfet", "kind": "composite", "fuel_economy_mpg": 55.0}]}
    with open_catalog(tmp_path / "c.duckdb") as cat:
        cat.start_run("r1", {})
        cat.add_result("r1", res)
        cat.finish_run("r1")
    with open_catalog(tmp_path / "c.duckdb", read_only=True) as cat:
        _, rows = cat.query("SELECT kind, scope FROM phase_results ORDER BY kind")
    assert rows == [("composite", "hwfet"), ("phase", "hwfet"), ("test_total", "test_total")]


def test_summary_and_batch_index_speak_display_units(tmp_path, capsys, monkeypatch):
    """The catalog is SI; `catalog summary` and the batch index show MJ, lb or kg, % (the
    fuel energy was printed 5.3859e+07, the SOC change as a fraction)."""
    from vehval.cli import main
    from vehval.report.batch_index import render_index_page

    db = tmp_path / "c.duckdb"
    with open_catalog(db) as cat:
        cat.start_run("r1", {})
        for tid, mj in (("a", 53.0), ("b", 55.0)):
            r = _res(tid, "r1", 50.0, -0.02)
            r["metrics"].update(fuel_energy_j=mj * 1e6, fuel_mass_kg=1.25, distance_m=11_990.0)
            cat.add_result("r1", r)
        cat.finish_run("r1")
        var = cat.summary()
    monkeypatch.setenv("COLUMNS", "200")
    assert main(["catalog", "summary", "--db", str(db)]) == 0
    out = capsys.readouterr().out
    assert "e+07" not in out
    energy = next(ln for ln in out.splitlines() if "fuel_energy" in ln).split()
    assert energy[energy.index("MJ") + 2:energy.index("MJ") + 4] == ["54", "1.414"]
    mass = next(ln for ln in out.splitlines() if "fuel_mass" in ln).split()
    assert "lb" in mass and "2.7558" in mass                 # 1.25 kg
    soc = next(ln for ln in out.splitlines() if "soc_change" in ln).split()
    assert "%" in soc and "-2" in soc
    tests = [{"test_id": "a", "status": "ok", "error": None, "vehicle": "v", "cycle": "udds",
              "outputs": [], "n_findings_by_severity": None, "headline_mpg": 50.0,
              "distance_m": 11_990.0, "fuel_mass_kg": 1.25, "fuel_economy_mpg": 50.0,
              "soc_change": None, "ess_energy_j": None, "eng_energy_j": None}]
    run = {"run_id": "r1", "started": "now", "vehval_version": "0", "n_ok": 1, "n_failed": 0,
           "n_skipped": 0}
    for system, dist, mass, shown in (("us", "distance [mi]", "fuel [lb]", ">7.45<"),
                                      ("metric", "distance [km]", "fuel [kg]", ">11.99<")):
        monkeypatch.setenv("VEHVAL_UNITS", system)
        html = render_index_page(run, tests, var, [], [])
        assert dist in html and mass in html and shown in html
        assert "e+07" not in html and ">MJ<" in html and ">54<" in html


def test_summary_in_metric_units_summarises_each_tests_l_per_100km(tmp_path, capsys,
                                                                   monkeypatch):
    """`--units metric catalog summary` reads L/100 km: the mean of the tests' own L/100 km
    (not the mean mpg converted); the JSON keeps the documented mpg metrics."""
    import json

    from vehval.cli import main

    db = tmp_path / "c.duckdb"
    with open_catalog(db) as cat:
        cat.start_run("r1", {})
        for tid, mpg in (("a", 40.0), ("b", 60.0)):
            r = _res(tid, "r1", mpg, -0.02)
            r["metrics"]["fuel_consumption_l_per_100km"] = 235.2146 / mpg
            cat.add_result("r1", r)
        cat.finish_run("r1")
    monkeypatch.setenv("COLUMNS", "200")
    assert main(["--units", "metric", "catalog", "summary", "--db", str(db)]) == 0
    out = capsys.readouterr().out
    line = next(ln for ln in out.splitlines() if "fuel_consumption" in ln).split()
    mean = (235.2146 / 40 + 235.2146 / 60) / 2  # 4.9003, not 235.2146 / 50 = 4.7043
    at = line.index("fuel_consumption")
    assert line[at + 1:at + 3] == ["L/100", "km"] and f"{mean:.5g}" in line
    assert "fuel_economy_mpg" not in out
    assert main(["--units", "metric", "catalog", "summary", "--db", str(db), "--json"]) == 0
    metrics = {r["metric"] for r in json.loads(capsys.readouterr().out)}
    assert "fuel_economy_mpg" in metrics and "fuel_consumption_l_per_100km" not in metrics


def test_catalog_db_option_takes_a_batch_folder_and_names_an_empty_file(tmp_path):
    out = tmp_path / "batch_out"
    with open_catalog(out / "catalog.duckdb") as cat:
        cat.start_run("r1", {})
        cat.add_result("r1", _res("a", "r1", 50.0, -0.01))
        cat.finish_run("r1")
    with open_catalog(out, read_only=True) as cat:  # the batch's output folder
        assert cat.path == out / "catalog.duckdb" and len(cat.summary()) > 0
    (tmp_path / "plain").mkdir()
    with pytest.raises(InputFileError, match="plain: is a directory without catalog.duckdb"):
        open_catalog(tmp_path / "plain", read_only=True)
    (tmp_path / "empty.csv").write_bytes(b"")
    with pytest.raises(InputFileError, match="empty.csv: is an empty file, not a DuckDB"):
        open_catalog(tmp_path / "empty.csv", read_only=True)
