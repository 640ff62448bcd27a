"""Hostile SQL and hostile catalogs: `vehval catalog query|summary` reads the catalog only.

Was: DuckDB's external access was on, so a "read-only" query read any file (read_csv,
read_text, glob), wrote one (COPY ... TO), attached another database or tried the network
(INSTALL); a received catalog could carry a view over read_text() that `catalog summary`
ran; now() failed with a pytz traceback; a huge join hung and a huge result ran out of memory.
"""

from __future__ import annotations

import json
import time

import duckdb
import pytest

from vehval.catalog import DEFAULT_LIMIT, open_catalog
from vehval.cli import main
from vehval.errors import ConfigError

SECRET = "TOPSECRET-CATALOG-LINE"


@pytest.fixture
def db(tmp_path):
    """A catalog as `vehval batch` writes it, with one run and one ok test."""
    path = tmp_path / "out" / "catalog.duckdb"
    with open_catalog(path) as cat:
        cat.start_run("r1", {"steps": ["qa"]})
        cat.add_result("r1", {"test_id": "t1", "status": "ok", "vehicle": "v", "cycle": "udds",
                              "metrics": {"fuel_economy_mpg": 50.0, "soc_change": -0.01}})
        cat.finish_run("r1")
    return path


@pytest.fixture
def secret(tmp_path):
    f = tmp_path / "secret.csv"
    f.write_text(f"a,b\n{SECRET},1\n")
    return f


def _query(capsys, db, sql, *extra):
    rc = main(["catalog", "query", sql, "--db", str(db), *extra])
    out, err = capsys.readouterr()
    return rc, out, err


def _refused(rc, out, err):
    """One `vehval: error:` line, exit 2, no traceback, no secret."""
    assert rc == 2, (rc, out, err)
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("vehval: error:"), err
    assert "Traceback" not in err and SECRET not in out + err
    return lines[0]


@pytest.mark.parametrize("sql", [
    "SELECT * FROM read_csv('{secret}')",
    "SELECT * FROM read_text('{secret}')",
    "SELECT * FROM read_blob('{secret}')",
    "SELECT * FROM glob('{dir}/*')",
    "SELECT t.test_id, s.* FROM tests t, read_csv_auto('{secret}') s",
])
def test_no_file_is_read(capsys, db, secret, sql):
    rc, out, err = _query(capsys, db, sql.format(secret=secret, dir=secret.parent))
    line = _refused(rc, out, err)
    assert "disabled" in line or "Permission" in line
    assert secret.name not in out


def test_copy_to_writes_nothing(capsys, db, tmp_path):
    target = tmp_path / "x.sh"
    rc, out, err = _query(capsys, db, f"COPY (SELECT 'echo owned') TO '{target}'")
    assert "read-only" in _refused(rc, out, err)
    assert not target.exists()
    # even inside a SELECT nothing writes: the sandbox refuses the file, not just the parser
    with open_catalog(db, read_only=True) as cat:
        with pytest.raises(Exception, match="disabled"):
            cat.con.execute(f"COPY (SELECT 1) TO '{target}'")
    assert not target.exists()


def test_attach_and_install_are_refused(capsys, db, tmp_path):
    other = tmp_path / "other.duckdb"
    duckdb.connect(str(other)).close()
    for sql in (f"ATTACH '{other}' AS o", "INSTALL httpfs", "LOAD httpfs",
                "SET enable_external_access = true", "DROP TABLE tests",
                "SELECT 1; SELECT 2"):
        _refused(*_query(capsys, db, sql))
    # the sandbox holds below the statement check too: locked configuration, no attach
    with open_catalog(db, read_only=True) as cat:
        for sql in ("SET enable_external_access = true", f"ATTACH '{other}' AS o",
                    "INSTALL httpfs"):
            with pytest.raises(duckdb.Error):
                cat.con.execute(sql)


@pytest.mark.parametrize("hostile", [
    "CREATE VIEW evil AS SELECT * FROM read_text('{secret}')",
    "CREATE OR REPLACE VIEW latest_tests AS SELECT * FROM read_text('{secret}')",
    "CREATE MACRO evil(x) AS x + 1",
    "CREATE TABLE extra (a INTEGER)",
    "CREATE SCHEMA other",
    "CREATE SEQUENCE seq",
])
def test_received_catalog_with_a_foreign_object_is_refused(capsys, db, secret, hostile):
    con = duckdb.connect(str(db))
    con.execute(hostile.format(secret=secret))
    con.close()
    for args in (["catalog", "summary", "--db", str(db)],
                 ["catalog", "query", "SELECT count(*) FROM tests", "--db", str(db)]):
        rc = main(args)
        out, err = capsys.readouterr()
        line = _refused(rc, out, err)
        assert "nothing in it was run" in line
        assert any(name in line for name in ("evil", "latest_tests", "extra", "other", "seq"))
    # the batch does not write into it either
    with pytest.raises(ConfigError, match="not written by vehval or was altered"):
        open_catalog(db)


def test_now_prints_without_pytz(capsys, db):
    rc, out, err = _query(capsys, db, "SELECT now() AS t, current_date AS d, 1 AS one", "--json")
    assert rc == 0, err
    row = json.loads(out)[0]
    assert row["one"] == 1 and str(time.gmtime().tm_year) in row["t"]
    rc, out, err = _query(capsys, db, "SELECT now() AS t, [now()] AS l")
    assert rc == 0 and "Traceback" not in err and str(time.gmtime().tm_year) in out


def test_a_billion_rows_stop_at_the_limit(capsys, db):
    t0 = time.perf_counter()
    rc, out, err = _query(capsys, db, "SELECT * FROM range(1000000000)", "--limit", "5", "--json")
    assert rc == 0, err
    assert [r["range"] for r in json.loads(out)] == [0, 1, 2, 3, 4]
    assert "first 5 rows" in err
    rc, out, err = _query(capsys, db, "SELECT * FROM range(1000000000)", "--json")
    assert rc == 0 and len(json.loads(out)) == DEFAULT_LIMIT == 10_000
    assert f"first {DEFAULT_LIMIT} rows" in err
    assert time.perf_counter() - t0 < 60      # not a billion rows fetched (generous: shared CPU)
    rc, out, err = _query(capsys, db, "SELECT test_id FROM tests", "--json")
    assert rc == 0 and err == "" and json.loads(out) == [{"test_id": "t1"}]   # not truncated
    _refused(*_query(capsys, db, "SELECT 1", "--limit", "0"))


def test_a_slow_query_stops_at_the_timeout(capsys, db):
    t0 = time.perf_counter()
    rc, out, err = _query(capsys, db, "SELECT count(*) FROM range(1000000) a, range(1000000) b "
                          "WHERE a.range + b.range = 7", "--timeout", "1")
    elapsed = time.perf_counter() - t0
    assert "1 s timeout" in _refused(rc, out, err)
    assert elapsed < 30, elapsed              # 10^12 pairs would take hours
    _refused(*_query(capsys, db, "SELECT 1", "--timeout", "-1"))
