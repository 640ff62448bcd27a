"""Drive cycles: parse cost of the package cycle files and resampling, against numpy.

Baselines are plain numpy on the same data in the same run: ``numpy.loadtxt`` of the same
CSV files (no validation, no metadata, no unit handling) and ``numpy.interp`` on the same
grid. The synthetic D3 generator used by other benchmarks is timed against ``numpy.savetxt``
of an array of the same shape.
"""

from __future__ import annotations

import tempfile
from importlib import resources
from pathlib import Path

import numpy as np

from benchmarks.common import best_of, make_d3_file, peak_memory, row
from vehval import cycles as cyc_mod


def _load_all_uncached() -> None:
    cyc_mod._load_package.cache_clear()
    for name in cyc_mod.list_cycles():
        cyc_mod.load_cycle(name)


def _loadtxt_all(paths: list[Path]) -> None:
    for p in paths:
        np.loadtxt(p, delimiter=",", comments="#", skiprows=6)  # 5 comments + header


def run() -> list[dict]:
    rows = []
    root = resources.files("vehval") / "data" / "cycles"
    paths = [Path(str(root / f"{n}.csv")) for n in cyc_mod.list_cycles()]

    t_ours = best_of(_load_all_uncached, n=5)
    t_base = best_of(lambda: _loadtxt_all(paths), n=5)
    rows.append(row("load_all_package_cycles", t_ours, "s", baseline=t_base, target=3.0,
                    note=f"{len(paths)} cycles, cache cleared; baseline numpy.loadtxt of the "
                         "same files"))

    wltc = cyc_mod.load_cycle("wltc3b")
    t_res = best_of(lambda: wltc.resampled(0.01), n=5)
    t_interp = best_of(lambda: np.interp(np.arange(0.0, wltc.duration_s + 1e-9, 0.01),
                                         wltc.time_s, wltc.speed_mps), n=5)
    rows.append(row("resample_wltc3b_100Hz", t_res, "s", baseline=t_interp, target=2.0,
                    note="180,001 points; baseline numpy.arange + numpy.interp"))
    _, peak = peak_memory(_load_all_uncached)
    rows.append(row("load_all_package_cycles_peak_memory", peak / 1e6, "MB", target=10.0,
                    note="tracemalloc peak while parsing every package cycle"))

    with tempfile.TemporaryDirectory() as tmp:
        p = Path(tmp) / "synthetic_d3.txt"
        t_gen = best_of(lambda: make_d3_file(p), n=3)
        arr = np.random.default_rng(0).normal(size=(15000, 61))
        q = Path(tmp) / "savetxt.txt"
        t_save = best_of(lambda: np.savetxt(q, arr, fmt="%.3f", delimiter="\t",
                                            newline="\r\n"), n=3)
        size_mb = p.stat().st_size / 1e6
    rows.append(row("make_d3_file_1500s_10Hz_60ch", t_gen, "s", baseline=t_save, target=1.5,
                    note=f"{size_mb:.1f} MB file; baseline numpy.savetxt of a 15000x61 array"))
    return rows
