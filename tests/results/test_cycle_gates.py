"""Plausibility gates on the cycle: a speed scale against the cycle's distance, the bags of a
phase channel against the cycle's phase table, and a whole-test headline without a cycle.

Each case is a virtual UDDS test (known truth: the speed follows the cycle, the phase channel
marks its bags) with one mutation of its template or file; the figures it would state wrong
are withheld (exit 4) by an error finding naming the factor or the offset. The same cases on
the real Cruze files skip when the data are absent.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from helpers.data import CRUZE, REAL
from vehval.synth import make_virtual_test

HERE = Path(__file__).resolve().parent
CRUZE_TEMPLATE = HERE.parents[0] / "qa" / "templates" / "cruze.yaml"
CAMRY = REAL / "d3_2018_toyota_camry_1hz_subset"
SPEED_LINE = "Dyno_Speed: {name: veh_spd_test, unit: mph}"


@pytest.fixture(scope="module")
def vt(tmp_path_factory):
    """A virtual prius_2004 UDDS test without faults: (files, template text, directory)."""
    d = tmp_path_factory.mktemp("cyclegates")
    out = make_virtual_test(vehicle="prius_2004", cycle="udds", seed=3, faults="none",
                            outdir=d / "vt")
    return [Path(f) for f in out.files], out.template_path.read_text(encoding="utf-8"), d


def _template(vt, tmp_path, old: str = "", new: str = "") -> Path:
    text = vt[1]
    if old:
        assert old in text
        text = text.replace(old, new)
    p = tmp_path / "template.yaml"
    p.write_text(text, encoding="utf-8")
    return p


def shift_phase(src: Path, dst: Path, shift_s: float) -> None:
    """Copy a D3 file with its ``Phase_#`` column ``shift_s`` seconds late."""
    lines = src.read_text(encoding="latin-1").splitlines()
    head = lines[0].split("\t")
    ip = next(i for i, h in enumerate(head) if h.startswith("Phase_#"))
    rows = [r.split("\t") for r in lines[1:]]
    t = np.array([float(r[0]) for r in rows])
    n = int(round(shift_s / float(np.median(np.diff(t)))))
    col = [r[ip] for r in rows]
    col = ["0"] * n + col[:len(col) - n]
    for r, v in zip(rows, col):
        r[ip] = v
    dst.write_text("\n".join([lines[0]] + ["\t".join(r) for r in rows]) + "\n",
                   encoding="latin-1")


def _qa_errors(outdir: Path, signal: str) -> list[dict]:
    doc = json.loads((outdir / "findings.json").read_text())
    return [f for f in doc["findings"] if f["signal"] == signal and f["severity"] == "error"]


# ------------------------------------------------------------------ virtual dyno
def test_true_test_states_its_figures(vt, cli, tmp_path):
    code, out, err = cli("results", *vt[0], "-t", _template(vt, tmp_path), "-o", tmp_path / "o")
    assert code == 0, out + err
    assert "WITHHELD" not in out and "speed scale" not in out and "off the cycle's" not in out
    doc = json.loads((tmp_path / "o" / "results.json").read_text())
    assert doc["headline"]["name"] == "udds" and doc["withheld_count"] == 0


@pytest.mark.parametrize("declare_cycle", [True, False])
def test_speed_scale_1_1_is_named_and_withholds_the_headline(vt, cli, tmp_path, declare_cycle):
    tpl = _template(vt, tmp_path, SPEED_LINE, SPEED_LINE.replace("mph}", "mph, scale: 1.1}"))
    if not declare_cycle:            # identified from another speed, or not at all
        tpl.write_text(tpl.read_text().replace("cycle: udds\n", ""))
    code, out, _ = cli("results", *vt[0], "-t", tpl, "-o", tmp_path / "o")
    assert code == 4, out
    assert "WITHHELD (veh_spd_test)" in out and "speed scale" in out
    assert "1.1000 x" in out and "remove 'scale: 1.1' from Dyno_Speed" in out
    doc = json.loads((tmp_path / "o" / "results.json").read_text())
    assert doc["headline"]["fuel_economy_mpg"] is None and doc["headline"]["withheld"]
    err, = _qa_errors(tmp_path / "o", "veh_spd_test")
    assert err["numbers"]["factor"] == pytest.approx(1.10, abs=0.005)
    assert err["numbers"]["declared_scale"] == 1.1


def test_speed_scale_3_percent_on_an_identified_cycle(vt, cli, tmp_path):
    tpl = _template(vt, tmp_path, SPEED_LINE, SPEED_LINE.replace("mph}", "mph, scale: 1.03}"))
    code, out, _ = cli("results", *vt[0], "-t", tpl, "-o", tmp_path / "o")
    assert code == 4, out
    assert "covers 1.0300 x the distance of udds" in out
    err, = _qa_errors(tmp_path / "o", "veh_spd_test")
    assert err["numbers"]["identified"] is True


def test_a_scale_within_the_tolerance_passes(vt, cli, tmp_path):
    tpl = _template(vt, tmp_path, SPEED_LINE, SPEED_LINE.replace("mph}", "mph, scale: 1.01}"))
    code, out, _ = cli("results", *vt[0], "-t", tpl, "-o", tmp_path / "o")
    assert code == 0 and "speed scale" not in out, out


def test_phase_channel_60_s_late_withholds_bags_and_composites(vt, cli, tmp_path):
    files = list(vt[0])
    late = tmp_path / files[0].name
    shift_phase(files[0], late, 60.0)
    code, out, _ = cli("results", late, files[1], "-t", _template(vt, tmp_path),
                       "-o", tmp_path / "o")
    assert code == 4, out
    assert "WITHHELD (test_phase_test)" in out and "+60.0 s" in out
    doc = json.loads((tmp_path / "o" / "results.json").read_text())
    for p in doc["phases"]:
        assert p["values"]["fuel_economy_mpg"] is None
        assert p["withheld"]["signals"] == ["test_phase_test"]
    assert all(c["values"]["fuel_economy_mpg"] is None for c in doc["composites"])
    assert doc["test_total"]["values"]["fuel_economy_mpg"] > 0     # no phase in it: stated
    found = [f for f in doc["findings"] if f["signal"] == "test_phase_test"]
    assert {f["numbers"]["part"] for f in found} == {"bag1", "bag2"}
    assert all(f["severity"] == "error" and f["fix"] for f in found)
    assert found[0]["numbers"]["start_offset_s"] == pytest.approx(60.0, abs=0.2)


def test_phase_channel_3_s_late_in_idle_is_harmless(vt, cli, tmp_path):
    files = list(vt[0])
    late = tmp_path / files[0].name
    shift_phase(files[0], late, 3.0)     # the UDDS bag marks at 0 s and 505 s fall in idle
    code, out, _ = cli("results", late, files[1], "-t", _template(vt, tmp_path),
                       "-o", tmp_path / "o")
    assert code == 0 and "off the cycle's" not in out, out


def test_no_identified_cycle_headline_says_so():
    from vehval.results import compute_results
    from vehval.results.gate import NO_CYCLE_CAVEAT

    from .helpers import make_test, true_signals

    t, s = true_signals("udds")
    keep = t < 400.0                     # a fragment: no package cycle
    test = make_test(t[keep], {k: v[keep] for k, v in s.items()}, cycle="", phase=False)
    res = compute_results(test, fuel="diesel")
    head = res.headline()
    assert res.cycle == "" and head["name"] == "test"
    assert head["caveats"] == [NO_CYCLE_CAVEAT]
    from vehval.cli.commands_results import headline_lines

    lines = headline_lines({"headline": head})
    assert lines[1].startswith("  ! caveat: no drive cycle identified")


# ------------------------------------------------------------------ real files
def _cruze(n: str) -> Path:
    return CRUZE / f"{n} Test Data.txt"


@pytest.mark.realdata
@pytest.mark.skipif(not CRUZE.is_dir(), reason="real data not available")
def test_cruze_hwfet_speed_scale_1_1(cli, tmp_path):
    tpl = tmp_path / "t.yaml"
    tpl.write_text(CRUZE_TEMPLATE.read_text().replace(
        SPEED_LINE, SPEED_LINE.replace("mph}", "mph, scale: 1.1}")))
    code, out, _ = cli("results", _cruze("61410015"), "-t", tpl, "-o", tmp_path / "o")
    assert code == 4 and "57.89" not in out, out
    assert "follows hwfet_x2 once divided by 1.10" in out and "WITHHELD (veh_spd_test)" in out


@pytest.mark.realdata
@pytest.mark.skipif(not CRUZE.is_dir(), reason="real data not available")
def test_cruze_udds_phase_channel_60_s_late(cli, tmp_path):
    late = tmp_path / "61410012 Test Data.txt"
    shift_phase(_cruze("61410012"), late, 60.0)
    code, out, _ = cli("results", late, "-t", CRUZE_TEMPLATE, "-o", tmp_path / "o")
    assert code == 4, out
    assert "phase 2 (bag2) of test_phase_test is off the cycle's bag2" in out
    assert "WITHHELD (test_phase_test)" in out


@pytest.mark.realdata
@pytest.mark.skipif(not (CRUZE.is_dir() and CAMRY.is_dir()), reason="real data not available")
def test_real_files_raise_no_scale_or_bag_finding(tmp_path):
    """The 10 Cruze and 4 Camry tests: no speed scale, no bag off its cycle part."""
    import yaml

    from vehval.workflow import TestRun

    camry = tmp_path / "camry.yaml"
    camry.write_text(yaml.safe_dump({"template_version": 1, "fuel": "gasoline_e10", "files": [{
        "source": "dyno", "format": "d3", "time": {"column": "Time"}, "channels": {
            "Eng_FuelFlow_Direct_DI": {"name": "fuel_rate_test", "unit": "ccps"},
            "Dyno_Spd": {"name": "veh_spd_test", "unit": "mph"}}}]}))
    cases = [(f, CRUZE_TEMPLATE) for f in sorted(CRUZE.glob("6*Test Data.txt"))]
    cases += [(f, camry) for f in sorted(CAMRY.glob("6*Test Data.txt"))]
    assert len(cases) == 14
    for f, tpl in cases:
        run = TestRun.load([f], tpl, None)
        res = run.results().results
        scale = [x for x in run.qa_outcome.result.findings if "speed scale" in x.message]
        bags = [x for x in res.findings if "off the cycle's" in x.message]
        assert not scale and not bags, (f.name, scale, bags)


@pytest.mark.parametrize("declare_cycle", [True, False])
def test_a_time_column_in_ms_declared_s_is_named_and_withholds(vt, cli, tmp_path,
                                                               declare_cycle):
    """The D3 file's time in ms under a `Time[sec]` header: the declared cycle is not
    found, no speed factor explains it, and the figures read 1000 x the distance (7450 mi,
    exit 0 with `cycle:` declared). The speed follows the cycle once the time is read
    x 0.001: an error on the speed withholds them, naming the slip."""
    d3 = next(f for f in vt[0] if f.name.endswith("_d3.txt"))
    lines = d3.read_text(encoding="latin-1").splitlines()
    rows = [r.split("\t") for r in lines[1:]]
    for r in rows:
        r[0] = f"{1000 * float(r[0]):.1f}"
    slow = tmp_path / d3.name
    slow.write_text("\n".join([lines[0]] + ["\t".join(r) for r in rows]) + "\n",
                    encoding="latin-1")
    tpl = _template(vt, tmp_path, "  source: obd\n", "  source: obd\n  optional: true\n")
    if not declare_cycle:
        tpl.write_text(tpl.read_text().replace("cycle: udds\n", ""))
    code, out, _ = cli("results", slow, "-t", tpl, "-o", tmp_path / "o")
    assert code == 4, out
    assert "follows udds once the time is read x 0.001 (a time column in ms declared s?)" in out
    doc = json.loads((tmp_path / "o" / "results.json").read_text())
    assert doc["headline"]["fuel_economy_mpg"] is None and doc["headline"]["withheld"]
