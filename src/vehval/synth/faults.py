"""Fault models of the virtual dyno: what can go wrong in a test file, injected on purpose.

A fault file is YAML: either a list of faults or ``{version: 1, faults: [...]}``; each fault is
``{kind, channel | file, start_s | start_frac, end_s | end_frac, magnitude, ...}`` (see
``data/faults/default.yaml`` for the meaning of ``magnitude`` per kind). ``"default"`` is the
package's representative mix, ``"none"`` injects nothing (and leaves every file on the true
clock).

Fault spans are on the clock of the file the channel is written to (the times a reader sees).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, ValidationError, model_validator

from vehval.errors import ConfigError
from vehval.safe_yaml import load_yaml, read_yaml
from vehval.synth.sensors import FileSpec, rng_for

FaultKind = Literal["clock_offset", "stuck", "dropout", "spikes", "gain_error", "offset",
                    "offset_drift", "sign_flip", "wrong_unit", "out_of_range", "zero", "truncated"]

#: Kinds that apply to a whole file rather than to one channel.
FILE_KINDS = frozenset({"clock_offset", "truncated"})
#: Kinds that need a magnitude.
NEEDS_MAGNITUDE = frozenset({"clock_offset", "spikes", "gain_error", "offset", "offset_drift",
                             "out_of_range"})
#: Kinds applied to the SI samples (in this order of the fault list), before quantisation.
SI_KINDS = frozenset({"stuck", "spikes", "gain_error", "offset", "offset_drift", "sign_flip",
                      "out_of_range"})
#: Kinds applied to the raw samples after quantisation.
RAW_KINDS = frozenset({"zero", "dropout"})


class FaultSpec(BaseModel):
    """One fault as written in a fault file (times may be fractions of the cycle duration)."""

    model_config = ConfigDict(extra="forbid")

    kind: FaultKind
    channel: str | None = None
    file: str | None = None
    start_s: float | None = None
    end_s: float | None = None
    start_frac: float | None = None
    end_frac: float | None = None
    magnitude: float | None = None
    delay_s: float = 0.0
    count: int = 5
    label_unit: str | None = None
    description: str = ""

    @model_validator(mode="after")
    def _check(self) -> "FaultSpec":
        if self.start_s is not None and self.start_frac is not None:
            raise ValueError("give start_s or start_frac, not both")
        if self.end_s is not None and self.end_frac is not None:
            raise ValueError("give end_s or end_frac, not both")
        if self.kind in FILE_KINDS:
            if not self.file:
                raise ValueError(f"kind '{self.kind}' applies to a file: set file (facility or obd)")
        elif not self.channel:
            raise ValueError(f"kind '{self.kind}' applies to a channel: set channel")
        if self.kind in NEEDS_MAGNITUDE and self.magnitude is None:
            raise ValueError(f"kind '{self.kind}' needs a magnitude")
        if self.kind == "wrong_unit" and not self.label_unit:
            raise ValueError("kind 'wrong_unit' needs label_unit (the unit written in the header)")
        if self.kind == "spikes" and self.count < 1:
            raise ValueError("spikes: count must be >= 1")
        if self.kind == "truncated" and self.start_s is None and self.start_frac is None:
            raise ValueError("truncated: set start_s or start_frac (where the file is cut)")
        for key in ("start_frac", "end_frac"):
            v = getattr(self, key)
            if v is not None and not 0.0 <= v <= 1.0:
                raise ValueError(f"{key} must be within 0..1")
        return self


@dataclass
class Fault:
    """A fault resolved against the files: absolute span on the file clock, target known."""

    index: int
    kind: str
    file: str
    channel: str | None
    signal: str | None
    start_s: float
    end_s: float
    magnitude: float | None
    description: str
    params: dict = field(default_factory=dict)
    details: dict = field(default_factory=dict)

    def to_dict(self, offset_s: float = 0.0) -> dict:
        """Truth record; ``true_start_s``/``true_end_s`` are on the true clock."""
        out = {"index": self.index, "kind": self.kind, "file": self.file, "channel": self.channel,
               "signal": self.signal, "start_s": self.start_s, "end_s": self.end_s,
               "true_start_s": round(self.start_s + offset_s, 6),
               "true_end_s": round(self.end_s + offset_s, 6),
               "magnitude": self.magnitude, "description": self.description}
        out.update(self.params)
        out.update(self.details)
        return out


def load_fault_specs(faults: str | Path | list) -> list[FaultSpec]:
    """Fault specs from ``"default"``, ``"none"``, a YAML path or an already-parsed list.

    Raises
    ------
    ConfigError
        When the file is missing or unreadable, or a fault is invalid (file, index, reason).
    """
    if isinstance(faults, list):
        data, origin = faults, "faults"
    elif str(faults) == "none":
        return []
    elif str(faults) == "default":
        origin = "data/faults/default.yaml"
        data = load_yaml(resources.files("vehval").joinpath(origin).read_text(encoding="utf-8"),
                         origin)
    else:
        path = Path(faults)
        origin = str(path)
        if not path.is_file():
            raise ConfigError(f"fault file '{path}' does not exist: give 'default', 'none' or "
                              "the path of a fault YAML file")
        data = read_yaml(path)
    if isinstance(data, dict):
        extra = set(data) - {"version", "faults"}
        if extra:
            raise ConfigError(f"{origin}: unknown top-level keys {sorted(extra)} (use version, faults)")
        if data.get("version", 1) != 1:
            raise ConfigError(f"{origin}: version {data.get('version')!r} not supported (use 1)")
        data = data.get("faults") or []
    if data is None:
        data = []
    if not isinstance(data, list):
        raise ConfigError(f"{origin}: expected a list of faults or a mapping with 'faults:'")
    specs = []
    for i, item in enumerate(data):
        if not isinstance(item, dict):
            raise ConfigError(f"{origin}: faults[{i}]: expected a mapping, got {type(item).__name__}")
        try:
            specs.append(FaultSpec.model_validate(item))
        except ValidationError as exc:
            err = exc.errors()[0]
            loc = ".".join(str(p) for p in err["loc"])
            msg = str(err["msg"]).removeprefix("Value error, ")
            raise ConfigError(f"{origin}: faults[{i}] ({item.get('kind', '?')}): "
                              f"{loc + ': ' if loc else ''}{msg}") from None
    return specs


def resolve_faults(specs: list[FaultSpec], files: dict[str, FileSpec], duration_s: float,
                   file_spans: dict[str, tuple[float, float]], origin: str = "faults",
                   ) -> list[Fault]:
    """Attach each fault to its file and standard signal and make its span absolute.

    Parameters
    ----------
    specs : list of FaultSpec
        Faults as read.
    files : dict
        Sensor table, keyed by file label.
    duration_s : float
        Cycle duration [s] used for ``*_frac`` times.
    file_spans : dict
        ``label -> (first, last)`` time on each file's clock [s], used for open spans.
    """
    owner = {ch: label for label, fs in files.items() for ch in fs.channels}
    out: list[Fault] = []
    seen: set[tuple[str, str]] = set()
    for i, s in enumerate(specs):
        where = f"{origin}: faults[{i}] ({s.kind})"
        if s.kind in FILE_KINDS:
            if s.file not in files:
                raise ConfigError(f"{where}: unknown file '{s.file}' (use {', '.join(files)})")
            label, channel, signal = s.file, None, None
        else:
            if s.channel not in owner:
                raise ConfigError(f"{where}: unknown channel '{s.channel}'; known channels: "
                                  f"{', '.join(sorted(owner))}")
            label, channel = owner[s.channel], s.channel
            if s.file is not None and s.file != label:
                raise ConfigError(f"{where}: channel '{channel}' is in file '{label}', not '{s.file}'")
            signal = files[label].channels[channel].name
        key = (s.kind, channel or label)
        if s.kind in ("clock_offset", "truncated", "wrong_unit") and key in seen:
            raise ConfigError(f"{where}: a second '{s.kind}' fault on '{channel or label}'")
        seen.add(key)
        lo, hi = file_spans[label]
        start = (s.start_s if s.start_s is not None else
                 s.start_frac * duration_s if s.start_frac is not None else lo)
        end = (s.end_s if s.end_s is not None else
               s.end_frac * duration_s if s.end_frac is not None else hi)
        if s.kind == "truncated":
            end = hi
        if not end > start:
            raise ConfigError(f"{where}: end ({end:g} s) must be after start ({start:g} s)")
        params: dict[str, Any] = {}
        if s.kind == "clock_offset":
            params = {"clock_offset_s": s.magnitude, "delay_s": s.delay_s}
        elif s.kind == "spikes":
            params = {"count": s.count}
        elif s.kind == "wrong_unit" and channel is not None:  # a channel fault: always set
            params = {"label_unit": s.label_unit,
                      "true_unit": files[label].channels[channel].unit}
        out.append(Fault(index=i, kind=s.kind, file=label, channel=channel, signal=signal,
                         start_s=round(float(start), 6), end_s=round(float(end), 6),
                         magnitude=s.magnitude,
                         description=s.description, params=params))
    return out


def _span(t: np.ndarray, f: Fault) -> np.ndarray:
    return (t >= f.start_s) & (t <= f.end_s)


def apply_si_faults(values: np.ndarray, t_file: np.ndarray, faults: list[Fault], seed: int,
                    ) -> np.ndarray:
    """Apply the SI-domain faults of one channel (in list order) to its sensor output.

    Parameters
    ----------
    values : numpy.ndarray
        Sensor output [SI].
    t_file : numpy.ndarray
        Sample times on the file clock [s].
    faults : list of Fault
        Faults of this channel; kinds outside :data:`SI_KINDS` are ignored here.
    seed : int
        Test seed (spike positions are drawn from a generator keyed by seed and fault index).
    """
    y = np.array(values, dtype=float)
    for f in faults:
        if f.kind not in SI_KINDS:
            continue
        m = _span(t_file, f)
        idx = np.flatnonzero(m)
        if idx.size == 0:
            f.details["samples_affected"] = 0
            continue
        # every kind using it needs a magnitude (NEEDS_MAGNITUDE, checked on reading)
        mag = float("nan") if f.magnitude is None else float(f.magnitude)
        if f.kind == "stuck":
            y[idx] = y[idx[0]]
            f.details["stuck_value_si"] = float(y[idx[0]])
        elif f.kind == "spikes":
            rng = rng_for(seed, "fault", str(f.index), f.channel or "")
            n = min(int(f.params["count"]), idx.size)
            pick = np.sort(rng.choice(idx, size=n, replace=False))
            signs = rng.choice([-1.0, 1.0], size=n)
            y[pick] += signs * mag
            f.details["spike_times_s"] = [round(float(t_file[k]), 3) for k in pick]
            f.details["spike_signs"] = [int(s) for s in signs]
            idx = pick
        elif f.kind == "gain_error":
            y[idx] *= 1.0 + mag
        elif f.kind == "offset":
            y[idx] += mag
        elif f.kind == "offset_drift":
            frac = (t_file[idx] - f.start_s) / (f.end_s - f.start_s)
            y[idx] += mag * np.clip(frac, 0.0, 1.0)
        elif f.kind == "sign_flip":
            y[idx] = -y[idx]
        elif f.kind == "out_of_range":
            y[idx] = mag
        f.details["samples_affected"] = int(idx.size)
    return y


def apply_raw_faults(raw: np.ndarray, t_file: np.ndarray, faults: list[Fault]) -> np.ndarray:
    """Apply the raw-domain faults (``zero``, ``dropout``) of one channel after quantisation."""
    y = np.array(raw, dtype=float)
    for f in faults:
        if f.kind not in RAW_KINDS:
            continue
        m = _span(t_file, f)
        y[m] = 0.0 if f.kind == "zero" else np.nan
        f.details["samples_affected"] = int(m.sum())
    return y
