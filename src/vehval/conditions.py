"""The test's physical conditions (mass, road load...), decided once, with provenance.

The fuel is not one of them: :func:`vehval.fuels.resolve_fuel` decides it (template ``fuel:``,
explicit constants, vehicle file; no default).

One policy for every stage (QA calculations, analysis, validation, batch metrics, report):
a **template constant beats the vehicle's value**, which beats a documented default. The
template describes the test as it was run (the dyno's inertia mass and coefficients; the
fuel is resolved by :mod:`vehval.fuels`); the vehicle file describes the car in general.

Vehicle values are found by their **dotted path** only (``body.mass_kg``), never by a
search for a bare key: ``max_torque_nm`` exists in several blocks, a search would pick one
by accident.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Mapping

from vehval.errors import ConfigError

#: Condition -> (template constant, vehicle dotted path, default). None: no such source.
CONDITIONS: dict[str, tuple[str | None, str | None, float | None]] = {
    "test_mass_kg": ("test_mass_kg", "body.mass_kg", None),
    "road_load_a_n": ("road_load_a_n", "body.road_load_a_n", None),
    "road_load_b_n_per_mps": ("road_load_b_n_per_mps", "body.road_load_b_n_per_mps", None),
    "road_load_c_n_per_mps2": ("road_load_c_n_per_mps2", "body.road_load_c_n_per_mps2", None),
    "wheel_radius_m": ("wheel_radius_m", "driveline.wheel_radius_m", None),
    "final_drive_ratio": ("final_drive_ratio", "driveline.final_drive_ratio", None),
}


def vehicle_value(vehicle: Any, path: str) -> Any:
    """The value at a dotted path of a vehicle (model or mapping); None when absent.

    Raises
    ------
    ConfigError
        When ``path`` is a bare key (no block): name the block, e.g. ``body.mass_kg``.
    """
    if "." not in path:
        raise ConfigError(f"vehicle parameter '{path}': give its dotted path with the block "
                          "(e.g. body.mass_kg)")
    cur = vehicle
    for part in path.split("."):
        if cur is None:
            return None
        cur = cur.get(part) if isinstance(cur, Mapping) else getattr(cur, part, None)
    return cur


def finite_number(value: Any) -> float | None:
    """``value`` as a finite float; None when it is missing, a boolean or not a finite number."""
    if value is None or isinstance(value, bool):
        return None
    try:
        f = float(value)
    except (TypeError, ValueError):
        return None
    return f if math.isfinite(f) else None


@dataclass(frozen=True)
class Resolved:
    """One condition: its value and where it came from (``template constant X``,
    ``vehicle body.mass_kg`` or ``default``)."""

    value: float
    source: str


@dataclass
class TestConditions:
    """The resolved conditions of a test (see the module docstring for the policy)."""

    __test__ = False  # not a pytest test class

    values: dict[str, Resolved] = field(default_factory=dict)

    @classmethod
    def resolve(cls, test: Any = None, template: Any = None, vehicle: Any = None,
                constants: Mapping[str, Any] | None = None) -> "TestConditions":
        """Resolve every condition of :data:`CONDITIONS`.

        Parameters
        ----------
        test : Test, optional
            Its ``meta.constants`` (the template's constants stored at import).
        template : Template, optional
            Its constants, for those not already in the test.
        vehicle : Vehicle, optional
            Vehicle values by dotted path.
        constants : mapping, optional
            Explicit constants (beat the template's).
        """
        merged: dict[str, Any] = {}
        if template is not None and hasattr(template, "constants_dict"):
            merged.update(template.constants_dict())
        if test is not None:
            merged.update(getattr(test.meta, "constants", None) or {})
        merged.update(constants or {})
        out: dict[str, Resolved] = {}
        for name, (const, path, default) in CONDITIONS.items():
            v = finite_number(merged.get(const)) if const else None
            if v is not None:
                out[name] = Resolved(v, f"template constant {const}")
                continue
            v = finite_number(vehicle_value(vehicle, path)) if (vehicle is not None and path) else None
            if v is not None:
                out[name] = Resolved(v, f"vehicle {path}")
            elif default is not None:
                out[name] = Resolved(float(default), "default")
        return cls(out)

    def get(self, name: str, default: float | None = None) -> float | None:
        """The value of a condition, or ``default`` when unresolved."""
        r = self.values.get(name)
        return r.value if r is not None else default

    def __getitem__(self, name: str) -> float:
        if name not in self.values:
            raise KeyError(f"condition '{name}' not resolved (no template constant, vehicle "
                           "value or default)")
        return self.values[name].value

    def source(self, name: str) -> str | None:
        """Where a condition came from, or None when unresolved."""
        r = self.values.get(name)
        return r.source if r is not None else None

    def as_dict(self) -> dict[str, float]:
        """Condition -> value."""
        return {k: r.value for k, r in self.values.items()}

    def provenance(self) -> dict[str, str]:
        """Condition -> source."""
        return {k: r.source for k, r in self.values.items()}


# ------------------------------------------------------------------------- cold start
#: A start is cold when the engine coolant at the start is less than this above the test
#: cell temperature [K].
COLD_START_BAND_K = 10.0
#: Cell temperature assumed when none is measured [degC]: the top of the FTP cell range
#: (40 CFR 86.130, 20-30 degC), so that a start called cold is cold in any FTP cell.
COLD_START_CELL_C = 30.0


def cold_start(coolant_start_c: float, cell_c: float | None = None) -> tuple[bool | None, str]:
    """Whether a test starts with a cold engine, from measured data, and why.

    The one rule: **cold when the engine coolant at the start is less than**
    :data:`COLD_START_BAND_K` **above the cell temperature** (:data:`COLD_START_CELL_C`
    when the cell is not measured: coolant below 40 degC). A lab defends it from the
    regulation's own definition: a cold start follows a 12-36 h soak in the cell (40 CFR
    86.132), after which the coolant is at the cell temperature; a coolant still 10 K or more
    above the cell has not soaked (a hot start, or one of a few hours' soak, which the
    warm-up fuel of a cold start would overstate). A coolant far *below* the cell (a car
    brought in cold) is cold too; an absolute threshold alone (below 40 degC) would call a
    35 degC start in a -7 degC cell cold, a test the cold-temperature FTP does not know.

    Parameters
    ----------
    coolant_start_c : float
        Engine coolant temperature at the start [degC] (NaN: unknown).
    cell_c : float, optional
        Mean test cell temperature [degC] (None or NaN: not measured).

    Returns
    -------
    (cold, why) : (bool or None, str)
        None when the coolant is not measured.
    """
    if coolant_start_c is None or not math.isfinite(coolant_start_c):
        return None, "no engine coolant temperature in the test"
    measured = cell_c is not None and math.isfinite(cell_c)
    cell = float(cell_c) if cell_c is not None and measured else COLD_START_CELL_C
    cold = coolant_start_c < cell + COLD_START_BAND_K
    where = (f"cell {cell:.1f} °C" if measured
             else f"no cell temperature: {COLD_START_CELL_C:g} °C, the top of the FTP range")
    return cold, (f"coolant {coolant_start_c:.0f} °C at the start, {where} (cold below "
                  f"{COLD_START_BAND_K:g} K above the cell)")
