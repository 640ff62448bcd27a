"""Derive the MG2 and MG1 loss maps of the 2004 Prius from ORNL's measurements.

    python scripts/derive_prius_2004_machines.py ORNL_DIR [--vehicle FILE] [--check]

ORNL_DIR holds ``mg2_inverter_map_tableB1.csv`` (ORNL/TM-2006/423 Table B-1: MG2 with its
inverter, 428 motoring points: speed_rpm, torque_Nm, p_dc_W, p_mech_W) and
``drivetrain_spin_losses_table3_7_25C.csv`` (ORNL/TM-2004/247 Table 3.7: open-circuit spin
losses by MG2 speed). The script

1. fits the loss surface of :mod:`vehval.vehicle.machine_fit` to the MG2 points below
   300 N·m (the rows at or above 300 N·m were run with ~0 °C coolant and their power
   readings are unreliable: loss falls as current rises);
2. tabulates MG2 over 0-6500 rpm and ±400 N·m, generating as the mirror of motoring,
   minus the open-circuit MG2 rotor loss (windage + eddy current) that the coast-down road
   load already contains;
3. derives MG1 (no measured map exists) from the same surface scaled to 30 kW and
   10,000 rpm (speeds x 10000/6500, losses x 30/50, torques x their ratio);
4. writes the maps and their provenance into the vehicle file (default: the packaged
   ``prius_2004.yaml``), replacing the ``speed_rpm``, ``torque_nm`` and ``loss_w`` entries
   and their sources in the ``mg1`` and ``mg2`` blocks. ``--check`` only prints the fit.

The vehicle file then carries the numbers; nothing reads ORNL_DIR at run time.
"""

from __future__ import annotations

import argparse
import csv
import re
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

from vehval.constants import RPM_RAD_PER_S as RPM  # noqa: E402
from vehval.vehicle.machine_fit import TERMS, LossSurface, fit_loss_surface, loss_table, scaled_losses  # noqa: E402

VEHICLE = ROOT / "src" / "vehval" / "data" / "vehicles" / "prius_2004.yaml"
UNRELIABLE_NM = 300.0  # SOURCE.txt of the ORNL table: rows at or above are unreliable
MG2_MAX_RPM, MG2_MAX_NM, MG2_KW = 6500.0, 400.0, 50.0
MG1_MAX_RPM, MG1_KW, MG1_TABLE_NM = 10000.0, 30.0, 60.0


def read_csv(path: Path) -> dict[str, np.ndarray]:
    with path.open(newline="", encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    if not rows:
        raise SystemExit(f"{path}: no data rows")
    return {k: np.array([float(r[k]) for r in rows]) for k in rows[0]}


def fit_mg2(ornl: Path) -> tuple[LossSurface, dict]:
    d = read_csv(ornl / "mg2_inverter_map_tableB1.csv")
    keep = d["torque_Nm"] < UNRELIABLE_NM
    surf = fit_loss_surface(d["speed_rpm"][keep], d["torque_Nm"][keep],
                            d["p_dc_W"][keep] - d["p_mech_W"][keep])
    return surf, {"n_total": int(keep.size), "n_dropped": int((~keep).sum())}


def rotor_spin_loss(ornl: Path):
    """Open-circuit MG2 rotor loss [W] as a function of MG2 speed [rad/s] (linear, 0 at 0)."""
    s = read_csv(ornl / "drivetrain_spin_losses_table3_7_25C.csv")
    w = np.r_[0.0, s["speed_rpm"] * RPM]
    p = np.r_[0.0, s["p_rotor_W"]]

    def loss(x):
        x = np.asarray(x, float)
        # beyond the last measured speed (6006 of 6500 rpm): windage-like, ∝ speed²
        return np.where(x <= w[-1], np.interp(x, w, p), p[-1] * (x / w[-1]) ** 2)
    return loss


def _fmt(values) -> str:
    return "[" + ", ".join(f"{v:g}" for v in values) + "]"


def block_text(speed, torque, table, indent="  ") -> list[str]:
    lines = [f"{indent}speed_rpm: {_fmt(speed)}", f"{indent}torque_nm: {_fmt(torque)}",
             f"{indent}loss_w:"]
    lines += [f"{indent}    - {_fmt(row)}" for row in table]
    return lines


def replace_block_maps(text: str, block: str, new_lines: list[str],
                       sources: dict[str, str]) -> str:
    lines = text.splitlines()
    start = lines.index(f"{block}:")
    end = next(i for i in range(start + 1, len(lines)) if lines[i] and not lines[i][0].isspace())
    body = lines[start + 1:end]
    out: list[str] = []
    skip = False
    inserted = False
    section = ""  # the two-space key a four-space line belongs to (sources, uncertainty...)
    for ln in body:
        key = re.match(r"^  (\w+):", ln)
        if key:
            section = key.group(1)
            skip = key.group(1) in ("speed_rpm", "torque_nm", "loss_w")
            if skip and not inserted:
                out += new_lines
                inserted = True
        src = re.match(r"^    (\w+): ", ln)
        if not skip and src and section == "sources" and src.group(1) in sources:
            out.append(f'    {src.group(1)}: "{sources[src.group(1)]}"')
            continue
        if not skip:
            out.append(ln)
        elif not key and not ln.startswith("    - ") and not ln.startswith("      - "):
            skip = False
            out.append(ln)
    return "\n".join(lines[:start + 1] + out + lines[end:]) + "\n"


def coef_text(surf: LossSurface) -> str:
    return ", ".join(f"{n} = {c:.4g}" for n, c in zip(TERMS, surf.coef))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("ornl_dir", type=Path)
    ap.add_argument("--vehicle", type=Path, default=VEHICLE)
    ap.add_argument("--check", action="store_true", help="print the fit, write nothing")
    a = ap.parse_args(argv)
    surf, info = fit_mg2(a.ornl_dir)
    spin = rotor_spin_loss(a.ornl_dir)
    print(f"MG2 fit on {surf.n_points} points ({info['n_dropped']} rows >= "
          f"{UNRELIABLE_NM:g} N·m dropped): {coef_text(surf)}; rms {surf.rms_w:.0f} W, "
          f"efficiency rms {surf.rms_efficiency:.4f}")
    if a.check:
        return 0
    m2_spd = np.linspace(0.0, MG2_MAX_RPM, 27)
    m2_trq = np.linspace(-MG2_MAX_NM, MG2_MAX_NM, 41)
    m2 = loss_table(surf.loss, m2_spd, m2_trq, spin_loss=spin)
    s_w, s_p = MG1_MAX_RPM / MG2_MAX_RPM, MG1_KW / MG2_KW
    m1_spd = np.linspace(-MG1_MAX_RPM, MG1_MAX_RPM, 41)
    m1_trq = np.linspace(-MG1_TABLE_NM, MG1_TABLE_NM, 25)
    m1 = loss_table(lambda w, t: scaled_losses(surf, w, t, s_w, s_p), m1_spd, m1_trq)
    fit = (f"fitted surface L = c0 + c1|w| + c2 w^2 + c3|T| + c4 T^2 + c5 (T w)^2 "
           f"(vehval.vehicle.machine_fit; w rad/s, T N·m): {coef_text(surf)}")
    ornl = ("ORNL/TM-2006/423 Table B-1 (2004 Prius MG2 + inverter, DC power minus shaft "
            f"power, {surf.n_points} motoring points below {UNRELIABLE_NM:g} N·m; the "
            f"{info['n_dropped']} rows at or above were run with ~0 degC coolant and are "
            f"unreliable); {fit}; fit rms {surf.rms_w:.0f} W, efficiency rms "
            f"{surf.rms_efficiency:.3f}")
    src2 = {
        "speed_rpm": "grid 0-6500 rpm (SAE 2006-01-0667 Table 1 MG2 max speed), 250 rpm steps",
        "torque_nm": "grid +-400 N·m (Table 1 MG2 max torque), 20 N·m steps",
        "loss_w": (f"{ornl}; generating = mirror of motoring at the same |w|, |T| "
                   "(assumption: same current, same copper/switching/conduction losses; "
                   "ORNL measured motoring only); minus the open-circuit MG2 rotor loss of "
                   "ORNL/TM-2004/247 Table 3.7 (windage + eddy current, 20-473 W), which the "
                   "coast-down road load already contains; written by "
                   "scripts/derive_prius_2004_machines.py"),
    }
    src1 = {
        "speed_rpm": "grid +-10,000 rpm (SAE 2006-01-0667 Table 1 MG1 max speed), 500 rpm steps",
        "torque_nm": "grid +-60 N·m (covers max_torque_nm), 5 N·m steps",
        "loss_w": ("no measured MG1 map of the 2004 car exists (ORNL: a similar 8-pole "
                   "interior PM machine); derived from the MG2 loss surface (mg2.loss_w) scaled as "
                   f"ADVISOR/Autonomie scale machines: speeds x {s_w:.4f} (10,000/6500 rpm), "
                   f"losses x {s_p:.2f} (30/50 kW), torques x {s_p / s_w:.4f}; MG2 {fit}; "
                   "generating = mirror of motoring; sensitivity to this choice in "
                   "docs/simulation.md; written by scripts/derive_prius_2004_machines.py"),
    }
    text = a.vehicle.read_text(encoding="utf-8")
    text = replace_block_maps(text, "mg2", block_text(m2_spd, m2_trq, m2), src2)
    text = replace_block_maps(text, "mg1", block_text(m1_spd, m1_trq, m1), src1)
    a.vehicle.write_text(text, encoding="utf-8")
    print(f"wrote the MG1 and MG2 maps into {a.vehicle}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
