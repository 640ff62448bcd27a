"""Test-to-test variability: repeats of the same cycle compared with each other.

Each test is reduced with the same formulas as the validation (fuel, SOC change, energies,
engine on time; :func:`vehval.validate.quantities.totals`); per quantity we report the
mean, min, max, spread (max - min), the sample standard deviation (ddof = 1) and the
coefficient of variation ``CV = std / |mean|``. :func:`error_vs_repeatability` then reads a
model error against that repeatability: an error smaller than about two standard deviations
of the repeats cannot be told apart from test-to-test scatter.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np

from vehval.errors import VehvalError
from vehval.fuels import resolve_fuel
from vehval.jsonsafe import clean
from vehval.test import Test
from vehval.validate.compare import SUMMARY_ROWS, Comparison
from vehval.validate.quantities import (
    engine_on_method,
    pick_signal,
    totals,
    uniform_grid,
)

#: Quantities reported by default (keys of ``totals``).
DEFAULT_QUANTITIES = ("fuel_mass_kg", "fuel_economy_mpg", "fuel_consumption_l_per_100km",
                      "distance_m", "soc_initial", "soc_final", "soc_delta", "engine_on_share",
                      "engine_starts", "eng_pwr_out_pos_j", "mot_pwr_out_pos_j",
                      "mot_pwr_out_neg_j", "gen_pwr_out_pos_j", "gen_pwr_out_neg_j",
                      "ess_pwr_pos_j", "ess_pwr_neg_j", "whl_pwr_out_pos_j", "whl_pwr_out_neg_j")


def stats(values: Sequence[float]) -> dict[str, float]:
    """Mean, min, max, spread, sample std (ddof=1) and CV of finite ``values``.

    ``std`` and ``cv`` are NaN with fewer than two finite values; ``cv`` is NaN when the
    mean is zero.
    """
    v = np.asarray([x for x in values if x is not None and np.isfinite(x)], dtype=float)
    nan = float("nan")
    if not v.size:
        return {"n": 0, "mean": nan, "min": nan, "max": nan, "spread": nan, "std": nan, "cv": nan}
    mean = float(v.mean())
    sd = float(v.std(ddof=1)) if v.size > 1 else nan
    return {"n": int(v.size), "mean": mean, "min": float(v.min()), "max": float(v.max()),
            "spread": float(v.max() - v.min()), "std": sd,
            "cv": sd / abs(mean) if (np.isfinite(sd) and mean != 0.0) else nan}


@dataclass
class Variability:
    """Variability of repeated tests.

    Attributes
    ----------
    test_ids : list of str
    values : dict
        Quantity -> value per test (SI, order of ``test_ids``).
    stats : dict
        Quantity -> :func:`stats` of the values.
    cycle : str
    notes : list of str
    """

    test_ids: list[str]
    values: dict[str, list[float]]
    stats: dict[str, dict[str, float]]
    cycle: str = ""
    notes: list[str] = field(default_factory=list)

    def rows(self) -> list[list[Any]]:
        """[quantity, unit, mean, min, max, spread, std, CV %] in display units."""
        labels = {k: (lab, unit, s) for k, lab, unit, s in SUMMARY_ROWS}
        out = []
        for q, st in self.stats.items():
            lab, unit, k = labels.get(q, (q, "SI", 1.0))
            out.append([lab, unit, st["mean"] * k, st["min"] * k, st["max"] * k,
                        st["spread"] * k, st["std"] * k,
                        st["cv"] * 100 if np.isfinite(st["cv"]) else float("nan")])
        return out

    def tables(self) -> list[dict]:
        return [{"title": f"Test-to-test variability ({len(self.test_ids)} tests"
                          f"{', ' + self.cycle if self.cycle else ''})",
                 "columns": ["quantity", "unit", "mean", "min", "max", "spread", "std (n-1)", "CV [%]"],
                 "rows": self.rows(),
                 "note": "tests: " + ", ".join(self.test_ids)}]

    def to_dict(self) -> dict[str, Any]:
        return clean({"cycle": self.cycle, "test_ids": self.test_ids, "values": self.values,
                       "stats": self.stats, "tables": self.tables(), "notes": self.notes})


def variability(tests: Sequence[Test], *, quantities: Sequence[str] = DEFAULT_QUANTITIES,
                dt: float = 0.1, vehicle: Any = None) -> Variability:
    """Compare repeated tests of one cycle with each other.

    Parameters
    ----------
    tests : sequence of Test
        At least two tests (normally of the same cycle; a mix is reported in ``notes``).
    quantities : sequence of str
        Keys of :func:`vehval.validate.quantities.totals` to report.
    dt : float
        Step of the grid each test is reduced on [s].
    vehicle : Vehicle, optional
        Each test's fuel is :func:`vehval.fuels.resolve_fuel` of the test and this vehicle:
        the fuel its validation uses (without a fuel, no fuel economy or energy).

    Raises
    ------
    VehvalError
        With fewer than two tests.
    """
    if len(tests) < 2:
        raise VehvalError(f"test-to-test variability needs at least two tests (got {len(tests)})")
    ids: list[str] = []
    per: list[dict] = []
    notes: list[str] = []
    cycles = sorted({t.meta.cycle for t in tests if t.meta.cycle})
    if len(cycles) > 1:
        notes.append(f"tests of different cycles compared: {', '.join(cycles)}")
    for i, t in enumerate(tests):
        spd = pick_signal(t, "veh_spd", "test")
        if spd is None:
            raise VehvalError(f"test '{t.meta.test_id or i}': no vehicle speed signal (veh_spd_test)")
        grid = uniform_grid(float(spd.time[0]), float(spd.time[-1]), dt)
        per.append(totals(t, "test", grid, on_method=engine_on_method(t),
                          fuel=resolve_fuel(test=t, vehicle=vehicle)))
        ids.append(t.meta.test_id or f"test{i + 1}")
    values = {q: [float(p.get(q, math.nan)) for p in per] for q in quantities}
    values = {q: v for q, v in values.items() if any(np.isfinite(v))}
    return Variability(test_ids=ids, values=values, stats={q: stats(v) for q, v in values.items()},
                       cycle=cycles[0] if len(cycles) == 1 else ", ".join(cycles), notes=notes)


def error_vs_repeatability(comp: Comparison, var: Variability) -> list[dict[str, Any]]:
    """Model error of each quantity read against the repeatability of the test.

    Returns
    -------
    list of dict
        ``quantity``, ``error`` (sim - test, SI), ``test_std`` (SI), ``ratio`` = |error| / std
        and ``verdict``: ``within scatter`` when ratio <= 2, else ``model error``.
    """
    out = []
    for q, st in var.stats.items():
        a, b = comp.totals_test.get(q), comp.totals_sim.get(q)
        if a is None or b is None or not (np.isfinite(a) and np.isfinite(b)):
            continue
        err = b - a
        sd = st["std"]
        ratio = abs(err) / sd if (np.isfinite(sd) and sd > 0) else float("nan")
        verdict = ("within scatter" if ratio <= 2.0 else "model error") if np.isfinite(ratio) else "n/a"
        out.append({"quantity": q, "error": err, "test_std": sd, "ratio": ratio, "verdict": verdict})
    return out
