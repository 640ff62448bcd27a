"""The test conditions an identification covered (cell temperature, coolant at the start)
and the warning of a prediction outside them."""

import json
from pathlib import Path

import numpy as np
import pytest

from helpers.data import CRUZE
from vehval.identify.conditions import (
    COND_MARGIN_C,
    conditions_warnings,
    identification_conditions,
    outside_conditions,
)
from vehval.identify.traces import Trace
from vehval.identify.warmup import COLD_COOLANT_C

HERE = Path(__file__).resolve().parent
TEMPLATE = HERE.parent / "qa" / "templates" / "cruze.yaml"


def _trace(test_id: str, cell: float, coolant: float) -> Trace:
    t = np.arange(0.0, 10.0, 0.1)
    z = np.zeros_like(t)
    return Trace(test_id=test_id, cycle="udds", t=t, v=z, a=z, force=z, w_eng=z, fuel=z,
                 phase=z, amb_temp_c=cell, coolant_start_c=coolant)


def test_the_ranges_count_each_test_for_what_it_identified():
    """Cell temperature: every test (the A/C load was fitted in the hot cell); coolant at the
    start: the fuel-map and cold-start tests only (the A/C load comes from later phases)."""
    cond = identification_conditions([_trace("hot", 22.6, 91.0), _trace("wltc", 24.0, 92.0)],
                                     cold_trace=_trace("cold", 22.5, 24.0),
                                     ac_trace=_trace("ac", 35.1, 10.0))
    assert cond["amb_temp_c"] == [22.5, 35.1]
    assert cond["coolant_start_c"] == [24.0, 92.0]
    assert [r["role"] for r in cond["tests"]] == ["fuel map", "fuel map", "warm-up", "A/C"]
    none = identification_conditions([_trace("x", float("nan"), float("nan"))])
    assert none["amb_temp_c"] is None and none["coolant_start_c"] is None
    assert none["tests"][0]["amb_temp_c"] is None                       # JSON-safe, not NaN


def test_outside_beyond_the_margin_and_warm_starts_are_one_condition():
    ident = {"conditions": identification_conditions([_trace("hot", 22.6, 91.0),
                                                      _trace("wltc", 24.0, 92.0)])}
    frozen = outside_conditions(ident, _trace("frozen", -6.6, -4.0))
    assert frozen == {"amb_temp_c": {"value": -6.6, "range": [22.6, 24.0]},
                      "coolant_start_c": {"value": -4.0, "range": [91.0, 92.0]}}
    # a cell within the margin of the range, and any warm start (thermostat-regulated)
    assert outside_conditions(ident, _trace("ok", 24.0 + 0.9 * COND_MARGIN_C, 80.0)) == {}
    assert outside_conditions(ident, _trace("warmish", 23.0, COLD_COOLANT_C)) == {}
    assert set(outside_conditions(ident, _trace("hot cell", 35.0, 95.0))) == {"amb_temp_c"}
    assert set(outside_conditions(ident, _trace("cold", 22.5, 24.0))) == {"coolant_start_c"}
    # not measured: not judged; a vehicle recording no conditions: unknown (None)
    assert outside_conditions(ident, _trace("n/a", float("nan"), float("nan"))) == {}
    assert outside_conditions({}, _trace("frozen", -6.6, -4.0)) is None
    assert outside_conditions(None, _trace("frozen", -6.6, -4.0)) is None


def test_one_warning_line_names_the_test_its_temperatures_and_the_range():
    ident = {"conditions": identification_conditions([_trace("hot", 22.6, 91.0),
                                                      _trace("wltc", 24.0, 92.0)])}
    rows = [{"test": t.test_id, "outside_identification": outside_conditions(ident, t)}
            for t in (_trace("frozen", -6.6, -4.0), _trace("fine", 23.0, 90.0))]
    lines = conditions_warnings(rows, ident)
    assert lines == [
        "frozen: cell -6.6 °C, coolant at the start -4 °C, outside the identification tests' "
        "cell 22.6 to 24 °C, coolant at the start 91 to 92 °C (hot, wltc): the model "
        "extrapolates, and its 95 % interval does not include the effect"]
    assert conditions_warnings([{"test": "x", "outside_identification": None}], {}) == []


@pytest.mark.realdata
@pytest.mark.skipif(not CRUZE.is_dir(), reason="real data not available")
def test_predict_of_the_cold_cruze_udds_warns(capsys):
    """The packaged cruze_diesel_2014 was identified at 22.6-24 °C (A/C load at 35 °C) from
    hot starts; the -6.6 °C cold UDDS (61410028) is predicted with one warning line, and the
    JSON row names what lies outside; the hot NEDC (80 °C coolant, 21.9 °C cell) is covered."""
    from vehval.cli import main

    files = [CRUZE / f"{i} Test Data.txt" for i in ("61410028", "61410005")]
    rc = main(["predict", "cruze_diesel_2014", *map(str, files), "-t", str(TEMPLATE),
               "--json"])
    assert rc == 0
    out, err = capsys.readouterr()
    warned = [line for line in err.splitlines() if "outside the identification" in line]
    assert len(warned) == 1 and warned[0].startswith("vehval: warning: 61410028 Test Data: "
                                                     "cell -6.6 °C, coolant at the start -4 °C")
    assert "cell 22.6 to 35.1 °C" in warned[0] and "coolant at the start 91 to 92 °C" in warned[0]
    rows = {r["test"]: r for r in json.loads(out)}
    frozen = rows["61410028 Test Data"]["outside_identification"]
    assert frozen["amb_temp_c"]["value"] == pytest.approx(-6.6, abs=0.05)
    assert frozen["amb_temp_c"]["range"] == pytest.approx([22.59, 35.05], abs=0.01)
    assert rows["61410005 Test Data"]["outside_identification"] == {}
