"""Parallel hybrids in the EPA Test Car Lists, and the model judged on the rows it can build.

    python scripts/parallel_list_rows.py [--lists DIR] [--json OUT]

Lists every row of a parallel hybrid (one engine with a motor on its shaft or behind a
clutch ahead of a stepped gearbox: Honda IMA, Hyundai/Kia TMED, VW, BMW, Audi, Infiniti,
Acura, Nissan P2, GM eAssist) in the 2016 / 2017 / 2019 lists. A vehicle can be built for
the Honda CR-Z with the manual gearbox (an IMA car like the 2000 Insight): the Insight's
components scaled to the row (engine maps x displacement ratio, the row's test weight,
road-load target, axle ratio and top gear from its N/V ratio, six gears spaced
geometrically from the Insight's first gear, shift at 2000 rpm up / 1100 rpm down); its FTP
and HWFET rows are run with :func:`vehval.epa.validation.predict_test` (charge-balanced
plan, energy-balance SOC correction, hot engine: no cold-start model) and compared with
the lists' unadjusted fuel economy.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

from vehval.constants import MPH_M_PER_S  # noqa: E402
from vehval.epa.procedures import plan_for  # noqa: E402
from vehval.epa.reader import find_list_files, read_lists  # noqa: E402
from vehval.epa.validation import predict_test  # noqa: E402
from vehval.vehicle import load_vehicle  # noqa: E402

PARALLEL = re.compile(r"CR-Z|CIVIC.*HYBRID|SONATA HYBRID|OPTIMA HYBRID|IONIQ|NIRO$|JETTA HYBRID|"
                      r"ACTIVEHYBRID|Q5 HYBRID|Q50.*HYBRID|Q70.*HYBRID|RLX.*HYBRID|"
                      r"MURANO.*HYBRID|PATHFINDER.*HYBRID", re.I)
NOT_PARALLEL = re.compile(r"plug|phev|electric", re.I)
UP_RPM, DOWN_RPM = 2000.0, 1100.0


def lists_dir(arg: str | None) -> Path:
    if arg:
        return Path(arg)
    base = Path(os.environ.get("VEHVAL_SHARED_DATA", ROOT.parent / "shared" / "data"))
    return base / "real" / "epa_test_car_list"


def crz_vehicle(base, row):
    """The 2000 Insight's components scaled to a CR-Z manual row (module docstring)."""
    k = row.displacement_l / base.engine.displacement_l
    e = base.engine
    r = base.driveline.wheel_radius_m
    top = row.n_v_ratio * 2 * math.pi * r / (60 * MPH_M_PER_S)  # overall ratio, top gear
    first = base.gearbox.ratios[0] * row.axle_ratio
    n = row.gears
    overall = [first * (top / first) ** (i / (n - 1)) for i in range(n)]
    w_up, w_dn = UP_RPM * math.pi / 30, DOWN_RPM * math.pi / 30
    up = [w_up * r / overall[i] for i in range(n - 1)]
    dn = [min(w_dn * r / overall[i + 1], 0.8 * up[i]) for i in range(n - 1)]
    return base.with_overrides({
        "engine.torque_nm": [t * k for t in e.torque_nm],
        "engine.max_torque_nm": [t * k for t in e.max_torque_nm],
        "engine.fuel_rate_g_per_s": [[f * k for f in row_] for row_ in e.fuel_rate_g_per_s],
        "engine.max_power_w": e.max_power_w * k, "engine.motoring_torque_nm":
            e.motoring_torque_nm * k, "engine.displacement_l": row.displacement_l,
        "driveline.final_drive_ratio": row.axle_ratio,
        "gearbox.ratios": [o / row.axle_ratio for o in overall],
        "gearbox.upshift_speed_mps": up, "gearbox.upshift_speed_full_load_mps": up,
        "gearbox.downshift_speed_mps": dn, "gearbox.downshift_speed_full_load_mps": dn,
    })


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lists")
    ap.add_argument("--json")
    a = ap.parse_args(argv)
    d = lists_dir(a.lists)
    files = find_list_files([d]) if d.is_dir() else []
    if not files:
        print(f"parallel_list_rows: no Test Car Lists in {d} (give --lists)", file=sys.stderr)
        return 2
    rows = [t for t in read_lists(files)
            if PARALLEL.search(t.model) and not NOT_PARALLEL.search(t.model)
            and t.displacement_l != 0.0 and (t.transmission, t.gears) != ("A", 1)]
    # (0 L or a one-speed "A" gearbox: the electric IONIQ rows)
    found: dict[str, int] = {}
    for t in rows:
        key = f"{t.year} {t.make} {t.model} ({t.transmission} {t.gears})"
        found[key] = found.get(key, 0) + 1
    base = load_vehicle("insight_2000")
    judged = []
    for t in rows:
        if not (re.search("CR-Z", t.model) and t.transmission == "M"):
            continue
        proc, why = plan_for(t)
        if proc is None:
            continue
        pred = predict_test(crz_vehicle(base, t), t, proc, dt=1.0)
        judged.append({"row": t.source, "model": f"{t.year} {t.make} {t.model}",
                       "procedure": proc.key, "test_mpg": t.fe,
                       "model_mpg": pred.overall_mpg,
                       "error_pct": 100 * (pred.overall_mpg / t.fe - 1),
                       "soc_delta": pred.soc_delta, "trace_n_miss": pred.trace_n_miss})
    out = {"parallel_hybrid_rows": found, "judged": judged}
    text = json.dumps(out, indent=1, default=float)
    if a.json:
        Path(a.json).write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
