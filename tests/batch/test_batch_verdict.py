"""The normalised error in a batch: each validated test's En in the catalog, the set verdict
over the run's tests (screen, catalog table, set_verdict.json, `catalog summary`)."""

from __future__ import annotations

import json
import math
import shutil

import pytest

from vehval.catalog import open_catalog


@pytest.fixture(scope="module")
def three_tests(tmp_path_factory):
    """Three virtual Prius tests (short steady runs, different seeds) and their template."""
    pytest.importorskip("vehval.sim.simulate")
    from vehval.cycles import steady_cycle
    from vehval.synth import make_virtual_test

    root = tmp_path_factory.mktemp("verdict")
    inp = root / "in"
    for i in range(3):
        out = make_virtual_test(cycle=steady_cycle(12.0 + i, 60.0), seed=i,
                                outdir=root / f"virtual{i}")
        d = inp / f"t{i}"
        d.mkdir(parents=True)
        for f in out.files:
            shutil.copy(f, d)
    return inp, out.template_path


def test_batch_records_en_and_the_set_verdict(three_tests, tmp_path, capsys):
    from vehval.batch import run_batch
    from vehval.batch.verdicts import stored_set_verdicts
    from vehval.cli import main

    inp, template = three_tests
    out = tmp_path / "out"
    s = run_batch(inp, template, out, vehicle="prius_2004", steps=["qa", "analyze", "validate"],
                  workers=0, progress=False)
    assert (s.n_ok, s.n_failed) == (3, 0), [r.get("error") for r in s.results]
    with open_catalog(out / "catalog.duckdb", read_only=True) as cat:
        cols, rows = cat.query("SELECT test_id, fuel_en, fuel_error_pct, fuel_u_model_kg, "
                               "fuel_u_meas_kg, fuel_s_r, fuel_consistent, fuel_uninformative, "
                               "in_sample FROM tests ORDER BY test_id")
        stored = stored_set_verdicts(cat)
        _, sv_rows = cat.query("SELECT n, verdict, mean_error_pct, coverage FROM set_verdicts")
    assert [r[0] for r in rows] == ["t0", "t1", "t2"]
    errors = []
    for tid, en, err, u_model, u_meas, s_r, consistent, unin, in_sample in rows:
        ne = json.loads((out / "tests" / tid / "validation.json").read_text())["normalised_error"]
        # the columns are the validate step's figures, and En is their ratio
        assert u_model > 0 and u_meas > 0 and s_r > 0      # parameter ranges; results U with s_r
        assert en == pytest.approx((ne["model_kg"] - ne["measured_kg"])
                                   / math.hypot(u_model, u_meas), rel=1e-12)
        assert err == pytest.approx(100 * (ne["model_kg"] / ne["measured_kg"] - 1), rel=1e-12)
        assert consistent == (abs(en) <= 1) and unin == (math.hypot(u_model, u_meas)
                                                         > 0.1 * ne["measured_kg"])
        assert in_sample is False
        errors.append(err)
    # the set verdict over the three tests: stored, in the JSON beside the catalog, on screen
    assert len(s.set_verdicts) == 1 and stored[0]["run_id"] == s.run_id
    sv = s.set_verdicts[0]["set_verdict"]
    assert sv["n"] == 3 and s.set_verdicts[0]["tests"] == ["t0", "t1", "t2"]
    assert sv["mean_error_pct"] == pytest.approx(sum(errors) / 3, rel=1e-9)
    assert sv["n_consistent"] == sum(r[6] for r in rows)
    lo, hi = sv["mean_error_ci_pct"]
    assert lo < sv["mean_error_pct"] < hi
    assert sv_rows == [(3, sv["verdict"], pytest.approx(sv["mean_error_pct"]),
                        pytest.approx(sv["coverage"]))]
    assert sv["verdict"].startswith(("consistent with the data", "biased by",
                                     "uncertainty understated"))
    doc = json.loads((out / "set_verdict.json").read_text())
    assert doc["run_id"] == s.run_id and doc["set_verdicts"][0]["set_verdict"] == sv
    capsys.readouterr()
    assert main(["catalog", "summary", "--db", str(out / "catalog.duckdb")]) == 0
    text = capsys.readouterr().out
    assert f"set verdict (prius_2004, fuel mass, n = 3): {sv['verdict']}" in text
    # the batch's index page: En per test and the set verdict under the tests table
    page = (out / "index.html").read_text(encoding="utf-8")
    assert "En (fuel, model)" in page
    assert f"set verdict (prius_2004, fuel mass, n = 3): {sv['verdict']}" in page
    assert all(f"{r[1]:+.2f}" in page for r in rows)


def test_set_verdict_needs_three_validated_tests():
    """Two tests give no set verdict, with the count named; failed and in-sample tests are
    not counted."""
    from vehval.batch.verdicts import batch_set_verdicts, verdict_line

    def res(tid, en=0.3, status="ok", in_sample=False):
        return {"test_id": tid, "status": status, "vehicle": "v", "validation": {
            "normalised_error": {"en": en, "model_kg": 0.101, "measured_kg": 0.1,
                                 "u_model_kg": 0.002, "u_meas_kg": 0.002, "s_r": 0.01,
                                 "in_sample": in_sample}}}
    rows = batch_set_verdicts([res("a"), res("b"), res("c", status="failed"),
                               res("d", in_sample=True), res("e", en=None)])
    assert rows[0]["set_verdict"] is None and rows[0]["n_validated"] == 3
    assert rows[0]["n_in_sample"] == 1 and "2 comparison(s)" in rows[0]["note"]
    assert "none (set verdict: 2 comparison(s)" in verdict_line(rows[0])
    three = batch_set_verdicts([res("a"), res("b"), res("c")])[0]["set_verdict"]
    assert three["n"] == 3 and three["mean_error_pct"] == pytest.approx(1.0)
    # a test outside the identification's conditions is left out, as `vehval predict` does
    cold = res("f")
    cold["validation"]["normalised_error"]["outside_identification"] = True
    row = batch_set_verdicts([res("a"), res("b"), res("c"), cold])[0]
    assert row["tests"] == ["a", "b", "c"] and row["set_verdict"]["n"] == 3
