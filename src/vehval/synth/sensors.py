"""Sensor models of the virtual dyno: lag, calibration error, noise and quantisation.

The per-channel specification lives in ``data/faults/sensors.yaml`` (one table per virtual
file). A channel is measured from one clean SI signal through the chain::

    clean [SI] -> first-order lag -> gain * x + offset -> + noise -> (faults) -> raw unit
               -> quantisation -> written with a fixed number of decimals

Every random draw comes from a generator keyed by (seed, file, channel), so adding a channel
or a fault never changes the samples of another channel.
"""

from __future__ import annotations

import zlib
from dataclasses import asdict, dataclass, field
from functools import lru_cache
from importlib import resources
from typing import Literal

import numpy as np

from vehval.errors import ConfigError
from vehval.nomenclature import registry
from vehval.safe_yaml import load_yaml
from vehval.units import conversion


@dataclass(frozen=True)
class SensorSpec:
    """Measurement model of one raw channel.

    Attributes
    ----------
    channel : str
        Raw channel name as written in the file header (without the unit).
    unit : str or None
        Raw unit written in the header (``None``: no unit, e.g. ``Phase_#``).
    name : str
        Standard signal name the template maps the channel to, e.g. ``eng_spd_out_obd_test``.
    clean : str
        Base name of the clean SI signal the channel is derived from, e.g. ``eng_spd_out``.
    noise_si : float
        Standard deviation of the white Gaussian noise [SI unit of ``name``].
    gain : float
        Calibration gain [-].
    offset_si : float
        Calibration offset [SI unit of ``name``].
    quant_raw : float
        Quantisation step [raw unit]; 0 means only the file's decimals.
    lag_s : float
        Time constant of the first-order sensor filter [s]; 0 means none.
    floor_si : float or None
        Lowest value the sensor can output [SI] (e.g. 0 for a pulse-counting speed pickup,
        which reads 0, never a negative noise value, at standstill); ``None`` for none.
    """

    channel: str
    unit: str | None
    name: str
    clean: str
    noise_si: float = 0.0
    gain: float = 1.0
    offset_si: float = 0.0
    quant_raw: float = 0.0
    lag_s: float = 0.0
    floor_si: float | None = None

    @property
    def si_unit(self) -> str:
        """SI unit of the standard signal (from the registry)."""
        return registry().spec_of(self.name).unit

    def raw_conversion(self, fuel_density_kg_per_m3: float | None = None) -> tuple[float, float]:
        """``(scale, offset)`` with ``si = raw * scale + offset`` for this channel's raw unit."""
        return conversion(self.unit, self.si_unit, fuel_density_kg_per_m3=fuel_density_kg_per_m3)

    def to_dict(self, fuel_density_kg_per_m3: float | None = None) -> dict:
        """The spec as plain data, with the quantisation also given in SI."""
        out = asdict(self)
        scale, _ = self.raw_conversion(fuel_density_kg_per_m3)
        out["si_unit"] = self.si_unit
        out["quant_si"] = abs(self.quant_raw * scale)
        return out


@dataclass(frozen=True)
class FileSpec:
    """Acquisition settings of one virtual file and its channels."""

    label: str
    format: Literal["d3", "csv"]
    source: str
    rate_hz: float
    decimals: int
    channels: dict[str, SensorSpec]
    settings: dict = field(default_factory=dict)

    def setting(self, key: str, default: float = 0.0) -> float:
        return float(self.settings.get(key, default))


_FILE_KEYS = {"format", "source", "rate_hz", "decimals", "channels", "pre_padding_s",
              "post_padding_s", "period_jitter_s", "slow_round_probability", "start_s"}
_CHANNEL_KEYS = {"unit", "name", "clean", "noise_si", "gain", "offset_si", "quant_raw", "lag_s",
                 "floor_si"}


def parse_sensor_table(data: dict, origin: str = "sensors.yaml") -> dict[str, FileSpec]:
    """Validate a sensor table (the content of ``sensors.yaml``) into :class:`FileSpec` objects.

    Raises
    ------
    ConfigError
        Naming the file, key and reason for any unknown key, unknown signal or bad value.
    """
    if not isinstance(data, dict) or "files" not in data:
        raise ConfigError(f"{origin}: expected a mapping with a 'files' key")
    reg = registry()
    out: dict[str, FileSpec] = {}
    for label, entry in data["files"].items():
        extra = set(entry) - _FILE_KEYS
        if extra:
            raise ConfigError(f"{origin}: files.{label}: unknown keys {sorted(extra)}")
        chans: dict[str, SensorSpec] = {}
        for ch, spec in (entry.get("channels") or {}).items():
            extra = set(spec) - _CHANNEL_KEYS
            if extra:
                raise ConfigError(f"{origin}: files.{label}.channels.{ch}: unknown keys {sorted(extra)}")
            try:
                s = SensorSpec(channel=str(ch), **spec)
                reg.parse(s.name)
                if s.clean not in reg:
                    raise ConfigError(f"clean base name '{s.clean}' is not in the registry")
                s.raw_conversion(1.0)  # any density: checks the units only
            except ConfigError as exc:
                raise ConfigError(f"{origin}: files.{label}.channels.{ch}: {exc}") from None
            except Exception as exc:  # noqa: BLE001 - reported with its location
                raise ConfigError(f"{origin}: files.{label}.channels.{ch}: {exc}") from None
            chans[s.channel] = s
        settings = {k: entry[k] for k in entry if k not in ("format", "source", "rate_hz",
                                                             "decimals", "channels")}
        out[label] = FileSpec(label=label, format=entry["format"], source=entry["source"],
                              rate_hz=float(entry["rate_hz"]), decimals=int(entry["decimals"]),
                              channels=chans, settings=settings)
    return out


@lru_cache(maxsize=1)
def _default_table_text() -> str:
    return resources.files("vehval").joinpath("data/faults/sensors.yaml").read_text(encoding="utf-8")


def load_sensor_table() -> dict[str, FileSpec]:
    """The package sensor table (``data/faults/sensors.yaml``), keyed by file label."""
    return parse_sensor_table(load_yaml(_default_table_text(), "data/faults/sensors.yaml"),
                              "data/faults/sensors.yaml")


def rng_for(seed: int, *keys: str) -> np.random.Generator:
    """A generator keyed by the seed and names, independent of the order of use."""
    words = [int(seed) & 0xFFFFFFFF] + [zlib.crc32(k.encode("utf-8")) for k in keys]
    return np.random.default_rng(words)


def first_order_lag(x: np.ndarray, dt: float, tau: float) -> np.ndarray:
    """First-order low-pass filter of a uniformly sampled signal.

    Exact discretisation of ``tau * dy/dt + y = x`` for a piecewise-constant input, started
    at rest on the first sample (``y[0] = x[0]``).

    Parameters
    ----------
    x : numpy.ndarray
        Input samples [any unit], uniform step ``dt``.
    dt : float
        Sample period [s].
    tau : float
        Time constant [s]; ``tau <= 0`` returns a copy of ``x``.
    """
    x = np.asarray(x, dtype=float)
    if tau <= 0 or x.size == 0:
        return x.copy()
    from scipy.signal import lfilter

    a = float(np.exp(-dt / tau))
    y, _ = lfilter([1.0 - a], [1.0, -a], x, zi=np.array([a * x[0]]))
    return y


def quantise(raw: np.ndarray, step: float) -> np.ndarray:
    """Round raw samples to a multiple of ``step`` (NaN kept); ``step <= 0`` is a no-op."""
    if step <= 0:
        return np.asarray(raw, dtype=float).copy()
    return np.round(np.asarray(raw, dtype=float) / step) * step


def measure(spec: SensorSpec, clean_grid: np.ndarray, clean_values: np.ndarray,
            true_times: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Sensor output in SI at the true sample instants, before faults and quantisation.

    Parameters
    ----------
    spec : SensorSpec
        Channel model.
    clean_grid : numpy.ndarray
        Uniform grid of the clean signal [s].
    clean_values : numpy.ndarray
        Clean signal on ``clean_grid`` [SI].
    true_times : numpy.ndarray
        Instants at which the value is sampled, on the true clock [s].
    rng : numpy.random.Generator
        Noise generator of this channel.
    """
    dt = float(clean_grid[1] - clean_grid[0])
    lagged = first_order_lag(clean_values, dt, spec.lag_s)
    if spec.clean == "test_phase":  # a state: sampled, never interpolated
        idx = np.clip(np.searchsorted(clean_grid, true_times, side="right") - 1, 0, clean_grid.size - 1)
        x = lagged[idx]
    else:
        x = np.interp(true_times, clean_grid, lagged)
    y = spec.gain * x + spec.offset_si
    if spec.noise_si > 0:
        y = y + rng.normal(0.0, spec.noise_si, size=y.shape)
    if spec.floor_si is not None:
        y = np.maximum(y, spec.floor_si)
    return y


def expected_measurement(spec: SensorSpec, clean_grid: np.ndarray, clean_values: np.ndarray,
                         true_times: np.ndarray) -> np.ndarray:
    """Noise-free sensor output [SI] at ``true_times``: what a round trip must recover."""
    dt = float(clean_grid[1] - clean_grid[0])
    lagged = first_order_lag(clean_values, dt, spec.lag_s)
    if spec.clean == "test_phase":
        idx = np.clip(np.searchsorted(clean_grid, true_times, side="right") - 1, 0, clean_grid.size - 1)
        y = spec.gain * lagged[idx] + spec.offset_si
    else:
        y = spec.gain * np.interp(true_times, clean_grid, lagged) + spec.offset_si
    if spec.floor_si is not None:
        y = np.maximum(y, spec.floor_si)
    return y
