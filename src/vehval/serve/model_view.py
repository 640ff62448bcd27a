"""Model and test: the simulation of a test's own conditions overlaid on its measured traces.

The test's template names the vehicle; :meth:`vehval.workflow.TestRun.validate` simulates it
on the test's speed trace and conditions and compares (verdicts against the measurement
uncertainty, docs/validation.md). The page gets the comparison tables, the fuel mass's
normalised error En with U_model and U_meas (``normalised_error``, and a table beside the
summary's % differences) and, per quantity, the measured and simulated traces on one time axis.
"""

from __future__ import annotations

from typing import Any

from vehval.display import as_unit
from vehval.errors import ConfigError
from vehval.serve.series import series

#: Quantities overlaid (standard base names).
BASES = ("veh_spd", "fuel_rate", "eng_spd_out", "ess_soc", "eng_trq_out", "mot_trq_out",
         "gen_spd_out", "ess_curr")


def model_overlay(bench: Any, n: int = 2000) -> dict:
    """Run the validation of ``bench``'s test and return tables and overlaid traces."""
    run = bench._ensure_run()
    if run.vehicle is None:
        raise ConfigError("the template names no vehicle ('vehicle: prius_2004'): the model "
                          "needs one")
    outcome = run.validate()
    val = outcome.validation
    measured = run.validated
    sim = val.sim.test
    traces = []
    for base in BASES:
        m = measured.best(base, ("test",))
        s = sim.best(base, ("simu",))
        if m is None or s is None:
            continue
        traces.append({"base": base, "unit": m.unit,
                       "measured": {"name": m.name, **series(m.time, m.values, None, None, n)},
                       "simulated": {"name": s.name, **series(s.time, s.values, None, None, n)}})
    figure = overlay_figure(measured, sim)
    ne = _normalised_error(run.vehicle, val.comparison)
    bench.model_verdict = ne
    tables = val.comparison.tables()
    tables.insert(1 if tables else 0, en_table(ne))   # beside the summary's % differences
    return {"vehicle": val.sim.vehicle.name, "tables": tables, "normalised_error": ne,
            "notes": outcome.payload(figures=False).get("notes", []), "traces": traces,
            "figure": figure}


def overlay_figure(measured: Any, sim: Any) -> dict:
    """Measured against simulated, one panel per quantity in its display unit, on one linked
    time axis (the report's figure layer), as plotly JSON the page draws."""
    import json

    import numpy as np

    from vehval.display import to_display
    from vehval.report.figures import PALETTE, figure_json, time_traces_figure

    panels = []
    for base in BASES:
        m = measured.best(base, ("test",))
        s = sim.best(base, ("simu",))
        if m is None or s is None:
            continue
        ym, unit = to_display(np.asarray(m.values, float), m.unit, signal=m.name)
        ys, _ = to_display(np.asarray(s.values, float), s.unit, signal=m.name)
        panels.append({"ylabel": f"{base} [{unit}]" if unit else base, "unit": unit, "traces": [
            {"name": f"{m.name} (test)", "t": m.time, "y": ym, "unit": unit, "color": PALETTE[0]},
            {"name": f"{s.name} (model)", "t": s.time, "y": ys, "unit": unit,
             "color": PALETTE[1], "dash": "dot"}]})
    fig = time_traces_figure(panels, row_height=140)
    fig["layout"]["meta"] = {"units": [p["unit"] for p in panels]}
    return json.loads(figure_json(fig))


def _normalised_error(veh: Any, comp: Any) -> dict:
    """En of the fuel mass as ``vehval validate`` gives it (U_model: the vehicle's parameter
    ranges on the test's cycle, linear; U_meas: the results stage's U with s_r)."""
    from vehval.workflow import fuel_normalised_error, model_uncertainty_by_cycle

    u, notes = model_uncertainty_by_cycle(veh, [comp.cycle or ""], "linear")
    return fuel_normalised_error(veh, comp, u.get(comp.cycle or ""), notes)


def en_table(ne: dict) -> dict:
    """The page's table of the fuel mass's normalised error, in display units (g)."""
    def g(v: Any) -> Any:
        return None if v is None else as_unit(v, "g")

    en = ne.get("en")
    flag = "; uninformative (combined U over 10 % of the measured fuel)" if ne.get("uninformative") else ""
    return {"title": "Verdict by the normalised error (fuel mass)",
            "columns": ["quantity", "unit", "test", "simulation", "error [%]",
                        "U_model (k = 2)", "U_meas (k = 2)", "En", "verdict", "sample"],
            "rows": [["fuel mass", "g", g(ne.get("measured_kg")), g(ne.get("model_kg")),
                      ne.get("error_pct"), g(ne.get("u_model_kg")), g(ne.get("u_meas_kg")),
                      None if en is None else round(en, 3), f"{ne.get('verdict')}{flag}",
                      "in-sample" if ne.get("in_sample") else "held-out"]],
            "note": ("En = (m_sim - m_test) / sqrt(U_model² + U_meas²); |En| ≤ 1 is consistent. "
                     "U_model: the vehicle's parameter ranges on the cycle; U_meas: the "
                     f"measured fuel's U with the repeatability s_r = {as_unit(ne.get('s_r') or 0, '%'):.2f} %"
                     + (f". {ne['note']}" if ne.get("note") else ""))}
