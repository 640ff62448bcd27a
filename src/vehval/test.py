"""The Test and Signal types: multi-rate signals in SI units with provenance.

Each acquisition system keeps its own time base; resampling to a common grid is explicit
and uses the registry's method per signal (linear for continuous quantities, previous value
for states and counters). The methods used are returned, never applied silently.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Collection, Iterable, Iterator, cast

import numpy as np

from vehval.errors import SignalError
from vehval.nomenclature import ResampleMethod, preference_rank, registry

if TYPE_CHECKING:  # pandas is imported by the one method that builds a data frame
    import pandas as pd


@dataclass
class Signal:
    """One channel in SI units on its own time base.

    Attributes
    ----------
    name : str
        Full standard name, e.g. ``eng_spd_out_obd_test``.
    time : numpy.ndarray
        Sample times [s], strictly increasing.
    values : numpy.ndarray
        Samples in ``unit`` (SI, float64; NaN marks a missing sample).
    unit : str
        SI unit from the registry, e.g. ``rad/s``.
    source : str
        Acquisition system (file tag) that produced it, e.g. ``dyno``, ``obd``, ``simu``.
    raw_name, raw_unit : str or None
        Channel name and unit as they were in the file (provenance).
    file : str or None
        File the samples came from.
    resample : {'linear', 'previous'}
        How the signal may be resampled.
    """

    name: str
    time: np.ndarray
    values: np.ndarray
    unit: str
    source: str = ""
    raw_name: str | None = None
    raw_unit: str | None = None
    file: str | None = None
    resample: ResampleMethod = "linear"
    notes: list[str] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.time = np.asarray(self.time, dtype=float)
        self.values = np.asarray(self.values, dtype=float)
        if self.time.shape != self.values.shape or self.time.ndim != 1:
            raise SignalError(
                f"signal '{self.name}': time and values must be 1-D of equal length "
                f"(got {self.time.shape} and {self.values.shape})")

    @classmethod
    def standard(cls, name: str, time: Iterable[float], values: Iterable[float], **kw) -> "Signal":
        """Build a signal whose unit and resample method come from the registry."""
        spec = registry().spec_of(name)
        kw.setdefault("unit", spec.unit)
        kw.setdefault("resample", spec.resample)
        return cls(name=name, time=np.asarray(time, float), values=np.asarray(values, float), **kw)

    @property
    def base(self) -> str:
        return registry().parse(self.name).base

    @property
    def sample_period(self) -> float:
        """Median sample period [s] (NaN for fewer than two samples)."""
        if self.time.size < 2:
            return float("nan")
        return float(np.median(np.diff(self.time)))

    def at(self, grid: np.ndarray, method: ResampleMethod | None = None) -> np.ndarray:
        """Samples on another time grid [s]; NaN outside the signal's own span."""
        return resample_values(self.time, self.values, np.asarray(grid, float), method or self.resample)

    def shifted(self, offset_s: float) -> "Signal":
        """A copy with ``offset_s`` [s] added to every timestamp."""
        return replace(self, time=self.time + offset_s, notes=list(self.notes))


def resample_values(time: np.ndarray, values: np.ndarray, grid: np.ndarray,
                    method: ResampleMethod) -> np.ndarray:
    """Resample ``values`` sampled at ``time`` onto ``grid`` [s].

    ``linear`` interpolates between neighbours (NaN samples stay NaN in their interval);
    ``previous`` holds the last sample at or before each grid time. Grid points outside
    ``[time[0], time[-1]]`` get NaN.
    """
    out = np.full(grid.shape, np.nan)
    if time.size == 0:
        return out
    inside = (grid >= time[0]) & (grid <= time[-1])
    g = grid[inside]
    if method == "previous":
        idx = np.searchsorted(time, g, side="right") - 1
        out[inside] = values[np.clip(idx, 0, time.size - 1)]
    elif method == "linear":
        if time.size == 1:
            out[inside] = values[0]
            return out
        idx = np.clip(np.searchsorted(time, g, side="right") - 1, 0, time.size - 2)
        t0, t1 = time[idx], time[idx + 1]
        w = np.where(t1 > t0, (g - t0) / np.where(t1 > t0, t1 - t0, 1.0), 0.0)
        v0, v1 = values[idx], values[idx + 1]
        res = v0 + w * (v1 - v0)
        exact = w == 0.0
        res[exact] = v0[exact]
        out[inside] = res
    else:
        raise SignalError(f"unknown resample method '{method}' (use 'linear' or 'previous')")
    return out


@dataclass
class TestMeta:
    """Test metadata: identity, provenance and the constants the template declared."""

    __test__ = False  # not a pytest test class

    test_id: str = ""
    vehicle: str = ""
    cycle: str = ""
    files: list[str] = field(default_factory=list)
    template: str | None = None
    constants: dict[str, float] = field(default_factory=dict)
    offsets_s: dict[str, float] = field(default_factory=dict)
    deleted: list[dict] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    synthetic: bool = False
    #: The template's ``fuel:`` (a fuel table name or explicit properties), kept at import.
    fuel: str | dict | None = None
    #: How the cycle was found in the record (:func:`vehval.cycles_match.identify_cycle`:
    #: name, score, offsets, windows...), kept at import for the later stages.
    cycle_match: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        return {k: getattr(self, k) for k in self.__dataclass_fields__}


class Test:
    """A vehicle test: standard-named SI signals, each on its own time base, plus metadata."""

    __test__ = False  # not a pytest class

    def __init__(self, signals: Iterable[Signal] = (), meta: TestMeta | None = None) -> None:
        self.signals: dict[str, Signal] = {}
        self.meta = meta or TestMeta()
        for sig in signals:
            self.add(sig)

    def add(self, signal: Signal, *, replace_existing: bool = False) -> None:
        """Add a signal; a duplicate name is an error unless ``replace_existing``."""
        if signal.name in self.signals and not replace_existing:
            raise SignalError(
                f"signal '{signal.name}' is defined twice (from {self.signals[signal.name].raw_name!r}"
                f" and {signal.raw_name!r}): give one of them a source qualifier in the template")
        self.signals[signal.name] = signal

    def drop(self, name: str) -> Signal:
        return self.signals.pop(name)

    def __contains__(self, name: object) -> bool:
        return name in self.signals

    def __getitem__(self, name: str) -> Signal:
        try:
            return self.signals[name]
        except KeyError:
            raise SignalError(f"test has no signal '{name}'; it has: {', '.join(sorted(self.signals))}") from None

    def __iter__(self) -> Iterator[Signal]:
        return iter(self.signals.values())

    def __len__(self) -> int:
        return len(self.signals)

    @property
    def names(self) -> list[str]:
        return list(self.signals)

    def data_digest(self) -> str:
        """Hash of the measured data (every signal's name, times and values): two tests with
        the same digest are the same data, whatever their files are called."""
        import hashlib

        h = hashlib.sha256()
        for name in sorted(self.signals):
            sig = self.signals[name]
            h.update(name.encode())
            h.update(np.ascontiguousarray(sig.time).tobytes())
            h.update(np.ascontiguousarray(sig.values).tobytes())
        return h.hexdigest()

    def by_base(self, base: str, origin: str | None = "test") -> list[Signal]:
        """All signals of a base name (any source), optionally of one origin."""
        reg = registry()
        out = []
        for sig in self.signals.values():
            parsed = reg.parse(sig.name)
            if parsed.base == base and (origin is None or parsed.origin == origin):
                out.append(sig)
        return out

    def best(self, base: str, origins: Iterable[str] = ("test", "calc"), *,
             kept: Collection[str] | None = None) -> Signal | None:
        """The signal of ``base`` to use: the package's one selection rule.

        Results, batch metrics, identification, QA checks, analysis, validation and the
        report all ask here; no stage picks a source of its own. The rule:

        1. origins in the order of ``origins`` (default: measured, then calculated); the
           first origin with a usable signal wins;
        2. usable: at least two samples and one finite value;
        3. QA's choice: with ``kept`` (the measured signals QA's selection kept, e.g.
           ``QAResult.selection.kept`` or ``findings.json`` ``selection.kept``), a measured
           signal (origin ``test``) QA did not keep is not used, so a quantity QA kept in
           no source has no measured signal. QA's validated test holds only the kept
           signals, so on it the choice needs no ``kept``; neither does a test imported with
           QA's ``template_final.yaml`` (its ``selection.drop`` deletes the others);
        4. among what remains, the most trusted source
           (:func:`vehval.nomenclature.preference_rank`: facility sensor without qualifier,
           facility qualifiers, vehicle network, others; ties by name).

        Parameters
        ----------
        base : str
            Base name of the quantity (``fuel_rate``).
        origins : iterable of str
            Origins to try, in order (``test``, ``calc``, ``simu``).
        kept : collection of str, optional
            Full names of the measured signals QA kept (None: QA did not run).

        Returns
        -------
        Signal or None
            None when the test has no usable signal of ``base`` in ``origins``.
        """
        allowed = None if kept is None else set(kept)
        for origin in origins:
            cands = [s for s in self.by_base(base, origin)
                     if s.time.size >= 2 and np.any(np.isfinite(s.values))]
            if allowed is not None and origin == "test":
                cands = [s for s in cands if s.name in allowed]
            if cands:
                return min(cands, key=lambda s: preference_rank(s.name))
        return None

    @property
    def sources(self) -> list[str]:
        return sorted({s.source for s in self.signals.values()})

    def span(self) -> tuple[float, float]:
        """Earliest and latest sample time over all signals [s]."""
        if not self.signals:
            return (0.0, 0.0)
        return (min(float(s.time[0]) for s in self if s.time.size),
                max(float(s.time[-1]) for s in self if s.time.size))

    def shift_source(self, source: str, offset_s: float) -> None:
        """Add ``offset_s`` [s] to the timestamps of every signal of ``source`` and record it."""
        for name, sig in list(self.signals.items()):
            if sig.source == source:
                self.signals[name] = sig.shifted(offset_s)
        self.meta.offsets_s[source] = self.meta.offsets_s.get(source, 0.0) + offset_s

    def grid(self, dt: float) -> np.ndarray:
        """A uniform time grid [s] over the test span with step ``dt`` [s]."""
        t0, t1 = self.span()
        n = int(np.floor((t1 - t0) / dt + 1e-9)) + 1
        return t0 + dt * np.arange(n)

    def resample(self, grid: np.ndarray | float, names: Iterable[str] | None = None,
                 methods: dict[str, ResampleMethod] | None = None,
                 ) -> tuple[pd.DataFrame, dict[str, ResampleMethod]]:
        """Resample signals to one grid.

        Parameters
        ----------
        grid : array or float
            Time grid [s], or a step [s] for a uniform grid over the test span.
        names : iterable of str, optional
            Signals to include (default all).
        methods : dict, optional
            Per-signal override of the registry's method.

        Returns
        -------
        frame : pandas.DataFrame
            Indexed by time [s]; ``frame.attrs['resample']`` and ``frame.attrs['units']``
            record the method and unit of each column.
        used : dict
            The method used for each signal.
        """
        g = self.grid(cast(float, grid)) if np.isscalar(grid) else np.asarray(grid, float)
        methods = methods or {}
        cols, used = {}, {}
        for name in (names if names is not None else self.names):
            sig = self[name]
            m = methods.get(name, sig.resample)
            cols[name] = sig.at(g, m)
            used[name] = m
        import pandas as pd

        frame = pd.DataFrame(cols, index=pd.Index(g, name="time"))
        frame.attrs["resample"] = dict(used)
        frame.attrs["units"] = {n: self[n].unit for n in used}
        return frame, used

    def time_bases(self) -> dict[str, list[str]]:
        """Group signal names by identical time arrays; keys are source-based labels."""
        groups: dict[str, list[str]] = {}
        arrays: dict[str, np.ndarray] = {}
        for sig in self:
            key = None
            for label, arr in arrays.items():
                if arr.shape == sig.time.shape and np.array_equal(arr, sig.time):
                    key = label
                    break
            if key is None:
                key = sig.source or "main"
                i = 2
                while key in arrays:
                    key = f"{sig.source or 'main'}{i}"
                    i += 1
                arrays[key] = sig.time
            groups.setdefault(key, []).append(sig.name)
        return groups


#: Name prefixes of the components only a hybrid has (battery, MG1, MG2, planetary gear,
#: boost converter).
HYBRID_PREFIXES = ("ess_", "mot_", "gen_", "pg_", "boost_")


def hybrid_signals(test: Test, *, measured_only: bool = True) -> list[str]:
    """Names of the hybrid-component signals of ``test`` (measured ``*_test`` ones only
    by default), sorted."""
    return sorted(s.name for s in test if s.name.startswith(HYBRID_PREFIXES)
                  and (not measured_only or s.name.endswith("_test")))


def is_hybrid(test: Test, vehicle: object = None, *, measured_only: bool = True) -> bool:
    """True for a hybrid: with a vehicle file, a powertrain that both burns fuel (an
    ``engine`` block) and stores traction energy (a ``battery`` block), the rule of the stage
    registry's :attr:`vehval.architectures.Stages.is_hybrid` (a battery-electric car or a
    conventional one is no hybrid); without one, a hybrid-component signal in the test (the
    one rule every stage asks)."""
    if getattr(vehicle, "architecture", None) is not None:
        return getattr(vehicle, "engine", None) is not None \
            and getattr(vehicle, "battery", None) is not None
    return bool(hybrid_signals(test, measured_only=measured_only))
