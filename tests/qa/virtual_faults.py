"""Fault mixes injected into virtual dyno tests and the scoring of QA against them.

A fault counts as found when a warning- or error-level finding names its signal with a span
overlapping the fault span (on the true clock, +-1 s); a false alarm is a warning or error on
a measured signal that carries no injected fault.
"""

from vehval.qa.findings import Severity

#: OBD logger behind the dyno, a frozen OBD motor speed, a reversed OBD motor torque...
MIX_B = [
    {"kind": "clock_offset", "file": "obd", "magnitude": -5.1, "delay_s": 0.2},
    {"kind": "spikes", "channel": "Dyno_Tractive_Effort", "start_frac": 0.1, "end_frac": 0.9,
     "magnitude": 3000.0, "count": 4},
    {"kind": "stuck", "channel": "MG2_RPM", "start_frac": 0.3, "end_frac": 0.45},
    {"kind": "dropout", "channel": "Hioki_Batt_Voltage", "start_frac": 0.6, "end_frac": 0.65},
    {"kind": "sign_flip", "channel": "MG2_TORQUE"},
    {"kind": "out_of_range", "channel": "Engine_Coolant_Temp", "start_frac": 0.5, "end_frac": 0.55,
     "magnitude": 200.0},
    {"kind": "zero", "channel": "Hioki_Boost_Voltage"},
]


#: A large offset with a long transport delay, gain errors on a single-source and on a
#: duplicated quantity, a drifting wheel torque, current spikes...
MIX_C = [
    {"kind": "clock_offset", "file": "obd", "magnitude": -11.3, "delay_s": 0.6},
    {"kind": "gain_error", "channel": "Eng_FuelFlow_Direct", "magnitude": -0.07},
    {"kind": "gain_error", "channel": "HV_BATT_VOLTAGE", "magnitude": 0.10},
    {"kind": "spikes", "channel": "Hioki_Batt_Current", "start_frac": 0.1, "end_frac": 0.9,
     "magnitude": 150.0, "count": 5},
    {"kind": "stuck", "channel": "ENGINE_RPM", "start_frac": 0.4, "end_frac": 0.55},
    {"kind": "dropout", "channel": "Dyno_Speed", "start_frac": 0.2, "end_frac": 0.23},
    {"kind": "offset_drift", "channel": "Wheel_Torque", "start_frac": 0.3, "magnitude": 60.0},
    {"kind": "out_of_range", "channel": "VEHICLE_SPEED", "start_frac": 0.8, "end_frac": 0.82,
     "magnitude": 80.0},
]


MIXES = {"default": "default", "mix_b": MIX_B, "mix_c": MIX_C, "none": "none"}


def score(truth, res):
    faulty = {f["signal"] for f in truth["faults"] if f.get("signal")}
    found, missed = [], []
    for f in truth["faults"]:
        if not f.get("signal"):
            continue
        t0, t1 = f["true_start_s"] - 1.0, f["true_end_s"] + 1.0
        hit = [g for g in res.findings if g.signal == f["signal"] and g.severity != Severity.INFO
               and g.overlaps(t0, t1)]
        (found if hit else missed).append((f["kind"], f["signal"], sorted({g.kind.value for g in hit})))
    measured = {s.name for s in res.validated} | set(res.selection.dropped) | set(res.selection.kept)
    measured = {n for n in measured if not n.endswith("_calc")}
    clean = measured - faulty
    alarms = sorted({(g.signal, g.kind.value) for g in res.findings
                     if g.severity != Severity.INFO and g.signal in clean})
    return found, missed, clean, alarms
