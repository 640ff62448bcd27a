"""`vehval validate --report` of a power-split hybrid: the test's own report states its
verdict by the normalised error En (and its ladder row), as the screen and the suite's
validation.json do; it showed only the |d|/u table."""

from __future__ import annotations

import json

from vehval.cli import main


def test_hybrid_validation_report_states_the_tests_en(tmp_path, capsys):
    out = tmp_path / "p04"
    assert main(["synth", "--vehicle", "prius_2004", "--cycle", "steady:12mps:60s", "--seed",
                 "1", "--faults", "none", "-o", str(out)]) == 0
    assert main(["validate", str(out), "--dt", "1", "--report", "-o", str(tmp_path / "v")]) == 0
    html = (tmp_path / "v" / "report.html").read_text(encoding="utf-8")
    suite = json.loads((tmp_path / "v" / "validation.json").read_text())
    en = next(t for t in suite["tables"] if t["title"].startswith("Verdict by the normalised"))
    assert "Verdict by the normalised error (fuel mass)" in html and "Validation ladder" in html
    assert f"{en['rows'][0][7]:.4g}" in html           # the En of validation.json
