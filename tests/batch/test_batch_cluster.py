"""A batch on a real ``dask.distributed`` cluster (scheduler + 2 worker processes on loopback).

Covers: >= 20 good tests and deliberately broken ones through ``vehval batch --scheduler``;
the catalog against a direct single-test run; killing the CLI midway (SIGKILL) and a rerun
that completes the batch without redoing finished tests (result.json mtimes and the
catalog's source_run_id prove it).
"""

from __future__ import annotations

import json
import logging
import math
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from vehval.batch.metrics import test_metrics as key_metrics
from vehval.batch.task import _selected, jsonable
from vehval.catalog import open_catalog

from .helpers import TEMPLATE, write_d3

N_DISTINCT, N_COPIES = 2, 10         # 20 good tests: 2 distinct recordings, 10 copies each
WAIT_S = 120                          # generous wall for subprocess waits (not an assertion of speed)
# The batch and the direct run execute the same code on the same bytes: only the order of
# float operations may differ between processes, so rtol 1e-9.
RTOL = 1e-9


def _virtual_dyno_available() -> bool:
    try:
        import vehval.sim.simulate  # noqa: F401
        from vehval.synth import make_virtual_test  # noqa: F401
    except ImportError:
        return False
    return True


@pytest.fixture(scope="module")
def batch_inputs(tmp_path_factory):
    """Good tests (virtual dyno on a short steady cycle when available, else D3 fixtures)
    plus broken ones: truncated, garbage bytes, wrong template (unrelated columns)."""
    root = tmp_path_factory.mktemp("batch")
    inp = root / "in"
    sources, truths = [], []
    if _virtual_dyno_available():
        from vehval.cycles import steady_cycle
        from vehval.synth import make_virtual_test

        for i in range(N_DISTINCT):
            out = make_virtual_test(cycle=steady_cycle(12.0 + i, 60.0), seed=i,
                                    outdir=root / f"virtual{i}")
            sources.append(list(out.files))
            truths.append(json.loads(Path(out.truth_path).read_text())["simulation"]["summary"])
        template = Path(out.template_path)
    else:
        template = root / "template.yaml"
        template.write_text(TEMPLATE, encoding="utf-8")
        for i in range(N_DISTINCT):
            f = root / f"src{i}" / f"run{i}.txt"
            write_d3(f, seed=i, n=600)
            sources.append([f])
    good = {}
    for i, files in enumerate(sources):
        for c in range(N_COPIES):
            d = inp / f"good_{i}_{c}"
            d.mkdir(parents=True)
            for f in files:
                shutil.copy(f, d / Path(f).name)
            good[d.name] = i
    main_file = Path(sources[0][0]).name
    broken = {}
    d = inp / "broken_truncated"
    shutil.copytree(inp / "good_0_0", d)
    (d / main_file).write_bytes((inp / "good_0_0" / main_file).read_bytes()[:40])
    broken[d.name] = main_file
    d = inp / "broken_garbage"
    shutil.copytree(inp / "good_0_0", d)
    (d / main_file).write_bytes(np.random.default_rng(0).integers(0, 256, 5000, dtype=np.uint8).tobytes())
    broken[d.name] = main_file
    d = inp / "broken_wrong_template"
    shutil.copytree(inp / "good_0_0", d)
    # a file of another layout (no time column where the template expects one)
    (d / main_file).write_text("Colour[-]\tMood[-]\n1\t2\n1\t2\n", encoding="utf-8")
    broken[d.name] = main_file
    return {"root": root, "inp": inp, "template": template, "good": good, "broken": broken,
            "sources": sources, "truths": truths}


@pytest.fixture(scope="module")
def cluster():
    import warnings

    from distributed import LocalCluster

    warnings.filterwarnings("ignore", message="Port 8787 is already in use")
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address="127.0.0.1:0", silence_logs=logging.ERROR) as c:
        yield c


#: Whole-test metrics of the catalog that the QA gate of the results may withhold.
WITHHELD_METRICS = ("distance_m", "fuel_mass_kg", "fuel_economy_mpg",
                    "fuel_consumption_l_per_100km", "fuel_energy_j")


def _direct(files, template) -> dict:
    """Single-test run in this process: import, QA, metrics (what the batch must reproduce)."""
    from vehval.io.importer import import_test
    from vehval.io.template import load_template

    tmpl = load_template(template)
    test = import_test(files, tmpl)
    qa = None
    try:
        from vehval.qa.pipeline import run_qa
        from vehval.vehicle import load_vehicle

        qa = run_qa(test, load_vehicle(tmpl.vehicle) if tmpl.vehicle else None, tmpl)
    except ImportError:
        pass
    return key_metrics(test, _selected(jsonable(qa) if qa is not None else {}))


def _cli(args, **kw):
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    return subprocess.Popen([sys.executable, "-m", "vehval", *args], env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, **kw)


def _results(out: Path) -> dict[str, Path]:
    return {p.parent.name: p for p in (out / "tests").glob("*/result.json")}


def _wait_idle(address: str) -> None:
    """Wait until the scheduler forgot the killed client's tasks and no worker runs one,
    so no straggler writes a result.json after the snapshot."""
    from distributed import Client

    with Client(address, timeout="20s") as c:
        deadline, idle = time.monotonic() + WAIT_S, 0
        while time.monotonic() < deadline:
            n_sched = c.run_on_scheduler(lambda dask_scheduler: len(dask_scheduler.tasks))
            # threads still running a task, including tasks the scheduler already released
            busy = c.run(lambda dask_worker: len(dask_worker.active_threads))
            idle = idle + 1 if n_sched == 0 and not any(busy.values()) else 0
            if idle >= 3:
                return
            time.sleep(0.1)
    raise AssertionError("cluster did not become idle")


def test_batch_on_cluster_kill_and_resume(batch_inputs, cluster, tmp_path):
    inp, template = batch_inputs["inp"], batch_inputs["template"]
    good, broken = batch_inputs["good"], batch_inputs["broken"]
    out = tmp_path / "out"
    n_total = len(good) + len(broken)
    assert len(good) >= 20
    args = ["batch", str(inp), "-t", str(template), "-o", str(out), "--scheduler",
            cluster.scheduler_address, "--no-report", "-q"]

    # 1. start, kill (SIGKILL) once a few results have landed
    proc = _cli(args)
    deadline = time.monotonic() + WAIT_S
    while len(_results(out)) < 3 and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.02)
    proc.send_signal(signal.SIGKILL)
    proc.communicate(timeout=WAIT_S)
    _wait_idle(cluster.scheduler_address)
    done_first = {t: (p.stat().st_mtime_ns, json.loads(p.read_text())["run_id"])
                  for t, p in _results(out).items()}
    assert 3 <= len(done_first) < n_total, "the kill must land midway"

    # 2. rerun to completion
    proc = _cli(args)
    stdout, stderr = proc.communicate(timeout=WAIT_S)
    assert proc.returncode == 1, stderr.decode()          # 1: some tests failed (the broken ones)
    assert "unchanged" in stdout.decode()

    with open_catalog(out / "catalog.duckdb", read_only=True) as cat:
        _, runs = cat.query("SELECT run_id, status FROM runs ORDER BY started")
        assert len(runs) == 2 and runs[1][1] == "done"
        cols, rows = cat.query("SELECT * FROM tests WHERE run_id = ?", [runs[1][0]])
        second = {r[0]: dict(zip(cols, r)) for r in rows}
        n_findings = dict(cat.query("SELECT test_id, count(*) FROM findings WHERE run_id = ? "
                                    "GROUP BY 1", [runs[1][0]])[1])

    # nothing lost: every test of the directory is in the completing run
    assert set(second) == set(good) | set(broken)
    # finished tests were not redone: same result.json, same producing run, status skipped
    for tid, (mtime, run_id) in done_first.items():
        assert second[tid]["status"] == "skipped", tid
        assert second[tid]["source_run_id"] == run_id == runs[0][0]
        assert (out / "tests" / tid / "result.json").stat().st_mtime_ns == mtime
    for tid in set(second) - set(done_first):
        assert second[tid]["source_run_id"] == runs[1][0]

    # good tests: metrics equal a direct single-test run of the same files
    direct = {i: _direct(files, template) for i, files in enumerate(batch_inputs["sources"])}
    for tid, i in good.items():
        row = second[tid]
        assert row["error"] is None and row["status"] in ("ok", "skipped"), (tid, row["error"])
        # figures the QA gate withheld (docs/results.md) are NULL, with their reason
        res = json.loads((out / "tests" / tid / "result.json").read_text())["results"]
        whole = next(r for r in res["rows"] if r["scope"] == "test")
        held = set(WITHHELD_METRICS) if whole["withheld_reason"] else set()
        for key, val in direct[i].items():
            if val is None or key in held:
                assert row[key] is None or key in held, (tid, key)
            else:
                assert row[key] == pytest.approx(val, rel=RTOL), (tid, key)
        assert row["distance_m"] > 0
        assert (row["fuel_economy_mpg"] or 0) > 0 or "fuel_rate" in (whole["withheld_reason"] or "")
        if batch_inputs["truths"]:
            # independent check against the simulation behind the virtual test: the file
            # stores speed in mph with 3 decimals on the simulation's 10 Hz grid, so the
            # distance agrees to ~1e-5; rtol 1e-3 leaves room for the dyno sensor model.
            truth = batch_inputs["truths"][i]
            assert row["distance_m"] == pytest.approx(truth["distance_m"], rel=1e-3)
        assert row["n_findings"] == n_findings.get(tid, 0)
    # broken tests: recorded as failed with a user error naming the file
    for tid, fname in broken.items():
        row = second[tid]
        assert row["status"] in ("failed", "skipped") and row["error"], tid
        res = json.loads((out / "tests" / tid / "result.json").read_text())
        assert res["status"] == "failed" and res["error_kind"] == "user", res["error"]
    assert (out / "index.html").is_file()


def test_all_steps_on_one_virtual_test(batch_inputs, tmp_path):
    """qa, analyze and validate plus the report on one test (glob target, plain loop)."""
    if not batch_inputs["truths"]:
        pytest.skip("virtual dyno not available")
    from vehval.batch import run_batch

    out = tmp_path / "out"
    target = str(batch_inputs["inp"] / "good_0_[0]")      # a glob naming one test directory
    s = run_batch(target, batch_inputs["template"], out, steps=["qa", "analyze", "validate"],
                  workers=0, report=True, progress=False, cycle="steady")
    assert (s.n_ok, s.n_failed) == (1, 0), s.results[0].get("error")
    files = {p.name for p in (out / "tests" / "good_0_0").iterdir()}
    assert {"findings.json", "control.json", "validation.json", "report.html",
            "result.json"} <= files
    with open_catalog(out / "catalog.duckdb", read_only=True) as cat:
        _, rows = cat.query("SELECT cycle, validation_errors->>'fuel_error', "
                            "validation->>'on_method' FROM tests")
    cycle, fuel_err, on_method = rows[0]
    # the importer names the cycle (template or identification); --cycle is only the fallback
    assert cycle.startswith("steady") and on_method
    assert math.isfinite(float(fuel_err))
    val = json.loads((out / "tests" / "good_0_0" / "validation.json").read_text())
    assert float(fuel_err) == pytest.approx(val["fuel_error"], rel=0, abs=0)


@pytest.mark.slow
def test_hanging_test_on_a_cluster_times_out(tmp_path):
    """--test-timeout on Dask workers: the hanging test fails with the reason, the others
    complete on the same worker, and the batch ends."""
    import warnings

    from distributed import Client, LocalCluster

    from vehval.batch import run_batch

    inp = tmp_path / "in"
    for name in ("s0", "s1", "s2"):
        write_d3(inp / name / f"{name}.txt", seed=len(name))
    tpl = tmp_path / "T.yaml"
    tpl.write_text(TEMPLATE)

    def patch():          # defined here so that it is pickled by value for the workers
        import threading

        import vehval.batch.task as tm

        tm.RELEASE = threading.Event()
        real = tm._run_steps

        def hang(job, stage, result):
            if job["test_id"] == "s0":
                tm.RELEASE.wait(120)
            return real(job, stage, result)

        tm._run_steps = hang

    def release():
        import vehval.batch.task as tm

        tm.RELEASE.set()

    warnings.filterwarnings("ignore", message="Port 8787 is already in use")
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address="127.0.0.1:0", silence_logs=logging.ERROR) as c, \
            Client(c) as client:
        client.run(patch)
        t0 = time.perf_counter()
        s = run_batch(inp, tpl, tmp_path / "out", steps=[], report=False, progress=False,
                      scheduler=c.scheduler_address, test_timeout_s=20)
        assert time.perf_counter() - t0 < WAIT_S
        client.run(release)
    res = {r["test_id"]: r for r in s.results}
    assert (s.n_ok, s.n_failed) == (2, 1), [(r["test_id"], r.get("error")) for r in s.results]
    assert res["s0"]["error_kind"] == "timeout" and "20 s test timeout" in res["s0"]["error"]
