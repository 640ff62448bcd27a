"""QA on real public files (skipped when the shared data directory is absent).

Cruze D3 files are imported with tests/qa/templates/cruze.yaml (test mass 3808 lb and the
target A, B, C of the D3 master summary, see the template).
Every other real file is imported with a template proposed by `template init` logic: the
point there is only that nothing crashes.
"""

import json
from pathlib import Path

import numpy as np
import pytest

from helpers.data import CRUZE, REAL
from vehval.qa.findings import Kind, Severity
from vehval.qa.pipeline import run_qa

HERE = Path(__file__).resolve().parent

pytestmark = [pytest.mark.realdata,
              pytest.mark.skipif(not CRUZE.is_dir(), reason="real data not available")]


def _qa(path):
    from vehval.io.importer import import_test
    test = import_test([path], HERE / "templates" / "cruze.yaml")
    return run_qa(test)


def test_cruze_wot_all_zero_fuel_and_force_check():
    res = _qa(CRUZE / "61410007 Test Data.txt")
    zero = [f for f in res.findings if f.kind == Kind.ALL_ZERO]
    assert [(f.signal, f.severity) for f in zero] == [("fuel_rate_test", Severity.ERROR)]
    assert "fuel_rate_test" in res.selection.dropped
    row = [r for r in res.table3 if r.measured == "veh_frc_in_test"][0]
    # dyno force vs m·a + A + B v + C v²: the check runs and agrees in shape
    assert row.r2 > 0.9
    print(f"\n61410007 vehicle-force check: R2 {row.r2:.3f}, mean |diff| {row.mean_abs_diff:.0f} N "
          f"= {100 * row.rel_diff:.1f} % of range, slope {row.slope:.3f}, offset {row.offset:.0f} N")


def test_cruze_negative_fuel_at_idle_found():
    hits = []
    for name in ("61410012 Test Data.txt", "61410005 Test Data.txt", "61410028 Test Data.txt"):
        res = _qa(CRUZE / name)
        neg = [f for f in res.findings if f.kind == Kind.NEGATIVE and f.signal == "fuel_rate_test"]
        hits.append(bool(neg))
        if neg:
            assert neg[0].numbers["value"] < 0
        json.dumps(res.to_dict())              # the document is JSON-serialisable
    assert all(hits)


def _propose_and_qa(path):
    """Proposed template, completed the way a user would: a fuel density for volumetric
    fuel channels and channels with no unit anywhere deleted."""
    from vehval.io.importer import import_test
    from vehval.io.propose import propose_template
    from vehval.io.readers import read_raw
    from vehval.nomenclature import registry
    tpl, _ = propose_template([path])
    if tpl.constants.fuel_density_kg_per_m3 is None:
        tpl.constants.fuel_density_kg_per_m3 = 745.0
    raw = read_raw(path)
    units = dict(zip(raw.names, raw.units))
    for spec in tpl.files:
        for key, ch in spec.channels.items():
            if ch.delete or ch.unit or units.get(key):
                continue
            if registry().spec_of(ch.name).unit not in ("dimensionless", ""):
                spec.channels[key] = ch.model_copy(update={"delete": True, "name": None,
                                                           "reason": "no unit known"})
    test = import_test([path], tpl, repair_time=True)
    return run_qa(test, None, tpl)


@pytest.mark.parametrize("path", sorted(p for p in REAL.glob("*/*") if p.suffix in (".txt", ".csv")
                                        and p.name != "SOURCE.txt") if REAL.is_dir() else [],
                         ids=lambda p: f"{p.parent.name[:12]}-{p.stem[:10]}")
def test_nothing_crashes_on_real_files(path):
    from vehval.errors import VehvalError
    try:
        res = _propose_and_qa(path)
    except VehvalError as exc:          # a clear user-facing error is acceptable, a crash is not
        pytest.skip(f"import refused with a clear error: {exc}")
    d = res.to_dict()
    json.dumps(d)
    assert set(d) >= {"test", "alignment", "findings", "table2", "table3", "calculations",
                      "selection", "summary"}
    assert np.isfinite(d["test"]["duration_s"])


PRIUS_C = REAL / "obd_2014_toyota_prius_c"
CAMRY = REAL / "d3_2018_toyota_camry_1hz_subset"


def _no_quantisation_spike_or_stuck_error(res, test):
    from vehval.qa.level1_shape import resolution
    stuck = [f.message for f in res.findings if f.kind == Kind.STUCK
             and f.severity == Severity.ERROR]
    assert stuck == []
    for f in res.findings:
        if f.kind == Kind.SPIKE and f.severity != Severity.INFO:
            q = resolution(test[f.signal].values)
            assert abs(f.numbers["deviation"]) > 2 * q, f.message


@pytest.mark.skipif(not PRIUS_C.is_dir(), reason="real data not available")
def test_prius_c_logs_raise_no_quantisation_spike_and_no_stuck_error():
    from vehval.io.importer import import_test
    from vehval.io.template import load_template
    tpl = load_template(HERE.parent / "io" / "templates" / "prius_c_obd.yaml")
    for path in sorted(PRIUS_C.glob("output*.csv")):
        test = import_test([path], tpl, repair_time=True)
        _no_quantisation_spike_or_stuck_error(run_qa(test, None, tpl), test)


@pytest.mark.skipif(not PRIUS_C.is_dir(), reason="real data not available")
def test_prius_c_no_answer_values_are_counted_gaps_not_range_errors():
    # 118.5 % / 0 % in SOC_ig_on and 0 kPa in the mode-01 pressures are the loggers' "no
    # answer" frames: declared as invalid_values they become NaN with the count in the notes
    from vehval.io.importer import import_test
    from vehval.io.template import load_template
    tpl = load_template(HERE.parent / "io" / "templates" / "prius_c_obd.yaml")
    test = import_test([PRIUS_C / "output7.csv"], tpl, repair_time=True)
    notes = test["ess_soc_ig_on_test"].notes
    assert any(n.startswith("3 sample(s) equal to invalid value(s) [118.5, 0.0]") for n in notes)
    assert int(np.isnan(test["amb_pres_test"].values).sum()) == 2
    assert "aux_volt_obd_test" not in test.names      # eng2bp is a minute counter, deleted
    for path in sorted(PRIUS_C.glob("output*.csv")):
        res = run_qa(import_test([path], tpl, repair_time=True), None, tpl)
        assert [f.message for f in res.findings if f.kind == Kind.RANGE
                and f.severity != Severity.INFO] == [], path.name


@pytest.mark.skipif(not CAMRY.is_dir(), reason="real data not available")
def test_camry_fuel_spikes_are_only_the_isolated_outliers():
    # docs/qa.md lists the 5 remaining warnings with their evidence
    total = 0
    for path in sorted(CAMRY.glob("6*Test Data.txt")):
        res = _propose_and_qa(path)
        warn = [f for f in res.findings if f.severity != Severity.INFO]
        assert {(f.kind, f.signal) for f in warn} <= {(Kind.SPIKE, "fuel_rate_test")}
        total += len(warn)
    assert total <= 5


def test_cruze_tests_raise_no_warning_and_only_the_unmeasured_fuel_error():
    for path in sorted(CRUZE.glob("6*Test Data.txt")):
        res = _qa(path)
        bad = [(f.severity, f.kind, f.signal) for f in res.findings if f.severity != Severity.INFO]
        expected = ([(Severity.ERROR, Kind.ALL_ZERO, "fuel_rate_test")]
                    if path.name.startswith("61410007") else [])
        assert bad == expected, (path.name, [f.message for f in res.findings
                                             if f.severity != Severity.INFO])
