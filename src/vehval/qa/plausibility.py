"""Unit plausibility: physics that catches a wrong unit or mapping in the template.

The QA pipeline's front door to the cross-checks of :mod:`vehval.qa.crosscheck` (fuel
energy against tractive energy, speed trace against the cycle, force against mass x
acceleration, engine speed, temperatures, pressures, file header against template). Each
finding is of kind ``unit_suspect``, names the declared and the probable unit with the
factor between them, and carries the one-line ``fix``. Then the fuel gates of
:mod:`vehval.qa.fuel_gates`: the fuel against the work the engine can give for it
(``fuel_efficiency``) and a fuel reading zero, missing or flat while the engine delivers
power (``fuel_response``).
"""

from __future__ import annotations

from typing import Any

from vehval.qa.crosscheck import run_crosschecks
from vehval.qa.findings import Finding
from vehval.qa.fuel_gates import run_fuel_gates
from vehval.test import Test


def run_plausibility(test: Test, table3: list[Any] | None = None, template: Any = None,
                     vehicle: Any = None) -> list[Finding]:
    """Every unit plausibility check on an aligned test.

    Parameters
    ----------
    test : Test
        The aligned test.
    table3 : list, optional
        Level-3 rows (not needed by the checks; kept for the call signature).
    template, vehicle : optional
        For the fuel and the constants (``test_mass_kg`` [kg]).

    Returns
    -------
    list of Finding
    """
    constants = dict(test.meta.constants)
    if template is not None and hasattr(template, "constants_dict"):
        for k, v in template.constants_dict().items():
            constants.setdefault(k, v)
    out = run_crosschecks(test, template, vehicle, constants)
    return out + run_fuel_gates(test, template, vehicle, out)
