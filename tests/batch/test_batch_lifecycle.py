"""A catalog's life in a test lab: a run that cannot write its catalog (disk full) stops with
one clear line and leaves the earlier runs as they were."""

from __future__ import annotations

import duckdb
import pytest

import vehval.batch.runner as runner_mod
from vehval.catalog import open_catalog
from vehval.cli import main
from vehval.errors import VehvalError

from .helpers import write_d3


class _DiskFullAtCommit:
    """A DuckDB connection whose COMMITs fail as on a full disk from the ``ok``-th on: DuckDB
    ends the transaction itself, so a ROLLBACK after it has no transaction to roll back."""

    def __init__(self, con, ok: int = 0):
        self._con, self._ok = con, ok

    def execute(self, sql, *args):
        if sql == "COMMIT":
            if self._ok <= 0:
                self._con.execute("ROLLBACK")
                raise duckdb.IOException('IO Error: Could not write file "catalog.duckdb.wal": '
                                         "No space left on device")
            self._ok -= 1
        return self._con.execute(sql, *args)

    def __getattr__(self, name):
        return getattr(self._con, name)


def _res(tid: str, run: str) -> dict:
    return {"test_id": tid, "run_id": run, "status": "ok", "files": [f"/d/{tid}.txt"],
            "metrics": {"fuel_economy_mpg": 50.0}, "findings": []}


def test_a_catalog_write_that_fails_says_why_and_keeps_earlier_rows(tmp_path):
    db = tmp_path / "catalog.duckdb"
    with open_catalog(db) as cat:
        cat.start_run("r1", {})
        cat.add_result("r1", _res("a", "r1"))
        cat.finish_run("r1")
        cat.start_run("r2", {})
        cat.con = _DiskFullAtCommit(cat.con)
        with pytest.raises(VehvalError, match="No space left on device") as err:
            cat.add_result("r2", _res("b", "r2"))
        assert "recording test b of run r2" in str(err.value)
        cat.con = cat.con._con
        assert cat.query("SELECT test_id, run_id FROM tests ORDER BY 1")[1] == [("a", "r1")]


def test_a_batch_whose_catalog_fills_the_disk_stops_with_one_line(tmp_path, template_path,
                                                                   monkeypatch, capsys):
    inp, out = tmp_path / "in", tmp_path / "out"
    for i in range(3):
        write_d3(inp / f"t{i}" / f"t{i}.txt", seed=i)
    args = ["batch", str(inp), "-t", str(template_path), "-o", str(out), "--steps", "",
            "--no-report", "--workers", "0", "-q"]
    assert main(args) == 0
    write_d3(inp / "t3" / "t3.txt", seed=3)
    write_d3(inp / "t4" / "t4.txt", seed=4)
    real_open = runner_mod.open_catalog

    def full_disk(path, **kw):
        cat = real_open(path, **kw)
        cat.con = _DiskFullAtCommit(cat.con, ok=3)      # 3 unchanged tests, then t3 fails
        return cat

    monkeypatch.setattr(runner_mod, "open_catalog", full_disk)
    capsys.readouterr()
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.count("vehval: error:") == 1 and "internal error" not in err
    assert "recording test t3" in err and "No space left on device" in err
    monkeypatch.undo()
    with open_catalog(out, read_only=True) as cat:
        runs = cat.query("SELECT status, n_tests FROM runs ORDER BY started")[1]
        assert runs == [("done", 3), ("failed", 3)]
    # space back: the batch resumes (t3's result.json was written before its row failed)
    assert main(args) == 0
    assert "1 ok, 0 failed, 4 unchanged" in capsys.readouterr().out


def _latest(out) -> dict:
    with open_catalog(out, read_only=True) as cat:
        return dict(cat.query("SELECT test_id, status FROM latest_tests")[1])


def _n_mpg(out) -> int:
    with open_catalog(out, read_only=True) as cat:
        return {r["metric"]: r["n"] for r in cat.summary()}["fuel_economy_mpg"]


def test_deleted_and_renamed_tests_are_removed_not_counted_twice(tmp_path, template_path,
                                                                 capsys):
    inp, out = tmp_path / "in", tmp_path / "out"
    for i in range(4):
        write_d3(inp / f"t{i}" / f"t{i}.txt", seed=i)
    args = ["batch", str(inp), "-t", str(template_path), "-o", str(out), "--steps", "",
            "--no-report", "--workers", "0", "-q"]
    assert main(args) == 0 and _n_mpg(out) == 4
    (inp / "t1").rename(inp / "t1_renamed")
    for f in (inp / "t2").iterdir():
        f.unlink()
    (inp / "t2").rmdir()
    capsys.readouterr()
    assert main(args) == 0
    cap = capsys.readouterr()
    assert "1 ok, 0 failed, 2 unchanged, 2 removed" in cap.out
    assert "removed t1: none of its files exists any more" in cap.err
    assert _latest(out) == {"t0": "skipped", "t1": "removed", "t1_renamed": "ok",
                            "t2": "removed", "t3": "skipped"}
    assert _n_mpg(out) == 3                         # not 5: t1 twice and the deleted t2
    page = (out / "index.html").read_text(encoding="utf-8")
    assert "2 removed since the earlier runs" in page and 'href="tests/t2/' not in page
    with open_catalog(out, read_only=True) as cat:  # the run's counts are of its tests
        assert cat.query("SELECT n_tests, n_skipped FROM runs ORDER BY started DESC "
                         "LIMIT 1")[1] == [(3, 2)]
    # said once; a narrower glob removes nothing; a test that comes back is unchanged
    assert main(args) == 0 and "removed" not in capsys.readouterr().out
    write_d3(inp / "t2" / "t2.txt", seed=2)
    assert main([*args[:1], str(inp / "t0"), *args[2:]]) == 0
    assert main(args) == 0 and "0 ok, 0 failed, 4 unchanged ->" in capsys.readouterr().out
    assert _latest(out)["t2"] == "skipped" and _n_mpg(out) == 4
