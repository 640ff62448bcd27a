"""The validated test holds no calculation that rests on a signal the selection dropped."""

import numpy as np

from vehval.equations.calc import compute
from vehval.qa.pipeline import _validated_test
from vehval.qa.select import Selection
from vehval.test import Signal, Test


def test_calculation_from_a_dropped_signal_is_recomputed_or_left_out():
    t = np.arange(0.0, 60.0, 0.1)
    work = Test([
        Signal.standard("ess_volt_test", t, 200.0 + np.sin(t), source="dyno"),
        Signal.standard("ess_curr_test", t, 20.0 * np.sin(t / 5), source="dyno"),
        Signal.standard("veh_spd_test", t, 10.0 + np.sin(t / 7), source="dyno"),
    ])
    calc = compute(work)
    assert "ess_pwr_calc" in calc.computed          # ess_volt x ess_curr
    sel = Selection(kept={"ess_volt_test": "ok", "veh_spd_test": "ok"},
                    dropped={"ess_curr_test": "sign_flip: reversed"})
    notes: list[str] = []
    validated = _validated_test(work, sel, calc, None, None, None, set(), notes)
    assert "ess_curr_test" not in validated
    assert "ess_pwr_calc" not in validated            # its only input was dropped
    assert "veh_acc_calc" in validated                # rests on kept signals only
    assert "ess_pwr_calc" in notes[0] and "ess_curr_test" in notes[0]


def test_nothing_recomputed_when_no_calculation_used_a_dropped_signal():
    t = np.arange(0.0, 30.0, 0.1)
    work = Test([Signal.standard("veh_spd_test", t, 5.0 + 0.1 * t, source="dyno"),
                 Signal.standard("amb_temp_test", t, 20.0 + 0 * t, source="dyno")])
    calc = compute(work)
    sel = Selection(kept={"veh_spd_test": "ok"}, dropped={"amb_temp_test": "range"})
    notes: list[str] = []
    validated = _validated_test(work, sel, calc, None, None, None, set(), notes)
    assert notes == [] and "veh_acc_calc" in validated
    np.testing.assert_array_equal(validated["veh_acc_calc"].values, work["veh_acc_calc"].values)
