"""Validate the 2000 Insight model on the real 10 Hz log (two HWFETs) and analyse its control.

    python scripts/insight_validation.py [--log FILE] [--json OUT]

Runs ``insight_2000`` over the log's own speed trace (dt 0.1 s, from the log's 69 % SOC) and
prints, per HWFET and over both: engine on/off agreement [%], engine speed error RMS [rpm]
per gear (gear read from the log's speed ratio), battery terminal energy [Wh] model vs test,
motor torque error RMS [N·m]; each with the model's uncertainty: half the spread of the
figure over one-at-a-time swings of the least-known inputs (road load ±15 %, test mass
±5 %, battery resistances ±30 %, wheel radius 0.275 / 0.279 m), combined root-sum-square.
Then the control analysis of the log (:mod:`vehval.analysis.parallel`). Nothing is fitted on
the log: every model figure is out of sample.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

from vehval.analysis.parallel import assist_regen_rules, engine_stop_rule, gears_from_speeds  # noqa: E402
from vehval.sim.simulate import architecture, make_grid, run_cycle  # noqa: E402
from vehval.vehicle import load_vehicle  # noqa: E402

MPH = 0.44704
RPM = np.pi / 30
SPLIT_S = 765.0   # [s] the stop between the two HWFETs
END_S = 1532.0    # [s] the end-of-test artefact after this (engine off, voltage drifting)
SWINGS = {
    "road load ±15 %": [{"body.road_load_a_n": f * 73.32, "body.road_load_c_n_per_mps2":
                         f * 0.285} for f in (0.85, 1.15)],
    "test mass ±5 %": [{"body.mass_kg": m} for m in (950.0, 1050.0)],
    "battery R ±30 %": ["r0.7", "r1.3"],
    "wheel radius 0.279 m": [{"driveline.wheel_radius_m": 0.279}],
}


def log_path(arg: str | None) -> Path:
    if arg:
        return Path(arg)
    base = Path(os.environ.get("VEHVAL_SHARED_DATA", ROOT.parent / "shared" / "data"))
    return base / "real" / "advisor_insight_hwfet_10hz" / "Hwy2x_Insight_test_data_69soc_hot.txt"


def read_log(path: Path) -> dict[str, np.ndarray]:
    data = np.genfromtxt(path, delimiter="\t", names=True)
    keep = data["time_s"] <= END_S
    d = {k: np.asarray(data[k][keep], float) for k in data.dtype.names}
    return {"t": d["time_s"], "v": np.maximum(d["speed_mph"] - 0.09, 0.0) * MPH,
            "volt": d["batt_volts"], "amp": d["batt_amps"], "w": d["eng_rpm"] * RPM,
            "t_axle": d["axle_torque_nm"], "t_mot": d["derived_em_trq_nm"]}


def variant(veh, sw):
    if sw == "r0.7" or sw == "r1.3":
        f = 0.7 if sw == "r0.7" else 1.3
        b = veh.battery
        return veh.with_overrides({
            "battery.resistance_discharge_ohm": [x * f for x in b.resistance_discharge_ohm],
            "battery.resistance_charge_ohm": [x * f for x in b.resistance_charge_ohm]})
    return veh.with_overrides(sw)


def simulate_on_log(veh, log) -> dict[str, np.ndarray]:
    grid = make_grid(veh, log["t"], log["v"], 0.1)
    out, _ = run_cycle(veh, grid, 0.69, True)
    col = architecture(veh).column
    return {k: out[:, col[k]] for k in ("eng_on", "eng_spd_out", "mot_trq_out", "ess_pwr",
                                        "gb_gear", "veh_spd", "ess_volt", "ess_curr")}


def figures(veh, log, sim) -> dict:
    t = log["t"]
    on_log = log["w"] > 31.4
    on_sim = sim["eng_on"] > 0.5
    gear = gears_from_speeds(log["w"], log["v"] / 0.279, veh.overall_ratios())
    out: dict = {}
    for name, sel in (("hwfet_1", t < SPLIT_S), ("hwfet_2", t >= SPLIT_S), ("both", t >= 0)):
        p_log = log["volt"] * log["amp"]
        both_on = sel & on_log & on_sim
        rpm_gear = {}
        for g in range(1, 6):
            m = both_on & (gear == g)
            if m.sum() >= 20:
                rpm_gear[g] = float(np.sqrt(np.mean((sim["eng_spd_out"][m] - log["w"][m]) ** 2))
                                    / RPM)
        mm = sel & on_log & on_sim
        out[name] = {
            "engine_on_agreement_pct": float(100 * np.mean(on_log[sel] == on_sim[sel])),
            "engine_speed_rms_rpm_by_gear": rpm_gear,
            "engine_speed_rms_rpm": float(np.sqrt(np.mean((sim["eng_spd_out"][mm]
                                                           - log["w"][mm]) ** 2)) / RPM),
            "battery_energy_test_wh": float(np.sum(p_log[sel]) * 0.1 / 3600),
            "battery_energy_model_wh": float(np.sum(sim["ess_pwr"][sel]) * 0.1 / 3600),
            "battery_out_test_wh": float(np.sum(np.maximum(p_log[sel], 0)) * 0.1 / 3600),
            "battery_out_model_wh": float(np.sum(np.maximum(sim["ess_pwr"][sel], 0)) * 0.1
                                          / 3600),
            "battery_in_test_wh": float(np.sum(np.minimum(p_log[sel], 0)) * -0.1 / 3600),
            "battery_in_model_wh": float(np.sum(np.minimum(sim["ess_pwr"][sel], 0)) * -0.1
                                         / 3600),
            "motor_torque_rms_nm": float(np.sqrt(np.mean((sim["mot_trq_out"][mm]
                                                          - log["t_mot"][mm]) ** 2))),
            "gear_agreement_pct": float(100 * np.mean(sim["gb_gear"][sel & (gear > 0)]
                                                      == gear[sel & (gear > 0)])),
        }
    return out


def _leaves(d, prefix=""):
    for k, v in d.items():
        if isinstance(v, dict):
            yield from _leaves(v, f"{prefix}{k}.")
        else:
            yield f"{prefix}{k}", v


def uncertainty(veh, log, base: dict) -> dict[str, float]:
    """Model uncertainty of every figure: RSS over the swings of half their spread."""
    flat0 = dict(_leaves(base))
    acc = {k: 0.0 for k in flat0}
    for sws in SWINGS.values():
        vals = {k: [v] for k, v in flat0.items()}
        for sw in sws:
            v2 = variant(veh, sw)
            f2 = dict(_leaves(figures(v2, log, simulate_on_log(v2, log))))
            for k in vals:
                if k in f2:
                    vals[k].append(f2[k])
        for k, xs in vals.items():
            acc[k] += (0.5 * (max(xs) - min(xs))) ** 2
    return {k: float(np.sqrt(x)) for k, x in acc.items()}


def control(veh, log, sel=None) -> dict:
    if sel is not None:
        log = {k: x[sel] for k, x in log.items()}
    gear = gears_from_speeds(log["w"], log["v"] / 0.279, veh.overall_ratios())
    ratios = np.r_[np.nan, veh.overall_ratios()]
    t_dem = np.where(gear > 0, log["t_axle"] / ratios[gear], np.nan)
    ok = gear > 0
    acc = np.gradient(log["v"], log["t"])
    acc = np.convolve(acc, np.ones(10) / 10, mode="same")
    rules = assist_regen_rules(t_dem[ok], log["t_mot"][ok], log["v"][ok], gear[ok],
                               (log["w"] > 31.4)[ok])
    rules["engine_stop"] = engine_stop_rule(log["t"], log["v"], log["w"], acc)
    return rules


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--log")
    ap.add_argument("--json")
    a = ap.parse_args(argv)
    path = log_path(a.log)
    if not path.exists():
        print(f"insight_validation: no log at {path} (give --log)", file=sys.stderr)
        return 2
    veh = load_vehicle("insight_2000")
    log = read_log(path)
    base = figures(veh, log, simulate_on_log(veh, log))
    res = {"figures": base, "uncertainty": uncertainty(veh, log, base),
           "control": control(veh, log)}
    # calibrated on HWFET 1 only: the assist threshold of the log's first half; judge HWFET 2
    c1 = control(veh, log, log["t"] < SPLIT_S)
    cal = {"controller.assist_threshold_nm": round(c1["assist_threshold"]["threshold"], 1)}
    vc = veh.with_overrides(cal)
    fc = figures(vc, log, simulate_on_log(vc, log))
    res["calibrated_on_hwfet_1"] = {"overrides": cal, "figures": fc,
                                    "uncertainty": uncertainty(vc, log, fc),
                                    "note": "hwfet_1 and both are in-sample; hwfet_2 is not"}
    text = json.dumps(res, indent=1, default=float)
    if a.json:
        Path(a.json).write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
