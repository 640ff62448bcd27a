"""`vehval validate QA_DIR` of a battery-electric test (the documented `vehval qa ... -o
out; vehval validate out`): the car the template named, with its SAE J1634 figures judged."""

from __future__ import annotations

import json

from vehval.cli import main


def test_validate_of_a_bev_qa_output_judges_its_j1634_figures(tmp_path, capsys):
    out = tmp_path / "leaf"
    assert main(["synth", "--vehicle", "bev/nissan_leaf_2016", "--cycle", "steady:15mps:60s",
                 "--seed", "1", "--faults", "none", "-o", str(out)]) == 0
    files = [str(f) for f in sorted(out.glob("virtual_*"))]
    assert main(["qa", *files, "-t", str(out / "template.yaml"), "-o", str(tmp_path / "q")]) == 0
    capsys.readouterr()
    assert main(["validate", str(tmp_path / "q"), "--dt", "1", "-o", str(tmp_path / "v")]) == 0
    doc = json.loads((tmp_path / "v" / "validation.json").read_text())
    j1634 = next(t for t in doc["tables"] if t["title"].startswith("SAE J1634 figures"))
    assert {r[1] for r in j1634["rows"]} == {"dc_wh_per_mile", "ac_kwh_per_100km", "mpge"}
    assert "test" in {r[0] for r in j1634["rows"]}
