"""Speed of identification and of the conventional simulation.

Rows (see benchmarks/common.py):

* ``identify_cruze_2_tests``: wall time of loading two 10 Hz tests (hot UDDS 61410013 and
  WLTC 61410004 of the 2014 Cruze diesel, ANL D3) and identifying the car from them
  (road load, gears, converter, shift lines, fuel map); target < 20 s. Without the real
  files the same is timed on virtual UDDS + WLTC tests of the packaged Cruze model (the
  note says which).
* ``identify_cross_validate_pairs_cruze``: ``identify --cross-validate --pairs`` on the five
  hot non-A/C Cruze tests (UDDS 61410013, HWFET 61410015, US06 61410016, NEDC 61410005, WLTC
  61410004) with the spec of ``tests/identify/cruze_spec.yaml``: loading, ten identifications
  and thirty predictions; target < 60 s on 2 cores. Skipped without the real files.
* ``simulate_conventional_udds_dt0.1``: one UDDS run of ``cruze_diesel_2014`` at dt = 0.1 s
  after warm-up, baseline one UDDS run of the power-split ``prius_2004`` at the same step
  in the same run; target ratio <= 1 (no slower than the hybrid).

Run standalone: ``python -m benchmarks.bench_identify``.
"""

from __future__ import annotations

import json
import os
import tempfile
import time
from pathlib import Path

from benchmarks.common import best_of, row
from vehval.cycles import load_cycle
from vehval.identify import identify_conventional, load_traces
from vehval.sim.simulate import simulate
from vehval.vehicle import load_vehicle

ROOT = Path(__file__).resolve().parents[1]
REAL = Path(os.environ.get("VEHVAL_SHARED_DATA", ROOT / ".." / "shared" / "data")) / "real"
CRUZE = REAL / "d3_2014_chevrolet_cruze_diesel"
TEMPLATE = ROOT / "tests" / "qa" / "templates" / "cruze.yaml"
SPEC = ROOT / "tests" / "identify" / "cruze_spec.yaml"
HOT = ("61410013", "61410015", "61410016", "61410005", "61410004")


def _inputs(tmp: Path) -> tuple[list[Path], Path, str]:
    files = [CRUZE / f"{i} Test Data.txt" for i in ("61410013", "61410004")]
    if all(f.is_file() for f in files):
        return files, TEMPLATE, "real ANL D3 files 61410013 + 61410004"
    from vehval.synth.conventional import make_conventional_test
    veh = load_vehicle("cruze_diesel_2014")
    out, tpl = [], None
    for cyc in ("udds", "wltc3b"):
        info = make_conventional_test(veh, load_cycle(cyc), 1, tmp / cyc)
        out += [Path(f) for f in info["files"]]
        tpl = Path(info["template"])
    return out, tpl, "virtual UDDS + WLTC of the packaged Cruze model (real files absent)"


def run() -> list[dict]:
    rows = []
    with tempfile.TemporaryDirectory() as d:
        files, tpl, what = _inputs(Path(d))
        identify_conventional(load_traces(files[:1] * 2, tpl))  # warm imports and caches
        t0 = time.perf_counter()
        idf = identify_conventional(load_traces(files, tpl))
        t_id = time.perf_counter() - t0
    rows.append(row("identify_cruze_2_tests", t_id, "s", target=20.0,
                    note=f"load + identify, {what}; fuel map R2 {idf.fuel_map.r2:.3f}"))
    files = [CRUZE / f"{i} Test Data.txt" for i in HOT]
    if all(f.is_file() for f in files):
        from vehval.identify.crossval import cross_validate
        from vehval.identify.spec import load_spec
        t0 = time.perf_counter()
        cv = cross_validate(load_traces(files, TEMPLATE), pairs=True, declared=load_spec(SPEC))
        t_cv = time.perf_counter() - t0
        s = cv["summary"]
        rows.append(row("identify_cross_validate_pairs_cruze", t_cv, "s", target=60.0,
                        note=f"{len(cv['rows'])} predictions, median |error| "
                             f"{100 * s['median_abs_error']:.1f} %"))
    conv, hyb = load_vehicle("cruze_diesel_2014"), load_vehicle("prius_2004")
    cyc = load_cycle("udds")
    simulate(conv, cyc, dt=0.1)
    simulate(hyb, cyc, dt=0.1)
    t_c = best_of(lambda: simulate(conv, cyc, dt=0.1), n=5)
    t_h = best_of(lambda: simulate(hyb, cyc, dt=0.1), n=5)
    rows.append(row("simulate_conventional_udds_dt0.1", t_c, "s", baseline=t_h, target=1.0,
                    note="baseline: prius_2004 (power split) on UDDS, dt = 0.1 s, same run"))
    return rows


if __name__ == "__main__":  # pragma: no cover
    print(json.dumps(run(), indent=1))
