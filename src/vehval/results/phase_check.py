"""Phases of the phase channel against the identified cycle's own phase table.

A phase channel numbers the bags the laboratory sampled. When the cycle is identified, each
phase the channel numbers is labelled with the cycle part it overlaps most
(:func:`vehval.results.phases.phases_from_channel`); its record-time span must then be that
part's, as the cycle's table (:data:`vehval.results.phases.CYCLE_PARTS`) placed by the
identification gives it. A channel shifted in time (logged by another clock, a late
marker) moves distance from one bag to the next, and every phase and composite figure
with it, while every per-signal check passes.

Two measures per phase, each within :data:`PHASE_TOL` of the part:

* **distance**: the distance the measured speed covers where the phase and the part differ
  (in the phase but not the part, or the reverse), over the distance it covers in the
  part: boundaries placed in idle cost nothing, boundaries in driving count;
* **duration**: the phase's duration against the part's.

A phase off by more is an **error** finding on the phase channel, which withholds the phase
and composite figures (:mod:`vehval.results.gate`); the whole-test figure does not depend
on the phases and stays.
"""

from __future__ import annotations

import math

import numpy as np

from vehval.display import format_value
from vehval.qa.findings import Finding, Kind, Severity
from vehval.results.phases import CycleMatch, Phase, reference_speed
from vehval.test import Signal

__all__ = ["PHASE_TOL", "check_phases"]

#: Largest relative difference [-] of a phase from its cycle part, in distance and in
#: duration. On the ANL D3 Cruze files (UDDS, HWFET, US06, SC03, NEDC, WLTC; 22 phases)
#: the bags' boundaries lie within 2.2 s of the cycle's and their durations within 0.6 %
#: (the final idle of a UDDS bag 2 is sampled 5 s longer); 2 % is more than the 1.2 %
#: expanded uncertainty of a fuel economy, the size of a bag error that changes the figure.
PHASE_TOL = 0.02
#: Time step [s] of the distance integrals.
_DT = 0.1


def _mask(t: np.ndarray, segments: list[tuple[float, float]]) -> np.ndarray:
    m = np.zeros(t.size, bool)
    for a, b in segments:
        m |= (t >= a) & (t < b)
    return m


def _distance(t: np.ndarray, v: np.ndarray, mask: np.ndarray) -> float:
    return float(np.sum(np.where(mask, v, 0.0)) * _DT)


def check_phases(phases: list[Phase], match: CycleMatch | None, speed: Signal | None,
                 channel: str) -> list[Finding]:
    """Error findings on ``channel`` for phases off their cycle part.

    Parameters
    ----------
    phases : list of Phase
        Phases numbered by the phase channel, labelled with their run and part.
    match : CycleMatch or None
        Where the identified cycle runs in the record (nothing is checked without one).
    speed : Signal or None
        The measured vehicle speed [m/s] (nothing is checked without one).
    channel : str
        Name of the phase channel, the signal the findings are on.

    Returns
    -------
    list of Finding
        One ``results`` error per phase off its part, naming the part, both distances and
        durations, and the boundary offsets [s].
    """
    if match is None or speed is None or not phases:
        return []
    parts: dict[tuple[int, str], list[tuple[float, float]]] = {}
    for run, part, a, b in match.parts():
        parts.setdefault((run, part), []).append((a, b))
    out = []
    for ph in phases:
        segs = parts.get((ph.run, ph.part))
        if not ph.part or not segs or not ph.segments:
            continue
        f = _check_one(ph, segs, match, speed, channel)
        if f is not None:
            out.append(f)
    return out


def _check_one(ph: Phase, segs: list[tuple[float, float]], match: CycleMatch, speed: Signal,
               channel: str) -> Finding | None:
    lo = min(a for a, _ in segs + ph.segments)
    hi = max(b for _, b in segs + ph.segments)
    t = np.arange(lo, hi, _DT)
    if t.size < 2:
        return None
    v = np.nan_to_num(np.maximum(speed.at(t), 0.0))
    in_phase, in_part = _mask(t, ph.segments), _mask(t, segs)
    d_part = _distance(t, v, in_part)
    d_phase = _distance(t, v, in_phase)
    d_moved = _distance(t, v, in_phase ^ in_part)
    dur_part = float(sum(b - a for a, b in segs))
    dist_off = d_moved / d_part if d_part > 0 else (math.inf if d_moved > 0 else 0.0)
    dur_off = abs(ph.duration_s - dur_part) / dur_part if dur_part > 0 else 0.0
    if dist_off <= PHASE_TOL and dur_off <= PHASE_TOL:
        return None
    ref = np.nan_to_num(reference_speed(t, match))
    d_cycle = _distance(t, ref, in_part)
    start = ph.segments[0][0] - segs[0][0]
    end = ph.segments[-1][1] - segs[-1][1]
    label = ph.part if match.runs == 1 else f"run {ph.run} {ph.part}"
    num = f"phase {ph.number} " if ph.number is not None else ""
    return Finding(
        channel, Kind.RESULTS, float("nan"), float("nan"), Severity.ERROR,
        f"{num}({ph.name}) of {channel} is off the cycle's {label}: it covers "
        f"{format_value(d_phase, 'm')} where the cycle's {label} has "
        f"{format_value(d_cycle, 'm')} ({format_value(d_part, 'm')} driven over the cycle's "
        f"{label}), {dist_off:.1%} of the distance moved across its boundaries, and lasts "
        f"{ph.duration_s:.1f} s against {dur_part:.1f} s (tolerance {PHASE_TOL:.0%} of each); "
        f"its boundaries lie {start:+.1f} s / {end:+.1f} s from the cycle's: the phase and "
        "composite figures would mix the bags",
        {"phase": ph.name, "part": ph.part, "run": ph.run, "distance_m": d_phase,
         "cycle_distance_m": d_cycle, "part_distance_m": d_part, "moved_fraction": dist_off,
         "duration_s": ph.duration_s, "cycle_duration_s": dur_part, "start_offset_s": start,
         "end_offset_s": end, "tolerance": PHASE_TOL},
        level=4,
        fix=(f"check the phase channel {channel}: its bag marks lie {start:+.1f} s from the "
             "cycle's (a late marker, another clock): correct the marks in the file, or leave "
             "the channel unmapped and the phases follow the cycle's table"))
