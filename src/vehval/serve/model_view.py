"""Model and test: the simulation of a test's own conditions overlaid on its measured traces.

The test's template names the vehicle; :meth:`vehval.workflow.TestRun.validate` simulates it
on the test's speed trace and conditions and compares (verdicts against the measurement
uncertainty, docs/validation.md). The page gets the comparison tables and, per quantity,
the measured and simulated traces on one time axis.
"""

from __future__ import annotations

from typing import Any

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
    return {"vehicle": val.sim.vehicle.name, "tables": val.comparison.tables(),
            "notes": outcome.payload(figures=False).get("notes", []), "traces": traces}
