"""A packaged engine's best-line efficiency against FASTSim's 1-D curve, and the ceiling variant.

Usage::

    python scripts/engine_curve_check.py DATA [--vehicle prius_2016] [--ceiling-from 0.2]
                                         [--write-ceiling FILE]

``DATA`` is the data root holding ``real/epa_test_car_list/reference_model/`` (FASTSim's 2016
Toyota Prius Two parameter set: ``fc_eff_map`` over ``fc_pwr_out_perc`` of ``fc_max_kw``).
Prints the vehicle's engine efficiency along its best-efficiency line at the curve's power
fractions of the vehicle's rated power, beside FASTSim's. ``--write-ceiling FILE`` writes a
copy of the vehicle file whose engine map uses FASTSim's curve as a ceiling above
``--ceiling-from`` of rated power: at each power where the best line is more efficient than
the curve, every map point of that power burns more fuel by the same factor (best-line speeds
unchanged). The copy is an experiment to measure what the curve would do (``vehval epa
validate ... --vehicle FILE``, ``vehval sensitivity --vehicle FILE --road-load``); it is not a
packaged vehicle.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

from vehval.constants import RPM_RAD_PER_S as RPM  # noqa: E402
from vehval.vehicle import load_vehicle  # noqa: E402
from vehval.vehicle.maps import bilinear  # noqa: E402

FASTSIM = "real/epa_test_car_list/reference_model/fastsim_2016_TOYOTA_Prius_Two.yaml"


def fastsim_curve(data: Path) -> tuple[np.ndarray, np.ndarray]:
    """FASTSim's engine efficiency [-] over the fraction of its rated power [-]."""
    d = yaml.safe_load((data / FASTSIM).read_text(encoding="utf-8"))
    return (np.asarray(d["fc_pwr_out_perc"]["data"], float),
            np.asarray(d["fc_eff_map"]["data"], float))


def best_line_efficiency(veh) -> tuple[np.ndarray, np.ndarray]:
    """Power [W] and efficiency [-] along the engine's best-efficiency line."""
    e = veh.engine
    p, w, t = veh.best_line
    fr = bilinear(np.asarray(e.speed_rpm, float) * RPM, np.asarray(e.torque_nm, float),
                  np.asarray(e.fuel_rate_g_per_s, float), w, t) * 1e-3
    with np.errstate(divide="ignore", invalid="ignore"):
        eta = np.where(fr > 0, p / (fr * e.fuel_lhv_j_per_kg), 0.0)
    return p, eta


def ceiling_fuel(veh, frac: np.ndarray, eff: np.ndarray, above: float) -> np.ndarray:
    """The engine's fuel map [g/s] with ``eff`` over ``frac`` as a ceiling above ``above``."""
    e = veh.engine
    p, eta = best_line_efficiency(veh)
    cap = np.interp(p / e.max_power_w, frac, eff)
    factor = np.where((p > above * e.max_power_w) & (eta > cap), eta / np.maximum(cap, 1e-9), 1.0)
    pw = (np.asarray(e.speed_rpm, float)[:, None] * RPM) * np.asarray(e.torque_nm, float)[None, :]
    return np.asarray(e.fuel_rate_g_per_s, float) * np.interp(pw, p, factor)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("data", type=Path, help="data root (holds real/epa_test_car_list/...)")
    ap.add_argument("--vehicle", default="prius_2016")
    ap.add_argument("--ceiling-from", type=float, default=0.2,
                    help="fraction of rated power above which the curve is a ceiling [-]")
    ap.add_argument("--write-ceiling", type=Path, help="write the ceiling variant here")
    args = ap.parse_args(argv)
    frac, eff = fastsim_curve(args.data)
    veh = load_vehicle(args.vehicle)
    p, eta = best_line_efficiency(veh)
    pmax = veh.engine.max_power_w
    print(f"{veh.name}: best-line efficiency against FASTSim's 2016 Prius Two curve "
          f"(fractions of {pmax / 1e3:.1f} kW)")
    print("| power fraction | power kW | model | FASTSim |\n|---|---|---|---|")
    for f, e in zip(frac, eff):
        if f <= 0:
            continue
        print(f"| {f:g} | {f * pmax / 1e3:.1f} | {np.interp(f * pmax, p, eta):.3f} | {e:.3f} |")
    if args.write_ceiling is not None:
        src = Path(veh.file)
        d = yaml.safe_load(src.read_text(encoding="utf-8"))
        fuel = ceiling_fuel(veh, frac, eff, args.ceiling_from)
        d["engine"]["fuel_rate_g_per_s"] = [[round(float(x), 5) for x in r] for r in fuel]
        d["name"] = f"{veh.name}_fastsim_ceiling"
        d["description"] = (f"EXPERIMENT: {veh.name} with FASTSim's 1-D engine curve as a "
                            f"ceiling above {args.ceiling_from:g} of rated power")
        args.write_ceiling.write_text(yaml.safe_dump(d, sort_keys=False), encoding="utf-8")
        ratio = fuel / np.maximum(np.asarray(veh.engine.fuel_rate_g_per_s, float), 1e-12)
        print(f"\nwrote {args.write_ceiling} (fuel x up to {ratio.max():.3f})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
