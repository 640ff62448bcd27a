"""Effort/flow calculation: every ``*_calc`` signal the measured inputs allow.

A calculation file (``data/calculations/<name>.yaml``) declares parameters (where to find
them: template constant, vehicle key, default) and relations ``output = expression``.
:func:`compute` evaluates them on a common grid, iterating to a fixed point: a relation
runs once all its inputs exist, either measured (the facility ``_test`` signal first, then
other sources) or already calculated. Relations of the same output are tried in file order
(included files first) and the first computable one is used. A relation may not use a calculated input that was
itself derived from the relation's own output (no circular self-confirmation). What could
not be computed is explained: the missing signals or parameters of each relation.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from vehval.conditions import vehicle_value
from vehval.equations.expr import parse_expression
from vehval.errors import ConfigError, SignalError
from vehval.fuels import CONSTANT_KEYS, ResolvedFuel, resolve_fuel
from vehval.nomenclature import registry
from vehval.safe_yaml import load_yaml
from vehval.test import Signal, Test

#: Template constant of a fuel property -> the property of the resolved fuel.
FUEL_PARAMETERS = {key: prop for prop, key in CONSTANT_KEYS.items()}


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid")


class ParameterSpec(_Strict):
    """Where a parameter comes from: template constant, vehicle keys, default."""

    constant: str | None = None
    vehicle: list[str] = Field(default_factory=list)
    default: float | None = None
    unit: str = ""
    description: str = ""


class RelationSpec(_Strict):
    """One relation ``<output>_calc = expr``."""

    output: str
    expr: str
    equation: str | None = None
    description: str = ""
    steady_state: bool = False     # holds only in steady state (QA3 tolerates transients)


class CheckSpec(_Strict):
    """A balance check ``lhs ≈ rhs`` between two independent expressions; disagreement is
    reported on the measured signal of base ``blame`` (the usual suspect)."""

    name: str
    lhs: str
    rhs: str
    blame: str
    r2_min: float = 0.6
    description: str = ""


class CalculationFile(_Strict):
    calculation_version: int = 1
    name: str
    description: str = ""
    include: list[str] = Field(default_factory=list)
    parameters: dict[str, ParameterSpec] = Field(default_factory=dict)
    relations: list[RelationSpec] = Field(default_factory=list)
    checks: list[CheckSpec] = Field(default_factory=list)


def load_calculations(name_or_path: str | Path) -> CalculationFile:
    """Load a calculation file (cached for package names; treat the result as read-only)."""
    p = Path(str(name_or_path))
    if p.suffix in (".yaml", ".yml") and p.exists():
        return _load_calculations(name_or_path)
    return _load_package_calculations(str(name_or_path))


@lru_cache(maxsize=16)
def _load_package_calculations(name: str) -> CalculationFile:
    return _load_calculations(name)


#: Calculation files being loaded (outermost first), to detect include cycles.
_INCLUDING: list[str] = []
#: Deepest include chain accepted.
MAX_INCLUDE_DEPTH = 16


def _load_calculations(name_or_path: str | Path) -> CalculationFile:
    p = Path(str(name_or_path))
    key = str(p.resolve()) if p.suffix in (".yaml", ".yml") and p.exists() else str(name_or_path)
    if key in _INCLUDING or len(_INCLUDING) >= MAX_INCLUDE_DEPTH:
        chain = " -> ".join([*_INCLUDING, key])
        raise ConfigError(f"calculation files include each other in a cycle or too deeply "
                          f"({chain}): remove the include that closes it")
    _INCLUDING.append(key)
    try:
        return _load_calculations_file(name_or_path)
    finally:
        _INCLUDING.pop()


def _load_calculations_file(name_or_path: str | Path) -> CalculationFile:
    """Load a calculation file (package name like ``power_split`` or a path), with includes.

    Raises
    ------
    ConfigError
        Unknown name, invalid YAML, unknown key, unknown output base name or bad expression.
    """
    p = Path(str(name_or_path))
    if p.suffix in (".yaml", ".yml") and p.exists():
        text, where = p.read_text(encoding="utf-8"), str(p)
    else:
        res = resources.files("vehval").joinpath(f"data/calculations/{name_or_path}.yaml")
        if not res.is_file():
            known = sorted(x.name[:-5] for x in resources.files("vehval").joinpath(
                "data/calculations").iterdir() if x.name.endswith(".yaml"))
            raise ConfigError(f"calculation set '{name_or_path}' not found; known: {', '.join(known)}")
        text, where = res.read_text(encoding="utf-8"), f"calculations/{name_or_path}.yaml"
    try:
        data = load_yaml(text, where)
        calc = CalculationFile.model_validate(data)
    except ValidationError as exc:
        err = exc.errors()[0]
        raise ConfigError(f"{where}: {'.'.join(str(x) for x in err['loc'])}: {err['msg']}") from None
    for pname, spec in calc.parameters.items():
        for key in spec.vehicle:
            if "." not in key:
                raise ConfigError(f"{where}: parameters.{pname}.vehicle: '{key}' is not a dotted "
                                  "vehicle path: name the block (e.g. body.mass_kg)")
    reg = registry()
    for i, rel in enumerate(calc.relations):
        if rel.output not in reg:
            raise ConfigError(f"{where}: relations[{i}].output '{rel.output}' is not a base name "
                              "of the nomenclature")
        parse_expression(rel.expr, f"{where}: relations[{i}].expr")
    for i, chk in enumerate(calc.checks):
        parse_expression(chk.lhs, f"{where}: checks[{i}].lhs")
        parse_expression(chk.rhs, f"{where}: checks[{i}].rhs")
    for inc in calc.include:
        sub = load_calculations(inc)
        params = dict(sub.parameters)
        params.update(calc.parameters)
        calc = calc.model_copy(update={"parameters": params,
                                       "relations": sub.relations + calc.relations,
                                       "checks": sub.checks + calc.checks})
    return calc


def _fuel_origin(fuel: ResolvedFuel, prop: str, key: str) -> str:
    if fuel.origin == "template fuel":
        return f"template fuel {fuel.name}"
    if fuel.sources.get(prop, "").startswith("template constant"):
        return f"template constant {key}"
    return f"vehicle engine.{key}"


def resolve_parameters(calc: CalculationFile, constants: dict[str, float] | None = None,
                       vehicle: Any = None, fuel: ResolvedFuel | None = None,
                       ) -> tuple[dict[str, float], dict[str, str], dict[str, str]]:
    """Parameter values, their provenance, and the reason each missing one is missing.

    A fuel property (a parameter whose constant is ``fuel_lhv_j_per_kg`` or
    ``fuel_density_kg_per_m3``) comes from the resolved fuel (:func:`vehval.fuels.resolve_fuel`
    of the template's ``fuel:``, the constants and the vehicle; default: resolved here from
    ``constants`` and ``vehicle``).
    """
    constants = constants or {}
    if fuel is None:
        fuel = resolve_fuel(constants=constants, vehicle=vehicle)
    values, origin, missing = {}, {}, {}
    for name, spec in calc.parameters.items():
        prop = FUEL_PARAMETERS.get(spec.constant or "")
        if prop is not None:
            v = getattr(fuel, prop, None) if fuel is not None else None
            if fuel is not None and v is not None:
                values[name] = float(v)
                origin[name] = _fuel_origin(fuel, prop, str(spec.constant))
            else:
                missing[name] = ("declare the test fuel: 'fuel:' in the template (e.g. fuel: "
                                 f"diesel) or template constant '{spec.constant}'")
            continue
        if spec.constant and constants.get(spec.constant) is not None:
            values[name] = float(constants[spec.constant])
            origin[name] = f"template constant {spec.constant}"
            continue
        found = None
        for key in spec.vehicle:
            found = vehicle_value(vehicle, key) if vehicle is not None else None
            if isinstance(found, bool) or not isinstance(found, (int, float)):
                found = None
            if found is not None:
                origin[name] = f"vehicle {key}"
                break
        if found is not None:
            values[name] = float(found)
            continue
        if spec.default is not None:
            values[name] = float(spec.default)
            origin[name] = "default"
            continue
        where = []
        if spec.constant:
            where.append(f"template constant '{spec.constant}'")
        if spec.vehicle:
            where.append(f"vehicle key '{spec.vehicle[0]}'" + ("" if vehicle is not None else
                                                               " (no vehicle given)"))
        missing[name] = "set " + " or ".join(where) if where else "no source declared"
    return values, origin, missing


@dataclass
class CalcResult:
    """Outcome of :func:`compute`."""

    grid: np.ndarray
    computed: dict[str, dict] = field(default_factory=dict)      # name -> details
    not_computed: dict[str, list[str]] = field(default_factory=dict)  # output -> reasons
    parameters: dict[str, dict] = field(default_factory=dict)
    calc_set: str = ""
    checks: dict[str, dict] = field(default_factory=dict)   # name -> lhs, rhs, inputs, blame
    #: relations and checks not run: they involve a signal the architecture does not have
    not_applicable: list[str] = field(default_factory=list)
    architecture: str | None = None

    def to_dict(self) -> dict:
        return {"set": self.calc_set, "architecture": self.architecture,
                "computed": self.computed, "not_applicable": self.not_applicable,
                "not_computed": self.not_computed, "parameters": self.parameters,
                "checks": {k: {"expr": v["text"], "inputs": v["inputs"], "blame": v["blame"]}
                           for k, v in self.checks.items()}}


def choose_calc_set(test: Test, vehicle: Any = None, architecture: str | None = None) -> str:
    """The relation set of a stated ``architecture`` (its entry of
    :data:`vehval.vehicle.definition.CALC_SETS`: ``parallel_hybrid``, or ``conventional``
    for a car whose missing signals' relations are then not run); else ``power_split`` when
    the vehicle or the signals show a planetary hybrid, else ``conventional``."""
    from vehval.vehicle.definition import CALC_SETS

    if architecture is not None and architecture in CALC_SETS:
        return CALC_SETS[architecture]
    if vehicle is not None and vehicle_value(vehicle, "planetary.ring_teeth") is not None:
        return "power_split"
    for sig in test:
        if sig.name.startswith(("gen_", "mot_", "pg_")):
            return "power_split"
    return "conventional"


def _why_not(output: str, names: Any, calc: CalculationFile, pvals: dict, pmissing: dict,
             measured: dict, calc_vals: dict, calc_deps: dict) -> list[str]:
    """Why the relation giving ``output`` could not be computed, one reason per input."""
    reasons = []
    for nm in sorted(names):
        if nm == "t":
            continue
        if nm in calc.parameters and nm not in pvals:
            reasons.append(f"parameter {nm} missing ({pmissing.get(nm, '')})")
        elif nm not in calc.parameters and nm not in measured and nm not in calc_vals:
            reasons.append(f"signal {nm} missing (no measured {nm}_test and not computable)")
        elif nm in calc_vals and nm not in measured and output in calc_deps.get(nm, ()):
            reasons.append(f"{nm}_calc is itself derived from {output} (circular)")
    return reasons


def _balance_checks(calc: CalculationFile, pvals: dict, measured: dict, calc_vals: dict,
                    measured_on_grid: Any, grid: np.ndarray, result: CalcResult,
                    architecture: str | None = None) -> None:
    """Balance checks: both sides from measured (preferred) or calculated signals, on ``grid``;
    a check on a signal ``architecture`` does not have is listed as not applicable."""
    from vehval.vehicle.definition import has_signal

    for chk in calc.checks:
        if not all(has_signal(n, architecture) for text in (chk.lhs, chk.rhs)
                   for n in parse_expression(text, f"{calc.name}: check {chk.name}").names):
            result.not_applicable.append(f"check {chk.name}")
            continue
        sides, used, ok = [], {}, True
        for text in (chk.lhs, chk.rhs):
            ex = parse_expression(text, f"{calc.name}: check {chk.name}")
            var = {}
            for nm in sorted(ex.names):
                if nm in pvals:
                    var[nm] = pvals[nm]
                elif nm in measured:
                    var[nm] = measured_on_grid(nm)
                    used[nm] = measured[nm].name
                elif nm in calc_vals:
                    var[nm] = calc_vals[nm]
                    used[nm] = f"{nm}_calc"
                elif nm != "t":
                    ok = False
            if not ok:
                break
            sides.append(ex.evaluate(var, grid))
        if ok and chk.blame in measured and grid.size:
            result.checks[chk.name] = {"lhs": sides[0], "rhs": sides[1], "inputs": used,
                                       "blame": measured[chk.blame].name, "r2_min": chk.r2_min,
                                       "text": f"{chk.lhs} ≈ {chk.rhs}"}


def _measured(test: Test, exclude: set[str] | frozenset[str]) -> dict[str, Signal]:
    """Base name -> the measured signal of it the one selection rule picks, in test order."""
    reg = registry()
    measured: dict[str, Signal] = {}
    usable = [n for n in test.names if n not in exclude]
    bases: dict[str, None] = {}  # in the test's order
    for name in usable:
        try:
            p = reg.parse(name)
        except SignalError:
            continue
        if p.origin == "test":
            bases[p.base] = None
    for base in bases:
        sig = test.best(base, ("test",), kept=usable)  # the one selection rule
        if sig is not None:
            measured[base] = sig
    return measured


def compute(test: Test, vehicle: Any = None, calc: CalculationFile | str | None = None,  # noqa: C901, PLR0912, PLR0915 - one block per family of powertrain equations  # long: the relation loop with its not-computed reasons, kept in one place
            constants: dict[str, float] | None = None, *, dt: float | None = None,
            exclude: set[str] | frozenset[str] = frozenset(), add: bool = True,
            architecture: str | None = None) -> CalcResult:
    """Compute every ``*_calc`` signal the test's inputs allow.

    Parameters
    ----------
    test : Test
        Aligned test; ``<base>_calc`` signals are added to it when ``add``.
    vehicle : Vehicle, optional
        Source of parameters not in the template constants (searched by key name).
    calc : CalculationFile or str, optional
        Relation set (default chosen by :func:`choose_calc_set`).
    constants : dict, optional
        Template constants (default ``test.meta.constants``).
    dt : float, optional
        Grid step [s] (default the fastest measured sample period, at least 0.01 s).
    exclude : set of str
        Measured signals not to use as inputs (e.g. dropped by QA).
    add : bool
        Add the computed signals to ``test``.
    architecture : str, optional
        The tested car's architecture (default the vehicle's): relations and checks that
        involve a signal it does not have (:func:`vehval.vehicle.definition.has_signal`: no
        engine or fuel on a battery-electric car) are not run, listed in ``not_applicable``.
    """
    from vehval.vehicle.definition import architecture_of, has_signal

    architecture = architecture or architecture_of(vehicle)
    if calc is None:
        calc = choose_calc_set(test, vehicle, architecture)
    if isinstance(calc, str):
        calc = load_calculations(calc)
    constants = dict(test.meta.constants if constants is None else constants)
    fuel = resolve_fuel(test=test, constants=constants, vehicle=vehicle)
    pvals, porigin, pmissing = resolve_parameters(calc, constants, vehicle, fuel)
    measured = _measured(test, exclude)
    if dt is None:
        periods = [s.sample_period for s in measured.values() if np.isfinite(s.sample_period)]
        dt = max(0.01, min(periods)) if periods else 0.1
    if measured:
        t0 = min(s.time[0] for s in measured.values())
        t1 = max(s.time[-1] for s in measured.values())
        grid = t0 + dt * np.arange(int(np.floor((t1 - t0) / dt + 1e-9)) + 1)
    else:
        grid = np.zeros(0)
    result = CalcResult(grid=grid, calc_set=calc.name, architecture=architecture,
                        parameters={k: {"value": v, "from": porigin[k]} for k, v in pvals.items()}
                        | {k: {"value": None, "missing": r} for k, r in pmissing.items()})
    cache: dict[str, np.ndarray] = {}
    calc_vals: dict[str, np.ndarray] = {}
    calc_deps: dict[str, frozenset[str]] = {}

    def measured_on_grid(base: str) -> np.ndarray:
        if base not in cache:
            cache[base] = measured[base].at(grid)
        return cache[base]

    exprs = []
    for rel in calc.relations:
        ex = parse_expression(rel.expr, f"{calc.name}: {rel.output}")
        if all(has_signal(n, architecture) for n in {rel.output, *ex.names}):
            exprs.append((rel, ex))
        else:
            result.not_applicable.append(f"{rel.output}_calc")
    done: set[str] = set()
    changed = True
    while changed and grid.size:
        changed = False
        for rel, ex in exprs:
            if rel.output in done:
                continue
            var: dict[str, object] = {}
            deps: set[str] = set()
            used: dict[str, str] = {}
            ok = True
            for nm in sorted(ex.names):
                if nm in pvals:
                    var[nm] = pvals[nm]
                elif nm in calc.parameters:
                    ok = False
                elif nm == "t":
                    continue
                elif nm in measured:
                    var[nm] = measured_on_grid(nm)
                    deps.add(nm)
                    used[nm] = measured[nm].name
                elif nm in calc_vals and rel.output not in calc_deps[nm]:
                    var[nm] = calc_vals[nm]
                    deps |= calc_deps[nm] | {nm}
                    used[nm] = f"{nm}_calc"
                else:
                    ok = False
            if not ok:
                continue
            values = ex.evaluate(var, grid)
            if not np.isfinite(values).any():
                continue
            calc_vals[rel.output] = values
            calc_deps[rel.output] = frozenset(deps)
            done.add(rel.output)
            changed = True
            result.computed[f"{rel.output}_calc"] = {
                "expr": rel.expr, "equation": rel.equation, "description": rel.description,
                "steady_state": rel.steady_state,
                "inputs": used, "parameters": {n: pvals[n] for n in sorted(ex.names) if n in pvals}}
    # explain what was not computed
    for rel, ex in exprs:
        if rel.output in done:
            continue
        reasons = _why_not(rel.output, ex.names, calc, pvals, pmissing, measured, calc_vals,
                           calc_deps)
        if not reasons:
            reasons.append("inputs available but the result is NaN everywhere "
                           "(inputs do not overlap in time)")
        result.not_computed.setdefault(f"{rel.output}_calc", []).append(f"{rel.expr}: " + "; ".join(reasons))
    _balance_checks(calc, pvals, measured, calc_vals, measured_on_grid, grid, result,
                    architecture)
    if add:
        for name in result.computed:
            sig = Signal.standard(name, grid, calc_vals[name[:-5]], source="calc",
                                  notes=[f"computed: {result.computed[name]['expr']}"])
            test.add(sig, replace_existing=True)
    return result
