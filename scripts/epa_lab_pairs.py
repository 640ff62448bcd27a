"""Rows of an EPA Test Car List run on one car at one setting by both labs, side by side.

Usage::

    python scripts/epa_lab_pairs.py LIST.csv [LIST.csv ...] --tests SELECTOR [--tol 0.05]
    python scripts/epa_lab_pairs.py LIST.csv [LIST.csv ...] --lab-summary [--tests SELECTOR]

Groups the selected FTP-75, HWFET and US06 rows by what a vehicle model is given: test vehicle,
equivalent test weight, road-load target (A, B, C), dynamometer set coefficients, test fuel and
procedure. Within a group every physical input of the model is the same, so one model predicts
one figure for all of its rows. For each group with more than one row the script prints every
row (originator, configuration, whole-test and bag figures), the ratio of each row to the
group's manufacturer-run mean, and whether one figure can lie within ``tol`` of every row
(possible only when the largest measured figure over the smallest is at most
(1 + tol) / (1 - tol)); the error is predicted / measured - 1, as in ``vehval epa validate``. It then lists the test vehicles that the list represents under
several models (one physical car, several trims).

``--lab-summary`` measures, over every setting run by both labs (all rows of the list unless
``--tests`` narrows them), each EPA-run figure against the mean of the manufacturer-run figures
of the same setting, and prints its distribution per procedure for hybrids and for the other
cars: the list's own reproducibility between two labs on one car. A row is counted as a
hybrid when its model name carries one of ``HYBRID_WORDS`` (the list has no powertrain
column).
"""

from __future__ import annotations

import argparse
import math
import statistics
import sys
from collections import defaultdict
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

from vehval.epa import apply_selector, read_test_car_list  # noqa: E402
from vehval.epa.select import procedure_key  # noqa: E402

PROCEDURES = ("ftp75", "hwfet", "us06")
HYBRID_WORDS = ("HYBRID", "PRIUS", "HEV", "C-MAX", "300H", "450H", "NIRO", "IONIQ", "INSIGHT")


def _key(t) -> tuple:
    return (t.vehicle_id, round(t.mass_kg, 1), round(t.target_a_n, 3),
            round(t.target_b_n_per_mps, 4), round(t.target_c_n_per_mps2, 5),
            round(t.set_a_n, 3), round(t.set_b_n_per_mps, 4), round(t.set_c_n_per_mps2, 5),
            t.fuel_code, procedure_key(t))


def one_model_window(figures: list[float], tol: float) -> tuple[float, float] | None:
    """Range of one predicted figure P with |P / m - 1| <= ``tol`` for every measured m,
    or None (the error of ``vehval epa validate`` is predicted / measured - 1)."""
    lo, hi = max(figures) * (1 - tol), min(figures) * (1 + tol)
    return (lo, hi) if lo <= hi else None


def lab_summary(groups: dict) -> list[str]:
    """Markdown table: EPA-run figure / manufacturer-run mean - 1, per procedure and class."""
    ratios: dict[tuple[str, str], list[float]] = defaultdict(list)
    for key, rows in groups.items():
        mfr = [r.fe for r in rows if r.originator == "MFR" and not math.isnan(r.fe)]
        if not mfr:
            continue
        ref = sum(mfr) / len(mfr)
        cls = "hybrid" if any(w in rows[0].model.upper() for w in HYBRID_WORDS) else "other"
        ratios[(cls, key[-1])] += [r.fe / ref - 1 for r in rows
                                   if r.originator == "EPA" and not math.isnan(r.fe)]
    out = ["| cars | procedure | EPA-run rows | median | 10th percentile | 90th percentile |",
           "|---|---|---|---|---|---|"]
    for (cls, proc), v in sorted(ratios.items()):
        if not v:
            continue
        v.sort()
        med = statistics.median(v)
        out.append(f"| {cls} | {proc} | {len(v)} | {100 * med:+.1f} % "
                   f"| {100 * v[len(v) // 10]:+.1f} % | {100 * v[(9 * len(v)) // 10]:+.1f} % |")
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("lists", nargs="+", type=Path)
    ap.add_argument("--tests", default=None, help="selector, e.g. 'model=PRIUS c,year=2016'")
    ap.add_argument("--lab-summary", action="store_true",
                    help="EPA-run against manufacturer-run figures of one setting, list-wide")
    ap.add_argument("--tol", type=float, default=0.05, help="tolerance [-] (default 0.05)")
    args = ap.parse_args(argv)
    tests = [t for f in args.lists for t in read_test_car_list(f)]
    chosen = apply_selector(tests, args.tests) if args.tests else tests
    sel = [t for t in chosen if procedure_key(t) in PROCEDURES]
    groups = defaultdict(list)
    for t in sel:
        groups[_key(t)].append(t)
    if args.lab_summary:
        print("\n".join(lab_summary(groups)))
        return 0
    if not args.tests:
        ap.error("--tests is required without --lab-summary")
    print(f"{len(sel)} FTP-75 / HWFET / US06 rows, {len(groups)} settings "
          f"(vehicle, weight, target and set coefficients, fuel, procedure)")
    print("| vehicle | procedure | weight kg | target A N | test | by | config | figure | "
          "vs MFR mean | bags | one figure within "
          f"{100 * args.tol:g} % of every row |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for key, rows in sorted(groups.items(), key=lambda kv: (kv[0][0], kv[0][-1], kv[0][1])):
        if len(rows) < 2:
            continue
        mfr = [r.fe for r in rows if r.originator == "MFR" and not math.isnan(r.fe)]
        ref = sum(mfr) / len(mfr) if mfr else float("nan")
        win = one_model_window([r.fe for r in rows], args.tol)
        wtxt = f"yes, {win[0]:.1f}-{win[1]:.1f}" if win else "no"
        for i, r in enumerate(sorted(rows, key=lambda r: (r.originator, r.test_number))):
            bags = ", ".join(f"{b:.1f}" for b in r.bags if not math.isnan(b)) or "-"
            rel = f"{100 * (r.fe / ref - 1):+.1f} %" if mfr else "-"
            print(f"| {r.vehicle_id} | {procedure_key(r)} | {r.mass_kg:.0f} | {r.target_a_n:.1f} "
                  f"| {r.test_number} | {r.originator} | {r.config} | {r.fe:.1f} | {rel} "
                  f"| {bags} | {wtxt if i == 0 else ''} |")
    by_vehicle = defaultdict(set)
    for t in apply_selector(tests, {k: v for k, v in
                                    (p.split("=", 1) for p in args.tests.split(","))
                                    if k in ("year", "make")}):
        by_vehicle[t.vehicle_id].add(t.model)
    shared = {v: sorted(m) for v, m in by_vehicle.items()
              if v in {t.vehicle_id for t in sel} and len(m) > 1}
    for v, models in sorted(shared.items()):
        print(f"\ntest vehicle {v} is listed under several models: {', '.join(models)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
