"""Batch under hostile options and folders: worker counts, a test that hangs, a symlink loop,
the output folder inside a test folder, an edited result.json, kills at every rename."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

import vehval.batch.task as task_mod
from helpers.cli import TEMPLATE, run_cli, write_d3
from vehval.batch import run_batch
from vehval.batch.runner import MAX_WORKERS_PER_CPU
from vehval.catalog import open_catalog
from vehval.errors import ConfigError

HELPER = Path(__file__).with_name("killrun.py")
#: Names of what an interrupted run may leave: staging folders and temporaries.
DEBRIS = re.compile(r"vehval-stage|vehval-tmp|\.tmp$")


@pytest.fixture
def folder(tmp_path):
    """``(input folder with tests s0 and s1, template)``."""
    d = tmp_path / "data"
    for name in ("s0", "s1"):
        (d / name).mkdir(parents=True)
        write_d3(d / name / f"{name}_d3.txt", n=200)
    t = tmp_path / "T.yaml"
    t.write_text(TEMPLATE)
    return d, t


def _batch(d, t, out, *extra):
    return ["batch", d, "-t", t, "-o", out, "--steps", "", "--no-report", "-q", *extra]


def _debris(root: Path) -> list[str]:
    return sorted(str(p.relative_to(root)) for p in root.rglob("*") if DEBRIS.search(p.name))


@pytest.mark.parametrize("workers", ["10000", str(MAX_WORKERS_PER_CPU * (os.cpu_count() or 1) + 1),
                                     "-5", "-1"])
def test_worker_count_is_bounded(tmp_path, folder, capsys, workers):
    d, t = folder
    out = tmp_path / "out"
    t0 = time.perf_counter()
    rc, _, err = run_cli(_batch(d, t, out, "-j", workers), capsys)
    assert rc == 2 and err.startswith("vehval: error: --workers") and len(err.splitlines()) == 1
    # the options table bounds every count ([0, 64]); the runner then the machine's CPUs
    assert ("CPUs" in err) if 0 < int(workers) <= 64 else ("must be within [0, 64]" in err)
    assert not out.exists() and time.perf_counter() - t0 < 30


@pytest.mark.slow
def test_a_hanging_test_times_out_and_the_batch_goes_on(tmp_path, folder, monkeypatch, capsys):
    d, t = folder
    out = tmp_path / "out"
    release = threading.Event()
    real = task_mod._run_steps

    def hang(job, stage, result):
        if job["test_id"] == "s0":
            release.wait(120)                # a reader blocked on its input, say
        return real(job, stage, result)

    monkeypatch.setattr(task_mod, "_run_steps", hang)
    t0 = time.perf_counter()
    rc, stdout, err = run_cli(_batch(d, t, out, "-j", "0", "--test-timeout", "10"), capsys)
    assert time.perf_counter() - t0 < 60
    assert rc == 1 and "1 ok, 1 failed" in stdout
    assert "failed s0: the test ran longer than the 10 s test timeout" in err
    res = json.loads((out / "tests" / "s0" / "result.json").read_text())
    assert res["error_kind"] == "timeout" and res["outputs"] == []
    with open_catalog(out / "catalog.duckdb", read_only=True) as cat:
        _, rows = cat.query("SELECT test_id, status, error_type FROM tests ORDER BY 1")
    assert rows == [("s0", "failed", "TestTimedOut"), ("s1", "ok", None)]
    # the stuck test finishing late writes nothing: its outputs are refused by the deadline
    release.set()
    for th in threading.enumerate():
        if th.name == "vehval-test-s0":
            th.join(60)
            assert not th.is_alive()
    assert json.loads((out / "tests" / "s0" / "result.json").read_text()) == res
    assert sorted(p.name for p in (out / "tests" / "s0").iterdir()) == ["result.json"]
    assert _debris(out) == []
    # a timed-out test is not 'unchanged': it runs again (and passes without the hang)
    monkeypatch.setattr(task_mod, "_run_steps", real)
    s = run_batch(d, t, out, steps=[], workers=0, report=False, progress=False)
    assert (s.n_ok, s.n_skipped) == (1, 1)
    for bad in ("-3", "nan"):
        rc, _, err = run_cli(_batch(d, t, out, "--test-timeout", bad), capsys)
        assert rc == 2 and "--test-timeout" in err


def test_symlink_loop_is_skipped_and_reported(tmp_path, folder, capsys):
    d, t = folder
    os.symlink(d / "loop", d / "loop")                   # a folder entry pointing to itself
    os.symlink(d / "s1" / "x_d3.txt", d / "s1" / "x_d3.txt")
    os.symlink(d / "gone", d / "dangling")
    out = tmp_path / "out"
    rc, stdout, err = run_cli(_batch(d, t, out, "-j", "0"), capsys)
    assert "internal error" not in err and "Traceback" not in err
    assert rc == 1 and "2 ok, 0 failed, 0 unchanged, 3 input(s) skipped" in stdout
    assert f"skipped {d / 'loop'}: a symlink loop" in err
    assert f"skipped {d / 's1' / 'x_d3.txt'}: a symlink loop" in err
    assert f"skipped {d / 'dangling'}: a broken symlink" in err
    with open_catalog(out / "catalog.duckdb", read_only=True) as cat:
        _, rows = cat.query("SELECT settings->>'$.skipped_inputs' FROM runs")
    assert len(json.loads(rows[0][0])) == 3


def test_output_folder_that_is_a_test_folder_is_refused(tmp_path, folder, capsys):
    d, t = folder
    rc, stdout, err = run_cli(_batch(d, t, d / "s0", "-j", "0"), capsys)
    assert rc == 2 and "test folder 's0'" in err and "s0_d3.txt" in err
    assert stdout == "" and not (d / "s0" / "catalog.duckdb").exists()
    # a new folder inside DIR is fine, and said not to be a test
    rc, stdout, err = run_cli(_batch(d, t, d / "results", "-j", "0"), capsys)
    assert rc == 0 and "2 ok, 0 failed" in stdout
    assert f"not a test: {d / 'results'} (the batch's output folder)" in err


def test_edited_result_json_is_recomputed_on_resume(tmp_path, folder):
    d, t = folder
    out = tmp_path / "out"
    first = run_batch(d, t, out, steps=[], workers=0, report=False, progress=False)
    assert first.n_ok == 2
    path = out / "tests" / "s0" / "result.json"
    rec = json.loads(path.read_text())
    true_distance = rec["metrics"]["distance_m"]
    assert rec["result_sha256"] == task_mod.result_digest(rec)
    rec["metrics"]["distance_m"] = 123456.0                     # hand-edited, same input hash
    path.write_text(json.dumps(rec, indent=1))
    again = run_batch(d, t, out, steps=[], workers=0, report=False, progress=False)
    assert (again.n_ok, again.n_skipped) == (1, 1)
    with open_catalog(out / "catalog.duckdb", read_only=True) as cat:
        _, rows = cat.query("SELECT distance_m, status FROM tests WHERE test_id = 's0' AND "
                            "run_id = ?", [again.run_id])
    assert rows == [(pytest.approx(true_distance, rel=1e-12), "ok")]
    assert json.loads(path.read_text())["metrics"]["distance_m"] == true_distance
    # unedited, it is taken as unchanged
    third = run_batch(d, t, out, steps=[], workers=0, report=False, progress=False)
    assert third.n_skipped == 2


def _dead_pid() -> int:
    p = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                       capture_output=True, text=True, check=True)
    return int(p.stdout)


def test_debris_of_killed_runs_is_removed(tmp_path, folder):
    d, t = folder
    out = tmp_path / "out"
    run_batch(d, t, out, steps=[], workers=0, report=False, progress=False)
    pid = _dead_pid()
    planted = [out / "tests" / f".s0.vehval-stage.{pid}.abc123",
               out / "tests" / "s0" / f".result.json.vehval-tmp.{pid}.abcdefgh.tmp",
               out / "assets" / f".plotly-9.9.9.min.js.vehval-tmp.{pid}.abcdefgh.tmp",
               out / f".index.html.vehval-tmp.{pid}.abcdefgh.tmp",
               out / "assets" / ".plotly-9.9.9.min.js.k3j_x9q2.tmp"]   # an older version's
    live = out / f".index.html.vehval-tmp.{os.getppid()}.abcdefgh.tmp"  # a live process's
    planted[0].mkdir()
    (planted[0] / "findings.json").write_text("{}")
    for p in planted[1:] + [live]:
        p.parent.mkdir(exist_ok=True)
        p.write_bytes(b"x" * 1000)
    s = run_batch(d, t, out, steps=[], workers=0, report=False, progress=False)
    assert s.n_debris_removed == len(planted) and s.n_skipped == 2
    assert not [p for p in planted if p.exists()] and live.exists()


def _killrun(k: int, args: list) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    return subprocess.run([sys.executable, str(HELPER), str(k), *map(str, args)],
                          capture_output=True, text=True, env=env, timeout=300)


@pytest.mark.slow
def test_kill_at_every_rename_then_resume_leaves_no_debris(tmp_path):
    """Was: after a killed batch resumed, staging folders and temporaries (one the 4.8 MB
    plotly.js) survived at 17 of 26 kill points."""
    d = tmp_path / "data"
    (d / "s0").mkdir(parents=True)
    write_d3(d / "s0" / "s0_d3.txt", n=200)
    t = tmp_path / "T.yaml"
    t.write_text(TEMPLATE)
    out = tmp_path / "out"
    args = ["batch", d, "-t", t, "-o", out, "--steps", "qa", "-j", "0", "-q", "--force"]
    left: list[str] = []
    seen: set[str] = set()
    for k in range(1, 100):                 # until a run gets past its last rename
        r = _killrun(k, args)
        # what the run before this one left is gone (this run swept it before anything else)
        assert not [p for p in left if (out / p).exists()], (k, left)
        left = _debris(out)
        seen.update(left)
        if r.returncode == 0:
            break
        assert r.returncode == -9, (k, r.returncode, r.stderr)
    assert k >= 6 and seen, "the killed runs left debris (the case to clean)"
    assert left == []
    done = _killrun(0, args[:-1])           # a resume: the test is unchanged
    assert done.returncode == 0 and "0 ok, 0 failed, 1 unchanged" in done.stdout, done.stdout
    res = json.loads((out / "tests" / "s0" / "result.json").read_text())
    assert res["status"] == "ok" and (out / "tests" / "s0" / "report.html").is_file()


def test_batch_library_refuses_bad_counts(tmp_path, folder):
    d, t = folder
    with pytest.raises(ConfigError, match="--workers -5"):
        run_batch(d, t, tmp_path / "o", workers=-5, progress=False)
    with pytest.raises(ConfigError, match="--test-timeout"):
        run_batch(d, t, tmp_path / "o", workers=0, test_timeout_s=-1, progress=False)
    assert not (tmp_path / "o").exists()
