"""No figure has two units on one axis, and none shows an SI unit the display system
replaces (rad/s, kg/s, m/s): every figure of the report and every finding figure of the
workbench, on a virtual Prius and on the conventional virtual car (default faults: spikes,
a sign flip, a fuel meter reading high...)."""

from __future__ import annotations

import re

import pytest

from vehval.cli import main

SI_SHOWN = re.compile(r"\[(rad/s|kg/s|m/s|m/s\*\*2)\]")


def _run(vehicle: str, tmp_path):
    from vehval.workflow import TestRun

    d = tmp_path / vehicle
    assert main(["synth", "--vehicle", vehicle, "--cycle", "udds", "--seed", "3",
                 "-o", str(d)]) == 0
    files = sorted(p for p in d.iterdir() if p.name.endswith(("_d3.txt", "_obd.csv")))
    return TestRun.load(files, d / "template.yaml")


def _axes(fig: dict) -> dict[str, set[str]]:
    from vehval.report.finding_figures import panel_units

    units = panel_units(fig)
    for axis, found in units.items():
        assert len(found) == 1, (axis, found, fig["layout"].get("title"))
        title = ((fig["layout"].get(axis) or {}).get("title") or {})
        text = title.get("text", "") if isinstance(title, dict) else str(title)
        assert len(re.findall(r"\[[^\]]+\]", text)) <= 1, text   # one unit in the title
        assert not SI_SHOWN.search(text), text
    return units


@pytest.mark.slow
@pytest.mark.parametrize("vehicle", ["prius_2004", "cruze_diesel_2014"])
def test_one_unit_per_axis_in_report_and_finding_figures(vehicle, tmp_path):
    from vehval.report.finding_figures import finding_figure
    from vehval.report.html import build_sections
    from vehval.results.all_findings import stage_findings

    run = _run(vehicle, tmp_path)
    qa = run.qa()
    results = run.results().results
    secs = build_sections(qa.validated, qa.result, template=run.template, vehicle=run.vehicle,
                          results=results, raw=run.test)
    n = 0
    for sec in secs:
        for spec in sec.figures:
            _axes(spec.figure)
            n += 1
    assert n > 5
    kinds = set()
    for f in stage_findings(qa.document, results.to_dict()):
        fig = finding_figure(qa.validated, f, results=results.to_dict(),
                             calc=qa.result.calculations, vehicle=run.vehicle,
                             imported=run.test)
        units = _axes(fig)
        assert list(fig["layout"]["meta"]["units"]) == [next(iter(v)) for v in units.values()]
        kinds.add(f["kind"])
    assert "spike" in kinds
