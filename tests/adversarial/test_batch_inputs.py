"""Batch under hostile folders: missing files, empty globs, symlinks out of the folder,
OUTDIR inside the input folder, documents beside the data, and resume after tampering."""

from __future__ import annotations

import json
import os

import pytest

from helpers.cli import TEMPLATE, write_d3
from vehval.batch import run_batch
from vehval.batch.discover import discover_tests
from vehval.io.template import load_template

TWO_FILES = TEMPLATE + """\
  - source: obd
    match: "*_obd.csv"
    time: {column: Time, unit: s}
    channels:
      Speed: {name: veh_spd_obd_test, unit: km/h}
"""


def _obd(path):
    rows = "\n".join(f"{i},{40 + (i % 7)}" for i in range(60))
    path.write_text(f"Time[s],Speed[km/h]\n{rows}\n")


def _run(d, t, out, **kw):
    kw.setdefault("steps", [])
    return run_batch(d, t, out, workers=0, report=kw.pop("report", False), progress=False, **kw)


def _by_id(res):
    return {r["test_id"]: r for r in res.results}


@pytest.fixture
def two_file_folder(tmp_path):
    d = tmp_path / "data"
    for name in ("a", "b"):
        (d / name).mkdir(parents=True)
        write_d3(d / name / f"{name}_d3.txt", n=200)
        _obd(d / name / f"{name}_obd.csv")
    (d / "b" / "b_d3.txt").unlink()          # test b lacks its D3 file
    t = tmp_path / "T.yaml"
    t.write_text(TWO_FILES)
    return d, t


def test_missing_required_file_fails_the_test(tmp_path, two_file_folder):
    """Was: a folder missing its D3 file ran on the OBD file alone with status ok."""
    d, t = two_file_folder
    res = _by_id(_run(d, t, tmp_path / "out"))
    assert res["a"]["status"] == "ok"
    assert res["b"]["status"] == "failed" and "files[0]" in res["b"]["error"]
    assert "optional: true" in res["b"]["error"]


def test_optional_entry_may_be_absent(tmp_path, two_file_folder):
    d, _ = two_file_folder
    t = tmp_path / "T2.yaml"
    t.write_text(TWO_FILES.replace('match: "*_d3.txt"', 'match: "*_d3.txt"\n    optional: true'))
    res = _by_id(_run(d, t, tmp_path / "out"))
    assert res["b"]["status"] == "ok"


def test_glob_matching_nothing_fails(tmp_path, two_file_folder):
    """Was: a match glob matching nothing ran on the other file with status ok."""
    d, _ = two_file_folder
    t = tmp_path / "T3.yaml"
    t.write_text(TWO_FILES.replace('"*_obd.csv"', '"*_can.mf4"'))
    res = _by_id(_run(d, t, tmp_path / "out"))
    assert res["a"]["status"] == "failed" and "files[1]" in res["a"]["error"]


def test_symlink_out_of_the_folder_is_not_followed(tmp_path):
    """Was: a symlink to a 0600 file outside was read and its first line copied into
    result.json, the catalog and index.html through an error message."""
    secret = tmp_path / "secret.txt"
    secret.write_text("TOPSECRET-LINE\n")
    secret.chmod(0o600)
    d = tmp_path / "data"
    d.mkdir()
    write_d3(d / "ok_d3.txt", n=100)
    os.symlink(secret, d / "leak_d3.txt")
    os.symlink(tmp_path, d / "up")
    t = tmp_path / "T.yaml"
    t.write_text(TEMPLATE)
    out = tmp_path / "out"
    ids = [s.test_id for s in discover_tests(d, load_template(t))]
    assert ids == ["ok_d3"]
    _run(d, t, out, report=True)
    for f in out.rglob("*"):
        if f.is_file():
            assert b"TOPSECRET" not in f.read_bytes(), f


def test_outdir_inside_input_folder_is_excluded(tmp_path):
    """Was: with OUTDIR equal to the input folder, the next run took tests/, assets/ and
    catalog.duckdb as tests."""
    t = tmp_path / "T.yaml"
    t.write_text(TEMPLATE)
    for case in ("same", "inside"):
        d = tmp_path / case
        (d / "t1").mkdir(parents=True)
        write_d3(d / "t1" / "t1_d3.txt", n=100)
        out = d if case == "same" else d / "results"
        first = _run(d, t, out, report=True)
        second = _run(d, t, out, report=True)
        assert [r["test_id"] for r in second.results] == ["t1"], out
        assert first.n_ok == 1 and second.n_skipped == 1


def test_template_without_match_ignores_documents(tmp_path):
    """Was: a template from `template init` (no match) took the PDF and SOURCE.txt as tests."""
    d = tmp_path / "data"
    d.mkdir()
    write_d3(d / "run_d3.txt", n=100)
    (d / "paper.pdf").write_bytes(b"%PDF-1.4\n")
    (d / "SOURCE.txt").write_text("Downloaded from the public database.\n")
    (d / "README.md").write_text("# data\n")
    t = tmp_path / "T.yaml"
    t.write_text(TEMPLATE.replace('    match: "*_d3.txt"\n', ""))
    assert [s.test_id for s in discover_tests(d, load_template(t))] == ["run_d3"]


@pytest.mark.parametrize("tamper", ["delete_report", "corrupt_findings"])
def test_resume_checks_recorded_output_hashes(tmp_path, tamper):
    """Was: resume trusted result.json alone (a deleted report.html or a corrupted
    findings.json counted as unchanged)."""
    d = tmp_path / "data"
    (d / "t1").mkdir(parents=True)
    write_d3(d / "t1" / "t1_d3.txt", n=100)
    t = tmp_path / "T.yaml"
    t.write_text(TEMPLATE)
    out = tmp_path / "out"
    first = _run(d, t, out, steps=["qa"], report=True)
    assert first.n_ok == 1
    tdir = out / "tests" / "t1"
    rec = json.loads((tdir / "result.json").read_text())
    assert set(rec["output_hashes"]) == set(rec["outputs"]) and "report.html" in rec["outputs"]
    if tamper == "delete_report":
        (tdir / "report.html").unlink()
    else:
        (tdir / "findings.json").write_text("{ corrupted")
    again = _run(d, t, out, steps=["qa"], report=True)
    assert again.n_skipped == 0 and again.n_ok == 1
    assert (tdir / "report.html").is_file()
    json.loads((tdir / "findings.json").read_text())
    third = _run(d, t, out, steps=["qa"], report=True)
    assert third.n_skipped == 1
