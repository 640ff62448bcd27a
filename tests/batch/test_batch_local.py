"""Batch runs in a plain loop (``--workers 0``): metrics, failures, resume, index, CLI."""

from __future__ import annotations

import json
import os

import pytest

from vehval.batch import run_batch
from vehval.catalog import open_catalog
from vehval.cli import main
from vehval.errors import ConfigError

from .helpers import write_d3

# Metrics are trapezoidal integrals of the values as written (10 significant digits) and the
# reader parses them exactly, so the only differences are float summation order: rtol 1e-9.
RTOL = 1e-9
#: Signals each metric is computed from.
NEEDS = {"distance_m": {"veh_spd_test"}, "fuel_mass_kg": {"fuel_rate_test"},
         "soc_change": {"ess_soc_test"}, "ess_energy_j": {"ess_curr_test", "ess_volt_test"},
         "fuel_economy_mpg": {"veh_spd_test", "fuel_rate_test"}}


def _inputs(root, n=3):
    expected = {}
    for i in range(n):
        expected[f"t{i}"] = write_d3(root / f"t{i}" / f"run{i}.txt", seed=i)
    (root / "garbage").mkdir(parents=True)
    (root / "garbage" / "x.txt").write_bytes(bytes(range(256)) * 3)
    (root / "empty").mkdir()                         # no matching file
    return expected


def _rows(db, run_id):
    with open_catalog(db, read_only=True) as cat:
        cols, rows = cat.query("SELECT * FROM tests WHERE run_id = ? ORDER BY test_id", [run_id])
    return {r[0]: dict(zip(cols, r)) for r in rows}


def test_plain_loop_metrics_failures_and_resume(tmp_path, template_path):
    inp, out = tmp_path / "in", tmp_path / "out"
    expected = _inputs(inp)
    s1 = run_batch(inp, template_path, out, steps=["qa"], workers=0, report=False, progress=False)
    assert (s1.n_ok, s1.n_failed, s1.n_skipped) == (3, 2, 0)
    rows = _rows(out / "catalog.duckdb", s1.run_id)
    assert set(rows) == {"t0", "t1", "t2", "garbage", "empty"}
    for tid, exp in expected.items():
        findings = json.loads((out / "tests" / tid / "findings.json").read_text())
        dropped = set(findings["selection"]["dropped"])
        for key, val in exp.items():
            if dropped & NEEDS.get(key, set()):
                # QA did not keep a signal the metric needs: no number, not a wrong one
                assert rows[tid][key] is None, (tid, key)
            else:
                assert rows[tid][key] == pytest.approx(val, rel=RTOL), (tid, key)
    assert rows["garbage"]["status"] == "failed" and "x.txt" in rows["garbage"]["error"]
    assert rows["empty"]["status"] == "failed" and rows["empty"]["error"]
    res = json.loads((out / "tests" / "garbage" / "result.json").read_text())
    assert res["error_kind"] == "user" and res["error_type"] == "InputFileError"

    # rerun: nothing recomputed; change one file: only that test is recomputed
    mtimes = {t: os.stat(out / "tests" / t / "result.json").st_mtime_ns for t in rows}
    write_d3(inp / "t1" / "run1.txt", seed=99)
    s2 = run_batch(inp, template_path, out, steps=["qa"], workers=0, report=False, progress=False)
    assert (s2.n_ok, s2.n_failed, s2.n_skipped) == (1, 0, 4)
    rows2 = _rows(out / "catalog.duckdb", s2.run_id)
    assert rows2["t1"]["status"] == "ok" and rows2["t1"]["source_run_id"] == s2.run_id
    assert rows2["t0"]["status"] == "skipped" and rows2["t0"]["source_run_id"] == s1.run_id
    assert rows2["t0"]["fuel_mass_kg"] == rows["t0"]["fuel_mass_kg"]
    assert rows2["garbage"]["error"] == rows["garbage"]["error"]
    for t in ("t0", "t2", "garbage", "empty"):
        assert os.stat(out / "tests" / t / "result.json").st_mtime_ns == mtimes[t]
    # different steps = different settings: everything is recomputed
    s3 = run_batch(inp, template_path, out, steps=[], workers=0, report=False, progress=False)
    assert s3.n_skipped == 0 and not (out / "tests" / "t0" / "findings.json").exists()


def test_index_and_report_links(tmp_path, template_path):
    inp, out = tmp_path / "in", tmp_path / "out"
    _inputs(inp, n=2)
    plotly_asset_name = pytest.importorskip("vehval.report").plotly_asset_name
    run_batch(inp, template_path, out, steps=["qa"], workers=0, report=True, progress=False)
    html = (out / "index.html").read_text(encoding="utf-8")
    for tid in ("t0", "t1"):
        assert f'href="tests/{tid}/report.html"' in html
        assert (out / "tests" / tid / "report.html").is_file()
    # every test report shares one local plotly.js: small, relative reference, no copy inside
    assets = list((out / "assets").iterdir())
    assert [a.name for a in assets] == [plotly_asset_name()] and assets[0].stat().st_size > 3e6
    asset_mtime = assets[0].stat().st_mtime_ns
    for tid in ("t0", "t1"):
        report = out / "tests" / tid / "report.html"
        text = report.read_text(encoding="utf-8")
        assert report.stat().st_size < 1e6, report.stat().st_size   # ~9 MB when embedded
        src = f'<script id="plotly-js" src="../../assets/{plotly_asset_name()}"></script>'
        assert src in text and text.count(" src=") == 1             # nothing else is loaded
        assert (report.parent / "../../assets" / plotly_asset_name()).resolve() == assets[0].resolve()
        assert "* plotly.js v" not in text                          # no embedded copy
    # a forced rerun leaves the identical asset untouched (written only when absent or different)
    run_batch(inp, template_path, out, steps=[], workers=0, report=True, progress=False, force=True)
    assert (out / "assets" / plotly_asset_name()).stat().st_mtime_ns == asset_mtime
    assert 'href="tests/garbage/report.html"' not in html
    # plotly.js embedded exactly once, nothing loaded from the network; two plots: fuel
    # economy per test and phase, fuel economy against SOC change
    assert html.count('class="vv-fig"') == 2 and "<script src=" not in html
    assert "Fuel economy by cycle and test conditions" in html and 'id="fe_phase"' in html
    assert html.count('<script id="plotly-gz" type="application/octet-stream">') == 1  # compressed, once
    assert "Test-to-test variability" in html


def test_unknown_step_fails_early(tmp_path, template_path):
    import vehval.batch.task as task
    from vehval.workflow import TestRun

    _inputs(tmp_path / "in", n=1)
    with pytest.raises(ConfigError, match="unknown step 'nope'"):
        run_batch(tmp_path / "in", template_path, tmp_path / "out", steps=["nope"], workers=0)
    # every step is a TestRun method: what batch runs is what the commands run
    assert task.STEPS["qa"] is TestRun.qa and task.STEPS["validate"] is TestRun.validate
    with pytest.raises(ConfigError, match="'validate' needs a vehicle"):   # template has none
        run_batch(tmp_path / "in", template_path, tmp_path / "out", steps=["qa", "validate"],
                  workers=0)
    assert not (tmp_path / "out").exists()  # nothing written before the settings are checked


def test_cli_batch_and_catalog(tmp_path, template_path, capsys):
    inp, out = tmp_path / "in", tmp_path / "out"
    _inputs(inp, n=2)
    rc = main(["batch", str(inp), "-t", str(template_path), "-o", str(out), "--steps", "",
               "--no-report", "--workers", "0", "-q", "--cycle", "hump120"])
    assert rc == 1  # two broken tests
    err = capsys.readouterr().err
    assert "failed garbage" in err and "failed empty" in err
    db = str(out / "catalog.duckdb")
    assert main(["catalog", "query", "SELECT test_id, status FROM latest_tests ORDER BY 1",
                 "--db", db, "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert [r["status"] for r in rows] == ["failed", "failed", "ok", "ok"]
    assert main(["catalog", "summary", "--db", db, "--json"]) == 0
    summ = json.loads(capsys.readouterr().out)
    assert {r["metric"] for r in summ} >= {"fuel_economy_mpg", "soc_change"}
    assert all(r["n"] == 2 and r["cycle"] == "hump120" for r in summ)
    assert main(["catalog", "query", "DROP TABLE tests", "--db", db]) == 2  # read-only
    assert "read-only" in capsys.readouterr().err


def test_internal_error_is_recorded_and_retried(tmp_path, template_path, monkeypatch):
    """A bug (non-VehvalError) in a step fails that test only, and is retried on rerun."""
    import vehval.batch.metrics as metrics_mod

    inp, out = tmp_path / "in", tmp_path / "out"
    write_d3(inp / "a" / "a.txt", seed=1)
    write_d3(inp / "b" / "b.txt", seed=2)
    real = metrics_mod.test_metrics

    def flaky(test, selected=None, **kw):
        if test.meta.test_id == "b":
            raise ZeroDivisionError("boom")
        return real(test, selected, **kw)

    monkeypatch.setattr(metrics_mod, "test_metrics", flaky)
    s1 = run_batch(inp, template_path, out, steps=[], workers=0, report=False, progress=False)
    res = json.loads((out / "tests" / "b" / "result.json").read_text())
    assert (s1.n_ok, s1.n_failed) == (1, 1)
    assert res["error"] == "ZeroDivisionError: boom" and res["error_kind"] == "internal"
    assert "traceback" in res and res["outputs"] == []
    monkeypatch.setattr(metrics_mod, "test_metrics", real)
    s2 = run_batch(inp, template_path, out, steps=[], workers=0, report=False, progress=False)
    assert (s2.n_ok, s2.n_skipped) == (1, 1)          # b retried and now ok, a unchanged
    assert _rows(out / "catalog.duckdb", s2.run_id)["b"]["status"] == "ok"


def test_shutdown_ignores_a_closed_connection(caplog):
    """Reported: about one batch run in twenty ended with a CommClosedError traceback."""
    import logging

    from distributed.comm.core import CommClosedError

    from vehval.batch.runner import shutdown

    class Closing:
        def __init__(self):
            self.closed = False

        def close(self):
            self.closed = True
            logging.getLogger("distributed.comm").error("CommClosedError: in <TCP (closed)>")
            raise CommClosedError("in <TCP (closed)>: Stream is closed")

    client, cluster = Closing(), Closing()
    with caplog.at_level(logging.WARNING):
        shutdown(client, cluster)           # no exception
    assert client.closed and cluster.closed
    assert not [r for r in caplog.records if "CommClosedError" in r.getMessage()]


def test_the_templates_vehicle_name_fills_the_vehicle_column(tmp_path, template_path, capsys):
    """A car with no vehicle file (a conventional car) is labelled by the template's
    ``vehicle_name``; ``--vehicle`` or ``vehicle:`` would take precedence."""
    inp, out = tmp_path / "in", tmp_path / "out"
    for i in range(2):
        write_d3(inp / f"t{i}.txt", seed=i)
    tpl = tmp_path / "named.yaml"
    tpl.write_text(template_path.read_text().replace(
        "template_version: 1\n", "template_version: 1\nvehicle_name: 2014 Test Car Diesel\n"))
    rc = main(["batch", str(inp), "-t", str(tpl), "-o", str(out), "--steps", "", "--no-report",
               "--workers", "0", "-q", "--cycle", "hump120"])
    assert rc == 0
    capsys.readouterr()
    assert main(["catalog", "summary", "--db", str(out / "catalog.duckdb"), "--json"]) == 0
    summ = json.loads(capsys.readouterr().out)
    assert summ and {r["vehicle"] for r in summ} == {"2014 Test Car Diesel"}


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs on this platform")
def test_a_fifo_is_skipped_and_listed_with_its_reason(tmp_path, template_path, capsys):
    """A FIFO (reading it would block until a writer comes) is never taken as an input: it is
    listed among the skipped inputs with the reason, beside a test of regular files and in a
    test folder of its own, whose failure then says that no regular file matches."""
    inp, out = tmp_path / "in", tmp_path / "out"
    write_d3(inp / "t0" / "run0.txt", seed=0)
    os.mkfifo(inp / "t0" / "extra.txt")              # beside the test's regular file
    (inp / "pipe").mkdir()
    os.mkfifo(inp / "pipe" / "run.txt")              # the folder's only matching entry
    rc = main(["batch", str(inp), "-t", str(template_path), "-o", str(out), "--steps", "",
               "--no-report", "--workers", "0", "-q"])
    err = capsys.readouterr().err
    assert rc == 1, err
    for fifo in (inp / "t0" / "extra.txt", inp / "pipe" / "run.txt"):
        assert f"skipped {fifo}: a FIFO (named pipe), not a regular file: not read" in err, err
    assert "no input file given" not in err
    assert "no regular file of the test folder matches the template's file patterns (*.txt)" in err
    res = json.loads((out / "tests" / "t0" / "result.json").read_text())
    assert res["status"] == "ok" and [os.path.basename(f) for f in res["files"]] == ["run0.txt"]


def test_output_folder_that_is_the_input_folder_stays_out_of_every_later_batch(
        tmp_path, template_path, capsys):
    """``batch DIR -o DIR`` puts the batch's ``tests`` and ``assets`` beside the tests: that
    run and a later one with another output folder take only the tests (the later one said
    'failed assets: ... no regular file ... matches')."""
    inp = tmp_path / "cruze dir"
    write_d3(inp / "t0.txt", seed=0)
    args = ["-t", str(template_path), "--steps", "", "--no-report", "--workers", "0", "-q"]
    assert main(["batch", str(inp), "-o", str(inp), *args]) == 0
    assert (inp / "catalog.duckdb").is_file() and (inp / "tests" / "t0").is_dir()
    capsys.readouterr()
    assert main(["batch", str(inp), "-o", str(tmp_path / "other"), *args]) == 0
    err = capsys.readouterr().err
    assert sorted(p.name for p in (tmp_path / "other" / "tests").iterdir()) == ["t0"]
    assert f"not a test: {inp / 'tests'} (an earlier batch's output" in err


def test_an_earlier_batch_output_in_the_input_folder_is_not_a_test(tmp_path, template_path,
                                                                   capsys):
    """An older run wrote its outputs into the input folder (``tests``, ``assets``, the
    catalog, the index), and another batch's output folder lies beside the tests: a later
    batch reads neither as tests, says so, and succeeds."""
    inp = tmp_path / "in"
    write_d3(inp / "t0" / "run0.txt", seed=0)
    write_d3(inp / "t1.txt", seed=1)
    run_batch(inp, template_path, inp / "old", steps=[], report=True, workers=0, progress=False)
    for name in ("tests/t0", "assets"):                  # what an input = output run left
        (inp / name).mkdir(parents=True)
        (inp / name / "x.txt").write_text("not data\n")
    (inp / "catalog.duckdb").write_bytes((inp / "old" / "catalog.duckdb").read_bytes())
    (inp / "index.html").write_text("<html></html>")
    rc = main(["batch", str(inp), "-t", str(template_path), "-o", str(tmp_path / "new"),
               "--steps", "", "--no-report", "--workers", "0", "-q"])
    err = capsys.readouterr().err
    assert rc == 0, err
    assert sorted(p.name for p in (tmp_path / "new" / "tests").iterdir()) == ["t0", "t1"]
    for name in ("tests", "assets", "old"):
        assert f"not a test: {inp / name} (an earlier batch's output" in err


def test_qa_outputs_in_the_input_folder_are_not_tests(tmp_path, template_path, capsys):
    """The workbench's ``qa/`` (one `vehval qa` output per one-file test) and a `vehval qa
    -o` folder beside the tests: not tests (the batch read the first as a failed test,
    '10 ok, 1 failed', and a failed row in the catalog); a test folder is still one."""
    inp = tmp_path / "cruze"
    write_d3(inp / "t0.txt", seed=0)
    write_d3(inp / "t1" / "run1.txt", seed=1)
    for out in (inp / "qa" / "t0", inp / "qa_by_hand"):
        out.mkdir(parents=True)
        (out / "findings.json").write_text("{}")
        (out / "validated.parquet").write_bytes(b"PAR1")
    rc = main(["batch", str(inp), "-t", str(template_path), "-o", str(tmp_path / "out"),
               "--steps", "", "--no-report", "--workers", "0", "-q"])
    err = capsys.readouterr().err
    assert rc == 0, err
    assert sorted(p.name for p in (tmp_path / "out" / "tests").iterdir()) == ["t0", "t1"]
    assert f"not a test: {inp / 'qa'} (a folder of `vehval qa` / workbench outputs" in err
    assert f"not a test: {inp / 'qa_by_hand'} (the output of `vehval qa` or the workbench" in err
