"""Batch throughput: tests per minute on a local Dask cluster against a plain loop.

All run the same tests (virtual-dyno UDDS tests, copied to make a batch), the same steps (import + QA, no HTML report) and write the same outputs and
catalog, in the same run on the same machine. The baseline is ``vehval batch --workers 0``
(a plain loop in one warm process). Two cluster figures: a new local cluster per batch (what
a user pays for one short batch: cluster start + cold worker imports) and a warm cluster
through ``--scheduler`` (the steady-state rate of a long batch). On a 2-core machine the
ideal ratio is 2.
"""

from __future__ import annotations

import logging
import os
import shutil
import tempfile
import time
from pathlib import Path

from benchmarks.common import row

N_TESTS = 16
N_DISTINCT = 2
CYCLE = "udds"  # 1369 s: a real test length (10 Hz facility file + 1 Hz OBD file)


def _inputs(root: Path) -> Path:
    """``N_TESTS`` test directories under ``root/in``; returns the template path."""
    from vehval.synth import make_virtual_test

    srcs = []
    for i in range(N_DISTINCT):
        out = make_virtual_test(cycle=CYCLE, seed=i, outdir=root / f"v{i}")
        srcs.append(out.files)
    for k in range(N_TESTS):
        d = root / "in" / f"t{k:03d}"
        d.mkdir(parents=True)
        for f in srcs[k % N_DISTINCT]:
            shutil.copy(f, d / Path(f).name)
    return Path(out.template_path)


def _timed(root: Path, template: Path, tag: str, workers: int = 0,
           scheduler: str | None = None) -> float:
    from vehval.batch import run_batch

    t0 = time.perf_counter()
    s = run_batch(root / "in", template, root / f"out_{tag}", steps=["qa"], workers=workers,
                  scheduler=scheduler, report=False, force=True, progress=False)
    dt = time.perf_counter() - t0
    if s.n_ok != N_TESTS:
        raise RuntimeError(f"benchmark batch had failures: {s.n_failed} of {N_TESTS}")
    return dt


def run() -> list[dict]:
    from distributed import LocalCluster

    rows = []
    ncpu = os.cpu_count() or 1
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        template = _inputs(root)
        _timed(root, template, "warm")                 # imports and caches warm in this process
        t_loop = _timed(root, template, "loop")
        t_cold = _timed(root, template, "cold", workers=ncpu)
        t0 = time.perf_counter()
        with LocalCluster(n_workers=ncpu, threads_per_worker=1, processes=True,
                          dashboard_address=None, host="127.0.0.1",
                          silence_logs=logging.ERROR) as cluster:
            t_start = time.perf_counter() - t0
            _timed(root, template, "prime", scheduler=cluster.scheduler_address)
            t_warm = _timed(root, template, "warmcluster", scheduler=cluster.scheduler_address)
    loop = 60.0 * N_TESTS / t_loop
    what = (f"{N_TESTS} virtual tests ({CYCLE}, D3 10 Hz + OBD 1 Hz files), import + QA, no "
            f"report, catalog written; {ncpu} worker processes x 1 thread")
    rows.append(row("batch_tests_per_min_new_local_cluster", 60.0 * N_TESTS / t_cold, "tests/min",
                    baseline=loop, target=1.0, better="higher",
                    note=what + "; includes cluster start/stop and each worker's cold imports "
                         "(about 3 s of scipy/pint/pandas per process); baseline plain loop in "
                         "one warm process (--workers 0)"))
    rows.append(row("batch_tests_per_min_warm_cluster", 60.0 * N_TESTS / t_warm, "tests/min",
                    baseline=loop, target=1.6, better="higher",
                    note=what + "; workers already warm (--scheduler on a running cluster), "
                         f"the steady-state rate of a long batch; ideal ratio {ncpu}"))
    rows.append(row("batch_tests_per_min_plain_loop", loop, "tests/min", better="higher",
                    note="same batch, --workers 0, warm process"))
    rows.append(row("local_cluster_start", t_start, "s", target=10.0,
                    note=f"LocalCluster({ncpu} processes) start, the fixed cost of a batch"))
    return rows


if __name__ == "__main__":  # pragma: no cover
    for r in run():
        print(r)
