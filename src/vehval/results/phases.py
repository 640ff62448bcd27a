"""Test phases (emission bags): from the test's phase channel, or from the identified cycle.

A phase is a set of record-time segments. The phase channel (``test_phase_test``) numbers
the bags; samples between two integers (the channel is resampled across a change) and zero
(not sampling) belong to no phase. Without a phase channel the boundaries come from the
identified cycle's regulatory parts (:data:`CYCLE_PARTS`), placed at the offsets where the
identification found each run. Either way every phase is labelled with the cycle run and
part it overlaps most, which the regulatory composites use.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from vehval.cycles import cycle_parts, cycles_with_parts, part_boundary_s, part_rule
from vehval.test import Signal

__all__ = [
    "CYCLE_PARTS",
    "PART_RULES",
    "CycleMatch",
    "Phase",
    "match_cycle",
    "phases_from_channel",
    "phases_from_cycle",
    "reference_speed",
]

#: Regulatory parts of each package cycle: (part, start, end) in cycle time [s], and where
#: the boundaries come from. The one table is ``vehval/data/cycles/parts.yaml`` (read by
#: :func:`vehval.cycles.cycle_parts`); these are views of it.
CYCLE_PARTS: dict[str, list[tuple[str, float, float]]] = {
    c: cycle_parts(c) for c in cycles_with_parts()}
PART_RULES: dict[str, str] = {c: part_rule(c) for c in cycles_with_parts()}
#: Largest distance [-] of a phase-channel sample from an integer still read as that phase.
_PHASE_TOL = 0.05


@dataclass
class Phase:
    """One phase of a test.

    Attributes
    ----------
    name : str
        Label used in tables (``bag1``, ``phase 3``, ``run 2 hwfet``).
    segments : list of (float, float)
        Record-time intervals [s] the phase covers.
    number : int or None
        Phase-channel value, when the phase comes from it.
    run : int
        Which occurrence of the identified cycle it belongs to (1-based; 0 unknown).
    part : str
        Regulatory part of the cycle (``bag1``, ``city``, ``eudc``...; "" unknown).
    """

    name: str
    segments: list[tuple[float, float]]
    number: int | None = None
    run: int = 0
    part: str = ""

    @property
    def duration_s(self) -> float:
        return float(sum(b - a for a, b in self.segments))

    def to_dict(self) -> dict[str, Any]:
        return {"name": self.name, "number": self.number, "run": self.run, "part": self.part,
                "segments_s": [[round(a, 3), round(b, 3)] for a, b in self.segments],
                "duration_s": round(self.duration_s, 3)}


@dataclass
class CycleMatch:
    """Where the identified cycle runs in the record.

    ``windows`` holds, per run, the (cycle start, cycle end, record offset) pieces:
    record time = cycle time + offset [s]. A split FTP-75 has two pieces in its run.
    """

    cycle: str
    windows: list[list[tuple[float, float, float]]] = field(default_factory=list)
    rms_mps: float | None = None

    @property
    def runs(self) -> int:
        return len(self.windows)

    def parts(self) -> list[tuple[int, str, float, float]]:
        """(run, part, record start, record end) of every regulatory part [s]."""
        out = []
        for r, pieces in enumerate(self.windows, start=1):
            for part, c0, c1 in CYCLE_PARTS.get(self.cycle, [(self.cycle, 0.0, 1e9)]):
                for p0, p1, off in pieces:
                    a, b = max(c0, p0), min(c1, p1)
                    if b > a:
                        out.append((r, part, a + off, b + off))
        return out


def match_cycle(speed: Signal | None, cycle_name: str | None,
                stored: dict[str, Any] | None = None,
                source_offsets_s: dict[str, float] | None = None) -> CycleMatch | None:
    """Where the runs of the test's cycle lie in the record (None when not found).

    Parameters
    ----------
    speed : Signal or None
        Measured vehicle speed, searched only when the test holds no stored match.
    cycle_name : str or None
        The test's cycle (``hwfet_x2``, ``udds``).
    stored : dict, optional
        The match kept at import (``test.meta.cycle_match``, from
        :func:`vehval.cycles_match.identify_cycle`); used as it is, its offsets moved by the
        time shift its speed source received since (alignment).
    source_offsets_s : dict, optional
        ``test.meta.offsets_s``: source -> time shift applied so far [s].
    """
    from vehval.cycles import load_cycle

    if not cycle_name:
        return None
    base = cycle_name.split("_x")[0]
    if base not in CYCLE_PARTS:
        return None
    if stored:
        det = stored
        if det.get("method") != "cycle" or det.get("cycle") != base:
            return None
        src = str(det.get("source") or "")
        shift = (float((source_offsets_s or {}).get(src, 0.0))
                 - float(det.get("source_offset_s") or 0.0))
    else:  # a test built without import (no stored match): locate the cycle
        from vehval.cycles_match import identify_cycle

        if speed is None:
            return None
        ok = np.isfinite(speed.values)
        name, _, det = identify_cycle(speed.time[ok], speed.values[ok], cycles=[base])
        if name is None or det.get("method") != "cycle":
            return None
        shift = 0.0
    dur = load_cycle(base).duration_s
    windows = []
    if det.get("split_by_soak") and len(det.get("windows_s", [])) == 2:
        split = part_boundary_s(base, "bag2")  # where the soak splits the FTP-75
        off = float(det["offsets_s"][0]) + shift
        tail_start = float(det["windows_s"][1][0]) + shift
        windows.append([(0.0, split, off), (split, dur, tail_start - (split + 1.0))])
    else:
        windows = [[(0.0, dur, float(o) + shift)] for o in det["offsets_s"]]
    return CycleMatch(base, windows, det.get("rms_mps"))


def _label(phases: list[Phase], match: CycleMatch | None) -> None:
    if match is None:
        return
    parts = match.parts()
    for ph in phases:
        best = (0.0, 0, "")
        for r in range(1, match.runs + 1):
            for part in dict.fromkeys(p for rr, p, _, _ in parts if rr == r):
                ov = sum(max(0.0, min(b, pb) - max(a, pa)) for a, b in ph.segments
                         for rr, pp, pa, pb in parts if rr == r and pp == part)
                if ov > best[0]:
                    best = (ov, r, part)
        if ph.duration_s > 0 and best[0] >= 0.5 * ph.duration_s:
            ph.run, ph.part = best[1], best[2]
    names = [(p.part if match.runs == 1 else f"run {p.run} {p.part}") if p.part else p.name
             for p in phases]
    if len(set(names)) == len(names):
        for p, n in zip(phases, names):
            p.name = n


def phases_from_channel(sig: Signal, match: CycleMatch | None = None) -> list[Phase]:
    """Phases numbered by a phase channel; [] when it holds no positive phase number.

    Each distinct positive integer is one phase, possibly of several segments (the US06
    city part before and after the highway part); samples off an integer are transitions.
    """
    t, v = sig.time, sig.values
    r = np.round(v)
    num = np.where(np.isfinite(v) & (np.abs(v - r) <= _PHASE_TOL) & (r > 0), r, 0).astype(int)
    if t.size < 2 or not num.any():
        return []
    dt = float(np.median(np.diff(t)))
    edges = np.flatnonzero(np.diff(num) != 0) + 1
    starts = np.concatenate([[0], edges])
    ends = np.concatenate([edges, [num.size]])
    by_num: dict[int, list[tuple[float, float]]] = {}
    for i0, i1 in zip(starts, ends):
        n = int(num[i0])
        if n > 0:
            by_num.setdefault(n, []).append((float(t[i0]), float(t[i1 - 1]) + dt))
    phases = [Phase(name=f"phase {n}", segments=segs, number=n) for n, segs in by_num.items()]
    _label(phases, match)
    return phases


def phases_from_cycle(match: CycleMatch) -> list[Phase]:
    """Phases at the regulatory part boundaries of the identified cycle, run by run."""
    grouped: dict[tuple[int, str], list[tuple[float, float]]] = {}
    for r, part, a, b in match.parts():
        grouped.setdefault((r, part), []).append((a, b))
    phases = []
    for (r, part), segs in grouped.items():
        name = part if match.runs == 1 else f"run {r} {part}"
        phases.append(Phase(name=name, segments=segs, run=r, part=part))
    return phases


def reference_speed(time: np.ndarray, match: CycleMatch) -> np.ndarray:
    """The cycle's target speed at record times ``time`` [m/s]; NaN outside every run."""
    from vehval.cycles import load_cycle

    cyc = load_cycle(match.cycle)
    out = np.full(np.shape(time), np.nan)
    for pieces in match.windows:
        for c0, c1, off in pieces:
            inside = (time >= c0 + off) & (time <= c1 + off)
            out[inside] = np.interp(time[inside] - off, cyc.time_s, cyc.speed_mps)
    return out
