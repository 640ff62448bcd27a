"""The results stage: per-phase, whole-test and regulatory results with their uncertainty.

:func:`compute_results` takes a test (after QA, or straight from import) and returns a
:class:`TestResults` whose :meth:`TestResults.to_dict` is ``results.json`` (contract in
docs/results.md). Data stay SI; display units are the report's business.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

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
from vehval.qa.findings import Finding, Kind, Severity
from vehval.results.composites import Composite, composites_for, substitute_direction, weighted_per_distance
from vehval.results.drive_quality import RMSSE_TOLERANCE_MPS, drive_quality, iwr_reading
from vehval.results.gate import headline
from vehval.results.phase_check import check_phases
from vehval.results.phases import (
    Phase,
    match_cycle,
    phases_from_channel,
    phases_from_cycle,
    reference_speed,
)
from vehval.results.soc import soc_correction
from vehval.results.uncertainty import (
    ChannelAccuracy,
    Parameter,
    channel_accuracy,
    propagate,
)
from vehval.test import Signal, Test

__all__ = [
    "QUANTITIES",
    "RESULTS_VERSION",
    "TestResults",
    "compute_results",
    "results_from_template",
]

#: Version of the results.json contract.
RESULTS_VERSION = 1
#: Quantity key -> SI unit, for every phase and the whole test.
QUANTITIES: dict[str, str] = {
    "duration_s": "s", "distance_m": "m", "mean_speed_mps": "m/s", "max_speed_mps": "m/s",
    "fuel_mass_kg": "kg", "fuel_volume_m3": "m^3", "fuel_economy_mpg": "mile/US gal",
    "fuel_consumption_l_per_100km": "L/100 km", "fuel_energy_j": "J", "co2_kg": "kg",
    "co2_g_per_km": "g/km", "ess_energy_net_j": "J",
}
#: Composite quantity key -> unit.
COMPOSITE_QUANTITIES = {"fuel_economy_mpg": "mile/US gal",
                        "fuel_consumption_l_per_100km": "L/100 km",
                        "fuel_per_distance_kg_per_m": "kg/m", "co2_g_per_km": "g/km",
                        "fuel_energy_per_distance_j_per_m": "J/m"}
#: Cell temperature [degC] at or above which a test runs with the A/C on (the hot-ambient
#: tests: SC03 at 35 degC, hot UDDS/FTP with A/C max); below it the A/C is off.
AC_HOT_CELL_C = 30.0
_SCOPE_TEST = "test"


class _Integrator:
    """Integrals of a signal over record-time segments from its cumulative trapezoid."""

    def __init__(self, time: np.ndarray, values: np.ndarray) -> None:
        ok = np.isfinite(time) & np.isfinite(values)
        self.t, self.v = time[ok], values[ok]
        if self.t.size < 2:
            self.c = np.zeros(self.t.size)
            return
        self.c = np.concatenate([[0.0], np.cumsum(0.5 * (self.v[1:] + self.v[:-1]) * np.diff(self.t))])

    def integral(self, segments: list[tuple[float, float]]) -> float:
        if self.t.size < 2:
            return float("nan")
        return float(sum(np.interp(b, self.t, self.c) - np.interp(a, self.t, self.c)
                         for a, b in segments))

    def covered(self, segments: list[tuple[float, float]]) -> float:
        if self.t.size < 2:
            return 0.0
        t0, t1 = self.t[0], self.t[-1]
        return float(sum(max(0.0, min(b, t1) - max(a, t0)) for a, b in segments))

    def extreme(self, segments: list[tuple[float, float]]) -> float:
        vals = [self.v[(self.t >= a) & (self.t <= b)] for a, b in segments]
        vals = [v for v in vals if v.size]
        return float(max(v.max() for v in vals)) if vals else float("nan")


@dataclass
class TestResults:
    """Results of one test (the content of ``results.json``)."""

    test_id: str
    cycle: str
    fuel: Fuel | None
    phase_source: str
    phases: list[Phase]
    values: dict[str, dict[str, float | None]]
    uncertainty: dict[str, dict[str, dict]]
    composites: list[Composite]
    drive_quality: dict[str, dict | None]
    soc: dict[str, Any]
    accuracy: dict[str, ChannelAccuracy]
    parameters: list[Parameter]
    conditions: dict[str, Any]
    method: str
    draws: int | None = None
    findings: list[Finding] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    #: Role (speed, fuel, co2, ess, phase) -> the signals the figures were computed from.
    inputs: dict[str, list[str]] = field(default_factory=dict)
    #: Scope -> withheld entry (:func:`vehval.results.gate.apply_gate`).
    withheld: dict[str, dict] = field(default_factory=dict)
    forced: bool = False

    def value(self, scope: str, quantity: str) -> float | None:
        """A result value [SI] of a scope (``test``, a phase name or a composite name)."""
        return self.values.get(scope, {}).get(quantity)

    def expanded(self, scope: str, quantity: str) -> float | None:
        """Its expanded uncertainty U (k = 2), same unit, or None."""
        u = self.uncertainty.get(scope, {}).get(quantity)
        return None if u is None else u["U"]

    def _block(self, scope: str) -> dict:
        return {"values": self.values.get(scope, {}),
                "uncertainty": self.uncertainty.get(scope, {}),
                "drive_quality": self.drive_quality.get(scope),
                "withheld": self.withheld.get(scope)}

    def headline(self) -> dict[str, Any]:
        """The regulatory figure of the test's cycle (:func:`vehval.results.gate.headline`)."""
        return headline(self)

    def to_dict(self) -> dict[str, Any]:
        return _clean({
            "results_version": RESULTS_VERSION,
            "test": {"id": self.test_id, "cycle": self.cycle or None},
            "fuel": self.fuel.to_dict() if self.fuel else None,
            "conditions": self.conditions,
            "phase_source": self.phase_source,
            "phases": [dict(p.to_dict(), **self._block(p.name)) for p in self.phases],
            "test_total": self._block(_SCOPE_TEST),
            "composites": [dict(c.to_dict(), values=self.values.get(c.name, {}),
                                uncertainty=self.uncertainty.get(c.name, {}),
                                withheld=self.withheld.get(c.name))
                           for c in self.composites],
            "headline": self.headline(),
            "withheld_count": len(self.withheld),
            "forced": self.forced,
            "inputs": {k: list(v) for k, v in self.inputs.items()},
            "soc_correction": self.soc,
            "uncertainty": {"method": self.method, "k": 2, "draws": self.draws,
                            "accuracy": {k: a.to_dict() for k, a in self.accuracy.items()},
                            "parameters": [{"name": p.name, "limit": p.limit, "kind": p.kind,
                                            "assumed": p.assumed} for p in self.parameters]},
            "units": {**QUANTITIES, **COMPOSITE_QUANTITIES},
            "findings": [f.to_dict() for f in self.findings],
            "notes": list(self.notes),
        })


def _clean(x: Any) -> Any:
    if isinstance(x, dict):
        return {str(k): _clean(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_clean(v) for v in x]
    if isinstance(x, (float, np.floating)):
        v = float(x)
        return v if math.isfinite(v) else None
    if isinstance(x, np.integer):
        return int(x)
    return x


def _ac(cycle: str, cell_c: float | None) -> tuple[str | None, str | None]:
    """A/C ``on``/``off`` (None: unknown) and its basis, from the cycle and the cell."""
    if cycle.lower().startswith("sc03"):
        return "on", "SC03 (40 CFR 86.160: run with the A/C on)"
    if cell_c is None:
        return None, None
    if cell_c >= AC_HOT_CELL_C:
        return "on", f"cell {cell_c:.1f} degC >= {AC_HOT_CELL_C:g} degC (hot-ambient test)"
    return "off", f"cell {cell_c:.1f} degC < {AC_HOT_CELL_C:g} degC, not an SC03 test"


def _conditions(test: Test, kept: list[str] | None) -> dict[str, Any]:
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


def _finding(message: str, signal: str = "", severity: Severity = Severity.WARNING,
             kind: Kind = Kind.RESULTS, **numbers: Any) -> Finding:
    return Finding(signal=signal, kind=kind, start_s=float("nan"), end_s=float("nan"),
                   severity=severity, message=message, numbers=numbers)


def _phases(test: Test, speed: Signal | None, phase_channel: str | None,
            findings: list[Finding]) -> tuple[list[Phase], str, Any]:
    match = match_cycle(speed, test.meta.cycle, getattr(test.meta, "cycle_match", None),
                        test.meta.offsets_s)
    name = phase_channel or ("test_phase_test" if "test_phase_test" in test else None)
    if name is not None:
        if name not in test:
            findings.append(_finding(f"phase channel '{name}' is not in the test: phases "
                                     "taken from the identified cycle", name))
        else:
            phases = phases_from_channel(test[name], match)
            if phases:
                return phases, f"phase channel {name}", match
            findings.append(_finding(
                f"phase channel '{name}' holds no phase (no positive whole number): phases "
                "taken from the identified cycle instead; check the channel mapping", name))
    if match is not None:
        return phases_from_cycle(match), f"cycle {match.cycle} part boundaries", match
    return [], "whole test only (no phase channel, no cycle with known phases)", None


def compute_results(test: Test, *, fuel: Any = None, accuracy: dict[str, Any] | None = None,
                    phase_channel: str | None = None, selected: dict[str, str] | None = None,
                    method: str = "first_order", draws: int = 1000, seed: int = 0,
                    hot_start_bag1: dict[str, float] | None = None,
                    soc_factor: float | None = None) -> TestResults:
    """Results of a test per phase, for the whole test and as regulatory composites.

    Parameters
    ----------
    test : Test
        Imported (and preferably QA-validated) test, SI signals.
    fuel : str, dict, FuelSpec, Fuel or ResolvedFuel, optional
        The test fuel; default the fuel :func:`vehval.fuels.resolve_fuel` finds for the test
        (the template ``fuel:`` kept at import, else the constants
        ``fuel_density_kg_per_m3`` / ``fuel_lhv_j_per_kg``). Without one, no volume, energy
        or carbon-based result is given and a mass-flow fuel channel gets a warning finding.
    accuracy : dict, optional
        Signal name -> ``AccuracySpec`` (template ``accuracy:``).
    phase_channel : str, optional
        Signal numbering the phases (default ``test_phase_test`` when present).
    selected : dict, optional
        Base name -> measured signal QA's selection kept; when given, only those measured
        signals are used. Every signal is chosen by :meth:`vehval.test.Test.best`.
    method : {'first_order', 'monte_carlo'}
        Uncertainty propagation.
    draws, seed : int
        Monte Carlo draws and seed.
    hot_start_bag1 : dict, optional
        ``fuel_mass_kg`` [kg], ``distance_m`` [m] (and ``co2_kg``) of a hot-start UDDS
        bag 1, standing in for the FTP bag 3 of a cold-start UDDS.
    soc_factor : float, optional
        Charge-balance factor [J fuel per J battery] for the SAE J1711 correction.

    Returns
    -------
    TestResults
    """
    findings: list[Finding] = []
    notes: list[str] = []
    if fuel is None:
        fuel = resolve_fuel(test=test)
    if isinstance(fuel, ResolvedFuel):
        if fuel.origin == "template constants":
            notes.append("fuel: properties from the template constants (fuel_density_kg_per_m3, "
                         "fuel_lhv_j_per_kg); declare 'fuel:' for CO2 and the property sources")
        fuel = fuel.fuel
    fuel_obj = fuel if isinstance(fuel, Fuel) else fuel_properties(fuel)
    accuracy = dict(accuracy or {})
    for name in accuracy:
        if name not in test:
            findings.append(_finding(f"accuracy declared for '{name}', which the test does "
                                     "not hold: not used", name))
    # the one selection rule (Test.best), restricted to QA's choice when given
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
        findings.append(_finding(
            f"fuel mass flow '{fuel_sig.name}' but no fuel declared: no volume-based result "
            "(mpg, L/100 km), fuel energy or CO2; declare 'fuel:' in the template "
            "(e.g. fuel: diesel)", fuel_sig.name))
    phases, phase_source, match = _phases(test, speed, phase_channel, findings)
    if phase_source.startswith("phase channel "):      # the bags against the cycle's table
        findings += check_phases(phases, match, speed, phase_source.removeprefix("phase channel "))
    inputs = {role: [s.name] for role, s in (("speed", speed), ("fuel", fuel_sig),
                                             ("co2", co2_sig)) if s is not None}
    ess = [s.name for s in (pwr, volt, curr) if s is not None]
    if ess:
        inputs["ess"] = ess
    if phase_source.startswith("phase channel "):
        inputs["phase"] = [phase_source.removeprefix("phase channel ")]
    else:
        # a mapped phase channel that was set aside still vouches for the phases: a QA error
        # on it (a channel that is no phase counter) withholds the phase figures, which then
        # rest on the cycle's boundaries instead of the laboratory's bags
        declared = phase_channel or ("test_phase_test" if "test_phase_test" in test else None)
        if declared is not None and declared in test:
            inputs["phase"] = [declared]
    t0, t1 = test.span()
    scopes = [p.name for p in phases] + [_SCOPE_TEST]
    segs = [p.segments for p in phases] + [[(t0, t1)]]
    cond = _conditions(test, kept)

    # -------- accuracies and parameters
    used = [s for s in (speed, fuel_sig, co2_sig, pwr, volt, curr) if s is not None]
    acc = {s.name: channel_accuracy(s.name, accuracy.get(s.name)) for s in used}
    params = [p for a in acc.values() for p in a.parameters()]
    if fuel_obj is not None:
        for key in ("density_kg_per_m3", "lhv_j_per_kg", "carbon_mass_fraction"):
            lim = fuel_obj.uncertainty.get(key, 0.0)
            if lim > 0 and getattr(fuel_obj, key) is not None:
                params.append(Parameter(f"fuel {key}", lim, "property"))

    # -------- integrals per scope
    def base(sig: Signal | None) -> tuple[np.ndarray, np.ndarray] | None:
        if sig is None:
            return None
        itg = _Integrator(sig.time, sig.values)
        return (np.array([itg.integral(s) for s in segs]), np.array([itg.covered(s) for s in segs]))

    dur = np.array([sum(b - a for a, b in s) for s in segs])
    b_v, b_f, b_c = base(speed), base(fuel_sig), base(co2_sig)
    vmax = (np.array([_Integrator(speed.time, speed.values).extreme(s) for s in segs])
            if speed is not None else None)
    b_p = base(pwr)
    b_vi = None
    if volt is not None and curr is not None:
        vi = Signal(name="ess_pwr_calc", time=curr.time, values=curr.values * volt.at(curr.time),
                    unit="W")
        volt_on_curr = Signal(name="ess_volt_calc", time=curr.time, values=volt.at(curr.time), unit="V")
        b_vi = (base(vi), base(volt_on_curr), base(curr))
    hot = hot_start_bag1

    def g(theta: dict[str, np.ndarray], sig: Signal | None, kind: str) -> np.ndarray:
        n = len(next(iter(theta.values())))
        key = f"{sig.name} {'reading' if kind == 'gain' else 'offset'}" if sig else ""
        v = theta.get(key)
        return np.zeros((n, 1)) if v is None else v[:, None]

    def prop(theta: dict[str, np.ndarray], name: str) -> np.ndarray:
        n = len(next(iter(theta.values())))
        v = theta.get(f"fuel {name}")
        return np.zeros((n, 1)) if v is None else v[:, None]

    def evaluate(theta: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        n = len(next(iter(theta.values()))) if theta else 1
        nan = np.full((n, len(scopes)), np.nan)
        q: dict[str, np.ndarray] = {"duration_s": np.broadcast_to(dur, (n, len(scopes)))}

        def lin(b, sig):
            if b is None:
                return nan
            return (1.0 + g(theta, sig, "gain")) * b[0] + g(theta, sig, "offset") * b[1]

        dist = lin(b_v, speed)
        q["distance_m"] = dist
        q["mean_speed_mps"] = dist / dur
        q["max_speed_mps"] = (nan if vmax is None else
                              (1.0 + g(theta, speed, "gain")) * vmax + g(theta, speed, "offset"))
        mass = lin(b_f, fuel_sig)
        q["fuel_mass_kg"] = mass
        fo = fuel_obj
        rho = (fo.density_kg_per_m3 + prop(theta, "density_kg_per_m3")
               if fo is not None and fo.density_kg_per_m3 else None)
        lhv = (fo.lhv_j_per_kg + prop(theta, "lhv_j_per_kg")
               if fo is not None and fo.lhv_j_per_kg else None)
        cf = (fo.carbon_mass_fraction + prop(theta, "carbon_mass_fraction")
              if fo is not None and fo.carbon_mass_fraction else None)
        vol = fuel_volume_m3(mass, rho) if rho is not None else nan
        q["fuel_volume_m3"] = vol
        q["fuel_economy_mpg"] = fuel_economy_mpg(dist, vol)
        q["fuel_consumption_l_per_100km"] = fuel_consumption_l_per_100km(vol, dist)
        q["fuel_energy_j"] = fuel_energy_j(mass, lhv) if lhv is not None else nan
        with np.errstate(divide="ignore", invalid="ignore"):
            if b_c is not None:
                co2 = lin(b_c, co2_sig)
            else:
                co2 = co2_kg(mass, cf) if cf is not None else nan
            q["co2_kg"] = co2
            q["co2_g_per_km"] = np.where(dist > 0, co2 / dist * 1e6, np.nan)
        if b_p is not None:
            q["ess_energy_net_j"] = lin(b_p, pwr)
        elif b_vi is not None and all(b is not None for b in b_vi):
            (s_vi, tt), (s_v, _), (s_i, _) = b_vi  # type: ignore[misc]  # checked above
            gv, ov = 1.0 + g(theta, volt, "gain"), g(theta, volt, "offset")
            gi, oi = 1.0 + g(theta, curr, "gain"), g(theta, curr, "offset")
            q["ess_energy_net_j"] = gv * gi * s_vi + gv * oi * s_v + ov * gi * s_i + ov * oi * tt
        else:
            q["ess_energy_net_j"] = nan
        out = {f"{sc}|{k}": v[:, i] for k, v in q.items() for i, sc in enumerate(scopes)}
        idx = {sc: i for i, sc in enumerate(scopes)}
        for comp in composites:
            fuel_terms, co2_terms = [], []
            for w, names in comp.groups:
                fm = np.zeros(n)
                dd = np.zeros(n)
                cc = np.zeros(n)
                for nm in names:
                    if nm == "__hot_bag1__":
                        assert hot is not None, "a hot bag 1 composite needs hot_start_bag1"
                        fm += hot["fuel_mass_kg"]
                        dd += hot["distance_m"]
                        cc += hot.get("co2_kg", np.nan) if b_c is not None else (
                            co2_kg(hot["fuel_mass_kg"], cf[:, 0]) if cf is not None else np.nan)
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
            out[pre + "fuel_per_distance_kg_per_m"] = fpd
            vpd = fuel_volume_m3(fpd, rho[:, 0]) if rho is not None else np.full(n, np.nan)
            out[pre + "fuel_economy_mpg"] = mpg_from_volume_per_distance(vpd)
            out[pre + "fuel_consumption_l_per_100km"] = l_per_100km_from_volume_per_distance(vpd)
            out[pre + "co2_g_per_km"] = cpd * 1e6
            out[pre + "fuel_energy_per_distance_j_per_m"] = (
                fuel_energy_j(fpd, lhv[:, 0]) if lhv is not None else np.full(n, np.nan))
        return out

    cold = None if cond["start"] is None else cond["start"] == "cold"
    composites = composites_for(match.cycle if match else None, phases, cold_start=cold,
                                hot_bag1=hot is not None, match=match, speed=speed,
                                fuel=fuel_sig, conditions=cond, notes=notes)
    theta_params = params

    def evaluate_full(theta):
        if not theta:
            theta = {"__none__": np.zeros(1)}
        return evaluate(theta)

    nominal, unc = propagate(evaluate_full, theta_params, method=method, draws=draws, seed=seed)
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

    def economy(fpd: float) -> float | None:
        """Fuel per distance [kg/m] -> fuel economy [mpg] with the nominal fuel density."""
        if fuel_obj is None or not fuel_obj.density_kg_per_m3:
            return None
        return float(mpg_from_volume_per_distance(fuel_volume_m3(fpd,
                                                                 fuel_obj.density_kg_per_m3)))

    notes.extend(substitute_direction(composites, values, hot, economy))

    # -------- drive quality
    dq: dict[str, dict | None] = {}
    if speed is not None and match is not None:
        c = test.meta.constants or {}
        road = None
        if all(c.get(k) is not None for k in ("road_load_a_n", "road_load_b_n_per_mps",
                                              "road_load_c_n_per_mps2")):
            road = (c["road_load_a_n"], c["road_load_b_n_per_mps"], c["road_load_c_n_per_mps2"])
        ref = reference_speed(speed.time, match)
        all_segs = [s for p in phases for s in p.segments]
        for sc, sg in zip(scopes, [p.segments for p in phases] + [all_segs]):
            res = drive_quality(speed.time, speed.values, ref, mass_kg=c.get("test_mass_kg"),
                                road_load=road, segments=sg)
            dq[sc] = res.to_dict() if res is not None else None
            if res is not None and res.within_tolerance is False and sc != _SCOPE_TEST:
                findings.append(_finding(
                    f"drive quality of {sc} outside the SAE J2951 tolerances applied by "
                    f"40 CFR 1066.425(j): IWR {res.iwr_pct:+.2f} % (allowed -2.0..+4.0), "
                    f"RMSSE {format_delta(res.rmsse_mps or 0.0, 'm/s', digits=2)} (allowed "
                    f"{format_delta(RMSSE_TOLERANCE_MPS, 'm/s', digits=3)})"
                    + (f"; {why}" if (why := iwr_reading(res)) else ""), speed.name,
                    kind=Kind.DRIVE_QUALITY, iwr_pct=res.iwr_pct, rmsse_mps=res.rmsse_mps,
                    iwr_1hz_pct=res.iwr_1hz_pct,
                    phase=sc))
        if road is None:
            notes.append("drive quality: ER and EER need test_mass_kg and road_load_a/b/c "
                         "constants in the template")
    else:
        notes.append("drive quality: no reference trace (the cycle was not identified or has "
                     "no known phases)")

    soc = soc_correction(values, scopes, composites=[c.name for c in composites],
                         battery=pwr is not None or volt is not None, factor=soc_factor)
    if soc.get("status") == "beyond_tolerance_uncorrected":
        battery_sig = pwr or curr
        findings.append(_finding(soc["message"], battery_sig.name if battery_sig else ""))
    return TestResults(test_id=test.meta.test_id, cycle=test.meta.cycle, fuel=fuel_obj,
                       phase_source=phase_source, phases=phases, values=values,
                       uncertainty=uncertainty, composites=composites, drive_quality=dq,
                       soc=soc, accuracy=acc, parameters=params, conditions=cond,
                       method=method, draws=draws if method == "monte_carlo" else None,
                       findings=findings, notes=notes, inputs=inputs)


def _round_unc(d: dict) -> dict:
    out = dict(d)
    for k in ("u", "U"):
        out[k] = float(f"{out[k]:.6g}")
    if "interval_95" in out:
        out["interval_95"] = [float(f"{x:.8g}") for x in out["interval_95"]]
    return out


def _registry_bases() -> set[str]:
    from vehval.nomenclature import registry
    return set(registry().specs)


def results_from_template(test: Test, template: Any, **kw: Any) -> TestResults:
    """:func:`compute_results` with the template's fuel (:func:`vehval.fuels.resolve_fuel`),
    ``accuracy`` and ``phase_channel``."""
    fuel = resolve_fuel(template=template, test=test)
    kw.setdefault("soc_factor", getattr(template.constants, "soc_correction_fuel_j_per_battery_j",
                                        None))
    return compute_results(test, fuel=fuel, accuracy=template.accuracy,
                           phase_channel=template.phase_channel, **kw)
