"""What-if of one list row: the same car with a changed weight, road load or axle ratio.

The car is built from its rows as the fleet builds it (:mod:`vehval.epa.fleet`); each of its
runnable rows is predicted as listed and as changed (the changed test weight and road-load
coefficients are the row's own, changed; a changed axle ratio changes N/V in proportion:
the gearbox is the same). The answer anchors the listed figure:
``answer = listed x changed / as listed`` (the model's bias on this car cancels to first
order), with its interval (k = 2) from

* the model's uncertainty of the change: the run repeated with the generic engine values at
  the ends of their ranges (:data:`ENGINE_RANGES`: friction scale, indicated efficiency;
  uniform, GUM 4.3.7: ``u_i = h_i / sqrt(3)`` of the half-swing of the ratio), and
* the spread of a repeated test of the listed figure (:func:`vehval.uncertainty.
  measurement_uncertainty` with the packaged repeatability of the procedure).
"""

from __future__ import annotations

import math
import re
from dataclasses import replace
from typing import Any, Sequence

from vehval.constants import LB_KG
from vehval.epa.fleet import FLEET_DT_S, CarJob, plan_fleet
from vehval.epa.procedures import RUNNABLE, plan_for
from vehval.epa.reader import EpaTest
from vehval.errors import ConfigError, InputFileError

#: generic engine values varied for the uncertainty of a change: name -> (low, high)
ENGINE_RANGES = {"friction_scale": (0.7, 1.3), "indicated_efficiency": (0.34, 0.42)}
K = 2.0
_CHANGE = re.compile(r"^\s*([+-]?)\s*(\d+(?:\.\d*)?|\.\d+)\s*(%|lb|lbs|kg)?\s*$", re.I)


def parse_change(text: str, option: str, units: Sequence[str]) -> tuple[str, float, str]:
    """``-200lb`` / ``+5%`` / ``3.2`` -> (sign '' '+' '-', value, unit '' '%' 'lb' 'kg').

    Raises ConfigError naming the option and the forms it takes."""
    m = _CHANGE.match(text or "")
    unit = (m.group(3) or "").lower().replace("lbs", "lb") if m else ""
    if m is None or unit not in units:
        forms = {"%": "-5%", "lb": "-200lb", "kg": "-90kg", "": "3.2"}
        raise ConfigError(f"{option} '{text}': not a change; give e.g. "
                          + " or ".join(forms[u] for u in units))
    return m.group(1), float(m.group(2)), unit


def _apply(value: float, change: tuple[str, float, str] | None, si: float = 1.0) -> float:
    if change is None:
        return value
    sign, x, unit = change
    if unit == "%":
        return value * (1.0 + (-x if sign == "-" else x) / 100.0)
    x *= {"lb": LB_KG, "kg": 1.0}.get(unit, si)
    return value - x if sign == "-" else value + x if sign == "+" else x


def _car(tests: list[EpaTest], vehicle_id: str, config: str | None) -> CarJob:
    rows = [t for t in tests if t.vehicle_id.upper() == vehicle_id.strip().upper()
            and (config is None or t.config == config.strip())]
    if not rows and config is not None:
        have = sorted({t.config for t in tests
                       if t.vehicle_id.upper() == vehicle_id.strip().upper()})
        if have:
            raise InputFileError(f"--vehicle-id {vehicle_id} --config {config}: no row of the "
                                 f"lists; its configurations: {', '.join(have)}")
    if not rows:
        import difflib

        near = difflib.get_close_matches(vehicle_id.upper(), sorted({t.vehicle_id for t in tests}),
                                         n=4, cutoff=0.5)
        hint = f"; did you mean {', '.join(near)}?" if near else ""
        raise InputFileError(f"--vehicle-id {vehicle_id}"
                             + (f" --config {config}" if config else "")
                             + f": no row of the lists{hint}")
    plan = plan_fleet(rows)
    if not plan.jobs:
        why = "; ".join(sorted({r["reason"] for r in plan.not_run})[:3])
        raise ConfigError(f"--vehicle-id {vehicle_id}: no runnable row ({why})")
    if len({j.key for j in plan.jobs}) > 1:
        cfgs = ", ".join(sorted({j.key.rsplit("|", 1)[1] or "?" for j in plan.jobs}))
        raise ConfigError(f"--vehicle-id {vehicle_id}: the rows describe several "
                          f"configurations ({cfgs}) or lists: choose one with --config N, "
                          "or give one list")
    return plan.jobs[0]


def _ratio_set(job: CarJob, t: EpaTest, t1: EpaTest, specs1: Any, **engine: Any
               ) -> tuple[float, float]:
    """(as listed, changed) predicted mpg of row ``t`` with the engine values ``engine``."""
    from vehval.epa.specs import vehicle_from_specs
    from vehval.epa.validation import predict_test

    proc, why = plan_for(t, job.fuel)
    if proc is None:
        raise ConfigError(why)
    veh0: Any = vehicle_from_specs(job.specs, **engine)
    veh1: Any = vehicle_from_specs(specs1, **engine)
    a = predict_test(veh0, t, proc, job.dt).overall_mpg
    b = predict_test(veh1, t1, proc, job.dt).overall_mpg
    return float(a), float(b)


def whatif(tests: list[EpaTest], vehicle_id: str, *, config: str | None = None,
           weight: str | None = None, road_load: str | None = None, axle: str | None = None,
           procedure: str | None = None, dt: float = FLEET_DT_S) -> dict[str, Any]:
    """The rows of one test vehicle as listed and with the changes (see the module docstring).

    Returns
    -------
    dict
        ``vehicle_id``, ``car``, ``changes`` (what was changed, SI) and ``rows``: per row
        ``row_id``, ``procedure``, ``measured_mpg``, ``model_mpg``, ``model_changed_mpg``,
        ``change`` [-], ``answer_mpg``, ``interval_mpg`` [low, high] (k = 2),
        ``u_change_rel``, ``u_meas_mpg``.
    """
    from vehval.uncertainty.defaults import precision_default
    from vehval.uncertainty.verdict import measurement_uncertainty

    if not (weight or road_load or axle):
        raise ConfigError("what-if: give at least one of --weight, --road-load, --axle")
    if procedure is not None and procedure not in RUNNABLE:
        raise ConfigError(f"--procedure {procedure}: unknown procedure; give one of "
                          f"{', '.join(RUNNABLE)}")
    cw = parse_change(weight, "--weight", ("lb", "kg", "%")) if weight else None
    cr = parse_change(road_load, "--road-load", ("%",)) if road_load else None
    ca = parse_change(axle, "--axle", ("", "%")) if axle else None
    job = _car(tests, vehicle_id, config)
    job = replace(job, dt=dt)
    s = job.specs
    axle1 = _apply(s.axle_ratio, ca)
    if not (0.5 < axle1 < 10.0):
        raise ConfigError(f"--axle {axle}: axle ratio {axle1:g} outside 0.5-10")
    specs1 = replace(s, axle_ratio=axle1, n_v_ratio=s.n_v_ratio * axle1 / s.axle_ratio)
    keys = {t.source: getattr(plan_for(t, job.fuel)[0], "key", "") for t in job.tests}
    rows = [t for t in job.tests if procedure is None or keys[t.source] == procedure]
    if not rows:
        raise ConfigError(f"--procedure {procedure}: no runnable row of {vehicle_id} on it")
    out = []
    for t in rows:
        k = 1.0 if cr is None else _apply(1.0, cr)
        t1 = replace(t, mass_kg=_apply(t.mass_kg, cw), target_a_n=t.target_a_n * k,
                     target_b_n_per_mps=t.target_b_n_per_mps * k,
                     target_c_n_per_mps2=t.target_c_n_per_mps2 * k)
        if not (t1.mass_kg > 0 and k > 0):
            raise ConfigError(f"{t.source}: the change leaves a test weight of "
                              f"{t1.mass_kg:.0f} kg and road load x {k:g}: not a car")
        a, b = _ratio_set(job, t, t1, specs1)
        var = 0.0
        for name, (lo, hi) in ENGINE_RANGES.items():
            r_lo = _ratio_set(job, t, t1, specs1, **{name: lo})
            r_hi = _ratio_set(job, t, t1, specs1, **{name: hi})
            h = (r_hi[1] / r_hi[0] - r_lo[1] / r_lo[0]) / 2.0
            var += (h / math.sqrt(3.0)) ** 2
        u_change = K * math.sqrt(var)
        answer = t.fe * b / a
        prec = precision_default(keys[t.source], "conventional")
        u_meas = measurement_uncertainty(answer, s_r=prec.s_r or 0.0)
        u = math.hypot(u_meas, u_change * answer)
        out.append({"row_id": t.source, "test_number": t.test_number,
                    "procedure": keys[t.source],
                    "measured_mpg": t.fe, "model_mpg": a, "model_changed_mpg": b,
                    "change": b / a - 1.0, "answer_mpg": answer,
                    "interval_mpg": [answer - u, answer + u], "u_change_rel": u_change,
                    "u_meas_mpg": u_meas, "mass_kg": t1.mass_kg,
                    "road_load_factor": k})
    return {"vehicle_id": s.vehicle_id, "car": f"{s.make} {s.model} {s.year}",
            "changes": {"weight": weight, "road_load": road_load, "axle": axle,
                        "axle_ratio": axle1, "n_v_ratio": specs1.n_v_ratio},
            "k": K, "rows": out}
