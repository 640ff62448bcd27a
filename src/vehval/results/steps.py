"""The named steps of the results stage, each returning a small typed object.

:func:`vehval.results.compute.compute_results` composes them in this order:

1. :func:`fuel_of_test` - the fuel of the test (:class:`vehval.fuels.Fuel` or None);
2. :func:`select_inputs` - the signals the figures rest on (:class:`Inputs`);
3. :func:`plan_phases` - phases, their source and the scopes (:class:`PhasePlan`);
4. :func:`input_roles` and :func:`conditions_of_test` - what the results record of both;
5. :func:`accuracies` - sensor accuracies and uncertain parameters (:class:`Accuracies`);
6. :func:`integrate_scopes` - the integrals of every signal per scope (:class:`ScopeIntegrals`);
7. :class:`ResultsModel` - the figures of every scope and composite from parameter errors,
   propagated by :func:`propagate_results` (:class:`Propagated`);
8. :func:`drive_quality_by_scope` and :func:`soc_step` - SAE J2951 and SAE J1711.

Every quantity is SI (s, m, kg, J, m^3); display units are the report's business.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

from vehval.conditions import cold_start
from vehval.display import format_delta
from vehval.fuels import (
    Fuel,
    ResolvedFuel,
    co2_kg,
    fuel_consumption_l_per_100km,
    fuel_economy_mpg,
    fuel_energy_j,
    fuel_properties,
    fuel_volume_m3,
    l_per_100km_from_volume_per_distance,
    mpg_from_volume_per_distance,
    resolve_fuel,
)
from vehval.integrals import battery_power, window_integral
from vehval.qa.findings import Finding, Kind, Severity
from vehval.results.composites import Composite, weighted_per_distance
from vehval.results.drive_quality import RMSSE_TOLERANCE_MPS, drive_quality, iwr_reading
from vehval.results.phase_check import check_phases
from vehval.results.phases import (
    Phase,
    match_cycle,
    phases_from_channel,
    phases_from_cycle,
    reference_speed,
)
from vehval.results.soc import soc_correction
from vehval.results.uncertainty import ChannelAccuracy, Parameter, channel_accuracy, propagate
from vehval.test import Signal, Test
from vehval.units import is_volume_rate

#: Cell temperature [degC] at or above which a test runs with the A/C on (the hot-ambient
#: tests: SC03 at 35 degC, hot UDDS/FTP with A/C max); below it the A/C is off.
AC_HOT_CELL_C = 30.0
#: Name of the whole-test scope.
SCOPE_TEST = "test"
_CHANNEL = "phase channel "

Segments = list[tuple[float, float]]


def finding(message: str, signal: str = "", severity: Severity = Severity.WARNING,
            kind: Kind = Kind.RESULTS, **numbers: Any) -> Finding:
    """A finding of the results stage (no time span)."""
    return Finding(signal=signal, kind=kind, start_s=float("nan"), end_s=float("nan"),
                   severity=severity, message=message, numbers=numbers)


# ----------------------------------------------------------------------------- 1. fuel
def fuel_of_test(test: Test, fuel: Any, notes: list[str]) -> Fuel | None:
    """The test fuel: the one given, else the one :func:`resolve_fuel` finds; None without."""
    if fuel is None:
        fuel = resolve_fuel(test=test)
    if isinstance(fuel, ResolvedFuel):
        if fuel.origin == "template constants":
            notes.append("fuel: properties from the template constants (fuel_density_kg_per_m3, "
                         "fuel_lhv_j_per_kg); declare 'fuel:' for CO2 and the property sources")
        fuel = fuel.fuel
    return fuel if isinstance(fuel, Fuel) else fuel_properties(fuel)


# ----------------------------------------------------------------------------- 2. inputs
class Inputs(NamedTuple):
    """The measured signals the figures rest on (None: absent)."""

    kept: list[str] | None
    speed: Signal | None
    fuel: Signal | None
    co2: Signal | None
    pwr: Signal | None
    volt: Signal | None
    curr: Signal | None

    def used(self) -> list[Signal]:
        """The signals present, in the order speed, fuel, CO2, power, voltage, current."""
        return [s for s in (self.speed, self.fuel, self.co2, self.pwr, self.volt, self.curr)
                if s is not None]


def _registry_bases() -> set[str]:
    from vehval.nomenclature import registry
    return set(registry().specs)


def select_inputs(test: Test, selected: dict[str, str] | None, fuel_obj: Fuel | None,
                  findings: list[Finding]) -> Inputs:
    """The one selection rule (:meth:`Test.best`), restricted to QA's choice when given.

    Battery voltage and current are used only without a battery power signal, and only
    as a pair.
    """
    kept = None if selected is None else list(selected.values())
    speed = test.best("veh_spd", ("test",), kept=kept)
    fuel_sig = test.best("fuel_rate", ("test",), kept=kept)
    co2_sig = (test.best("co2_rate", ("test",), kept=kept)
               if "co2_rate" in _registry_bases() else None)
    pwr = test.best("ess_pwr", ("test",), kept=kept)
    volt = curr = None
    if pwr is None:
        volt = test.best("ess_volt", ("test",), kept=kept)
        curr = test.best("ess_curr", ("test",), kept=kept)
        if volt is None or curr is None:
            volt = curr = None
    if fuel_sig is not None and fuel_obj is None:
        findings.append(finding(
            f"fuel mass flow '{fuel_sig.name}' but no fuel declared: no volume-based result "
            "(mpg, L/100 km), fuel energy or CO2; declare 'fuel:' in the template "
            "(e.g. fuel: diesel)", fuel_sig.name))
    return Inputs(kept, speed, fuel_sig, co2_sig, pwr, volt, curr)


# ----------------------------------------------------------------------------- 3. phases
@dataclass(frozen=True)
class PhasePlan:
    """The phases of the test and the scopes the figures are given for.

    ``scopes`` are the phase names then ``test``; ``segments`` the record-time spans [s] of
    each scope, in the same order.
    """

    phases: list[Phase]
    source: str
    match: Any
    scopes: list[str]
    segments: list[Segments]

    @property
    def channel(self) -> str | None:
        """The phase channel the phases come from, or None."""
        return self.source.removeprefix(_CHANNEL) if self.source.startswith(_CHANNEL) else None


def _phases(test: Test, speed: Signal | None, phase_channel: str | None,
            findings: list[Finding]) -> tuple[list[Phase], str, Any]:
    match = match_cycle(speed, test.meta.cycle, getattr(test.meta, "cycle_match", None),
                        test.meta.offsets_s)
    name = phase_channel or ("test_phase_test" if "test_phase_test" in test else None)
    if name is not None:
        if name not in test:
            findings.append(finding(f"phase channel '{name}' is not in the test: phases "
                                    "taken from the identified cycle", name))
        else:
            phases = phases_from_channel(test[name], match)
            if phases:
                return phases, f"{_CHANNEL}{name}", match
            findings.append(finding(
                f"phase channel '{name}' holds no phase (no positive whole number): phases "
                "taken from the identified cycle instead; check the channel mapping", name))
    if match is not None:
        return phases_from_cycle(match), f"cycle {match.cycle} part boundaries", match
    return [], "whole test only (no phase channel, no cycle with known phases)", None


def plan_phases(test: Test, speed: Signal | None, phase_channel: str | None,
                findings: list[Finding]) -> PhasePlan:
    """Phases from the phase channel, else from the identified cycle; the bags of a
    channel are checked against the cycle's table."""
    phases, source, match = _phases(test, speed, phase_channel, findings)
    if source.startswith(_CHANNEL):
        findings += check_phases(phases, match, speed, source.removeprefix(_CHANNEL))
    t0, t1 = test.span()
    return PhasePlan(phases, source, match, [p.name for p in phases] + [SCOPE_TEST],
                     [p.segments for p in phases] + [[(t0, t1)]])


# ----------------------------------------------------------------------------- 4. records
def input_roles(test: Test, inputs: Inputs, plan: PhasePlan,
                phase_channel: str | None) -> dict[str, list[str]]:
    """Role (speed, fuel, co2, ess, phase) -> the signals the figures were computed from."""
    roles = {role: [s.name] for role, s in (("speed", inputs.speed), ("fuel", inputs.fuel),
                                            ("co2", inputs.co2)) if s is not None}
    ess = [s.name for s in (inputs.pwr, inputs.volt, inputs.curr) if s is not None]
    if ess:
        roles["ess"] = ess
    if plan.channel is not None:
        roles["phase"] = [plan.channel]
    else:
        # a mapped phase channel that was set aside still vouches for the phases: a QA error
        # on it (a channel that is no phase counter) withholds the phase figures, which then
        # rest on the cycle's boundaries instead of the laboratory's bags
        declared = phase_channel or ("test_phase_test" if "test_phase_test" in test else None)
        if declared is not None and declared in test:
            roles["phase"] = [declared]
    return roles


def _ac(cycle: str, cell_c: float | None) -> tuple[str | None, str | None]:
    """A/C ``on``/``off`` (None: unknown) and its basis, from the cycle and the cell."""
    if cycle.lower().startswith("sc03"):
        return "on", "SC03 (40 CFR 86.160: run with the A/C on)"
    if cell_c is None:
        return None, None
    if cell_c >= AC_HOT_CELL_C:
        return "on", f"cell {cell_c:.1f} degC >= {AC_HOT_CELL_C:g} degC (hot-ambient test)"
    return "off", f"cell {cell_c:.1f} degC < {AC_HOT_CELL_C:g} degC, not an SC03 test"


def conditions_of_test(test: Test, kept: list[str] | None) -> dict[str, Any]:
    """Cell temperature [degC], cold or hot start (and its basis), A/C on or off."""
    out: dict[str, Any] = {"cell_temp_c": None, "start": None, "start_basis": None}
    amb = test.best("amb_temp", ("test",), kept=kept)
    if amb is not None and np.isfinite(amb.values).any():
        out["cell_temp_c"] = round(float(np.nanmean(amb.values)), 2)
    cool = test.best("eng_temp_coolant", ("test",), kept=kept)
    if cool is not None and out["cell_temp_c"] is not None:
        v = cool.values[np.isfinite(cool.values)]
        if v.size:
            c0 = float(np.median(v[: max(1, min(v.size, 20))]))
            cold, out["start_basis"] = cold_start(c0, out["cell_temp_c"])
            out["start"] = "cold" if cold else "hot"
    out["ac"], out["ac_basis"] = _ac(test.meta.cycle or "", out["cell_temp_c"])
    return out


# ----------------------------------------------------------------------------- 5. accuracy
class Accuracies(NamedTuple):
    """Accuracy of each used channel and the uncertain parameters they and the fuel give."""

    accuracy: dict[str, ChannelAccuracy]
    parameters: list[Parameter]


def declared_accuracy(test: Test, accuracy: dict[str, Any] | None,
                      findings: list[Finding]) -> dict[str, Any]:
    """The template's accuracies; one finding per channel the test does not hold."""
    accuracy = dict(accuracy or {})
    for name in accuracy:
        if name not in test:
            findings.append(finding(f"accuracy declared for '{name}', which the test does "
                                    "not hold: not used", name))
    return accuracy


def accuracies(inputs: Inputs, accuracy: dict[str, Any], fuel_obj: Fuel | None) -> Accuracies:
    """Channel accuracies of the used signals, and the parameters to propagate (theirs and
    the fuel properties' with a declared uncertainty)."""
    acc = {s.name: channel_accuracy(s.name, accuracy.get(s.name)) for s in inputs.used()}
    params = [p for a in acc.values() for p in a.parameters()]
    if fuel_obj is not None:
        for key in ("density_kg_per_m3", "lhv_j_per_kg", "carbon_mass_fraction"):
            lim = fuel_obj.uncertainty.get(key, 0.0)
            if lim > 0 and getattr(fuel_obj, key) is not None:
                params.append(Parameter(f"fuel {key}", lim, "property"))
    return Accuracies(acc, params)


# ----------------------------------------------------------------------------- 6. integrals
class _Integrator:
    """Integrals of a signal over record-time segments (:func:`window_integral`)."""

    def __init__(self, time: np.ndarray, values: np.ndarray) -> None:
        ok = np.isfinite(time) & np.isfinite(values)
        self.t, self.v = time[ok], values[ok]

    def integral(self, segments: Segments) -> float:
        return window_integral(self.t, self.v, segments)

    def covered(self, segments: Segments) -> float:
        if self.t.size < 2:
            return 0.0
        t0, t1 = self.t[0], self.t[-1]
        return float(sum(max(0.0, min(b, t1) - max(a, t0)) for a, b in segments))

    def extreme(self, segments: Segments) -> float:
        vals = [self.v[(self.t >= a) & (self.t <= b)] for a, b in segments]
        vals = [v for v in vals if v.size]
        return float(max(v.max() for v in vals)) if vals else float("nan")


#: Per scope: the integral of a signal [unit·s] and the time its samples cover [s].
Base = tuple[np.ndarray, np.ndarray]


@dataclass(frozen=True)
class ScopeIntegrals:
    """The integrals each figure is linear in, per scope (None: signal absent).

    ``vi`` is (U x I, U, I) when the battery is measured by voltage and current.
    """

    duration: np.ndarray
    speed: Base | None
    fuel: Base | None
    co2: Base | None
    vmax: np.ndarray | None
    pwr: Base | None
    vi: tuple[Base | None, Base | None, Base | None] | None


def integrate_scopes(inputs: Inputs, plan: PhasePlan) -> ScopeIntegrals:
    """Integral and coverage of every input over every scope."""
    segs = plan.segments

    def base(sig: Signal | None) -> Base | None:
        if sig is None:
            return None
        itg = _Integrator(sig.time, sig.values)
        return (np.array([itg.integral(s) for s in segs]), np.array([itg.covered(s) for s in segs]))

    speed, volt, curr = inputs.speed, inputs.volt, inputs.curr
    vmax = (np.array([_Integrator(speed.time, speed.values).extreme(s) for s in segs])
            if speed is not None else None)
    vi = None
    if volt is not None and curr is not None:
        u = volt.at(curr.time)
        p = Signal(name="ess_pwr_calc", time=curr.time, values=battery_power(u, curr.values),
                   unit="W")
        vi = (base(p), base(Signal(name="ess_volt_calc", time=curr.time, values=u, unit="V")),
              base(curr))
    return ScopeIntegrals(np.array([sum(b - a for a, b in s) for s in segs]), base(speed),
                          base(inputs.fuel), base(inputs.co2), vmax, base(inputs.pwr), vi)


# ----------------------------------------------------------------------------- 7. model
def _error(theta: dict[str, np.ndarray], sig: Signal | None, kind: str) -> np.ndarray:
    """Gain (``kind='gain'``) or offset error of a channel, one row per draw."""
    n = len(next(iter(theta.values())))
    key = f"{sig.name} {'reading' if kind == 'gain' else 'offset'}" if sig else ""
    v = theta.get(key)
    return np.zeros((n, 1)) if v is None else v[:, None]


def _property_error(theta: dict[str, np.ndarray], name: str) -> np.ndarray:
    n = len(next(iter(theta.values())))
    v = theta.get(f"fuel {name}")
    return np.zeros((n, 1)) if v is None else v[:, None]


@dataclass
class ResultsModel:
    """Every figure (``scope|quantity``) from the parameter errors ``theta``.

    Each figure is linear in the scope integrals, so a draw costs no new integration.
    """

    inputs: Inputs
    integrals: ScopeIntegrals
    fuel: Fuel | None
    scopes: list[str]
    composites: list[Composite]
    hot: dict[str, float] | None

    def __call__(self, theta: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        if not theta:
            theta = {"__none__": np.zeros(1)}
        q, props = self._scope_figures(theta)
        out = {f"{sc}|{k}": v[:, i] for k, v in q.items() for i, sc in enumerate(self.scopes)}
        for comp in self.composites:
            out.update(self._composite_figures(comp, q, props))
        return out

    def _prop(self, theta: dict[str, np.ndarray], name: str) -> np.ndarray | None:
        fo = self.fuel
        val = getattr(fo, name) if fo is not None else None
        return val + _property_error(theta, name) if val else None

    def _scope_figures(self, theta: dict[str, np.ndarray]) -> tuple[dict[str, np.ndarray], dict]:
        n = len(next(iter(theta.values())))
        ints, sel = self.integrals, self.inputs
        nan = np.full((n, len(self.scopes)), np.nan)

        def lin(b: Base | None, sig: Signal | None) -> np.ndarray:
            if b is None:
                return nan
            return (1.0 + _error(theta, sig, "gain")) * b[0] + _error(theta, sig, "offset") * b[1]

        q: dict[str, np.ndarray] = {"duration_s": np.broadcast_to(ints.duration, (n, len(self.scopes)))}
        dist = lin(ints.speed, sel.speed)
        q["distance_m"] = dist
        q["mean_speed_mps"] = dist / ints.duration
        q["max_speed_mps"] = (nan if ints.vmax is None else (1.0 + _error(theta, sel.speed, "gain"))
                              * ints.vmax + _error(theta, sel.speed, "offset"))
        rho, lhv = self._prop(theta, "density_kg_per_m3"), self._prop(theta, "lhv_j_per_kg")
        # a volume meter measures the volume (the imported mass over the density it was
        # imported with): its mass is that volume times the density drawn
        scale = (fuel_volume_m3(1.0, self.fuel.density_kg_per_m3) * rho
                 if rho is not None and self.fuel is not None and sel.fuel is not None
                 and is_volume_rate(sel.fuel.raw_unit) else 1.0)
        mass = lin(ints.fuel, sel.fuel) * scale
        q["fuel_mass_kg"] = mass
        cf = self._prop(theta, "carbon_mass_fraction")
        vol = fuel_volume_m3(mass, rho) if rho is not None else nan
        q["fuel_volume_m3"] = vol
        q["fuel_economy_mpg"] = fuel_economy_mpg(dist, vol)
        q["fuel_consumption_l_per_100km"] = fuel_consumption_l_per_100km(vol, dist)
        q["fuel_energy_j"] = fuel_energy_j(mass, lhv) if lhv is not None else nan
        with np.errstate(divide="ignore", invalid="ignore"):
            if ints.co2 is not None:
                co2 = lin(ints.co2, sel.co2)
            else:
                co2 = co2_kg(mass, cf) if cf is not None else nan
            q["co2_kg"] = co2
            q["co2_g_per_km"] = np.where(dist > 0, co2 / dist * 1e6, np.nan)
        q["ess_energy_net_j"] = self._battery(theta, lin, nan)
        return q, {"n": n, "rho": rho, "lhv": lhv, "cf": cf,
                   "scale": scale[:, 0] if isinstance(scale, np.ndarray) else np.ones(n)}

    def _battery(self, theta: dict[str, np.ndarray], lin: Any, nan: np.ndarray) -> np.ndarray:
        """Net battery energy [J]: from the power, else from voltage and current."""
        ints, sel = self.integrals, self.inputs
        if ints.pwr is not None:
            return lin(ints.pwr, sel.pwr)
        if ints.vi is not None and all(b is not None for b in ints.vi):
            (s_vi, tt), (s_v, _), (s_i, _) = ints.vi  # type: ignore[misc]  # checked above
            gv, ov = 1.0 + _error(theta, sel.volt, "gain"), _error(theta, sel.volt, "offset")
            gi, oi = 1.0 + _error(theta, sel.curr, "gain"), _error(theta, sel.curr, "offset")
            return gv * gi * s_vi + gv * oi * s_v + ov * gi * s_i + ov * oi * tt
        return nan

    def _composite_figures(self, comp: Composite, q: dict[str, np.ndarray],
                           props: dict) -> dict[str, np.ndarray]:
        """The weighted figures of one regulatory composite."""
        n, rho, lhv, cf = props["n"], props["rho"], props["lhv"], props["cf"]
        idx = {sc: i for i, sc in enumerate(self.scopes)}
        mass, dist, hot = q["fuel_mass_kg"], q["distance_m"], self.hot
        fuel_terms, co2_terms = [], []
        for w, names in comp.groups:
            fm, dd, cc = np.zeros(n), np.zeros(n), np.zeros(n)
            for nm in names:
                if nm == "__hot_bag1__":
                    assert hot is not None, "a hot bag 1 composite needs hot_start_bag1"
                    hot_mass = hot["fuel_mass_kg"] * props["scale"]
                    fm += hot_mass
                    dd += hot["distance_m"]
                    cc += hot.get("co2_kg", np.nan) if self.integrals.co2 is not None else (
                        co2_kg(hot_mass, cf[:, 0]) if cf is not None else np.nan)
                    continue
                i = idx[nm]
                fm += mass[:, i]
                dd += dist[:, i]
                cc += q["co2_kg"][:, i]
            fuel_terms.append((w, fm, dd))
            co2_terms.append((w, cc, dd))
        fpd = np.zeros(n) + weighted_per_distance(fuel_terms)
        cpd = np.zeros(n) + weighted_per_distance(co2_terms)
        pre = f"{comp.name}|"
        vpd = fuel_volume_m3(fpd, rho[:, 0]) if rho is not None else np.full(n, np.nan)
        return {pre + "fuel_per_distance_kg_per_m": fpd,
                pre + "fuel_economy_mpg": mpg_from_volume_per_distance(vpd),
                pre + "fuel_consumption_l_per_100km": l_per_100km_from_volume_per_distance(vpd),
                pre + "co2_g_per_km": cpd * 1e6,
                pre + "fuel_energy_per_distance_j_per_m": (
                    fuel_energy_j(fpd, lhv[:, 0]) if lhv is not None else np.full(n, np.nan))}


class Propagated(NamedTuple):
    """Nominal figures and their uncertainty per scope, and the method that gave U."""

    values: dict[str, dict[str, float | None]]
    uncertainty: dict[str, dict[str, dict]]
    method: str


def _round_unc(d: dict) -> dict:
    out = dict(d)
    for k in ("u", "U"):
        out[k] = float(f"{out[k]:.6g}")
    if "interval_95" in out:
        out["interval_95"] = [float(f"{x:.8g}") for x in out["interval_95"]]
    return out


def propagate_results(model: ResultsModel, params: list[Parameter], *, method: str, draws: int,
                      seed: int, notes: list[str]) -> Propagated:
    """Run the model through :func:`vehval.results.uncertainty.propagate`."""
    nominal, unc = propagate(model, params, method=method, draws=draws, seed=seed)
    # the method that gave the stated U: first order when no parameter was drawn
    if method == "monte_carlo" and not any(u.get("method") == "monte_carlo" for u in unc.values()):
        method = "first_order"
        notes.append("uncertainty: first-order propagation: Monte Carlo asked for, but no "
                     "parameter has an uncertainty to draw")
    values: dict[str, dict[str, float | None]] = {}
    uncertainty: dict[str, dict[str, dict]] = {}
    for key, v in nominal.items():
        scope, qty = key.split("|", 1)
        values.setdefault(scope, {})[qty] = v if math.isfinite(v) else None
        if key in unc:
            uncertainty.setdefault(scope, {})[qty] = _round_unc(unc[key])
    return Propagated(values, uncertainty, method)


# ----------------------------------------------------------------------------- 8. J2951, J1711
def drive_quality_by_scope(test: Test, speed: Signal | None, plan: PhasePlan,
                           findings: list[Finding], notes: list[str]) -> dict[str, dict | None]:
    """SAE J2951 drive-quality metrics per scope (empty without a reference trace)."""
    dq: dict[str, dict | None] = {}
    if speed is None or plan.match is None:
        notes.append("drive quality: no reference trace (the cycle was not identified or has "
                     "no known phases)")
        return dq
    c = test.meta.constants or {}
    road = None
    if all(c.get(k) is not None for k in ("road_load_a_n", "road_load_b_n_per_mps",
                                          "road_load_c_n_per_mps2")):
        road = (c["road_load_a_n"], c["road_load_b_n_per_mps"], c["road_load_c_n_per_mps2"])
    ref = reference_speed(speed.time, plan.match)
    all_segs = [s for p in plan.phases for s in p.segments]
    for sc, sg in zip(plan.scopes, [p.segments for p in plan.phases] + [all_segs]):
        res = drive_quality(speed.time, speed.values, ref, mass_kg=c.get("test_mass_kg"),
                            road_load=road, segments=sg)
        dq[sc] = res.to_dict() if res is not None else None
        if res is not None and res.within_tolerance is False and sc != SCOPE_TEST:
            findings.append(finding(
                f"drive quality of {sc} outside the SAE J2951 tolerances applied by "
                f"40 CFR 1066.425(j): IWR {res.iwr_pct:+.2f} % (allowed -2.0..+4.0), "
                f"RMSSE {format_delta(res.rmsse_mps or 0.0, 'm/s', digits=3)} (allowed "
                f"{format_delta(RMSSE_TOLERANCE_MPS, 'm/s', digits=3)})"
                + (f"; {why}" if (why := iwr_reading(res)) else ""), speed.name,
                kind=Kind.DRIVE_QUALITY, iwr_pct=res.iwr_pct, rmsse_mps=res.rmsse_mps,
                iwr_1hz_pct=res.iwr_1hz_pct,
                phase=sc))
    if road is None:
        notes.append("drive quality: ER and EER need test_mass_kg and road_load_a/b/c "
                     "constants in the template")
    return dq


def soc_step(values: dict[str, dict[str, float | None]], plan: PhasePlan,
             composites: list[Composite], inputs: Inputs, soc_factor: float | None,
             findings: list[Finding]) -> dict[str, Any]:
    """SAE J1711 SOC correction (:func:`vehval.results.soc.soc_correction`); a finding when
    the battery's change is beyond tolerance and left uncorrected."""
    soc = soc_correction(values, plan.scopes, composites=[c.name for c in composites],
                         battery=inputs.pwr is not None or inputs.volt is not None,
                         factor=soc_factor)
    if soc.get("status") == "beyond_tolerance_uncorrected":
        battery_sig = inputs.pwr or inputs.curr
        findings.append(finding(soc["message"], battery_sig.name if battery_sig else ""))
    return soc
