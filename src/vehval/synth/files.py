"""Sample the clean signals into the virtual files (time bases, sensors, faults).

Time convention (also written into ``truth.json``): every file has its own clock. A sample
stamped ``file_time`` in a file holds the value the quantity had at the true (simulation)
instant ``true_time = file_time + offset_s``, with ``offset_s = -(clock_offset_s + delay_s)``:
the file's clock runs ``clock_offset_s`` ahead of the true clock and the value reaches the
logger ``delay_s`` after it happened. ``Test.shift_source(source, offset_s)`` therefore puts an
imported source back on the true clock.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from vehval.synth.faults import Fault, apply_raw_faults, apply_si_faults
from vehval.synth.sensors import FileSpec, measure, quantise, rng_for
from vehval.synth.writers import header_text

#: Time column (name, unit) per file style.
TIME_HEADER = {"d3": ("Time", "sec"), "csv": ("Timestamp", "s")}


@dataclass
class FileData:
    """One virtual file, ready to be written (raw units)."""

    label: str
    spec: FileSpec
    file_time: np.ndarray
    offset_s: float
    clock_offset_s: float
    delay_s: float
    headers: list[str] = field(default_factory=list)
    columns: list[np.ndarray] = field(default_factory=list)
    header_units: dict[str, str | None] = field(default_factory=dict)
    truncate_rows: int | None = None

    @property
    def true_time(self) -> np.ndarray:
        return self.file_time + self.offset_s


def d3_times(spec: FileSpec, duration_s: float, seed: int) -> np.ndarray:
    """File-clock stamps of a D3 file [s]: from -pre_padding at ``1/rate`` with clock drift.

    The real 10 Hz files advance by a step a hair below 0.1 s, so that after some minutes a
    0.099 s step appears once the value is written with 3 decimals; the drift here is drawn
    between 5e-8 and 1.5e-7 s per sample.
    """
    rng = rng_for(seed, spec.label, "time")
    step = 1.0 / spec.rate_hz - rng.uniform(5e-8, 1.5e-7)
    t0 = -spec.setting("pre_padding_s", 10.0)
    t_end = duration_s + spec.setting("post_padding_s", 3.0)
    n = int(np.floor((t_end - t0) / step)) + 1
    return t0 + step * np.arange(n)


def logger_times(spec: FileSpec, duration_s: float, seed: int) -> np.ndarray:
    """Polling instants of the OBD logger on its own clock before any clock offset [s].

    Periods are ``1/rate`` plus Gaussian jitter (std ``period_jitter_s``), and with
    probability ``slow_round_probability`` a round takes 0.5 s longer.
    """
    rng = rng_for(seed, spec.label, "time")
    period = 1.0 / spec.rate_hz
    t0 = spec.setting("start_s", -4.0)
    t_end = duration_s + spec.setting("post_padding_s", 2.0)
    n_max = int(np.ceil((t_end - t0) / (0.5 * period))) + 2
    jitter = rng.normal(0.0, spec.setting("period_jitter_s", 0.04), n_max)
    slow = rng.random(n_max) < spec.setting("slow_round_probability", 0.0)
    steps = np.clip(period + jitter, 0.5 * period, 2.0 * period) + 0.5 * period * slow
    t = t0 + np.concatenate([[0.0], np.cumsum(steps)])
    return t[t <= t_end]


def build_file(spec: FileSpec, grid: np.ndarray, clean: dict[str, np.ndarray],
               duration_s: float, seed: int, faults: list[Fault],
               fuel_density_kg_per_m3: float) -> FileData:
    """Sample, measure, corrupt and convert every channel of one file.

    Parameters
    ----------
    spec : FileSpec
        The file's sensor table.
    grid, clean
        Clean signals on the extended grid (see :mod:`vehval.synth.clean`).
    duration_s : float
        Cycle duration [s].
    seed : int
        Test seed.
    faults : list of Fault
        Resolved faults of this file (file-level and channel-level); their ``details`` are
        filled with what was done.
    fuel_density_kg_per_m3 : float
        For volumetric fuel flow units [kg/m^3].
    """
    clock = next((f for f in faults if f.kind == "clock_offset"), None)
    c = float(clock.params["clock_offset_s"]) if clock else 0.0
    d = float(clock.params["delay_s"]) if clock else 0.0
    if spec.format == "d3":
        # the facility DAQ stamps its samples on its own clock: stamps fixed, content shifted
        file_time = d3_times(spec, duration_s, seed)
    else:
        # the logger polls on the true clock, stamps with its own (offset) clock
        file_time = logger_times(spec, duration_s, seed) + c
    # the stamps as written are the sampling instants (no hidden rounding error)
    file_time = np.round(file_time, spec.decimals) + 0.0
    data = FileData(label=spec.label, spec=spec, file_time=file_time, offset_s=-(c + d),
                    clock_offset_s=c, delay_s=d)
    if clock:
        clock.details["offset_s"] = round(data.offset_s, 9) + 0.0
    true_t = data.true_time
    style = "d3" if spec.format == "d3" else "csv"
    data.headers.append(header_text(*TIME_HEADER[style], style))
    data.columns.append(file_time)
    for ch, sensor in spec.channels.items():
        mine = [f for f in faults if f.channel == ch]
        rng = rng_for(seed, spec.label, ch)
        si = measure(sensor, grid, clean[sensor.clean], true_t, rng)
        si = apply_si_faults(si, file_time, mine, seed)
        scale, off = sensor.raw_conversion(fuel_density_kg_per_m3)
        raw = quantise((si - off) / scale, sensor.quant_raw)
        raw = apply_raw_faults(raw, file_time, mine)
        wrong = next((f for f in mine if f.kind == "wrong_unit"), None)
        unit = wrong.params["label_unit"] if wrong else sensor.unit
        if wrong:
            wrong.details["samples_affected"] = int(raw.size)
        data.header_units[ch] = unit
        data.headers.append(header_text(ch, unit, style))
        data.columns.append(raw)
    trunc = next((f for f in faults if f.kind == "truncated"), None)
    if trunc:
        keep = int(np.searchsorted(file_time, trunc.start_s, side="right"))
        data.truncate_rows = keep
        trunc.details["rows_kept"] = keep
        trunc.details["rows_total"] = int(file_time.size)
        trunc.details["last_complete_time_s"] = round(float(file_time[keep - 1]), 3) if keep else None
    return data
