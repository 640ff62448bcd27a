"""A virtual test's template names the vehicle it was made from, and `vehval validate`
without --vehicle validates that car (not the default Prius)."""

from __future__ import annotations

import json

from helpers.cli import virtual_qa_output
from vehval.cli import main


def test_validate_takes_the_template_vehicle(tmp_path, capsys):
    out = tmp_path / "p16"
    assert main(["synth", "--vehicle", "prius_2016", "--cycle", "steady:12mps:60s", "--seed",
                 "1", "--faults", "none", "-o", str(out)]) == 0
    assert "vehicle: prius_2016" in (out / "template.yaml").read_text()
    capsys.readouterr()
    assert main(["validate", str(out), "--dt", "1", "-o", str(tmp_path / "val")]) == 0
    intro = json.loads((tmp_path / "val" / "validation.json").read_text())["intro"]
    assert intro.startswith("prius_2016 ")
    # --vehicle still wins over the template's
    assert main(["validate", str(out), "--dt", "1", "--vehicle", "prius_2004",
                 "-o", str(tmp_path / "val4")]) == 0
    intro = json.loads((tmp_path / "val4" / "validation.json").read_text())["intro"]
    assert intro.startswith("prius_2004 ")


def test_a_conventional_virtual_test_is_not_validated_against_a_hybrid(tmp_path, capsys):
    out = tmp_path / "cruze"
    assert main(["synth", "--vehicle", "cruze_diesel_2014", "--cycle", "steady:15mps:60s",
                 "--seed", "1", "-o", str(out)]) == 0
    assert 'vehicle: "cruze_diesel_2014"' in (out / "template.yaml").read_text()
    capsys.readouterr()
    # validated against the template's car (the Cruze, judged test by test by its fuel's
    # En), never against the default hybrid
    assert main(["validate", str(out), "--dt", "1", "-o", str(tmp_path / "val")]) == 0
    assert "cruze: fuel " in capsys.readouterr().out
    doc = json.loads((tmp_path / "val" / "metrics.json").read_text())
    assert doc["vehicle"] == "cruze_diesel_2014" and doc["architecture"] == "conventional"


def test_a_conventional_virtual_test_is_marked_synthetic(tmp_path):
    """The conventional car's virtual test carries ``synthetic: true`` like the hybrid's and
    the battery-electric car's, so its report shows the virtual-test banner."""
    from vehval.io.importer import import_test
    from vehval.report.html import _is_virtual

    out = tmp_path / "cruze"
    assert main(["synth", "--vehicle", "cruze_diesel_2014", "--cycle", "steady:15mps:30s",
                 "--seed", "1", "--faults", "none", "-o", str(out)]) == 0
    test = import_test(sorted(out.glob("virtual_*")), out / "template.yaml")
    assert test.meta.synthetic
    assert _is_virtual(test, None)


def test_validate_of_a_qa_output_takes_the_vehicle_its_template_named(tmp_path, capsys):
    """`vehval validate QA_DIR` (the documented `vehval qa ... -o out; vehval validate out`)
    validates the car the test's template named, not the default Prius."""
    q = virtual_qa_output(tmp_path, "cruze_diesel_2014", capsys)
    assert main(["validate", str(q), "--dt", "1", "-o", str(tmp_path / "val")]) == 0
    assert "does not match test" not in capsys.readouterr().err
    doc = json.loads((tmp_path / "val" / "metrics.json").read_text())
    assert doc["vehicle"] == "cruze_diesel_2014" and doc["architecture"] == "conventional"
