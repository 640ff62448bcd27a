"""The Test data model: multi-rate signals and explicit resampling."""

import numpy as np
import pytest

from vehval.errors import SignalError
from vehval.test import Signal, Test, resample_values


def _test():
    t10 = np.arange(0, 10.0001, 0.1)
    t1 = np.arange(0, 11.0) + 0.5
    return Test([
        Signal.standard("eng_spd_out_test", t10, 2 * t10, source="dyno"),
        Signal.standard("test_phase_test", t1, np.floor(t1 / 4), source="obd"),
    ])


def test_resample_methods_declared_and_applied():
    test = _test()
    frame, used = test.resample(np.array([1.0, 4.7, 5.05]))
    assert used == {"eng_spd_out_test": "linear", "test_phase_test": "previous"}
    assert frame.attrs["resample"] == used
    np.testing.assert_allclose(frame["eng_spd_out_test"], [2.0, 9.4, 10.1], atol=1e-12)
    # previous value: at 4.7 s the last sample is t=4.5 (phase floor(4.5/4)=1)
    np.testing.assert_array_equal(frame["test_phase_test"], [0.0, 1.0, 1.0])


def test_outside_span_is_nan_and_shift_recorded():
    test = _test()
    assert np.isnan(test["eng_spd_out_test"].at(np.array([-1.0, 11.0]))).all()
    test.shift_source("obd", -0.5)
    assert test["test_phase_test"].time[0] == 0.0
    assert test.meta.offsets_s == {"obd": -0.5}


def test_duplicate_signal_rejected():
    test = _test()
    with pytest.raises(SignalError, match="defined twice"):
        test.add(Signal.standard("eng_spd_out_test", [0, 1], [0, 1]))


def test_resample_values_linear_hand_case():
    out = resample_values(np.array([0.0, 2.0]), np.array([0.0, 10.0]), np.array([0.5, 2.0, 3.0]), "linear")
    np.testing.assert_allclose(out[:2], [2.5, 10.0])
    assert np.isnan(out[2])
