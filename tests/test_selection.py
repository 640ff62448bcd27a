"""One selection rule for every stage (:meth:`vehval.test.Test.best`).

A virtual Prius test gets a second fuel-rate channel: the facility's fuel meter is mapped
as ``fuel_rate_dyno_test`` (read 25 % high through the template's ``scale``) and the OBD
logger gains a CAN fuel rate ``fuel_rate_can_test`` (the true rate). Each stage must use
the same one: the one QA's selection kept when QA ran, else the documented rule (facility
before vehicle network). A 25 % gap makes the choice visible in every fuel figure.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml

from vehval.test import Signal, Test, TestMeta

DYNO, CAN = "fuel_rate_dyno_test", "fuel_rate_can_test"
BIAS = 1.25   # the dyno channel reads this much high (template scale)


# ----------------------------------------------------------------------- the rule itself
def _t(*names: str, values=None) -> Test:
    t = np.arange(0.0, 10.0, 0.5)
    test = Test(meta=TestMeta(test_id="x"))
    for n in names:
        test.add(Signal.standard(n, t, 1.0 + 0 * t if values is None else values(n, t)))
    return test


def test_rule_facility_before_network_then_qa_choice():
    test = _t(CAN, DYNO, "fuel_rate_calc")
    assert test.best("fuel_rate").name == DYNO                       # facility first
    assert test.best("fuel_rate", kept={CAN: "kept"}).name == CAN    # QA's choice wins
    assert test.best("fuel_rate", ("test",), kept=[]) is None         # QA kept none
    assert test.best("fuel_rate", kept=[]).name == "fuel_rate_calc"   # then calculated
    assert _t(CAN, "fuel_rate_test").best("fuel_rate").name == "fuel_rate_test"


def test_rule_skips_unusable_signals():
    test = _t(CAN, DYNO, values=lambda n, t: np.full(t.size, np.nan) if n == DYNO else 1 + 0 * t)
    assert test.best("fuel_rate").name == CAN


# ----------------------------------------------------------------------- virtual tests
def _short_udds():
    from vehval.cycles import Cycle, load_cycle

    udds = load_cycle("udds")
    keep = udds.time_s <= 240.0
    return Cycle.from_trace(udds.time_s[keep], udds.speed_mps[keep], "udds240",
                            description="first 240 s of the UDDS")


@pytest.fixture(scope="module")
def base_dir(tmp_path_factory) -> Path:
    """A virtual Prius test (no faults) with a dyno and a CAN fuel-rate channel."""
    from vehval.synth import make_virtual_test

    d = tmp_path_factory.mktemp("sel") / "vt"
    out = make_virtual_test(vehicle="prius_2004", cycle=_short_udds(), outdir=d, faults="none")
    clean = pd.read_parquet(out.clean_path)
    obd = out.files[1]
    frame = pd.read_csv(obd)
    frame["FUEL_RATE_CAN"] = np.round(
        np.interp(frame["Timestamp"], clean["time"], clean["fuel_rate"]) * 1e3, 4)
    frame.to_csv(obd, index=False)
    tpl = yaml.safe_load(out.template_path.read_text(encoding="utf-8"))
    tpl["files"][0]["channels"]["Eng_FuelFlow_Direct"] = {"name": DYNO, "unit": "ccps",
                                                          "scale": BIAS}
    tpl["files"][1]["channels"]["FUEL_RATE_CAN"] = {"name": CAN, "unit": "g/s"}
    out.template_path.write_text(yaml.safe_dump(tpl, sort_keys=False), encoding="utf-8")
    return d


def _variant(base: Path, tmp_path: Path, keep: list[str] | None = None) -> Path:
    d = tmp_path / "vt"
    shutil.copytree(base, d)
    if keep:
        tpl = yaml.safe_load((d / "template.yaml").read_text(encoding="utf-8"))
        tpl["selection"] = {"keep": keep}
        (d / "template.yaml").write_text(yaml.safe_dump(tpl, sort_keys=False), encoding="utf-8")
    return d


def _mass(sig: Signal) -> float:
    ok = np.isfinite(sig.values)
    return float(np.trapezoid(sig.values[ok], sig.time[ok]))


def _stage_choices(run) -> dict[str, str]:
    """The fuel-rate signal each stage used on ``run`` (a TestRun)."""
    from vehval.analysis.inputs import after_qa, prepare_inputs
    from vehval.batch.metrics import test_metrics
    from vehval.batch.task import _selected
    from vehval.report.plots import pick
    from vehval.validate.quantities import pick_signal

    out: dict[str, str] = {}
    doc = run.results().document
    used = [n for n in doc["uncertainty"]["accuracy"] if n.startswith("fuel_rate")]
    assert len(used) == 1, used
    out["results"] = used[0]
    # batch metrics read the imported test with QA's kept names: which integral is it?
    kept = _selected(run.qa_outcome.document) if run.qa_outcome is not None else None
    m = test_metrics(run.test, kept)["fuel_mass_kg"]
    masses = {n: _mass(run.test[n]) for n in (DYNO, CAN) if n in run.test}
    out["batch"] = min(masses, key=lambda n: abs(masses[n] - m))
    assert m == pytest.approx(masses[out["batch"]], rel=1e-9)
    work = after_qa(run.qa().result, run.test)[0] if run.use_qa else run.validated
    out["analysis"] = prepare_inputs(work, run.vehicle).sources["fuel rate"]
    out["validate"] = pick_signal(run.validated, "fuel_rate", "test").name
    out["report"] = pick(run.validated, "fuel_rate").name
    return out


def test_qa_choice_default_is_used_by_every_stage(base_dir, tmp_path):
    """QA keeps the facility meter (both agree in shape, no calculation to judge): all follow."""
    from vehval.workflow import TestRun

    run = TestRun.from_paths([_variant(base_dir, tmp_path)])
    sel = run.qa().result.selection
    assert DYNO in sel.kept and CAN in sel.dropped
    assert set(_stage_choices(run).values()) == {DYNO}


def test_qa_choice_can_is_used_by_every_stage(base_dir, tmp_path):
    """QA keeps the CAN channel (the template's selection.keep): every stage uses it, the
    batch metrics on the imported test too, and the next test imported with QA's
    template_final.yaml without QA."""
    from vehval.qa.select import save_final_template
    from vehval.workflow import TestRun

    d = _variant(base_dir, tmp_path, keep=[CAN])
    run = TestRun.from_paths([d])
    sel = run.qa().result.selection
    assert CAN in sel.kept and DYNO in sel.dropped
    assert set(_stage_choices(run).values()) == {CAN}
    final = save_final_template(run.template, sel, tmp_path / "template_final.yaml")
    again = TestRun.from_paths([d], final, use_qa=False)
    assert DYNO not in again.test
    assert set(_stage_choices(again).values()) == {CAN}


def test_qa_off_every_stage_follows_the_rule(base_dir, tmp_path):
    """Without QA both channels reach every stage: each takes the facility one."""
    from vehval.workflow import TestRun

    run = TestRun.from_paths([_variant(base_dir, tmp_path)], use_qa=False)
    assert DYNO in run.test and CAN in run.test
    assert set(_stage_choices(run).values()) == {DYNO}


def test_validation_fuel_is_the_chosen_channel(base_dir, tmp_path):
    """The validation's measured fuel mass is the integral of the channel QA kept."""
    from vehval.workflow import TestRun

    run = TestRun.from_paths([_variant(base_dir, tmp_path, keep=[CAN])])
    val = run.validate().validation
    m = val.comparison.totals_test["fuel_mass_kg"]
    assert m == pytest.approx(_mass(run.validated[CAN]), rel=0.02)   # grid vs own samples
    assert m != pytest.approx(_mass(run.test[DYNO]), rel=0.1)


# ----------------------------------------------------------------------- identification
@pytest.fixture(scope="module")
def conventional_dir(tmp_path_factory) -> Path:
    """A virtual conventional test whose D3 file also has a CAN fuel rate (true x 0.8)."""
    from vehval.cycles import load_cycle
    from vehval.synth.conventional import make_conventional_test
    from vehval.vehicle import load_vehicle

    d = tmp_path_factory.mktemp("selconv") / "vt"
    info = make_conventional_test(load_vehicle("cruze_diesel_2014"), load_cycle("hwfet"), seed=3,
                                  outdir=d)
    raw = Path(info["files"][0])
    lines = raw.read_text(encoding="utf-8").splitlines()
    head = lines[0].split("\t")
    i = head.index("Fuel_Flow_Bench_Modal[g/s]")
    rows = [lines[0] + "\tFuel_Flow_CAN[g/s]"]
    rows += [ln + f"\t{0.8 * float(ln.split(chr(9))[i]):.4f}" for ln in lines[1:]]
    raw.write_text("\n".join(rows) + "\n", encoding="utf-8")
    tpl = Path(info["template"])
    text = tpl.read_text(encoding="utf-8").replace(
        "{name: fuel_rate_test, unit: g/s}", "{name: fuel_rate_dyno_test, unit: g/s}")
    tpl.write_text(text + "      Fuel_Flow_CAN: {name: fuel_rate_can_test, unit: g/s}\n",
                   encoding="utf-8")
    return d


def test_identification_traces_follow_the_rule_and_qa_final_template(conventional_dir, tmp_path):
    from vehval.identify.loading import load_traces
    from vehval.io.template import load_template
    from vehval.workflow import TestRun

    raw = next(conventional_dir.glob("*_d3.txt"))
    tpl = load_template(conventional_dir / "template.yaml")
    test = TestRun.load([raw], tpl, use_qa=False).test
    dyno, can = test[DYNO], test[CAN]
    tr = load_traces([raw], tpl)[0]
    assert np.allclose(tr.fuel, dyno.at(tr.t), equal_nan=True)          # the rule: facility
    assert not np.allclose(tr.fuel, can.at(tr.t), equal_nan=True)
    # QA kept the CAN one (user keep): its template_final.yaml drops the dyno channel
    from vehval.qa.select import Selection, save_final_template

    final = save_final_template(tpl, Selection(kept={CAN: "kept by the user"},
                                               dropped={DYNO: "dropped by the user: CAN kept"}),
                                tmp_path / "template_final.yaml")
    tr2 = load_traces([raw], load_template(final))[0]
    assert np.allclose(tr2.fuel, can.at(tr2.t), equal_nan=True)
    assert tr2.results.to_dict()["uncertainty"]["accuracy"].keys() & {CAN}
