"""Predict a measured test with a vehicle model: its own speed trace, fuel per phase.

The model drives the test's measured speed trace (from time 0) at the trace's step; the
fuel it burns is compared with the measured fuel over the test proper (every numbered
phase; samples of phase 0, a soak between runs, are left out) and per phase.
Measured fuel is the integral of the fuel-rate signal; the meter's delay (a second or
two) moves a few grams across phase borders, which is why the whole-test figure is the
headline.

The A/C (when the vehicle has an A/C load) runs as ``ac`` says: ``on``, ``off`` or
``auto``: on for an SC03 test (the regulation runs it with the A/C on) or a test cell at
``AC_AUTO_TEMP_C`` or more (hot-ambient tests are run with the A/C on), off otherwise.

A test that starts cold (:func:`vehval.identify.warmup.cold_start_state`: its engine coolant
at the start) runs with the vehicle's warm-up fuel when the vehicle has one
(``engine.warmup_fuel_fraction`` > 0, e.g. identified with ``vehval identify --cold-test``).
"""

from __future__ import annotations

import copy

import numpy as np

from vehval.calibration.provenance import same_test
from vehval.cycles import Cycle
from vehval.errors import ConfigError
from vehval.identify.conditions import outside_conditions
from vehval.identify.traces import Trace, dead_fuel_channel
from vehval.identify.uncertainty import POOR_COVERAGE, interval_parts
from vehval.identify.warmup import cold_start_state
from vehval.integrals import held_sum
from vehval.sim.simulate import simulate

AC_AUTO_TEMP_C = 30.0  # [°C] test cells at or above this run with the A/C on ("auto")
AC_MODES = ("auto", "on", "off")


def with_ac(vehicle, on: bool):
    """A copy of a conventional ``vehicle`` with its A/C switched ``on`` (or off)."""
    veh = copy.deepcopy(vehicle)
    veh.engine_control.ac_on = bool(on)
    return veh


def ac_state(trace: Trace, mode: str = "auto") -> tuple[bool, str]:
    """Whether the A/C runs in ``trace`` and why (see the module docstring)."""
    if mode not in AC_MODES:
        raise ConfigError(f"--ac {mode}: give one of {', '.join(AC_MODES)}")
    if mode != "auto":
        return mode == "on", f"--ac {mode}"
    if trace.cycle.lower().startswith("sc03"):
        return True, "SC03 (run with the A/C on)"
    if not np.isfinite(trace.amb_temp_c):
        return False, "auto: not an SC03 test, no cell temperature in the file"
    if trace.amb_temp_c >= AC_AUTO_TEMP_C:
        return True, f"cell {trace.amb_temp_c:.1f} °C >= {AC_AUTO_TEMP_C:.0f} °C"
    return False, f"auto: not an SC03 test, cell below {AC_AUTO_TEMP_C:.0f} °C"


def predict_trace(vehicle, trace: Trace, ac: str = "auto") -> dict:
    """Simulate ``vehicle`` over ``trace``'s speed and compare fuel.

    Returns
    -------
    dict with ``test``, ``cycle``, ``amb_temp_c``, ``fuel_measured_g``,
    ``fuel_predicted_g``, ``error_rel`` (predicted / measured - 1), ``phases`` (list of
    {phase, measured_g, predicted_g, error_rel} plus, from the results stage,
    ``results_name``, ``results_fuel_g``, ``results_fuel_U_g``), the same three keys for the
    whole test, ``trace_max_miss_mps``, ``ac_on`` and ``ac_reason`` (the A/C state the
    model ran with; see :func:`ac_state`), ``starts_cold`` (the test starts cold: True, False
    or None, unknown), ``cold_start`` and ``cold_reason`` (whether the model ran with its
    warm-up fuel, and why), ``in_sample`` (the test is one the vehicle was identified from:
    its identification's ``tests``, its warm-up's cold test, its A/C test; per phase too),
    ``outside_identification`` (the test's cell temperature and coolant at the start outside
    the identification tests' range, :func:`vehval.identify.conditions.outside_conditions`:
    ``{key: {value, range}}``, empty when covered, None when the vehicle records no
    conditions), ``uncovered_share``, ``pi95_rel`` and ``pi95_g``
    (coverage and 95 % prediction interval, :mod:`vehval.identify.uncertainty`; also per
    phase; None for a vehicle without identification uncertainty), ``sim`` (the
    :class:`~vehval.sim.simulate.SimResult`) and ``trace``.
    """
    m = trace.t >= 0.0
    t = trace.t[m] - trace.t[m][0]
    cyc = Cycle(name=f"trace_{trace.test_id}", time_s=t, speed_mps=trace.v[m],
                description=f"measured speed of {trace.test_id}")
    ac_on, ac_reason = ac_state(trace, ac)
    ctl = getattr(vehicle, "engine_control", None)
    if ctl is not None and ctl.ac_power_w > 0 and ac_on != ctl.ac_on:
        vehicle = with_ac(vehicle, ac_on)
    if ctl is None or ctl.ac_power_w <= 0:
        ac_reason += " (no A/C load in the vehicle)"
    cold, cold_reason = cold_start_state(trace)
    warmup = vehicle.engine.warmup_fuel_fraction > 0.0
    cold_run = bool(cold) and warmup
    if cold and not warmup:
        cold_reason += " (no warm-up model in the vehicle)"
    res = simulate(vehicle, cyc, dt=trace.dt, cold_start=cold_run)
    fuel_sim = res.test["fuel_rate_simu"].values
    fuel_meas = trace.fuel[m][: fuel_sim.size]
    phase = trace.phase[m][: fuel_sim.size]
    dt = trace.dt
    stage = _results_stage(trace)
    phases = []
    for p in np.unique(phase[phase > 0]):
        sel = phase == p
        mg, pg = held_sum(fuel_meas, dt, sel) * 1e3, held_sum(fuel_sim, dt, sel) * 1e3
        row = {"phase": int(p), "measured_g": mg, "predicted_g": pg,
               "error_rel": pg / mg - 1 if mg > 0 else float("nan")}
        row.update(stage.get(int(p), {}))
        phases.append(row)
    # the test proper: its phases when the file numbers them (phase 0 between runs is a
    # soak, often with the engine off, which the model cannot know), else everything
    sel = phase > 0 if np.any(phase > 0) else np.ones(phase.size, dtype=bool)
    mg, pg = held_sum(fuel_meas, dt, sel) * 1e3, held_sum(fuel_sim, dt, sel) * 1e3
    ident = getattr(vehicle, "identification", None) or {}
    sels: dict = {int(r["phase"]): (phase == r["phase"], [1.0]) for r in phases}
    tot = sum(r["predicted_g"] for r in phases) or 1.0
    sels["test"] = (sel, [r["predicted_g"] / tot for r in phases] or [1.0])
    unc = interval_parts(ident, res.test, dt, sels)
    ac_fit = ident.get("ac") or {}
    fitted = same_test(trace.test_id, _fitted_tests(ident))
    ac_test = same_test(trace.test_id, [ac_fit.get("test") or ""])
    for r in phases:     # the A/C test's load was fitted on its phases after the first
        _add_interval(r, unc.get(int(r["phase"])))
        r["in_sample"] = fitted or (ac_test and r["phase"] in (ac_fit.get("phases") or []))
    out = {"test": trace.test_id, "cycle": trace.cycle, "amb_temp_c": trace.amb_temp_c,
            "fuel_measured_g": mg, "fuel_predicted_g": pg,
            "error_rel": pg / mg - 1 if mg > 0 else float("nan"), "phases": phases,
            "trace_max_miss_mps": res.summary["trace_max_miss_mps"], "ac_on": ac_on,
            "ac_reason": ac_reason, "starts_cold": cold, "cold_start": cold_run,
            "cold_reason": cold_reason,
            "in_sample": fitted or any(r["in_sample"] for r in phases),
            "outside_identification": outside_conditions(ident, trace),
            "sim": res, "trace": trace,
            "not_judged": dead_fuel_channel(trace)}
    _add_interval(out, unc.get("test"))
    out.update(stage.get("test", {}))
    return out


def _fitted_tests(ident: dict) -> set[str]:
    """The tests a vehicle's identification fitted as a whole: its identification tests and
    the cold-start test of its warm-up fuel (the A/C test is fitted on some phases only); a
    test is one of them by :func:`vehval.calibration.provenance.same_test`."""
    warm = ident.get("warmup") or {}
    return set(ident.get("tests") or []) | ({warm["cold_test"]} if warm.get("cold_test") else set())


MASS_TOL = 0.15    # [-] relative inertia-mass difference beyond which the car is another
FORCE_TOL = 0.30   # [-] relative road-force difference at 20 m/s beyond which likewise


def check_same_car(vehicle, trace: Trace) -> None:
    """Refuse, in one line, to predict ``trace`` with a vehicle of another car: the test's own
    inertia mass and road force at 20 m/s (least squares on its moving samples) are compared
    with the vehicle's (tolerances ``MASS_TOL``, ``FORCE_TOL`` + 50 N)."""
    from vehval.identify.roadload import _solve
    body = vehicle.body
    lag = float(((getattr(vehicle, "identification", None) or {}).get("road_load") or {})
                .get("lag_s", 0.0))
    theta = _solve([trace], lag, 1.0)[4]
    a, b, c, m = (float(x) for x in theta)
    f_t = a + 20 * b + 400 * c
    f_v = body.road_load_a_n + 20 * body.road_load_b_n_per_mps + 400 * body.road_load_c_n_per_mps2
    if (abs(m / body.mass_kg - 1) > MASS_TOL
            or abs(f_t - f_v) > FORCE_TOL * abs(f_v) + 50.0):
        raise ConfigError(
            f"{trace.file or trace.test_id}: the vehicle {vehicle.name} is not the tested car: "
            f"inertia mass {body.mass_kg:.0f} kg against the test's {m:.0f} kg, road force at "
            f"20 m/s {f_v:.0f} N against {f_t:.0f} N; give this car's vehicle file (or "
            "identify it from its tests)")


def _add_interval(row: dict, part: dict | None) -> None:
    """Add ``uncovered_share``, ``pi95_rel`` and ``pi95_g`` [low, high] to a result row
    (None when the vehicle carries no identification uncertainty)."""
    if part is None:
        row.update(uncovered_share=None, pi95_rel=None, pi95_g=None)
        return
    h = part["pi95_rel"]
    pg = row["predicted_g"] if "predicted_g" in row else row["fuel_predicted_g"]
    row.update(uncovered_share=part["uncovered_share"], pi95_rel=h,
               pi95_g=[pg * (1 - h), pg * (1 + h)])


def poor_coverage(rows: list[dict]) -> list[str]:
    """One warning line per phase whose predicted fuel is more than ``POOR_COVERAGE``
    uncovered by the identification data."""
    out = []
    for r in rows:
        for p in r["phases"]:
            u = p.get("uncovered_share")
            if u is not None and u > POOR_COVERAGE:
                out.append(f"{r['test']} {p.get('results_name', 'phase ' + str(p['phase']))}: "
                           f"{100 * u:.0f} % of the predicted fuel from operating points the "
                           "identification data did not cover (extrapolated)")
    return out


def _results_stage(trace: Trace) -> dict:
    """Fuel mass [g] and its expanded uncertainty U (k = 2) [g] from the results stage, per
    phase number and for the test (keys ``results_name``, ``results_fuel_g``,
    ``results_fuel_U_g``); empty without results."""
    res = trace.results
    if res is None:
        return {}
    out: dict = {}
    scopes = [(p.number, p.name) for p in res.phases if p.number is not None] + [("test", "test")]
    for key, name in scopes:
        val = res.value(name, "fuel_mass_kg")
        if val is None:
            continue
        u = res.expanded(name, "fuel_mass_kg")
        out[int(key) if key != "test" else key] = {
            "results_name": name, "results_fuel_g": 1e3 * val,
            "results_fuel_U_g": None if u is None else 1e3 * u}
    return out


def public_row(r: dict, vehicle=None) -> dict:
    """A prediction row without its arrays, with the fuel economy of the measured and the
    predicted fuel over the test's own distance (the test's fuel, else the vehicle's)."""
    out = {k: v for k, v in r.items() if k not in ("sim", "trace")}
    trace = r.get("trace")
    if trace is None:
        return out
    import numpy as np

    from vehval.fuels import fuel_consumption_l_per_100km, fuel_economy_mpg, fuel_volume_m3

    sel = trace.phase > 0 if np.any(trace.phase > 0) else np.ones(trace.phase.size, dtype=bool)
    dist = float(np.sum(trace.v[sel]) * trace.dt)
    dens = trace.test_fuel.density_kg_per_m3 if trace.test_fuel is not None else None
    if dens is None and vehicle is not None:
        dens = getattr(vehicle.engine, "fuel_density_kg_per_m3", None)
    out["distance_m"] = dist
    for which in ("measured", "predicted"):
        vol = fuel_volume_m3(out[f"fuel_{which}_g"] / 1e3, dens) if dens else None
        out[f"fuel_economy_{which}_mpg"] = (float(fuel_economy_mpg(dist, vol))
                                            if vol else None)
        out[f"fuel_consumption_{which}_l_per_100km"] = (
            float(fuel_consumption_l_per_100km(vol, dist)) if vol else None)
    return out
