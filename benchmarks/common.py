"""Shared helpers for the benchmarks: timing, peak memory, result rows, synthetic D3 files.

Speed is always reported as a ratio against a baseline measured in the same run on the same
machine (e.g. ``numpy.loadtxt`` for a reader), never as an absolute number checked in a test.
"""

from __future__ import annotations

import gc
import time
import tracemalloc
from pathlib import Path
from typing import Any, Callable

import numpy as np

from vehval.io.atomic import atomic_path

__all__ = ["best_of", "peak_memory", "row", "make_d3_file", "D3_CHANNELS"]


def best_of(fn: Callable[[], Any], n: int = 5, warmup: int = 1) -> float:
    """Best wall-clock time of ``n`` calls of ``fn`` after ``warmup`` untimed calls [s].

    The minimum is the least noisy estimate of the cost of the code itself; garbage
    collection is disabled during each timed call.
    """
    for _ in range(warmup):
        fn()
    best = float("inf")
    for _ in range(max(1, n)):
        gc_was = gc.isenabled()
        gc.disable()
        try:
            t0 = time.perf_counter()
            fn()
            best = min(best, time.perf_counter() - t0)
        finally:
            if gc_was:
                gc.enable()
    return best


def peak_memory(fn: Callable[[], Any]) -> tuple[Any, int]:
    """Run ``fn`` once under tracemalloc; return ``(result, peak traced bytes)``.

    Only Python/numpy allocations made through the Python allocator are seen (numpy data
    buffers are traced); memory held by C libraries outside it is not.
    """
    gc.collect()
    tracemalloc.start()
    try:
        tracemalloc.reset_peak()
        result = fn()
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    return result, int(peak)


def row(name: str, value: float, unit: str, *, baseline: float | None = None,
        target: float | None = None, better: str = "lower", note: str = "") -> dict[str, Any]:
    """One result row.

    Parameters
    ----------
    name : str
        What was measured, e.g. ``"import_d3_1500s_60ch"``.
    value : float
        Measured value in ``unit``.
    unit : str
        Unit of ``value`` and ``baseline`` (e.g. ``"s"``, ``"MB"``, ``"samples/s"``).
    baseline : float, optional
        The same quantity for the reference implementation, measured in the same run.
    target : float, optional
        Goal for ``ratio`` (when a baseline is given) or for ``value`` (otherwise).
    better : {"lower", "higher"}
        Direction in which the compared quantity improves.
    note : str
        What the baseline is and anything needed to read the figure.
    """
    ratio = (value / baseline) if baseline not in (None, 0) else None
    return {"name": name, "value": float(value), "unit": unit,
            "baseline": None if baseline is None else float(baseline),
            "ratio": None if ratio is None else float(ratio),
            "target": None if target is None else float(target),
            "better": better, "note": note}


# --------------------------------------------------------------------------- D3 files
#: Realistic channel headers of an Argonne D3 hybrid test file, in file order (after Time).
D3_CHANNELS: list[str] = [
    "Dyno_Speed[mph]", "Dyno_Tractive_Effort[N]", "Dyno_Spd_Front[mph]", "Dyno_Spd_Rear[mph]",
    "Test_Cell_Temp[C]", "Test_Cell_RH[%]", "Test_Cell_Baro[inHg]", "Phase_#",
    "Engine_Speed[rpm]", "Engine_Coolant_Temp[C]", "Engine_Oil_Temp[C]",
    "Fuel_Flow_Bench_Modal[g/s]", "Eng_FuelFlow_Direct[ccps]", "Accel_Pedal_Pos[%]",
    "Brake_Pedal[-]", "Bty_Volt[V]", "Bty_Curr[A]", "Bty_Pwr[kW]", "Bty_SOC_OBD[%]",
    "MG1_Speed[rpm]", "MG2_Speed[rpm]", "MG1_Torque[Nm]", "MG2_Torque[Nm]",
    "Inverter_Volt[V]", "Bty_Temp[C]", "Eng_Speed_OBD[rpm]", "Veh_Speed_OBD[kph]",
    "Intake_Air_Temp[C]", "Exhaust_Temp[C]", "Aux_12V_Volt[V]", "Aux_12V_Curr[A]",
]


def _udds_mph(t: np.ndarray) -> np.ndarray:
    from vehval.cycles import load_cycle

    cyc = load_cycle("udds")
    period = cyc.duration_s
    tt = np.where(t < 0, -1.0, np.mod(np.maximum(t, 0.0), period))
    return np.where(t < 0, 0.0, np.interp(tt, cyc.time_s, cyc.speed_mps)) / 0.44704


def make_d3_file(path: str | Path, duration_s: float = 1500, rate_hz: float = 10,
                 n_channels: int = 60, seed: int = 0) -> Path:
    """Write a synthetic D3-style tab-separated test file quickly and return its path.

    The file looks like an Argonne D3 export: a header line ``Time[sec]<TAB>Dyno_Speed[mph]
    <TAB>...`` with units in brackets, CRLF line endings, values with three decimals, time
    starting at -10 s. The speed follows the UDDS (repeated to fill the duration) and the
    other channels are plausible functions of it plus noise, so readers and QA see
    realistic data. Beyond the named channels, extra ``DAQ_Temp_<k>[C]`` and
    ``DAQ_Volt_<k>[V]`` channels fill up to ``n_channels``.

    Parameters
    ----------
    path : str or Path
        Output file (written atomically).
    duration_s : float
        Length of the record [s]; ``duration_s * rate_hz`` rows.
    rate_hz : float
        Sample rate [Hz].
    n_channels : int
        Number of data channels besides time.
    seed : int
        Seed of the noise generator (same seed, same file).
    """
    rng = np.random.default_rng(seed)
    n = int(round(duration_s * rate_hz))
    t = -10.0 + np.arange(n) / rate_hz
    mph = _udds_mph(t)
    mps = mph * 0.44704
    acc = np.gradient(mps, t)
    on = (mps > 12.0) | (acc > 0.8)  # crude engine-on pattern for a hybrid
    eng_rpm = np.where(on, 1000.0 + 2000.0 * np.clip(mps / 25.0 + acc / 2.0, 0, 1), 0.0)
    force = 1295.0 * acc + 88.6 + 0.14 * mps + 0.36 * mps ** 2
    mg2_rpm = mps / 0.305 * 4.113 * 60 / (2 * np.pi)
    mg1_rpm = (eng_rpm * (78 + 30) - mg2_rpm * 78) / 30
    bty_curr = np.clip(force * mps / 201.6 * np.where(on, 0.3, 1.0), -100, 100)
    soc = 60.0 - np.cumsum(bty_curr) / rate_hz / (6.5 * 3600) * 100

    def noise(scale: float) -> np.ndarray:
        return rng.normal(0.0, scale, n)

    base = {
        "Dyno_Speed[mph]": mph + noise(0.01),
        "Dyno_Tractive_Effort[N]": force + noise(5.0),
        "Dyno_Spd_Front[mph]": mph + noise(0.01),
        "Dyno_Spd_Rear[mph]": mph + noise(0.01),
        "Test_Cell_Temp[C]": 22.0 + noise(0.05),
        "Test_Cell_RH[%]": 45.0 + noise(0.2),
        "Test_Cell_Baro[inHg]": 29.1 + noise(0.01),
        "Phase_#": np.where(t < 505, 1.0, 2.0),
        "Engine_Speed[rpm]": eng_rpm + noise(5.0) * on,
        "Engine_Coolant_Temp[C]": 90.0 - 60.0 * np.exp(-np.maximum(t, 0) / 300.0),
        "Engine_Oil_Temp[C]": 95.0 - 70.0 * np.exp(-np.maximum(t, 0) / 500.0),
        "Fuel_Flow_Bench_Modal[g/s]": np.where(on, 0.3 + eng_rpm / 3000.0, 0.0) + noise(0.005),
        "Eng_FuelFlow_Direct[ccps]": np.where(on, 0.4 + eng_rpm / 2200.0, 0.0) + noise(0.005),
        "Accel_Pedal_Pos[%]": np.clip(acc * 30.0 + mps, 0, 100),
        "Brake_Pedal[-]": (acc < -0.3).astype(float),
        "Bty_Volt[V]": 201.6 - 0.3 * bty_curr + noise(0.2),
        "Bty_Curr[A]": bty_curr + noise(0.5),
        "Bty_Pwr[kW]": (201.6 - 0.3 * bty_curr) * bty_curr / 1000.0,
        "Bty_SOC_OBD[%]": np.round(soc * 2) / 2,
        "MG1_Speed[rpm]": mg1_rpm + noise(5.0),
        "MG2_Speed[rpm]": mg2_rpm + noise(5.0),
        "MG1_Torque[Nm]": np.where(on, -20.0, 0.0) + noise(0.5),
        "MG2_Torque[Nm]": np.clip(force * 0.305 / 4.113, -400, 400) + noise(1.0),
        "Inverter_Volt[V]": np.where(mps > 0, 500.0, 201.6) + noise(1.0),
        "Bty_Temp[C]": 25.0 + np.maximum(t, 0) / 300.0,
        "Eng_Speed_OBD[rpm]": np.round(eng_rpm),
        "Veh_Speed_OBD[kph]": np.round(mps * 3.6),
        "Intake_Air_Temp[C]": 30.0 + noise(0.1),
        "Exhaust_Temp[C]": np.where(on, 450.0, 200.0) + noise(2.0),
        "Aux_12V_Volt[V]": 13.8 + noise(0.02),
        "Aux_12V_Curr[A]": 15.0 + noise(0.3),
    }
    names = list(base)[:n_channels]
    cols = [base[k] for k in names]
    k = 0
    while len(names) < n_channels:
        k += 1
        if k % 2:
            names.append(f"DAQ_Temp_{k}[C]")
            cols.append(25.0 + k + noise(0.1))
        else:
            names.append(f"DAQ_Volt_{k}[V]")
            cols.append(5.0 + noise(0.01))
    data = np.column_stack([t] + cols)
    out = Path(path)
    with atomic_path(out) as tmp:
        with open(tmp, "w", encoding="ascii", newline="") as fh:
            fh.write("\t".join(["Time[sec]"] + names) + "\r\n")
            np.savetxt(fh, data, fmt="%.3f", delimiter="\t", newline="\r\n")
    return out
