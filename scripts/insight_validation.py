"""Validate the 2000 Insight model on the real 10 Hz log (two HWFETs) and analyse its control.

    python scripts/insight_validation.py [--log FILE] [--json OUT]

Imports the log with its template (tests/io/templates/insight_2000_10hz.yaml), runs
``insight_2000`` over the log's own speed trace (dt 0.1 s, from the log's 69 % SOC) and
prints, per HWFET and over both: engine on/off agreement [%], engine speed error RMS [rpm]
per gear (gear read from the log's speed ratio), battery terminal energy [Wh] model vs test,
motor torque error RMS [N·m]; each with the model's uncertainty: half the spread of the
figure over one-at-a-time swings of the least-known inputs (road load ±15 %, test mass
±5 %, battery resistances ±30 %, wheel radius 0.275 / 0.279 m), combined root-sum-square.
Then the control analysis of the log (:mod:`vehval.analysis.parallel`) and a second set of
figures with the strategy read from HWFET 1 alone (its ``strategy``: assist and regen
thresholds, lowest assisting gear, regen and engine-stop speeds, the idle motor's draw;
in-sample on HWFET 1, held out on HWFET 2).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

from vehval.analysis.parallel import analyze_parallel  # noqa: E402
from vehval.io.importer import import_test  # noqa: E402
from vehval.validate.parallel import battery_verdicts, model_uncertainty, parallel_figures, simulate_on_test  # noqa: E402
from vehval.vehicle import load_vehicle  # noqa: E402

TEMPLATE = ROOT / "tests" / "io" / "templates" / "insight_2000_10hz.yaml"
SOC0 = 0.69       # [-] the log's initial SOC (its file name)
SPLIT_S = 765.0   # [s] the stop between the two HWFETs
END_S = 1532.0    # [s] the end-of-test artefact after this (engine off, voltage drifting)
RADIUS_M = 0.279  # [m] rolling radius on this dyno, to read the log's gears (NOTES)
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


def variant(veh, sw):
    if sw in ("r0.7", "r1.3"):
        f = 0.7 if sw == "r0.7" else 1.3
        b = veh.battery
        return veh.with_overrides({
            "battery.resistance_discharge_ohm": [x * f for x in b.resistance_discharge_ohm],
            "battery.resistance_charge_ohm": [x * f for x in b.resistance_charge_ohm]})
    return veh.with_overrides(sw)


def figures(veh, test) -> dict:
    d = simulate_on_test(veh, test, soc0=SOC0, end_s=END_S)
    f = parallel_figures(veh, d, (SPLIT_S,), radius_m=RADIUS_M)
    return {"hwfet_1": f["part_1"], "hwfet_2": f["part_2"], "both": f["all"]}


def uncertainty(veh, test, base: dict) -> dict[str, float]:
    """Model uncertainty of every figure: RSS over this log's swings of half their spread
    (vehval.validate.parallel.model_uncertainty)."""
    swings = {label: [variant(veh, sw) for sw in sws] for label, sws in SWINGS.items()}
    return model_uncertainty(lambda v: figures(v, test), veh, base, swings)


def normalised_errors(figs: dict, unc: dict) -> dict:
    """En of the battery energies per part (vehval.validate.parallel.battery_verdicts: the
    test's U from the class defaults of the battery current and voltage, at 155 V)."""
    return battery_verdicts(figs, unc, 155.0)


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
    test = import_test(path, TEMPLATE)
    base = figures(veh, test)
    unc = uncertainty(veh, test, base)
    res = {"figures": base, "uncertainty": unc, "en": normalised_errors(base, unc),
           "control": analyze_parallel(test, veh).to_dict()}
    # the strategy read from HWFET 1 only (the log's first half); judged on HWFET 2
    first = import_test(path, TEMPLATE)
    for sig in first:
        keep = sig.time < SPLIT_S
        sig.time, sig.values = sig.time[keep], sig.values[keep]
    c1 = analyze_parallel(first, veh)
    cal = {f"controller.{k}": v for k, v in c1["strategy"].items()}
    vc = veh.with_overrides(cal)
    fc = figures(vc, test)
    uc = uncertainty(vc, test, fc)
    res["calibrated_on_hwfet_1"] = {"overrides": cal, "figures": fc, "uncertainty": uc,
                                    "en": normalised_errors(fc, uc),
                                    "note": "hwfet_1 and both are in-sample; hwfet_2 is not"}
    text = json.dumps(res, indent=1, default=float)
    if a.json:
        Path(a.json).write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
