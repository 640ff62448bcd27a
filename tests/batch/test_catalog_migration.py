"""An older catalog opened by the batch: versions 3 and 4 (and a version 5 written before the
kWh/100 mi columns) are migrated in place in one transaction; a newer version, a missing or
corrupt schema_info, and a migration that fails half-way are refused with one line and leave
the file as it was.

The old files are built here with the CREATE statements those vehval versions ran (copied
from their sources), not with vehval's own code.
"""

from __future__ import annotations

import hashlib

import duckdb
import pytest

from vehval import catalog_schema
from vehval.batch.index import index_data, render_index
from vehval.catalog import SCHEMA_VERSION, open_catalog
from vehval.errors import ConfigError

_HEAD = [
    "CREATE TABLE IF NOT EXISTS schema_info ( version INTEGER NOT NULL, created TIMESTAMP NOT "
    "NULL, vehval_version VARCHAR)",
    "CREATE TABLE IF NOT EXISTS runs ( run_id VARCHAR PRIMARY KEY, started TIMESTAMP NOT NULL, "
    "finished TIMESTAMP, status VARCHAR NOT NULL, vehval_version VARCHAR NOT NULL, settings "
    "JSON, n_tests INTEGER, n_ok INTEGER, n_failed INTEGER, n_skipped INTEGER)",
]
_TESTS_START = (
    "CREATE TABLE IF NOT EXISTS tests ( test_id VARCHAR NOT NULL, run_id VARCHAR NOT NULL, "
    "status VARCHAR NOT NULL, error VARCHAR, error_type VARCHAR, source_run_id VARCHAR, recorded "
    "TIMESTAMP, vehicle VARCHAR, cycle VARCHAR, files VARCHAR[], file_hashes JSON, input_hash "
    "VARCHAR, elapsed_s DOUBLE, duration_s DOUBLE, distance_m DOUBLE, fuel_mass_kg DOUBLE, "
    "fuel_economy_mpg DOUBLE, fuel_consumption_l_per_100km DOUBLE, soc_initial DOUBLE, "
    "soc_final DOUBLE, soc_change DOUBLE, fuel_energy_j DOUBLE, ess_energy_j DOUBLE, "
    "eng_energy_j DOUBLE, tractive_energy_j DOUBLE, fuel VARCHAR, cell_temp_c DOUBLE, "
    "start_condition VARCHAR, ac VARCHAR, headline_name VARCHAR, headline_rule VARCHAR, ")
_TESTS_MID = (
    "withheld_reason VARCHAR, withheld_count INTEGER, n_findings INTEGER, n_findings_by_severity "
    "JSON, qa_summary JSON, validation JSON, validation_errors JSON, outputs VARCHAR[], ")
_EN = ("fuel_en DOUBLE, fuel_error_pct DOUBLE, fuel_u_model_kg DOUBLE, fuel_u_meas_kg DOUBLE, "
       "fuel_s_r DOUBLE, fuel_consistent BOOLEAN, fuel_uninformative BOOLEAN, in_sample BOOLEAN, ")
_FINDINGS = (
    "CREATE TABLE IF NOT EXISTS findings ( test_id VARCHAR NOT NULL, run_id VARCHAR NOT NULL, "
    "signal VARCHAR, kind VARCHAR, severity VARCHAR, start_s DOUBLE, end_s DOUBLE, message "
    "VARCHAR)")
_PHASES = (
    "CREATE TABLE IF NOT EXISTS phase_results ( test_id VARCHAR NOT NULL, run_id VARCHAR NOT "
    "NULL, scope VARCHAR NOT NULL, kind VARCHAR NOT NULL, part VARCHAR, run INTEGER, duration_s "
    "DOUBLE, distance_m DOUBLE, fuel_mass_kg DOUBLE, fuel_economy_mpg DOUBLE, fuel_economy_u_mpg "
    "DOUBLE, fuel_consumption_l_per_100km DOUBLE, co2_g_per_km DOUBLE, ess_energy_net_j DOUBLE, "
    "iwr_pct DOUBLE, rmsse_mps DOUBLE, withheld_reason VARCHAR, PRIMARY KEY (test_id, run_id, {key}))")
_SET_VERDICTS = (
    "CREATE TABLE IF NOT EXISTS set_verdicts ( run_id VARCHAR NOT NULL, vehicle VARCHAR NOT NULL, "
    "figure VARCHAR NOT NULL, n_validated INTEGER, n INTEGER, mean_error_pct DOUBLE, "
    "mean_error_lo_pct DOUBLE, mean_error_hi_pct DOUBLE, bias_limit_pct DOUBLE, biased BOOLEAN, "
    "n_consistent INTEGER, coverage DOUBLE, coverage_lo DOUBLE, coverage_hi DOUBLE, understated "
    "BOOLEAN, n_uninformative INTEGER, verdict VARCHAR, note VARCHAR, detail JSON, PRIMARY KEY "
    "(run_id, vehicle, figure))")
_VIEW = ("CREATE OR REPLACE VIEW latest_tests AS SELECT t.* FROM tests t JOIN runs r USING "
         "(run_id) QUALIFY row_number() OVER (PARTITION BY t.test_id ORDER BY r.started DESC, "
         "t.recorded DESC) = 1")
_MPG = "headline_mpg DOUBLE, headline_u_mpg DOUBLE, headline_l_per_100km DOUBLE, "

#: The CREATE statements of each old catalog (git history of vehval.catalog).
OLD_DDL = {
    # schema version 3 as first written: phase_results keyed by (test_id, run_id, scope)
    "3-scope": (3, [*_HEAD, _TESTS_START + _MPG + _TESTS_MID + "PRIMARY KEY (test_id, run_id))",
                    _FINDINGS, _PHASES.format(key="scope"), _VIEW]),
    "3": (3, [*_HEAD, _TESTS_START + _MPG + _TESTS_MID + "PRIMARY KEY (test_id, run_id))",
              _FINDINGS, _PHASES.format(key="kind, scope"), _VIEW]),
    "4": (4, [*_HEAD, _TESTS_START + _MPG + _TESTS_MID + _EN + "PRIMARY KEY (test_id, run_id))",
              _FINDINGS, _PHASES.format(key="kind, scope"), _SET_VERDICTS, _VIEW]),
    # schema version 5 before the kWh/100 mi columns
    "5-km": (5, [*_HEAD, _TESTS_START + "headline_j1634_scope VARCHAR, " + _MPG
                 + "headline_mpge DOUBLE, headline_u_mpge DOUBLE, headline_kwh_per_100km DOUBLE, "
                 "headline_u_kwh_per_100km DOUBLE, headline_battery_share DOUBLE, " + _TESTS_MID
                 + _EN + "PRIMARY KEY (test_id, run_id))",
                 _FINDINGS, _PHASES.format(key="kind, scope"), _SET_VERDICTS, _VIEW]),
}
#: Columns the old rows are checked on (present in every old version).
OLD_COLUMNS = ("test_id", "run_id", "status", "error", "vehicle", "cycle", "files",
               "fuel_economy_mpg", "fuel_mass_kg", "soc_change", "headline_name", "headline_mpg",
               "headline_u_mpg", "withheld_reason", "n_findings")


def _sha(path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _old_catalog(path, shape: str, *, version: int | None = None, schema_info: bool = True):
    """A catalog file as the vehval of ``shape`` wrote it: one run, an ok test with a headline,
    a failed test, a finding and a phase row."""
    ver, ddl = OLD_DDL[shape]
    con = duckdb.connect(str(path))
    for statement in ddl if schema_info else ddl[1:]:
        con.execute(statement)
    if schema_info:
        con.execute("INSERT INTO schema_info VALUES (?, TIMESTAMP '2026-11-20 10:00:00', '0.1.0')",
                    [ver if version is None else version])
    con.execute("INSERT INTO runs VALUES ('r-old', TIMESTAMP '2026-11-20 10:00:00', "
                "TIMESTAMP '2026-11-20 10:05:00', 'done', '0.1.0', '{}', 2, 1, 1, 0)")
    con.execute("INSERT INTO tests (test_id, run_id, status, error, source_run_id, recorded, vehicle, "
                "cycle, files, fuel_economy_mpg, fuel_mass_kg, soc_change, headline_name, "
                "headline_mpg, headline_u_mpg, n_findings, n_findings_by_severity, outputs) VALUES "
                "('a', 'r-old', 'ok', NULL, 'r-old', TIMESTAMP '2026-11-20 10:01:00', 'prius', "
                "'udds', ['/d/a.txt'], 48.5, 0.61, -0.02, 'udds', 48.1, 0.9, 1, "
                "'{\"warning\": 1}', []), "
                "('b', 'r-old', 'failed', 'bad file', 'r-old', TIMESTAMP '2026-11-20 10:02:00', NULL, "
                "NULL, ['/d/b.txt'], NULL, NULL, NULL, NULL, NULL, NULL, 0, '{}', [])")
    if shape == "5-km":
        con.execute("UPDATE tests SET headline_kwh_per_100km = 17.5, headline_u_kwh_per_100km = 0.2, "
                    "headline_mpge = 120.0 WHERE test_id = 'a'")
    con.execute("INSERT INTO findings VALUES ('a', 'r-old', 'veh_spd_test', 'spike', 'warning', "
                "1.0, 2.0, 'spike')")
    con.execute("INSERT INTO phase_results (test_id, run_id, scope, kind, fuel_economy_mpg) "
                "VALUES ('a', 'r-old', 'udds', 'phase', 48.5)")
    con.close()
    return path


def _old_rows(path):
    con = duckdb.connect(str(path), read_only=True)
    try:
        return con.execute(f"SELECT {', '.join(OLD_COLUMNS)} FROM tests ORDER BY test_id").fetchall()
    finally:
        con.close()


def _new_result(tid: str) -> dict:
    return {"test_id": tid, "run_id": "r-new", "status": "ok", "vehicle": "prius", "cycle": "udds",
            "files": [f"/d/{tid}.txt"], "metrics": {"fuel_economy_mpg": 50.0},
            "results": {"headline": {"name": "udds", "fuel_economy_mpg": 49.0},
                        "battery_share": 0.01},
            "findings": [], "findings_by_severity": {}}


@pytest.mark.parametrize("shape", ["3-scope", "3", "4"])
def test_an_older_catalog_is_migrated_and_reads_back(tmp_path, shape):
    db = _old_catalog(tmp_path / "catalog.duckdb", shape)
    before = _old_rows(db)
    with open_catalog(db) as cat:       # the batch's open: migrates
        cat.start_run("r-new", {"steps": ["qa"]})
        cat.add_result("r-new", _new_result("c"))
        cat.finish_run("r-new")
    with open_catalog(db, read_only=True) as cat:
        assert cat.query("SELECT version FROM schema_info")[1] == [(SCHEMA_VERSION,)]
        _, rows = cat.query(f"SELECT {', '.join(OLD_COLUMNS)} FROM tests WHERE run_id = 'r-old' "
                            "ORDER BY test_id")
        assert rows == before
        new_cols = catalog_schema.ADDED_COLUMNS[5] + (catalog_schema.ADDED_COLUMNS[4]
                                                       if shape.startswith("3") else ())
        _, nulls = cat.query(f"SELECT {', '.join(new_cols)} FROM tests WHERE run_id = 'r-old'")
        assert all(v is None for row in nulls for v in row)
        _, latest = cat.query("SELECT test_id, run_id, headline_battery_share FROM latest_tests "
                              "ORDER BY 1")
        assert latest == [("a", "r-old", None), ("b", "r-old", None), ("c", "r-new", 0.01)]
        assert cat.query("SELECT count(*) FROM phase_results")[1] == [(1,)]
        assert cat.query("SELECT count(*) FROM set_verdicts")[1] == [(0,)]
        old = index_data(cat, "r-old")
        assert "48.1" in render_index(cat, "r-old")
        assert [r["test_id"] for r in old["tests"]] == ["a", "b"]
        summary = {(r["metric"]): r for r in cat.summary(("headline_mpg", "headline_mpge"))}
        assert summary["headline_mpg"]["n"] == 2 and "headline_mpge" not in summary


def test_the_workbench_shows_a_migrated_rows_new_columns_as_absent(tmp_path):
    from vehval.serve.catalog_view import rows

    db = _old_catalog(tmp_path / "catalog.duckdb", "4")
    open_catalog(db).close()
    page = rows(db, {})
    raw = {r["test_id"]: r for r in page["rows"]}
    assert raw["a"]["headline_mpge"] is None and raw["a"]["headline_battery_share"] is None
    view = {r["test_id"]: r for r in page["view"]["rows"]}
    assert view["a"]["headline_battery_share"] == ""          # absent, not 0.00
    assert "48.1" in view["a"]["headline"] and "MPGe" not in view["a"]["headline"]


def test_an_early_version_5_gets_kwh_per_100mi_from_kwh_per_100km(tmp_path):
    db = _old_catalog(tmp_path / "catalog.duckdb", "5-km")
    with open_catalog(db) as cat:
        _, got = cat.query("SELECT test_id, headline_kwh_per_100mi, headline_u_kwh_per_100mi "
                           "FROM tests ORDER BY 1")
    assert got[0] == ("a", pytest.approx(17.5 * 1.609344), pytest.approx(0.2 * 1.609344))
    assert got[1] == ("b", None, None)


def test_read_only_open_of_an_older_catalog_says_how_to_migrate(tmp_path):
    db = _old_catalog(tmp_path / "catalog.duckdb", "4")
    sha = _sha(db)
    with pytest.raises(ConfigError, match="migrate it in place") as err:
        open_catalog(db, read_only=True)
    assert "\n" not in str(err.value) and str(db) in str(err.value)
    assert _sha(db) == sha


def test_a_failed_migration_leaves_the_file_unchanged(tmp_path, monkeypatch):
    db = _old_catalog(tmp_path / "catalog.duckdb", "3-scope")   # tests and phase_results rebuilt
    sha = _sha(db)
    real = catalog_schema._rebuild_table

    def fail_on_phases(con, name, statement, old_columns):
        if name == "phase_results":   # after tests was rebuilt
            con.execute("ALTER TABLE no_such_table ADD COLUMN x DOUBLE")
        real(con, name, statement, old_columns)

    monkeypatch.setattr(catalog_schema, "_rebuild_table", fail_on_phases)
    with pytest.raises(ConfigError, match="the file is unchanged") as err:
        open_catalog(db)
    assert "\n" not in str(err.value) and str(db) in str(err.value)
    assert _sha(db) == sha
    assert not (tmp_path / "catalog.duckdb.wal").exists()
    monkeypatch.setattr(catalog_schema, "_rebuild_table", real)
    with open_catalog(db) as cat:
        assert cat.query("SELECT version FROM schema_info")[1] == [(SCHEMA_VERSION,)]


@pytest.mark.parametrize("case, message", [
    ("newer", "schema version 6, newer than the version 5 this vehval reads: use the vehval"),
    ("v2", "schema version 2, this vehval reads version 5 and migrates versions 3, 4 only"),
    ("no schema_info", "not a vehval catalog \\(no schema_info table\\): pass a catalog"),
    ("two rows", "corrupt schema_info \\(2 rows"),
    ("altered 4", "holds table 'tests' differs"),
])
def test_catalogs_it_cannot_migrate_are_refused_with_one_line(tmp_path, case, message):
    db = tmp_path / "catalog.duckdb"
    if case == "newer":
        _old_catalog(db, "4", version=6)
    elif case == "v2":
        _old_catalog(db, "3", version=2)
    elif case == "no schema_info":
        _old_catalog(db, "4", schema_info=False)
    else:
        _old_catalog(db, "4")
        con = duckdb.connect(str(db))
        con.execute("INSERT INTO schema_info VALUES (4, current_timestamp, 'x')"
                    if case == "two rows" else "ALTER TABLE tests ADD COLUMN extra DOUBLE")
        con.close()
    sha = _sha(db)
    for read_only in (False, True):
        with pytest.raises(ConfigError, match=message) as err:
            open_catalog(db, read_only=read_only)
        assert "\n" not in str(err.value) and str(db) in str(err.value)
    assert _sha(db) == sha


def test_the_batch_command_refuses_a_newer_catalog_with_exit_2(tmp_path, template_path, capsys):
    from vehval.cli import main

    from .helpers import write_d3

    inp, out = tmp_path / "in", tmp_path / "out"
    write_d3(inp / "t0" / "run0.txt", seed=0)
    out.mkdir()
    db = _old_catalog(out / "catalog.duckdb", "4", version=6)
    sha = _sha(db)
    rc = main(["batch", str(inp), "-t", str(template_path), "-o", str(out), "--steps", "",
               "--no-report", "--workers", "0", "-q"])
    err = capsys.readouterr().err
    assert rc == 2 and "Traceback" not in err and "newer than the version 5" in err
    assert [ln for ln in err.splitlines() if ln.strip()] == [
        ln for ln in err.splitlines() if "schema version 6" in ln]
    assert sorted(p.name for p in out.iterdir()) == ["catalog.duckdb"] and _sha(db) == sha


def test_the_batch_migrates_a_version_4_folder_and_adds_its_rows(tmp_path, template_path):
    from vehval.batch import run_batch

    from .helpers import write_d3

    inp, out = tmp_path / "in", tmp_path / "out"
    write_d3(inp / "t0" / "run0.txt", seed=0)
    out.mkdir()
    _old_catalog(out / "catalog.duckdb", "4")
    s = run_batch(inp, template_path, out, steps=["qa"], workers=0, report=False, progress=False)
    with open_catalog(out / "catalog.duckdb", read_only=True) as cat:
        _, got = cat.query("SELECT run_id, test_id, status FROM tests ORDER BY run_id, test_id")
    # the old tests' files (/d/a.txt, /d/b.txt) are gone: the new run records them removed
    assert sorted(got) == sorted([("r-old", "a", "ok"), ("r-old", "b", "failed"),
                                  (s.run_id, "a", "removed"), (s.run_id, "b", "removed"),
                                  (s.run_id, "t0", "ok")])
