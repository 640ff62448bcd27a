"""Many simulations of one vehicle and cycle with varied parameters (for calibration).

Variants are dicts of dotted parameter paths -> value (``{"controller.soc_gain_w": 1e5}``)
or a 2-D array whose columns are named by ``columns``. Variants that change only scalar
parameters share the maps and run in parallel in one compiled call (numba ``prange``);
a variant that changes a map-related parameter of the engine is run on its own.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Sequence

import numpy as np

from vehval.cycles import Cycle, load_cycle
from vehval.errors import ConfigError
from vehval.sim.kernel import run_batch
from vehval.sim.layout import SIGNALS
from vehval.sim.packing import pack, param_vector
from vehval.sim.simulate import check_dt, cycle_grid, run_cycle, summarise
from vehval.vehicle import Vehicle, load_vehicle

#: engine parameters that change the best-efficiency line (and so the packed maps)
_MAP_KEYS = {"engine.idle_speed_rpm", "engine.max_speed_rpm", "engine.max_power_w"}


def _as_dicts(variants, columns: Sequence[str] | None) -> list[dict[str, Any]]:
    if isinstance(variants, np.ndarray) or (variants and not isinstance(variants[0], dict)):
        arr = np.atleast_2d(np.asarray(variants, dtype=float))
        if columns is None or len(columns) != arr.shape[1]:
            raise ConfigError("a 2-D parameter array needs 'columns' naming each column "
                              "(dotted parameter paths such as controller.soc_gain_w)")
        return [dict(zip(columns, row.tolist())) for row in arr]
    return [dict(v) for v in variants]


def simulate_batch(vehicle: Vehicle | str | Path, cycle: Cycle | str | Path,
                   variants, dt: float = 1.0, workers: int = 2,
                   columns: Sequence[str] | None = None, soc_initial: float | None = None,
                   traces: Sequence[str] = ()) -> list[dict[str, Any]]:
    """Simulate every parameter variant; return one summary dict per variant (same order).

    Parameters
    ----------
    vehicle, cycle
        As for :func:`vehval.sim.simulate.simulate`.
    variants : list of dict or 2-D array
        Overrides by dotted path per variant (an empty dict is the base vehicle).
    dt : float
        Step [s].
    workers : int
        Threads for the parallel loop (numba), >= 1.
    columns : sequence of str, optional
        Dotted paths naming the columns when ``variants`` is an array.
    soc_initial : float, optional
        Initial SOC for every variant (default: each variant's SOC target).
    traces : sequence of str
        Base names of signals to return per variant (``summary['traces'][name]``); these
        variants are then run one by one with recording.
    """
    import numba

    base = load_vehicle(vehicle)
    cyc = load_cycle(cycle)
    dt = check_dt(dt)
    if workers < 1:
        raise ConfigError(f"workers must be >= 1, got {workers}")
    rows = _as_dicts(variants, columns)
    grid = cycle_grid(base, cyc, dt)
    vehs = [base.with_overrides(r) for r in rows]
    socs = [v.controller.soc_target if soc_initial is None else float(soc_initial) for v in vehs]
    results: list[dict[str, Any] | None] = [None] * len(rows)
    shared: list[int] = []
    for k, (r, v) in enumerate(zip(rows, vehs)):
        keys = {key.replace("__", ".") for key in r}
        if traces or (keys & _MAP_KEYS):
            out, ys = run_cycle(v, cycle_grid(v, cyc, dt), socs[k], record=bool(traces))
            res = results[k] = summarise(v, ys, socs[k])
            if traces:
                res["traces"] = {"time": grid.t, **{n: out[:, SIGNALS.index(n)]
                                                   for n in traces}}
        else:
            shared.append(k)
    if shared:
        maps = pack(base, socs[shared[0]]).maps
        prms = np.stack([param_vector(vehs[k], socs[k]) for k in shared])
        old = numba.get_num_threads()
        numba.set_num_threads(min(workers, numba.config.NUMBA_NUM_THREADS))  # type: ignore[attr-defined]  # set at run time
        try:
            ys_all = run_batch(grid.vt, grid.lo, grid.hi, dt, prms, maps)
        finally:
            numba.set_num_threads(old)
        for j, k in enumerate(shared):
            results[k] = summarise(vehs[k], ys_all[j], socs[k])
    done = [res for res in results if res is not None]  # every row ran, alone or batched
    for res, r in zip(done, rows):
        res["variant"] = r
    return done
