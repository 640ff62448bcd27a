"""A battery-electric test's headline (SAE J1634 MPGe) on the batch index and in
`catalog summary`, with its unit: it burns no fuel, so an mpg column alone showed nothing."""

from __future__ import annotations

from vehval.catalog import open_catalog


def _bev(tid: str, mpge: float) -> dict:
    return {"test_id": tid, "run_id": "r1", "status": "ok", "vehicle": "bev/nissan_leaf_2016",
            "cycle": "udds", "files": [f"/d/{tid}.txt"], "file_hashes": {f"{tid}.txt": "ab"},
            "input_hash": "h" + tid, "elapsed_s": 0.5, "error": None,
            "metrics": {"distance_m": 11_990.0, "ess_energy_j": 4.34e6},
            "results": {"headline": {"name": "udds", "kind": "composite"},
                        "electric": {"scope": "test", "mpge": mpge, "u_mpge": 1.7,
                                     "kwh_per_100km": 11.43, "u_kwh_per_100km": 0.11,
                                     "kwh_per_100mi": 18.39, "u_kwh_per_100mi": 0.17}},
            "findings": [], "findings_by_severity": {}, "outputs": ["report.html"]}


def test_bev_headline_on_the_index_and_in_the_summary(tmp_path, capsys, monkeypatch):
    from vehval.batch.index import index_data
    from vehval.cli import main
    from vehval.report.batch_index import render_index_page

    db = tmp_path / "c.duckdb"
    with open_catalog(db) as cat:
        cat.start_run("r1", {})
        cat.add_result("r1", _bev("leaf", 183.28))
        cat.finish_run("r1")
        data = index_data(cat, "r1")
    html = render_index_page(**data)
    assert "headline [MPGe]" in html and ">183.3<" in html
    # the headline figure is the whole test's (J1634 has no composites), not "udds"
    assert ">test<" in html and ">udds<" in html          # the cycle column keeps udds
    var = next(v for v in data["variability"] if v["metric"] == "headline_mpge")
    assert var["mean"] == 183.28
    assert ">MPGe<" in html
    monkeypatch.setenv("COLUMNS", "200")
    assert main(["--units", "metric", "catalog", "summary", "--db", str(db)]) == 0
    line = next(ln for ln in capsys.readouterr().out.splitlines() if "11.43" in ln).split()
    assert line[5:8] == ["headline", "kWh/100", "km"]
    assert main(["catalog", "summary", "--db", str(db)]) == 0
    line = next(ln for ln in capsys.readouterr().out.splitlines() if "183.28" in ln).split()
    assert line[5:7] == ["headline_mpge", "MPGe"]
    # a run without a battery-electric test keeps its columns
    conv = dict(data["tests"][0], headline_mpge=None, headline_mpg=40.0)
    assert "headline [MPGe]" not in render_index_page(data["run"], [conv], [], [], [])
