"""Predict a measured test with a vehicle model: its own speed trace, fuel per phase.

The model drives the test's measured speed trace (from time 0) at the trace's step; the
fuel it burns is compared with the measured fuel over the test proper (every numbered
phase; samples of phase 0, a soak between runs, are left out) and per phase.
Measured fuel is the integral of the fuel-rate signal; the meter's delay (a second or
two) moves a few grams across phase borders, which is why the whole-test figure is the
headline.
"""

from __future__ import annotations

import numpy as np

from vehval.cycles import Cycle
from vehval.identify.traces import Trace
from vehval.sim.simulate import simulate


def predict_trace(vehicle, trace: Trace) -> dict:
    """Simulate ``vehicle`` over ``trace``'s speed and compare fuel.

    Returns
    -------
    dict with ``test``, ``cycle``, ``amb_temp_c``, ``fuel_measured_g``,
    ``fuel_predicted_g``, ``error_rel`` (predicted / measured - 1), ``phases`` (list of
    {phase, measured_g, predicted_g, error_rel} plus, from the results stage,
    ``results_name``, ``results_fuel_g``, ``results_fuel_U_g``), the same three keys for the
    whole test, ``trace_max_miss_mps``, ``sim`` (the
    :class:`~vehval.sim.simulate.SimResult`) and ``trace``.
    """
    m = trace.t >= 0.0
    t = trace.t[m] - trace.t[m][0]
    cyc = Cycle(name=f"trace_{trace.test_id}", time_s=t, speed_mps=trace.v[m],
                description=f"measured speed of {trace.test_id}")
    res = simulate(vehicle, cyc, dt=trace.dt)
    fuel_sim = res.test["fuel_rate_simu"].values
    fuel_meas = trace.fuel[m][: fuel_sim.size]
    phase = trace.phase[m][: fuel_sim.size]
    dt = trace.dt
    stage = _results_stage(trace)
    phases = []
    for p in np.unique(phase[phase > 0]):
        sel = phase == p
        mg, pg = float(fuel_meas[sel].sum() * dt * 1e3), float(fuel_sim[sel].sum() * dt * 1e3)
        row = {"phase": int(p), "measured_g": mg, "predicted_g": pg,
               "error_rel": pg / mg - 1 if mg > 0 else float("nan")}
        row.update(stage.get(int(p), {}))
        phases.append(row)
    # the test proper: its phases when the file numbers them (phase 0 between runs is a
    # soak, often with the engine off, which the model cannot know), else everything
    sel = phase > 0 if np.any(phase > 0) else np.ones(phase.size, dtype=bool)
    mg, pg = float(fuel_meas[sel].sum() * dt * 1e3), float(fuel_sim[sel].sum() * dt * 1e3)
    out = {"test": trace.test_id, "cycle": trace.cycle, "amb_temp_c": trace.amb_temp_c,
            "fuel_measured_g": mg, "fuel_predicted_g": pg,
            "error_rel": pg / mg - 1 if mg > 0 else float("nan"), "phases": phases,
            "trace_max_miss_mps": res.summary["trace_max_miss_mps"], "sim": res, "trace": trace}
    out.update(stage.get("test", {}))
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
