"""How a drive-cycle identification reads (:func:`vehval.cycles_match.identify_cycle`).

One text for the test's notes (data: SI, ``system_name=None``) and for the screen (the
display units of ``--units``: ``rms 1.9 mph``, ``plateaus at 56 mph``).
"""

from __future__ import annotations

from typing import Any

__all__ = ["cycle_note", "describe", "no_match_reason"]


def _speed(v_mps: float, system_name: str | None, digits: int = 3, delta: bool = True) -> str:
    """A speed [m/s]: SI as stored (``0.83 m/s``) or in the display units."""
    if system_name is None:
        return f"{v_mps:.2f} m/s"
    from vehval.display import format_delta, format_value

    fmt = format_delta if delta else format_value
    return fmt(v_mps, "m/s", system_name=system_name, digits=digits)


def no_match_reason(details: dict[str, Any], system_name: str | None = None) -> str:
    """Why no cycle matched, from the figures ``identify_cycle`` keeps in ``details``
    (``best``: name, explained, rms_mps; ``limits``: max_rms_mps, min_coverage,
    min_explained; ``steady_fraction``); the stored ``reason`` when they are absent."""
    limits, best = details.get("limits"), details.get("best")
    if not limits:
        return str(details.get("reason", "no match"))
    frac = details.get("steady_fraction", 0.0)
    if best:
        return (f"no cycle explains {limits['min_explained']:.0%} of the driving: best "
                f"{best['name']} explains {best['explained']:.0%} (rms "
                f"{_speed(best['rms_mps'], system_name)}); {frac:.0%} of the moving time on "
                "steady plateaus")
    rms = (f"{limits['max_rms_mps']:g} m/s" if system_name is None
           else _speed(limits['max_rms_mps'], system_name))
    return (f"no cycle follows the speed within {rms} RMS over {limits['min_coverage']:.0%} "
            f"of its duration; {frac:.0%} of the moving time on steady plateaus")


def describe(name: str | None, details: dict, system_name: str | None = None) -> str:
    """One-line account of an identification: SI for the notes (``system_name`` None),
    else in that unit system's display units.

    Examples: ``cycle identified as udds (rms 0.21 m/s, offset 0.0 s)``,
    ``cycle identified as hwfet_x2 (hwfet x2, rms 0.30 m/s, offsets 0.0, 781.0 s)``.
    """
    if name is None:
        return f"cycle not identified: {no_match_reason(details, system_name)}"
    if details.get("method") == "steady":
        plats = details.get("plateaus", [])
        if system_name is None:
            speeds = ", ".join(f"{p[2] * 3.6:.0f}" for p in plats) + " km/h"
        else:
            speeds = ", ".join(_speed(p[2], system_name, 3, delta=False) for p in plats)
        return (f"cycle identified as {name} (steady speed: {len(plats)} plateau(s) at "
                f"{speeds}, {details.get('steady_fraction', 0):.0%} of the moving time)")
    offs = details.get("offsets_s", [])
    extra = ""
    if details.get("repeats", 1) > 1:
        extra = f"{details['cycle']} x{details['repeats']}, "
    if details.get("split_by_soak"):
        extra += "split by a soak, "
    where = (f"offset {offs[0]:.1f} s" if len(offs) == 1
             else "offsets " + ", ".join(f"{o:.1f}" for o in offs) + " s")
    return f"cycle identified as {name} ({extra}rms {_speed(details['rms_mps'], system_name)}, {where})"


def cycle_note(match: dict[str, Any], system_name: str | None = None) -> str:
    """The note of an identification kept as a test's ``meta.cycle_match`` (its details
    plus ``name`` and ``signal``): ``cycle identified as udds (...) from veh_spd_test`` or
    ``cycle not identified: ... (from veh_spd_test)``."""
    text = describe(match.get("name"), match, system_name)
    sig = match.get("signal")
    return text if not sig else f"{text} from {sig}" if match.get("name") else f"{text} (from {sig})"
