"""The SAE J1711 NEC correction: battery state-of-charge correction of measured hybrid
results per SAE J1711 (2010).

Not the simulator's energy-balance correction (:func:`vehval.sim.simulate.energy_balance_fuel_kg`),
which converts any net battery energy of a model run to fuel through the run's engine
efficiency; this one judges a measured test by the standard's tolerance.

The net energy change (NEC) of the battery over a test biases its fuel consumption: energy
taken from the battery was not paid for in fuel. J1711 accepts a result uncorrected when
|NEC| is at most 1 % of the fuel energy of the test; beyond it the result is corrected,
either with a regression of fuel consumption against NEC over several tests (the value at
NEC = 0) or with a stated charge-balance factor (fuel energy per battery energy).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from vehval.fuels import mpg_with_fuel_scaled

__all__ = ["NEC_TOLERANCE", "regression_correction", "soc_correction"]

#: |NEC| / fuel energy at or below which the result stands uncorrected (SAE J1711 3.x).
NEC_TOLERANCE = 0.01


def soc_correction(values: dict[str, dict[str, float | None]], scopes: list[str], *,
                   composites: list[str] | None = None, battery: bool,
                   factor: float | None = None) -> dict[str, Any]:
    """The J1711 status of every scope.

    Parameters
    ----------
    values : dict
        Scope -> quantity -> value [SI] (``ess_energy_net_j`` positive discharged,
        ``fuel_energy_j``, ``fuel_mass_kg``, ``distance_m``, ``fuel_economy_mpg``).
    scopes : list of str
        Phases and ``test``.
    battery : bool
        Whether the test has battery power (or voltage and current).
    factor : float, optional
        Charge-balance factor [J fuel / J battery]: corrected fuel energy =
        fuel energy + factor x NEC.

    Returns
    -------
    dict
        ``status`` (``not_applicable``, ``undetermined`` (no fuel energy in any scope),
        ``within_tolerance``, ``corrected``, ``beyond_tolerance_uncorrected``), ``message``, ``tolerance``, ``method`` and
        ``scopes`` (per scope: ``nec_j``, ``nec_ratio``, ``status``, corrected figures).
    """
    if not battery:
        return {"status": "not_applicable", "tolerance": NEC_TOLERANCE, "method": None,
                "message": "no battery power or voltage and current: no SOC correction "
                           "(conventional vehicle or battery not measured)", "scopes": {}}
    per: dict[str, dict] = {}
    worst = "within_tolerance"
    for sc in scopes:
        v = values.get(sc, {})
        nec, ef = v.get("ess_energy_net_j"), v.get("fuel_energy_j")
        if nec is None or not ef:
            per[sc] = {"nec_j": nec, "nec_ratio": None, "status": "undetermined"}
            continue
        ratio = nec / ef
        entry: dict[str, Any] = {"nec_j": nec, "nec_ratio": ratio}
        if abs(ratio) <= NEC_TOLERANCE:
            entry["status"] = "within_tolerance"
        elif factor is not None:
            ef_c = ef + factor * nec
            scale = ef_c / ef
            mpg = v.get("fuel_economy_mpg")
            entry.update(status="corrected", fuel_energy_corrected_j=ef_c,
                         fuel_economy_mpg_corrected=mpg_with_fuel_scaled(mpg, scale) if mpg
                         else None)
            worst = "corrected" if worst == "within_tolerance" else worst
        else:
            entry["status"] = "beyond_tolerance_uncorrected"
            worst = "beyond_tolerance_uncorrected"
        per[sc] = entry
    t = per.get("test", {})
    if all(e["status"] == "undetermined" for e in per.values()):
        nec = t.get("nec_j")
        return {"status": "undetermined", "tolerance": NEC_TOLERANCE, "method": None,
                "message": ("battery net energy change "
                            + (f"{nec / 1e3:+.1f} kJ" if nec is not None else "unknown")
                            + " but no fuel energy (fuel not measured or not declared): the SAE "
                            "J1711 ratio cannot be formed, no SOC correction"),
                "scopes": per}
    if worst == "within_tolerance":
        msg = (f"battery net energy change {100 * (t.get('nec_ratio') or 0):+.2f} % of the fuel "
               f"energy, within the SAE J1711 tolerance of {100 * NEC_TOLERANCE:g} %: results "
               "stand uncorrected")
        method = None
    elif worst == "corrected":
        msg = (f"battery net energy change beyond {100 * NEC_TOLERANCE:g} % of the fuel energy: "
               f"corrected with the stated charge-balance factor {factor:g} J fuel per J battery "
               "(SAE J1711)")
        method = "charge_balance_factor"
    else:
        msg = (f"battery net energy change {100 * (t.get('nec_ratio') or 0):+.2f} % of the fuel "
               f"energy, beyond the SAE J1711 tolerance of {100 * NEC_TOLERANCE:g} %: results "
               "NOT corrected; give constants.soc_correction_fuel_j_per_battery_j or correct by "
               "regression over several tests (vehval.results.soc.regression_correction)")
        method = None
    return {"status": worst, "tolerance": NEC_TOLERANCE, "method": method, "message": msg,
            "scopes": per}


def regression_correction(nec_ratio: list[float], fuel_per_distance: list[float]) -> dict:
    """SAE J1711 regression correction over several tests of one cycle.

    Fits fuel consumption against NEC / fuel energy by least squares and returns the value
    at NEC = 0.

    Parameters
    ----------
    nec_ratio : list of float
        NEC / fuel energy of each test [-] (positive: battery discharged).
    fuel_per_distance : list of float
        Fuel consumption of each test [kg/m] (or any per-distance unit).

    Returns
    -------
    dict
        ``corrected`` (consumption at NEC = 0), ``slope`` (per unit NEC ratio),
        ``r2`` and ``tests``.
    """
    x = np.asarray(nec_ratio, float)
    y = np.asarray(fuel_per_distance, float)
    if x.size < 2 or np.ptp(x) == 0:
        from vehval.errors import VehvalError
        raise VehvalError("SOC regression needs at least two tests with different battery "
                          "net energy changes")
    slope, intercept = np.polyfit(x, y, 1)
    pred = intercept + slope * x
    ss = float(np.sum((y - y.mean()) ** 2))
    r2 = 1.0 - float(np.sum((y - pred) ** 2)) / ss if ss > 0 else 1.0
    return {"corrected": float(intercept), "slope": float(slope), "r2": r2, "tests": int(x.size)}
