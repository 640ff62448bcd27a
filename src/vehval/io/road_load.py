"""Road-load constants of a template: signs and magnitudes a car's target road load has.

A template's ``road_load_a_n``, ``road_load_b_n_per_mps`` and ``road_load_c_n_per_mps2``
are the target (coast-down) coefficients, ``F = A + B v + C v^2`` [N] with ``v`` [m/s]:
the drive-quality ratings (SAE J2951 energy ratings) and the control analysis rest on them.
The EPA Test Car Lists of model years 2016, 2017 and 2019 (11,631 tests of every light-duty
make) bound them:

* A: 69..667 N, never zero or negative (rolling at walking pace takes force);
* B: -8.2..17.2 N/(m/s): may be slightly negative (26 % of the rows), the force stays
  positive at every speed;
* C: 0.19..1.10 N/(m/s)^2, never zero or negative (air drag);
* ``F(50 mph) / (m g)``, the road load at 80 km/h per test weight: 0.016..0.067.

The same sets written as lbf, lbf/mph, lbf/mph^2 numbers (the EPA list's own units) read as
SI give 0.0018..0.0105 of the weight at 50 mph. :func:`road_load_errors` refuses, one line
per key, a coefficient of the wrong sign and a set whose load at 50 mph is outside
:data:`LOAD_PER_WEIGHT_BAND`, naming the units that bring it inside. An SI set over a test
mass written in pounds (about half the true ratio) is not refused here: the mass is judged
from the data by the QA force/mass cross-check (:func:`vehval.qa.crosscheck.mass_gain`),
its one owner.
"""

from __future__ import annotations

import math
from typing import Any

__all__ = ["B_MIN_N_PER_MPS", "LOAD_PER_WEIGHT_BAND", "road_load_errors"]

#: Lowest B [N/(m/s)]: below the EPA lists' lowest target B (-8.2 N/(m/s), -0.82 lbf/mph).
B_MIN_N_PER_MPS = -10.0
#: Road load at 50 mph over the test weight [-]: the EPA lists' 0.016..0.067 with a margin;
#: the lower bound lies above every lbf-valued set read as SI (at most 0.0105).
LOAD_PER_WEIGHT_BAND = (0.012, 0.10)
#: Speeds [m/s] over which the road-load force must stay positive (0..45 m/s, 100 mph).
_V_MAX = 45.0
_V50 = 50 * 0.44704
_G = 9.80665
_LBF = 4.4482216152605
_MPH = 0.44704
_LB = 0.45359237
#: The EPA lists' median road load at 50 mph per test weight [-].
_TYPICAL = 0.0245
_KEYS = ("road_load_a_n", "road_load_b_n_per_mps", "road_load_c_n_per_mps2")


def _load(a: float, b: float, c: float, v: float) -> float:
    return a + b * v + c * v * v


def _sign_errors(a: float | None, b: float | None, c: float | None) -> list[str]:
    out = []
    if a is not None and a <= 0:
        out.append(f"constants.road_load_a_n: {a:g} N: the target road-load A must be > 0 "
                   "(69-667 N on every car of the EPA Test Car Lists); a dyno set coefficient "
                   "(which may be negative) is not the target: give the target A")
    if b is not None and b < B_MIN_N_PER_MPS:
        out.append(f"constants.road_load_b_n_per_mps: {b:g} N/(m/s): below "
                   f"{B_MIN_N_PER_MPS:g} N/(m/s) (the EPA lists' target B: -8.2..17.2); give "
                   "the target B in N/(m/s)")
    if c is not None and c <= 0:
        out.append(f"constants.road_load_c_n_per_mps2: {c:g} N/(m/s)^2: the target road-load "
                   "C (air drag) must be > 0; give the target C in N/(m/s)^2")
    if out or a is None or b is None or c is None:
        return out
    vmin = min(max(-b / (2 * c), 0.0), _V_MAX)
    if _load(a, b, c, vmin) <= 0:
        out.append(f"constants.road_load_b_n_per_mps: {b:g} N/(m/s): with A {a:g} N and C "
                   f"{c:g} N/(m/s)^2 the road-load force is {_load(a, b, c, vmin):.3g} N at "
                   f"{vmin:.1f} m/s: a road load is positive at every speed; check B (and "
                   "its unit)")
    return out


def _magnitude_error(a: float, b: float, c: float, m: float) -> str | None:
    f50 = _load(a, b, c, _V50)
    r = f50 / (m * _G)
    lo, hi = LOAD_PER_WEIGHT_BAND
    if lo <= r <= hi:
        return None
    alts: list[tuple[float, str, str]] = []     # (distance from the typical ratio, key, text)
    r_lbf = _load(a * _LBF, b * _LBF / _MPH, c * _LBF / _MPH ** 2, _V50) / (m * _G)
    if lo <= r_lbf <= hi:
        alts.append((abs(math.log(r_lbf / _TYPICAL)), ", ".join(_KEYS),
                     f"the coefficients look like lbf, lbf/mph, lbf/mph^2 values: in SI they "
                     f"are A {a * _LBF:.4g} N, B {b * _LBF / _MPH:.4g} N/(m/s), C "
                     f"{c * _LBF / _MPH ** 2:.4g} N/(m/s)^2 (x4.448, x9.950, x22.26)"))
    r_lb = f50 / (m * _LB * _G)
    if lo <= r_lb <= hi:
        alts.append((abs(math.log(r_lb / _TYPICAL)), "test_mass_kg",
                     f"test_mass_kg {m:g} looks like pounds ({m * _LB:.1f} kg)"))
    alts.sort()
    if alts and alts[0][1] == "test_mass_kg":
        return None     # a mass in pounds: the QA force/mass cross-check judges it from the data
    key = alts[0][1] if alts else ", ".join(_KEYS)
    hint = ("; or ".join(t for _, _, t in alts) if alts else
            "check the coefficients' units (N, N/(m/s), N/(m/s)^2) and the test mass (kg)")
    return (f"constants.{key}: the road load A + B v + C v^2 at 50 mph is {f50:.4g} N, "
            f"{r:.4f} of the test weight ({m:g} kg), outside {lo:g}..{hi:g} (EPA Test Car "
            f"Lists: 0.016-0.067): {hint}")


def road_load_errors(constants: Any) -> list[str]:
    """Problems of a template's road-load constants, one ``constants.<key>: ...`` line each.

    Parameters
    ----------
    constants : Constants or dict
        The template's ``constants`` (SI: N, N/(m/s), N/(m/s)^2, kg); absent keys are not
        judged, the load per weight only when A, B, C and ``test_mass_kg`` are all given.

    Returns
    -------
    list of str
        Empty when the constants are a car's plausible target road load.
    """
    get = constants.get if isinstance(constants, dict) else (
        lambda k: getattr(constants, k, None))
    a, b, c = (get(k) for k in _KEYS)
    out = _sign_errors(a, b, c)
    m = get("test_mass_kg")
    if out or a is None or b is None or c is None or not m or m <= 0:
        return out
    err = _magnitude_error(float(a), float(b), float(c), float(m))
    return [err] if err else []
