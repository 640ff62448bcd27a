"""`vehval validate QA_DIR` of a battery-electric test (the documented `vehval qa ... -o
out; vehval validate out`): the car the template named, with its SAE J1634 figures judged."""

from __future__ import annotations

import json

from helpers.cli import virtual_qa_output
from vehval.cli import main


def test_validate_of_a_bev_qa_output_judges_its_j1634_figures(tmp_path, capsys):
    q = virtual_qa_output(tmp_path, "bev/nissan_leaf_2016", capsys)
    assert main(["validate", str(q), "--dt", "1", "-o", str(tmp_path / "v")]) == 0
    doc = json.loads((tmp_path / "v" / "validation.json").read_text())
    j1634 = next(t for t in doc["tables"] if t["title"].startswith("SAE J1634 figures"))
    assert {r[1] for r in j1634["rows"]} == {"dc_wh_per_mile", "ac_kwh_per_100km", "mpge"}
    assert "test" in {r[0] for r in j1634["rows"]}
