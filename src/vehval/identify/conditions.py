"""The test conditions an identification covered: cell temperature and coolant at the start.

A model identified from tests run at about 23 °C knows nothing of a test at -7 °C: the fuel
map, the friction and the warm-up were all measured warm. The identification records the
conditions of the tests it used (``identification.conditions`` of the vehicle file, written
by :func:`identification_conditions`), and :func:`outside_conditions` says when a predicted
test lies outside them, so that a prediction there is read as an extrapolation (its 95 %
interval, :mod:`vehval.identify.uncertainty`, covers the operating points, not the
temperature).

Which test counts for which condition:

- cell temperature: every test the identification used (the fuel-map tests, the cold-start
  test of the warm-up fuel, the A/C test, whose load was fitted in its hot cell);
- coolant at the start: the fuel-map tests and the cold-start test (the A/C load was fitted
  on the phases after the first, so that test's start tells nothing).

A start at or above :data:`~vehval.identify.warmup.COLD_COOLANT_C` is warm (thermostat
regulated: one condition whatever its temperature); below it the coolant temperature sets
the warm-up.
"""

from __future__ import annotations

import math

from vehval.identify.traces import Trace
from vehval.identify.warmup import COLD_COOLANT_C

#: [°C] a temperature within this of the identification's range counts as covered: the
#: FTP and HWFET accept any test cell from 20 to 30 °C (40 CFR 86.130-78, 68-86 °F), that is
#: +-5 °C around its 25 °C, as one condition; a cold-start soak likewise
COND_MARGIN_C = 5.0
#: [°C] the cell of a standard warm test: the FTP and HWFET's 20-30 °C (40 CFR 86.130-78)
STANDARD_CELL_C = (20.0, 30.0)
#: The recorded conditions: key -> what the warning line calls it.
CONDITIONS = {"amb_temp_c": "cell", "coolant_start_c": "coolant at the start"}


def _finite(x: float | None) -> float | None:
    return float(x) if x is not None and math.isfinite(float(x)) else None


def in_standard_cell(trace: Trace) -> bool:
    """The test's cell is within :data:`STANDARD_CELL_C` (True when not measured)."""
    cell = _finite(trace.amb_temp_c)
    return cell is None or STANDARD_CELL_C[0] <= cell <= STANDARD_CELL_C[1]


def off_standard(trace: Trace) -> str | None:
    """Why ``trace`` is not a standard warm test (None: it is, or its conditions are not
    measured): a cold start (:func:`~vehval.identify.warmup.cold_start_state`: its warm-up
    fuel), or a cell outside :data:`STANDARD_CELL_C` (a -7 °C test, an SC03 or other hot
    test with its A/C). Fitted into the warm fuel map, such a test pulls it by its own
    excess fuel: on the Cruze's folder the warm tests' leave-one-out errors were 11 % (median)
    with three such tests in the map, 4 % without them."""
    from vehval.identify.warmup import cold_start_state

    cold, why = cold_start_state(trace)
    if cold:
        return f"{trace.test_id}: a cold start ({why})"
    if not in_standard_cell(trace):
        lo, hi = STANDARD_CELL_C
        return (f"{trace.test_id}: cell {trace.amb_temp_c:.1f} °C, outside the standard "
                f"{lo:g}-{hi:g} °C")
    return None


def identification_conditions(traces: list[Trace], cold_trace: Trace | None = None,
                              ac_trace: Trace | None = None,
                              no_fuel: frozenset[str] = frozenset()) -> dict:
    """The conditions of the tests an identification used (see the module docstring).

    Returns
    -------
    dict
        ``tests``: one ``{test, role, amb_temp_c, coolant_start_c}`` per test [°C, None when
        not measured], ``role`` one of ``fuel map``, ``warm-up``, ``A/C``; ``amb_temp_c`` and
        ``coolant_start_c``: the ``[low, high]`` range the identification covers [°C], None
        when no test measured it. A test of ``no_fuel`` (its fuel rate reads 0 throughout:
        left out of the fuel map) has the role ``road load and gears`` and no part in the
        ranges.
    """
    roles = [(t, "road load and gears" if t.test_id in no_fuel else "fuel map") for t in traces]
    roles += [(t, role) for t, role in ((cold_trace, "warm-up"), (ac_trace, "A/C"))
              if t is not None]
    tests: list[dict] = [{"test": t.test_id, "role": role, "amb_temp_c": _finite(t.amb_temp_c),
                          "coolant_start_c": _finite(t.coolant_start_c)} for t, role in roles]
    out: dict = {"tests": tests}
    for key in CONDITIONS:
        values = [float(r[key]) for r in tests if r[key] is not None
                  and r["role"] != "road load and gears"
                  and (key == "amb_temp_c" or r["role"] != "A/C")]
        out[key] = [min(values), max(values)] if values else None
    return out


def _warm(x: float, key: str) -> float:
    """A coolant start at or above ``COLD_COOLANT_C`` is one (warm) condition: counted as
    ``COLD_COOLANT_C``."""
    return min(x, COLD_COOLANT_C) if key == "coolant_start_c" else x


def outside_conditions(identification: dict | None, trace: Trace) -> dict | None:
    """The conditions of ``trace`` outside the identification's (beyond ``COND_MARGIN_C``).

    Returns
    -------
    dict or None
        ``{key: {"value": x, "range": [low, high]}}`` [°C] per condition outside (empty when
        every measured condition is covered); None when the vehicle records no conditions
        (identified before they were recorded, or not identified).
    """
    cond = (identification or {}).get("conditions")
    if not isinstance(cond, dict):
        return None
    out: dict = {}
    for key in CONDITIONS:
        x, rng = _finite(getattr(trace, key)), cond.get(key)
        if x is None or not rng:
            continue
        lo, hi = (_warm(float(v), key) for v in rng)
        if not lo - COND_MARGIN_C <= _warm(x, key) <= hi + COND_MARGIN_C:
            out[key] = {"value": x, "range": [float(rng[0]), float(rng[1])]}
    return out


def conditions_warnings(rows: list[dict], identification: dict | None) -> list[str]:
    """One warning line per predicted test outside the identification's conditions (rows of
    :func:`vehval.identify.predict.predict_trace`, key ``outside_identification``)."""
    cond = (identification or {}).get("conditions") or {}
    names = ", ".join(dict.fromkeys(r["test"] for r in cond.get("tests") or []))
    lines = []
    for r in rows:
        out = r.get("outside_identification") or {}
        if not out:
            continue
        parts = [f"{CONDITIONS[k]} {_deg(v['value'])}" for k, v in out.items()]
        ranges = [f"{CONDITIONS[k]} {_deg(v['range'][0], False)} to {_deg(v['range'][1])}"
                  for k, v in out.items()]
        lines.append(f"{r['test']}: {', '.join(parts)}, outside the identification tests' "
                     f"{', '.join(ranges)} ({names}): the model extrapolates, and its 95 % "
                     "interval does not include the effect")
    return lines


def _deg(x: float, unit: bool = True) -> str:
    """A temperature [°C] as the warning writes it (``-6.6 °C``)."""
    from vehval.display import number

    return f"{number(float(x), 3)} °C" if unit else number(float(x), 3)
