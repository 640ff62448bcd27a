"""Calibrate a vehicle from specifications on the fuel of dyno tests with speed and fuel only.

:func:`vehval.epa.specs.vehicle_from_specs` leaves two parameters of the fuel model free:
the indicated efficiency (slope of the Willans line) and a scale on the generic friction
MEP. :func:`calibrate_specs` fits them on the measured fuel of some tests, with the warm
idle fuel rate measured in the same tests (:func:`measured_idle`):

* the fuel of the model is exactly affine in 1 / indicated efficiency (the map and the
  warm-up fuel scale with it; the measured idle and the idle control's shift, measured
  idle minus the map at idle, are affine in it), so for each friction scale of a grid
  (0.5-2.0, step 0.025) two simulations per test give the best efficiency in closed form
  (least squares of the relative fuel errors; exact unless the shift would take the map
  below zero somewhere, where it is clipped, and the errors reported are simulated anyway);
* the friction scale minimises the mean squared relative error plus a prior
  ``(SIGMA_FUEL / SIGMA_FRICTION)^2 (scale - 1)^2``: fuel measured to about 1 %
  (``SIGMA_FUEL``), the generic friction curve known to about 30 % (``SIGMA_FRICTION``).
  Two tests of different cycles identify both parameters; two of the same cycle only
  the efficiency, and the prior keeps the friction at Heywood's curve.

A dyno test (:class:`DynoRun`) is read from its speed and fuel signals. A standstill of
``SOAK_S`` or longer is a soak (an FTP-75's 10-minute hot soak, usually engine off): the
test is simulated as its driven runs, the soaks left out of both fuel sums; a test with a
soak is FTP-75 type and starts cold (the vehicle's warm-up fuel applies to its first run).
"""

from __future__ import annotations

import datetime as _dt
import itertools
import math
from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np

from vehval.calibration.provenance import Provenance
from vehval.constants import BRAKE_EFFICIENCY_RANGE
from vehval.cycles import Cycle
from vehval.epa.specs import (
    ENRICHMENT,
    INDICATED_EFFICIENCY,
    Specs,
    vehicle_from_specs,
)
from vehval.errors import ConfigError, SignalError
from vehval.integrals import held_sum
from vehval.sim.simulate import simulate
from vehval.vehicle.maps import brake_efficiency_plausible, peak_brake_efficiency

SOAK_S = 300.0  # standstill [s] taken as a soak between runs
WARM_S = 600.0  # a cold-started engine idles warm after this [s]
STOP_MPS = 0.1  # standstill below this speed [m/s]
SIGMA_FUEL = 0.01  # relative uncertainty of a test's measured fuel [-]
SIGMA_FRICTION = 0.3  # relative uncertainty of the generic friction MEP [-]
FRICTION_GRID = np.round(np.arange(0.5, 2.0001, 0.025), 4)


@dataclass
class DynoRun:
    """A dyno test reduced to its driven runs and measured fuel.

    Attributes
    ----------
    test_id : str
    runs : list of Cycle
        The driven parts between soaks (measured speed, 1 s grid).
    fuel_kg : float
        Measured fuel over the runs [kg].
    distance_m : float
        Measured distance over the runs [m].
    cold : bool
        FTP-75 type (a soak splits it): its first run starts cold.
    soak_s : float
        Total soak time left out [s].
    """

    test_id: str
    runs: list[Cycle]
    fuel_kg: float
    distance_m: float
    cold: bool
    soak_s: float = 0.0
    idle_fuel_kg_s: float = float("nan")  # median warm fuel rate at standstill [kg/s]
    fuel_note: str = ""                   # how the test fuel was counted in the model's fuel


def dyno_run(test: Any, test_id: str | None = None, dt: float = 1.0,
             model_lhv_j_per_kg: float | None = None) -> DynoRun:
    """Reduce an imported test (``veh_spd_test`` and ``fuel_rate_test``) to a DynoRun.

    Parameters
    ----------
    model_lhv_j_per_kg : float, optional
        Lower heating value of the model's fuel [J/kg]. When the test's declared fuel has
        another one (an E10 dyno test, a model of certification E0), the measured fuel mass
        is counted as the mass of the model's fuel holding the same energy (mass x
        LHV_test / LHV_model): the fitted efficiency is then the engine's, not a fuel
        difference.
    """
    tid = test_id or test.meta.test_id or "test"
    scale, note = 1.0, ""
    if model_lhv_j_per_kg:
        from vehval.fuels import resolve_fuel

        fuel = resolve_fuel(test=test)
        lhv = fuel.lhv_j_per_kg if fuel is not None else None
        if fuel is not None and lhv and abs(lhv / model_lhv_j_per_kg - 1.0) > 1e-6:
            scale = float(lhv) / float(model_lhv_j_per_kg)
            note = (f"fuel {fuel.name} ({lhv / 1e6:.1f} MJ/kg) counted as its energy in the "
                    f"model's fuel ({model_lhv_j_per_kg / 1e6:.1f} MJ/kg): mass x {scale:.3f}")
    try:
        spd, fuel = test["veh_spd_test"], test["fuel_rate_test"]
    except KeyError as exc:
        raise SignalError(f"test {tid}: needs vehicle speed and fuel rate signals "
                          f"(veh_spd_test, fuel_rate_test): {exc}") from None
    t0, t1 = float(spd.time[0]), float(spd.time[-1])
    t = np.arange(t0, t1 + 1e-9, dt)
    v = np.clip(np.interp(t, spd.time, spd.values), 0.0, None)
    f = np.clip(np.interp(t, fuel.time, fuel.values), 0.0, None) * scale
    moving = v >= STOP_MPS
    # standstill stretches of SOAK_S or more split the test into runs
    keep = np.ones(t.size, dtype=bool)
    i = 0
    while i < t.size:
        if moving[i]:
            i += 1
            continue
        j = i
        while j < t.size and not moving[j]:
            j += 1
        if (j - i) * dt >= SOAK_S and i > 0 and j < t.size:
            keep[i + 1:j - 1] = False  # one standstill second either side stays
        i = j
    edges = np.flatnonzero(np.diff(np.r_[0, keep.astype(int), 0]))
    runs = []
    for k, (a, b) in enumerate(zip(edges[::2], edges[1::2])):
        runs.append(Cycle(name=f"{tid}_run{k + 1}", time_s=t[a:b] - t[a], speed_mps=v[a:b],
                          description=f"measured speed of {tid}, run {k + 1}"))
    if not runs or sum(r.time_s.size for r in runs) < 10:
        raise SignalError(f"test {tid}: too short to simulate")
    cold = len(runs) > 1
    # warm idle: standstill with the engine running, after the first WARM_S of a cold test
    idle = keep & ~moving & (f > 0) & ((t - t0 >= WARM_S) if cold else True)
    return DynoRun(test_id=tid, runs=runs, fuel_kg=held_sum(f, dt, keep),
                   distance_m=held_sum(v, dt, keep), cold=cold,
                   soak_s=float(np.sum(~keep) * dt),
                   idle_fuel_kg_s=float(np.median(f[idle])) if idle.sum() >= 10 else math.nan,
                   fuel_note=note)


def simulated_fuel_kg(vehicle: Any, run: DynoRun, dt: float = 0.5) -> float:
    """Fuel of the vehicle over the test's runs [kg] (first run cold for a cold test)."""
    total = 0.0
    for k, cyc in enumerate(run.runs):
        res = simulate(vehicle, cyc, dt=dt, cold_start=run.cold and k == 0)
        total += float(res.summary["fuel_mass_kg"])
    return total


@dataclass
class SpecsFit:
    """Result of :func:`calibrate_specs` (errors relative, predicted / measured - 1)."""

    specs: Specs
    tests: list[str]
    indicated_efficiency: float
    friction_scale: float
    errors: dict[str, float]  # calibration tests, after
    start_errors: dict[str, float]  # with the generic start values
    objective: float
    dt: float
    date: str = field(default_factory=lambda: _dt.date.today().isoformat())
    idle_fuel_g_per_s: float | None = None  # measured warm idle (None: from the map)
    idle_source: str = ""
    enrichment: float = ENRICHMENT

    def provenance(self, name: str) -> str:
        """Source text of the calibrated fuel values (the tests named as calibration tests)."""
        rms0 = float(np.sqrt(np.mean(np.square(list(self.start_errors.values())))))
        rms1 = float(np.sqrt(np.mean(np.square(list(self.errors.values())))))
        return Provenance(
            by="vehval epa vehicle", tests=self.tests,
            objective="RMS relative fuel error", start_value=rms0, best_value=rms1,
            percent=True,
            method="friction-scale grid, indicated efficiency in closed form at each",
            start={name: INDICATED_EFFICIENCY},
            ranges={name: "friction scale 0.5-2 step 0.025, start 1"}, dt=self.dt,
            details=[f"indicated efficiency {self.indicated_efficiency:.4f}, friction scale "
                     f"{self.friction_scale:.3f}; prior: fuel {SIGMA_FUEL:g}, friction "
                     f"{SIGMA_FRICTION:g}"],
            date=self.date).text(name)

    def vehicle(self) -> Any:
        """The calibrated vehicle; its fuel values name the calibration tests."""
        veh = self.model(note=f"; fuel model calibrated on {', '.join(self.tests)}")
        data = veh.model_dump()
        for blk, key in (("engine", "fuel_rate_g_per_s"),
                         ("engine_control", "idle_fuel_rate_g_per_s")):
            data[blk]["sources"][key] += "; " + self.provenance(f"{blk}.{key}")
        return type(veh).model_validate(data)

    def model(self, note: str = "") -> Any:
        """The vehicle with the fitted values (sources without the calibration text)."""
        return vehicle_from_specs(self.specs, self.indicated_efficiency, self.friction_scale,
                                  note=note, idle_fuel_g_per_s=self.idle_fuel_g_per_s,
                                  idle_source=self.idle_source, enrichment=self.enrichment,
                                  technology=False)

    def to_dict(self) -> dict[str, Any]:
        eff = peak_brake_efficiency(self.model().engine)
        return {"tests": self.tests, "indicated_efficiency": self.indicated_efficiency,
                "best_brake_efficiency": eff[0],
                "plausibility_note": efficiency_note(self.model()),
                "idle_fuel_g_per_s": self.idle_fuel_g_per_s,
                "friction_scale": self.friction_scale, "errors": self.errors,
                "start_errors": self.start_errors, "objective": self.objective,
                "dt_s": self.dt, "specs": self.specs.to_dict()}


def efficiency_note(vehicle: Any) -> str:
    """'' when the map's best brake efficiency is plausible, else what is wrong with it."""
    eff, rpm, nm = peak_brake_efficiency(vehicle.engine)
    if brake_efficiency_plausible(eff):
        return ""
    lo, hi = BRAKE_EFFICIENCY_RANGE
    return (f"the fitted fuel map's best brake efficiency is {100 * eff:.1f} % ({rpm:.0f} rpm, "
            f"{nm:.0f} N·m), outside the {100 * lo:.0f}-{100 * hi:.0f} % of real "
            "spark-ignition engines: the tests' fuel (its unit, density or fuel) or the list "
            "row (weight, road load) does not describe this car; the figures it predicts are "
            "not to be trusted")


def measured_idle(runs: Sequence[DynoRun]) -> tuple[float | None, str]:
    """Warm idle fuel rate [g/s] of the tests (median of their medians) and its source."""
    vals = [r.idle_fuel_kg_s for r in runs if math.isfinite(r.idle_fuel_kg_s)]
    if not vals:
        return None, ""
    g = float(np.median(vals)) * 1e3
    return g, (f"measured: median fuel rate at standstill with the engine running in "
               f"{', '.join(r.test_id for r in runs if math.isfinite(r.idle_fuel_kg_s))} "
               f"(warm: after {WARM_S:g} s of a cold test): {g:.4f} g/s")


def calibrate_specs(specs: Specs, runs: Sequence[DynoRun], dt: float = 0.5) -> SpecsFit:
    """Fit indicated efficiency and friction scale on the measured fuel of ``runs``.

    The warm idle fuel rate is measured in the same tests (:func:`measured_idle`). With it
    fixed, a test's simulated fuel is affine in 1 / indicated efficiency (idle apart, the
    map and the warm-up fuel scale with it): two simulations per test and friction scale
    give it exactly, and the best efficiency follows in closed form.
    """
    if not runs:
        raise ConfigError("give at least one calibration test")
    from vehval.results.headline import MIN_HEADLINE_DISTANCE_M

    still = [f"{r.test_id} ({r.distance_m:.0f} m)" for r in runs
             if not r.distance_m >= MIN_HEADLINE_DISTANCE_M]
    if still:
        raise SignalError(f"test(s) {', '.join(still)}: drive under {MIN_HEADLINE_DISTANCE_M:g} m, "
                          "so their fuel is idle fuel, not a fuel economy to calibrate on: "
                          "calibrate on whole dyno tests (check the speed channel and its unit)")
    meas = np.array([r.fuel_kg for r in runs])
    if np.any(meas <= 0):
        bad = [r.test_id for r in runs if r.fuel_kg <= 0]
        raise SignalError(f"test(s) {', '.join(bad)}: no measured fuel to calibrate on")
    idle, idle_src = measured_idle(runs)

    def build(eta: float, kf: float, en: float) -> Any:
        return vehicle_from_specs(specs, eta, kf, idle_fuel_g_per_s=idle,
                                  idle_source=idle_src, enrichment=en, technology=False)

    start = np.array([simulated_fuel_kg(build(INDICATED_EFFICIENCY, 1.0, ENRICHMENT), r, dt)
                      for r in runs])
    best: tuple[float, float, float] | None = None
    w = (SIGMA_FUEL / SIGMA_FRICTION) ** 2
    eta1, eta2 = INDICATED_EFFICIENCY, INDICATED_EFFICIENCY / 2  # x = eta_ref / eta: 1, 2
    en = ENRICHMENT
    for kf in FRICTION_GRID:
        f1 = np.array([simulated_fuel_kg(build(eta1, float(kf), en), r, dt) for r in runs])
        f2 = np.array([simulated_fuel_kg(build(eta2, float(kf), en), r, dt) for r in runs])
        q = (f2 - f1) / meas  # d(fuel / measured) / dx
        p = f1 / meas - q  # at x = 0
        x = float(np.sum(q * (1.0 - p)) / np.sum(q * q))
        if x <= 0 or not 0.1 <= eta1 / x <= 0.6:
            continue
        j = float(np.mean((p + q * x - 1.0) ** 2) + w * (kf - 1.0) ** 2)
        if best is None or j < best[0]:
            best = (j, eta1 / x, float(kf))
    if best is None:
        raise ConfigError("no friction scale of the grid gives an indicated efficiency in "
                          "0.1-0.6: the tests' fuel does not fit this specification")
    j, eta, kf = best
    veh = build(eta, kf, en)
    after = {r.test_id: simulated_fuel_kg(veh, r, dt) / r.fuel_kg - 1 for r in runs}
    return SpecsFit(specs=specs, tests=[r.test_id for r in runs], indicated_efficiency=eta,
                    friction_scale=kf, errors=after,
                    start_errors={r.test_id: float(s / r.fuel_kg - 1)
                                  for r, s in zip(runs, start)},
                    objective=j, dt=dt, idle_fuel_g_per_s=idle, idle_source=idle_src,
                    enrichment=en)


def predict_runs(vehicle: Any, runs: Sequence[DynoRun], dt: float = 0.5) -> dict[str, float]:
    """Relative fuel error (predicted / measured - 1) of each test."""
    return {r.test_id: simulated_fuel_kg(vehicle, r, dt) / r.fuel_kg - 1 for r in runs}


def all_splits(specs: Specs, runs: Sequence[DynoRun], n_cal: int = 2,
               dt: float = 0.5) -> list[dict[str, Any]]:
    """Every split of the tests into ``n_cal`` calibration tests and the others held out.

    Returns
    -------
    list of dict
        ``calibration`` (ids), ``indicated_efficiency``, ``friction_scale``,
        ``calibration_errors`` and ``held_out_errors`` {id: relative error},
        ``max_abs_held_out``.
    """
    if not 1 <= n_cal < len(runs):
        raise ConfigError(f"--splits {n_cal}: each split calibrates on {n_cal} test(s) and "
                          f"holds out the others, so it needs between 1 and {len(runs) - 1} "
                          f"calibration tests with {len(runs)} tests given"
                          if len(runs) > 1 else
                          f"--splits {n_cal}: a split holds out at least one test: give two "
                          "tests or more")
    out = []
    for cal in itertools.combinations(range(len(runs)), n_cal):
        fit = calibrate_specs(specs, [runs[i] for i in cal], dt)
        held = [runs[i] for i in range(len(runs)) if i not in cal]
        errs = predict_runs(fit.model(), held, dt)
        out.append({"calibration": fit.tests, "indicated_efficiency": fit.indicated_efficiency,
                    "friction_scale": fit.friction_scale, "enrichment": fit.enrichment,
                    "idle_fuel_g_per_s": fit.idle_fuel_g_per_s,
                    "calibration_errors": fit.errors, "held_out_errors": errs,
                    "max_abs_held_out": max(abs(e) for e in errs.values())})
    return out


def cold_note(run: DynoRun) -> str:
    """How the test is simulated: runs, soak, cold start."""
    if not run.cold:
        return f"{len(run.runs)} run, warm start"
    return (f"{len(run.runs)} runs, {run.soak_s:.0f} s soak left out, FTP-75 type: first "
            "run cold")


__all__ = ["DynoRun", "SpecsFit", "all_splits",
           "calibrate_specs", "cold_note", "dyno_run", "efficiency_note",
           "measured_idle", "predict_runs", "simulated_fuel_kg"]
