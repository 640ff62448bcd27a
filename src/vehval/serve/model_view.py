"""Model and test: the simulation of a test's own conditions overlaid on its measured traces,
for every architecture the stage registry validates by simulation.

The test's template names the vehicle; :meth:`vehval.workflow.TestRun.validate` runs the
architecture's validation (:mod:`vehval.architectures`: the power-split hybrid's comparison,
the battery-electric car's traces, DC energy and SAE J1634 figures) and the page reads the
outcome's generic interface only: its tables and notes (``payload``) and its measured and
simulated traces on one time grid (``overlays``). The verdict the headline carries is the
architecture's own: the fuel mass's normalised error En with U_model and U_meas for a car
that burns fuel (a table beside the summary's % differences), the whole test's DC energy En
for a battery-electric car.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from vehval.display import as_unit
from vehval.errors import ConfigError
from vehval.serve.series import series

#: Quantities overlaid, in this order, when the comparison has both sides (standard base
#: names).
BASES = ("veh_spd", "fuel_rate", "eng_spd_out", "ess_soc", "eng_trq_out", "mot_trq_out",
         "gen_spd_out", "ess_curr", "ess_volt")


def model_overlay(bench: Any, n: int = 2000) -> dict:
    """Run the validation of ``bench``'s test and return tables and overlaid traces (SI)."""
    run = bench._ensure_run()
    if run.vehicle is None:
        raise ConfigError("the template names no vehicle ('vehicle: prius_2004'): the model "
                          "needs one")
    outcome = run.validate()
    payload = outcome.payload(figures=False)
    traces = overlay_traces(run.validated, outcome.overlays, n)
    tables = list(payload.get("tables") or [])
    ne = model_verdict(run.vehicle, outcome.comparison)
    bench.model_verdict = ne
    if ne is not None and ne.get("quantity") is None:   # the fuel mass: its own table
        tables.insert(1 if tables else 0, en_table(ne))  # beside the summary's % differences
    return {"vehicle": str(outcome.document.get("vehicle") or run.vehicle.name),
            "tables": tables, "normalised_error": ne, "notes": payload.get("notes", []),
            "traces": traces}


def overlay_traces(measured: Any, overlays: Any, n: int = 2000) -> list[dict]:
    """Per quantity of :data:`BASES` the comparison has on both sides: ``base``, ``unit``
    (the measured signal's SI unit) and the ``measured`` / ``simulated`` series."""
    if overlays is None:
        return []
    t = np.asarray(overlays["time"], float)
    out = []
    for base in BASES:
        if f"{base}_test" not in overlays or f"{base}_simu" not in overlays:
            continue
        m = measured.best(base, ("test",))
        if m is None:
            continue
        out.append({"base": base, "unit": m.unit,
                    "measured": {"name": m.name, **series(
                        t, np.asarray(overlays[f"{base}_test"], float), None, None, n)},
                    "simulated": {"name": f"{base}_simu", **series(
                        t, np.asarray(overlays[f"{base}_simu"], float), None, None, n)}})
    return out


def model_verdict(veh: Any, comparison: Any) -> dict | None:
    """The verdict the headline carries: the whole test's DC energy En of a battery-electric
    comparison (``quantity``: ``DC energy``), else the fuel mass's En (:func:`_normalised_error`)
    of a simulation on the test's conditions; None for other comparisons."""
    energy = getattr(comparison, "energy", None)
    if energy is not None:
        row = next((r for r in energy if r.get("scope") == "test"), None)
        if row is None or row.get("en") is None:
            return None
        return {"quantity": "DC energy", "en": row["en"], "error_pct": row.get("error_pct"),
                "verdict": "consistent" if abs(row["en"]) <= 1.0 else "inconsistent",
                "u_model_wh": row.get("U_model"), "u_meas_wh": row.get("U_meas"),
                "model_wh": row.get("model_wh"), "measured_wh": row.get("test_wh")}
    inner = getattr(comparison, "comparison", None)
    return None if inner is None else _normalised_error(veh, inner)


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
