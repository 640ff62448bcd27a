"""Inputs of the report tests: a small multi-source Test, a QA dict shaped like findings.json,
control and validation documents.

Imported by the tests of this folder (and its conftest); fixtures stay in conftest.py.
"""

from __future__ import annotations

import json
from functools import lru_cache

import numpy as np

from vehval.test import Signal, Test, TestMeta

LHV = 42.6e6


def make_test(duration_s: float = 300.0, dt: float = 0.1, synthetic: bool = True) -> Test:
    """Dyno 10 Hz + OBD 1 Hz signals of a smooth drive, with one NaN gap and one spike."""
    t = np.arange(0.0, duration_s, dt)
    v = 12.0 * np.sin(t / 40.0) ** 2                              # [m/s]
    acc = np.gradient(v, t)
    w_eng = 200.0 + 50.0 * np.sin(t / 7.0)                         # [rad/s]
    trq = 60.0 + 20.0 * np.sin(t / 5.0)                            # [N·m]
    fuel = (2.7 * w_eng * trq + 4000.0) / LHV                      # Willans: slope 2.7, 4 kW
    curr = 20.0 * np.sin(t / 3.0)
    curr[100] = 250.0                                              # a spike
    ess_pwr = 200.0 * curr
    gap = curr.copy()
    gap[500:520] = np.nan
    sig = Signal.standard
    sigs = [
        sig("veh_spd_test", t, v, source="dyno", raw_name="Dyno_Speed", raw_unit="mph", file="t_d3.txt"),
        sig("eng_spd_out_test", t, w_eng, source="dyno", raw_name="Engine_Speed", raw_unit="rpm", file="t_d3.txt"),
        sig("eng_trq_out_test", t, trq, source="dyno", raw_name="Eng_Trq", raw_unit="N*m", file="t_d3.txt"),
        sig("fuel_rate_test", t, fuel, source="dyno", raw_name="Fuel_Flow", raw_unit="g/s", file="t_d3.txt"),
        sig("ess_curr_test", t, gap, source="dyno", raw_name="Bty_Curr", raw_unit="A", file="t_d3.txt"),
        sig("ess_pwr_test", t, ess_pwr, source="dyno", file="t_d3.txt"),
        sig("veh_frc_loss_test", t, 88.6 + 0.14 * v + 0.36 * v ** 2, source="dyno"),
        sig("veh_frc_in_test", t, 1295 * acc + 88.6 + 0.14 * v + 0.36 * v ** 2, source="dyno"),
        sig("veh_spd_obd_test", t[::10], v[::10] + 0.1, source="obd", raw_name="VSS", raw_unit="km/h",
            file="t_obd.csv"),
        sig("mot_trq_out_test", t, 50.0 * np.cos(t / 9.0), source="dyno"),
        sig("mot_spd_out_test", t, v / 0.305 * 4.113, source="dyno"),
        sig("mot_trq_out_calc", t, 52.0 * np.cos(t / 9.0), source="calc"),
    ]
    meta = TestMeta(test_id="T-report", vehicle="", cycle="udds", files=["t_d3.txt", "t_obd.csv"],
                    template="prius_d3.yaml", synthetic=synthetic,
                    deleted=[{"channel": "Test_Cell_RH", "file": "t_d3.txt", "reason": "not used"}],
                    offsets_s={"obd": 1.2}, constants={"fuel_lhv_j_per_kg": LHV})
    return Test(sigs, meta)


def make_qa() -> dict:
    """A QA result with the structure of findings.json (vehval.qa)."""
    return {
        "test": {"test_id": "T-report"},
        "alignment": [{"source": "obd", "reference": "dyno", "offset_s": 1.2, "confidence": 0.93,
                       "applied": True, "corr_before": 0.97, "corr_after": 0.999, "agreement": 1.0,
                       "message": "1 pair",
                       "pairs": [{"ref": "veh_spd_test", "other": "veh_spd_obd_test", "kind": "duplicate",
                                  "offset_s": 1.2, "peak_corr": 0.999, "second_ratio": 0.1,
                                  "confidence": 0.93, "corr_before": 0.97, "corr_after": 0.999}]}],
        "findings": [
            {"signal": "ess_curr_test", "kind": "spike", "level": 1, "severity": "warning", "start_s": 10.0,
             "end_s": 10.0, "message": "1 spike", "numbers": {"value": 250.0}, "related": []},
            {"signal": "ess_curr_test", "kind": "nan_gap", "level": 1, "severity": "warning", "start_s": 50.0,
             "end_s": 51.9, "message": "20 missing samples", "numbers": {"count": 20}, "related": []},
            {"signal": "veh_spd_test", "kind": "range", "level": 1, "severity": "error", "start_s": 100.0,
             "end_s": 120.0, "message": "outside", "numbers": {"value": 75.0, "limit_min": -2.0,
                                                               "limit_max": 70.0}, "related": []},
            {"signal": "veh_spd_obd_test", "kind": "gain", "level": 2, "severity": "info", "start_s": 0.0,
             "end_s": 290.0, "message": "gain 1.0", "numbers": {}, "related": ["veh_spd_test"]},
        ],
        "table2": [{"base": "veh_spd", "ref": "veh_spd_test", "other": "veh_spd_obd_test", "n": 290, "r2": 0.998,
                    "r": 0.999, "mean_abs_diff": 0.1, "mean_rel_diff": 0.02, "slope": 1.0, "offset": 0.1,
                    "residual_lag_s": None, "ref_range": 12.0, "unit": "m/s", "start_s": 0.0, "end_s": 290.0,
                    "notes": []}],
        "table3": [{"base": "mot_trq_out", "measured": "mot_trq_out_test", "calculated": "mot_trq_out_calc",
                    "n": 3000, "mean_abs_diff": 1.3, "test_range": 100.0, "rel_diff": 0.013, "r2": 0.99,
                    "slope": 0.96, "offset": 0.0, "unit": "N*m", "inputs": {"whl_trq_out": "whl_trq_out_test"}}],
        "calculations": [{"signal": "mot_trq_out_calc", "equation": "T_mot = T_wheel / ratio_fd - T_ring",
                          "inputs": ["whl_trq_out_test", "eng_trq_out_test"], "status": "computed"}],
        "selection": {"kept": {"veh_spd": "veh_spd_test", "mot_trq_out": "mot_trq_out_test"},
                      "dropped": {"veh_spd_obd_test": "slower source (1 Hz) agreeing with veh_spd_test"}},
        "summary": {"total": 4, "by_severity": {"info": 1, "warning": 2, "error": 1}},
    }


@lru_cache(maxsize=1)
def _control_json() -> str:
    from vehval.analysis import analyze
    from vehval.vehicle import load_vehicle

    return json.dumps(analyze(make_test(), load_vehicle("prius_2004")).to_dict())


@lru_cache(maxsize=1)
def _validation_json() -> str:
    from vehval.jsonsafe import clean as _clean
    from vehval.validate import validate_test
    from vehval.vehicle import load_vehicle

    payload = validate_test(make_test(), load_vehicle("prius_2004"), dt=0.1).payload()
    return json.dumps(_clean(payload))


def make_control() -> dict:
    """control.json of the real control-strategy analysis of :func:`make_test`."""
    return json.loads(_control_json())


def make_validation() -> dict:
    """validation.json payload of the real validation of :func:`make_test` (prius_2004)."""
    return json.loads(_validation_json())
