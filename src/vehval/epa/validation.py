"""Simulate EPA certification tests with each test's own weight and road load; compare.

For every selected test :func:`validate_tests` builds the vehicle with the test's
equivalent test weight and road-load *target* coefficients (the total road load the dyno
reproduces), runs the procedure's plan (:mod:`vehval.epa.procedures`) with the battery
charge carried from run to run, iterates the initial SOC until the whole test is charge
balanced (SAE J1711 basis of the lab result) and integrates fuel and distance per bag.
Like is compared with like: the whole-test result is charge balanced, the bags are raw
(the lab's bags are not individually balanced either; each UDDS of an FTP-75, bags 1+2 and
3+4, nearly is), and every figure carries the model's battery share (battery energy over
fuel energy). Hot-start figures (bags 2-4, hot UDDS, HWFET, US06) are judged;
a test the list marks as analytically derived (``Analytically Derived FE?`` Yes: its
figures are computed from another test) and one whose listed figures contradict each other
are simulated and listed, never judged;
the cold-start figures (FTP bag 1, cold UDDS and the composite) only when the vehicle models
the cold start (warm-up fuel, a hybrid's engine-on hold, applied to the FTP's first run),
else they are reported as the cold-start gap.

In-sample honesty: a figure of a test the vehicle file was calibrated on (read from the
provenance of its calibrated values, :func:`vehval.calibration.provenance.calibration_tests`)
is marked ``in_sample``; the headline statistics (:meth:`EpaValidation.stats`) count only
held-out judged figures, the in-sample ones are summarised apart
(``stats(in_sample=True)``). A list without test numbers (the reduced 2017 columns) repeats
earlier lists' tests: such a row that repeats a calibration test (same vehicle, procedure,
weight, road load and figures, :func:`repeated_calibration_tests`) is in-sample; one that
cannot be told apart (a calibration test not among the lists read) is ``sample_unknown``
and counted neither as held-out nor as in-sample.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from vehval import progress
from vehval.calibration.provenance import calibration_tests
from vehval.cycles import load_cycle
from vehval.epa.consistency import (
    ListCheck,
    VehicleCheck,
    check_listed_figures,
    check_vehicle_match,
    group_mismatches,
)
from vehval.epa.procedures import (
    CERTIFICATION_CYCLES,
    Procedure,
    fuel_family,
    plan_for,
    procedure_key,
    road_load_without_b,
)
from vehval.epa.reader import EpaTest
from vehval.epa.verdicts import check_model_u, judge
from vehval.errors import ConfigError
from vehval.fuels import (
    combine_mpg,
    fuel_economy_mpg,
    fuel_energy_j,
    fuel_volume_m3,
    mpg_from_volume_per_distance,
    resolve_fuel,
)
from vehval.integrals import battery_power, window_integral
from vehval.results.composites import FTP_WEIGHTS, weighted_reciprocal_sum
from vehval.sim.simulate import BALANCE_TOL as BALANCE_TOL  # charge balance [-]
from vehval.sim.simulate import (
    Grid,
    architecture,
    balanced_plan,
    cycle_grid,
    plan_summary,
)
from vehval.vehicle import Vehicle, load_vehicle

#: judging tolerance of the issue: each hot-start figure within 5 % (goal 3 %)
TOLERANCE = 0.05


@dataclass
class Comparison:
    """One predicted-vs-measured figure (a bag or a whole test), fuel economy in mpg."""

    test: str
    vehicle_id: str
    originator: str
    procedure: str
    item: str  # "overall", "bag 1"...
    name: str
    predicted_mpg: float
    measured_mpg: float
    judged: bool  # judged against the tolerance (hot start, or cold start with a model)
    note: str = ""
    cold_start: bool = False  # the figure contains a cold start
    battery_share: float | None = None  # model: battery chemical / fuel energy [-]
    list_doubtful: bool = False  # the list's own figures of this test disagree (not judged)
    in_sample: bool = False  # the vehicle file was calibrated on this test
    sample_unknown: bool = False  # no test number, may be a calibration test (not counted)
    analytically_derived: bool = False  # the list computed the figure, not measured (not judged)
    # normalised error (vehval.epa.verdicts.judge): En, U_model and U_meas [mpg, k = 2]
    en: float | None = None
    u_model: float | None = None
    u_meas: float | None = None
    uninformative: bool | None = None
    precision: dict[str, Any] | None = None  # s_r, s and the source rule of U_meas
    verdict: Any = None  # the vehval.uncertainty.Comparison behind en

    @property
    def error(self) -> float:
        """(predicted - measured) / measured [-]."""
        return self.predicted_mpg / self.measured_mpg - 1.0

    def to_dict(self) -> dict[str, Any]:
        return {"test": self.test, "vehicle_id": self.vehicle_id,
                "originator": self.originator, "procedure": self.procedure,
                "item": self.item, "name": self.name,
                "predicted_mpg": round(self.predicted_mpg, 3),
                "measured_mpg": round(self.measured_mpg, 3),
                "error": round(self.error, 5), "judged": self.judged,
                "within_tolerance": abs(self.error) <= TOLERANCE, "note": self.note,
                "cold_start": self.cold_start,
                "battery_share": (None if self.battery_share is None
                                  else round(self.battery_share, 5)),
                "list_doubtful": self.list_doubtful, "in_sample": self.in_sample,
                "sample_unknown": self.sample_unknown,
                "analytically_derived": self.analytically_derived,
                "en": None if self.en is None or not math.isfinite(self.en) else round(self.en, 4),
                "consistent": None if self.en is None else abs(self.en) <= 1.0,
                "u_model": None if self.u_model is None else round(self.u_model, 4),
                "u_meas": None if self.u_meas is None else round(self.u_meas, 4),
                "uninformative": self.uninformative, "precision": self.precision}


@dataclass
class TestPrediction:
    """Simulation of one EPA test."""

    test: EpaTest
    procedure: str
    overall_mpg: float
    bags_mpg: dict[int, float]
    bag_distance_m: dict[int, float]
    bag_fuel_j: dict[int, float]  # fuel energy burnt in the bag [J]
    bag_battery_j: dict[int, float]  # battery chemical energy spent in the bag [J] (> 0 out)
    soc_initial: float
    soc_delta: float
    trace_n_miss: int
    energy_balance_rel: float
    distance_m: float
    fuel_kg: float
    engine_on_fraction: float
    list_check: ListCheck | None = None  # the list's own figures agree (set by validate_tests)
    vehicle_check: VehicleCheck | None = None  # the test's driveline matches the vehicle file


@dataclass
class EpaValidation:
    """Result of :func:`validate_tests`."""

    vehicle: str
    predictions: list[TestPrediction] = field(default_factory=list)
    comparisons: list[Comparison] = field(default_factory=list)
    skipped: list[dict[str, str]] = field(default_factory=list)
    #: test id -> parameters the vehicle file was calibrated on it (its figures in-sample)
    calibrated: dict[str, list[str]] = field(default_factory=dict)
    #: label of a test without a number -> the calibration test whose list row it repeats
    repeats: dict[str, str] = field(default_factory=dict)
    #: labels of tests without a number that may be calibration tests (not counted)
    sample_unknown: list[str] = field(default_factory=list)
    #: procedure -> U_model of its cycle (vehval.sim.model_uncertainty), None: not propagated
    model_uncertainty: dict[str, Any] = field(default_factory=dict)
    #: bias, coverage and verdict of the held-out figures (vehval.epa.verdicts)
    set_verdict: dict[str, Any] | None = None
    set_verdict_note: str = ""
    #: the same over every judged test, in-sample included (None: no in-sample test)
    set_verdict_all: dict[str, Any] | None = None
    set_verdict_all_note: str = ""
    notes: list[str] = field(default_factory=list)

    def stats(self, in_sample: bool = False) -> dict[str, Any]:
        """Counts, errors of the judged figures and the correlation of spreads.

        Parameters
        ----------
        in_sample : bool
            False (the headline): the held-out judged figures only; True: the judged
            figures of the tests the vehicle file was calibrated on.
        """
        figures = [c for c in self.comparisons if c.in_sample == in_sample and not c.sample_unknown]
        judged = [c for c in figures if c.judged]
        err = np.array([c.error for c in judged])
        out: dict[str, Any] = {
            "n_tests_selected": len(self.predictions) + len(self.skipped),
            "n_tests_simulated": len(self.predictions),
            "n_tests_skipped": len(self.skipped),
            "n_tests_vehicle_mismatch": sum(map(len, group_mismatches(
                (p.test.label, p.vehicle_check) for p in self.predictions).values())),
            "figures": "in-sample" if in_sample else "held-out",
            "n_tests_in_sample": sum(p.test.label in self.calibrated for p in self.predictions),
            "n_judged": len(judged),
            "n_judged_held_out": sum(c.judged and not c.in_sample and not c.sample_unknown
                                     for c in self.comparisons),
            "n_judged_sample_unknown": sum(c.judged and c.sample_unknown for c in self.comparisons),
            "n_judged_in_sample": sum(c.judged and c.in_sample for c in self.comparisons),
            "n_within_tolerance": int(np.sum(np.abs(err) <= TOLERANCE)) if err.size else 0,
            "n_within_3pct": int(np.sum(np.abs(err) <= 0.03)) if err.size else 0,
            "tolerance": TOLERANCE,
            "mean_error": float(err.mean()) if err.size else None,
            "mean_abs_error": float(np.abs(err).mean()) if err.size else None,
            "max_abs_error": float(np.abs(err).max()) if err.size else None,
        }
        out["spread_correlation"] = spread_correlation(figures)
        out["per_kind"] = per_kind_errors(figures)
        return out

    def to_dict(self) -> dict[str, Any]:
        return {"vehicle": self.vehicle, "stats": self.stats(),
                "stats_in_sample": self.stats(in_sample=True),
                "calibration_tests": self.calibrated,
                "repeated_calibration_tests": self.repeats,
                "sample_unknown_tests": self.sample_unknown,
                "comparisons": [c.to_dict() for c in self.comparisons],
                "tests": [{"test": p.test.label, "vehicle_id": p.test.vehicle_id,
                           "originator": p.test.originator, "procedure": p.procedure,
                           "mass_kg": p.test.mass_kg, "road_load_a_n": p.test.target_a_n,
                           "road_load_b_n_per_mps": p.test.target_b_n_per_mps,
                           "road_load_c_n_per_mps2": p.test.target_c_n_per_mps2,
                           "soc_initial": p.soc_initial, "soc_delta": p.soc_delta,
                           "trace_n_miss": p.trace_n_miss,
                           "energy_balance_rel": p.energy_balance_rel,
                           "engine_on_fraction": p.engine_on_fraction,
                           "list_check": (None if p.list_check is None
                                          else p.list_check.to_dict()),
                           "vehicle_check": (None if p.vehicle_check is None
                                             else p.vehicle_check.to_dict()),
                           "in_sample": p.test.label in self.calibrated,
                           "calibrated_parameters": self.calibrated.get(p.test.label, []),
                           "sample_unknown": p.test.label in self.sample_unknown,
                           "analytically_derived": p.test.analytically_derived,
                           "adfe_test_number": p.test.adfe_test_number,
                           "source": p.test.source} for p in self.predictions],
                "skipped": self.skipped, "model_uncertainty": self.model_uncertainty,
                "set_verdict": self.set_verdict, "set_verdict_note": self.set_verdict_note,
                "set_verdict_all": self.set_verdict_all,
                "set_verdict_all_note": self.set_verdict_all_note,
                "notes": self.notes}


def per_kind_errors(comparisons: list[Comparison]) -> dict[str, dict[str, Any]]:
    """Per figure kind ("ftp75 bag 2", "hwfet overall"...) of the judged figures: count,
    mean error, mean |error|, largest |error| [-] and how many within the tolerance."""
    kinds: dict[str, list[float]] = {}
    for c in comparisons:
        if c.judged:
            kinds.setdefault(f"{c.procedure} {c.item}", []).append(c.error)
    return {k: {"n": len(v), "mean_error": float(np.mean(v)),
                "mean_abs_error": float(np.mean(np.abs(v))),
                "max_abs_error": float(np.max(np.abs(v))),
                "n_within_tolerance": int(np.sum(np.abs(v) <= TOLERANCE))}
            for k, v in sorted(kinds.items())}


def spread_correlation(comparisons: list[Comparison]) -> dict[str, Any]:
    """Pearson r of predicted vs measured over the judged figures, per figure kind and pooled.

    The spread of one kind (e.g. every HWFET) comes from the tests' different road loads
    and originators; a model that follows it has r near 1 within each kind. Kinds with
    fewer than 3 figures or no measured spread give None.
    """
    def pearson(pairs):
        if len(pairs) < 3:
            return None
        a = np.array(pairs)
        if np.std(a[:, 1]) == 0 or np.std(a[:, 0]) == 0:
            return None
        return float(np.corrcoef(a[:, 0], a[:, 1])[0, 1])

    kinds: dict[str, list] = {}
    for c in comparisons:
        if c.judged:
            kinds.setdefault(f"{c.procedure} {c.item}", []).append((c.predicted_mpg,
                                                                    c.measured_mpg))
    pooled = [p for v in kinds.values() for p in v]
    return {"pooled": pearson(pooled), "n_pooled": len(pooled),
            "per_kind": {k: pearson(v) for k, v in sorted(kinds.items())}}


def vehicle_for_test(vehicle: Vehicle, test: EpaTest,
                     cycles: tuple[str, ...] = CERTIFICATION_CYCLES) -> Vehicle:
    """The vehicle with the test's equivalent test weight and road-load target (a negative
    B refitted as A' + C' v^2 over the speeds of ``cycles``: :func:`road_load_without_b`)."""
    a, b, c = road_load_without_b(test.target_a_n, test.target_b_n_per_mps,
                                  max(test.target_c_n_per_mps2, 0.0), cycles)
    return vehicle.with_overrides({
        "body.mass_kg": test.mass_kg, "body.road_load_a_n": a,
        "body.road_load_b_n_per_mps": b, "body.road_load_c_n_per_mps2": c})


def _grids(veh: Vehicle, proc: Procedure, dt: float) -> list[Grid]:
    """One grid per run of the plan; the runs holding a cold-start bag start cold."""
    cold_runs = {b.run for b in proc.bags if b.cold_start}
    return [cycle_grid(veh, load_cycle(name), dt, k in cold_runs)
            for k, name in enumerate(proc.runs)]


def _chemical_power(veh: Vehicle, out: np.ndarray, col: dict[str, int]) -> np.ndarray:
    """Battery chemical power OCV(SOC) x current [W] of recorded signals (> 0 discharging)."""
    b = veh.battery
    return battery_power(np.interp(out[:, col["ess_soc"]], b.soc, b.ocv_v), out[:, col["ess_curr"]])


def _mpg(distance_m: float, fuel_kg: float, rho: float) -> float:
    return fuel_economy_mpg(distance_m, fuel_volume_m3(fuel_kg, rho), empty=math.inf)


def predict_test(vehicle: Vehicle, test: EpaTest, proc: Procedure,
                 dt: float = 1.0) -> TestPrediction:
    """Simulate one test: charge-balanced whole test (hybrid), raw bags.

    A conventional vehicle (``architecture: conventional``) runs its own loop; it has no
    battery, so nothing is balanced (``soc_initial`` NaN, ``soc_delta`` 0)."""
    veh = vehicle_for_test(vehicle, test, tuple(dict.fromkeys(proc.runs)))
    grids = _grids(veh, proc, dt)
    arch = architecture(veh)
    conventional = not arch.has_battery
    col = arch.column
    soc0, runs, _ = balanced_plan(veh, grids)
    fuel = resolve_fuel(vehicle=veh)  # the vehicle's: the certification fuel of the tests
    if fuel is None or not fuel.density_kg_per_m3 or not fuel.lhv_j_per_kg:
        raise ConfigError(f"vehicle {veh.name}: no fuel density and LHV: name the fuel "
                          "(engine.fuel) or give engine.fuel_density_kg_per_m3 and fuel_lhv_j_per_kg")
    rho, lhv = fuel.density_kg_per_m3, fuel.lhv_j_per_kg
    bag_fuel, bag_dist, bag_batt = {}, {}, {}
    for bag in proc.bags:
        out = runs[bag.run][0]
        t = grids[bag.run].t
        # the simulator holds each step's value over the step: a bag is the held sum
        bag_fuel[bag.number] = window_integral(t, out[:, col["fuel_rate"]], bag.windows, step_s=dt)
        bag_dist[bag.number] = window_integral(t, out[:, col["veh_spd"]], bag.windows, step_s=dt)
        bag_batt[bag.number] = 0.0 if conventional else window_integral(
            t, _chemical_power(veh, out, col), bag.windows, step_s=dt)
    bags = {k: _mpg(bag_dist[k], bag_fuel[k], rho) for k in bag_fuel}
    # whole-test figures from the run summaries (fuel, battery energy, closure)
    summ = plan_summary(veh, runs, soc0)
    if conventional:
        summ.update(soc_delta=0.0, engine_on_fraction=1.0,
                    fuel_economy_soc_corrected_mpg=summ["fuel_economy_mpg"])
        corr = 1.0
    else:
        corr = summ["fuel_mass_soc_corrected_kg"] / max(summ["fuel_mass_kg"], 1e-12)
    if proc.composite == "ftp":
        hot_b = 4 if not math.isnan(test.bags[3]) else 2
        cold = (bag_dist[1] + bag_dist[2]) / (bag_fuel[1] + bag_fuel[2])
        hot = (bag_dist[3] + bag_dist[hot_b]) / (bag_fuel[3] + bag_fuel[hot_b])
        fuel_per_m = weighted_reciprocal_sum(FTP_WEIGHTS, (cold, hot))
        overall = mpg_from_volume_per_distance(fuel_volume_m3(fuel_per_m * corr, rho))
    else:
        overall = summ["fuel_economy_soc_corrected_mpg"]
    return TestPrediction(
        test=test, procedure=proc.key, overall_mpg=float(overall), bags_mpg=bags,
        bag_distance_m=bag_dist,
        bag_fuel_j={k: fuel_energy_j(f, lhv) for k, f in bag_fuel.items()},
        bag_battery_j=bag_batt,
        soc_initial=float(soc0), soc_delta=float(summ["soc_delta"]),
        trace_n_miss=int(summ["trace_n_miss"]),
        energy_balance_rel=float(summ["energy_balance_rel"]),
        distance_m=float(summ["distance_m"]), fuel_kg=float(summ["fuel_mass_kg"]),
        engine_on_fraction=float(summ["engine_on_fraction"]))


#: parameters of the power-split cold-start model (FTP-75 first run, ``simulate --cold-start``)
COLD_START_PARAMS = ("engine.warmup_fuel_fraction", "engine.warmup_time_constant_s",
                     "controller.cold_start_engine_on_s", "controller.cold_start_engine_power_w")


def has_cold_start_model(veh: Vehicle) -> bool:
    """Whether the vehicle models a cold start (warm-up fuel, or a hybrid's engine-on hold)."""
    return architecture(veh).cold_start_model(veh)


def _battery_share(pred: TestPrediction, bags) -> float | None:
    """Battery chemical energy / fuel energy of the model over some bags [-] (J1711's
    net-energy-change ratio; None for a vehicle without a battery)."""
    if math.isnan(pred.soc_initial):
        return None
    fuel = sum(pred.bag_fuel_j[k] for k in bags)
    return sum(pred.bag_battery_j[k] for k in bags) / fuel if fuel > 0 else None


def _pair(pred: TestPrediction, t: EpaTest, first: int, second: int) -> tuple[float, float]:
    """Predicted and measured mpg of two bags combined by distance (one UDDS)."""
    d1, d2 = pred.bag_distance_m[first], pred.bag_distance_m[second]
    meas = combine_mpg([d1, d2], [t.bags[first - 1], t.bags[second - 1]])
    pred_mpg = combine_mpg([d1, d2], [pred.bags_mpg[first], pred.bags_mpg[second]])
    return pred_mpg, meas


def _compare(pred: TestPrediction, proc: Procedure, cold_model: bool) -> list[Comparison]:
    """Figures of one test; cold-start figures are judged only with a cold-start model."""
    t = pred.test
    base: dict[str, Any] = {"test": t.label, "vehicle_id": t.vehicle_id,
            "originator": t.originator or "?", "procedure": proc.key}
    rows = []
    cold_in_overall = any(b.cold_start for b in proc.bags)
    if not math.isnan(t.fe):
        note = ("" if not cold_in_overall else "contains the cold start (warm-up model)"
                if cold_model else "contains the cold start: cold-start gap, not judged")
        # a hybrid's whole-test figure is charge-balanced (SAE J1711); a car without a
        # battery has nothing to balance
        name = proc.name + ("" if math.isnan(pred.soc_initial) else " (J1711 balanced)")
        rows.append(Comparison(**base, item="overall", name=name,
                               predicted_mpg=pred.overall_mpg, measured_mpg=t.fe,
                               judged=cold_model or not cold_in_overall, note=note,
                               cold_start=cold_in_overall,
                               battery_share=_battery_share(pred, pred.bag_fuel_j)))
    if len(proc.bags) > 1:
        for bag in proc.bags:
            meas = t.bags[bag.number - 1]
            if math.isnan(meas):
                continue
            rows.append(Comparison(
                **base, item=f"bag {bag.number}", name=bag.name,
                predicted_mpg=pred.bags_mpg[bag.number], measured_mpg=meas,
                judged=cold_model or not bag.cold_start,
                note=("cold start (warm-up model)" if cold_model else
                      "cold start (no thermal model): gap reported, not judged")
                if bag.cold_start else "raw bag, not individually charge balanced",
                cold_start=bag.cold_start,
                battery_share=_battery_share(pred, (bag.number,))))
    if proc.composite == "ftp" and not any(math.isnan(x) for x in t.bags[:4]):
        # one UDDS each (cold: bags 1 + 2, hot: bags 3 + 4): the charge one phase stores
        # and the next spends cancels out (battery share near 0)
        p12, m12 = _pair(pred, t, 1, 2)
        rows.append(Comparison(**base, item="bags 1+2", name="cold UDDS (bags 1 + 2)",
                               predicted_mpg=p12, measured_mpg=m12, judged=cold_model,
                               note=("cold start (warm-up model), the two phases combined "
                                     "by distance" if cold_model else
                                     "cold start (no thermal model): gap reported, not judged"),
                               cold_start=True, battery_share=_battery_share(pred, (1, 2))))
        p34, m34 = _pair(pred, t, 3, 4)
        rows.append(Comparison(**base, item="bags 3+4", name="hot UDDS (bags 3 + 4)",
                               predicted_mpg=p34, measured_mpg=m34, judged=True,
                               note="hot start, the two phases combined by distance",
                               battery_share=_battery_share(pred, (3, 4))))
    return rows


def derived_note(t: EpaTest) -> str:
    """Why a test the list marks as analytically derived is not judged."""
    src = f" from test {t.adfe_test_number}" if t.adfe_test_number else ""
    return (f"analytically derived{src} (the list's 'Analytically Derived FE?'): a computed "
            "figure, not a measurement; listed, not judged")


def _row_key(t: EpaTest) -> tuple:
    """What identifies a list row without its test number: vehicle, procedure, weight, road
    load and the listed figures (a later list repeating a test repeats all of them)."""
    def r(x: float, n: int) -> float | None:
        return None if math.isnan(x) else round(x, n)
    return (t.vehicle_id, t.procedure_code, r(t.fe, 2), tuple(r(b, 3) for b in t.bags),
            r(t.mass_kg, 1), r(t.target_a_n, 2), r(t.target_b_n_per_mps, 4),
            r(t.target_c_n_per_mps2, 5))


def repeated_calibration_tests(tests: list[EpaTest], calibrated: dict[str, list[str]],
                               reference: list[EpaTest]) -> tuple[dict[str, str], list[str]]:
    """Tests without a number that repeat a calibration test, and those that cannot be told.

    Parameters
    ----------
    tests : list of EpaTest
        The selected tests.
    calibrated : dict
        Test id -> calibrated parameters (:func:`calibration_tests` of the vehicle).
    reference : list of EpaTest
        Every test read from the lists (where the calibration tests are looked up).

    Returns
    -------
    repeats : dict
        Label of a test without a number -> id of the calibration test it repeats.
    unknown : list of str
        Labels of tests without a number that repeat no calibration test found in
        ``reference`` while some calibration test is not there: they may be one.
    """
    if not calibrated:
        return {}, []
    found = {t.test_number: t for t in reference if t.test_number in calibrated}
    keys = {_row_key(t): n for n, t in found.items()}
    repeats: dict[str, str] = {}
    unknown: list[str] = []
    for t in tests:
        if t.test_number:
            continue
        same = keys.get(_row_key(t))
        if same is not None:
            repeats[t.label] = same
        elif len(found) < len(calibrated):
            unknown.append(t.label)
    return repeats, unknown


def validate_tests(vehicle: Vehicle | str | Path, tests: list[EpaTest],
                   dt: float = 0.2, reference: list[EpaTest] | None = None,
                   model_uncertainty: str = "none", draws: int = 200) -> EpaValidation:
    """Simulate every test that the model can run; name, skip and count the others.

    Parameters
    ----------
    vehicle : Vehicle, name or path
        One vehicle file for every test (only weight and road load change per test).
    tests : list of EpaTest
        Selected tests (:func:`vehval.epa.select.apply_selector`).
    dt : float
        Simulation step [s].
    reference : list of EpaTest, optional
        Every test of the lists read (default ``tests``): where the calibration tests of the
        vehicle file are looked up for the tests without a number
        (:func:`repeated_calibration_tests`).
    model_uncertainty : str
        How U_model of the normalised error is found (:func:`vehval.epa.verdicts.judge`):
        ``linear``, ``monte_carlo`` (``draws`` draws) or ``none`` (U_model = 0, no extra
        runs: the default, for callers that only need the errors).
    """
    check_model_u(model_uncertainty, draws)
    veh = load_vehicle(vehicle)
    # the tests on the vehicle's fuel: a diesel's on diesel, any other's on gasoline
    fuel = resolve_fuel(vehicle=veh)
    fuel_name = ("diesel" if fuel is not None and fuel_family(fuel.name) == "diesel"
                 else "gasoline")
    cold_model = has_cold_start_model(veh)
    res = EpaValidation(vehicle=veh.name, calibrated=calibration_tests(veh))
    res.repeats, res.sample_unknown = repeated_calibration_tests(
        tests, res.calibrated, tests if reference is None else reference)
    for label, same in res.repeats.items():
        res.calibrated[label] = res.calibrated[same]
    progress.add(len(tests))
    for t in tests:
        proc, why = plan_for(t, fuel_name)
        progress.advance()
        if proc is None:
            res.skipped.append({"test": t.label, "vehicle_id": t.vehicle_id,
                                "procedure": procedure_key(t),
                                "description": t.procedure, "reason": why})
            continue
        pred = predict_test(veh, t, proc, dt)
        pred.list_check = check_listed_figures(t)
        pred.vehicle_check = check_vehicle_match(t, veh)
        res.predictions.append(pred)
        rows = _compare(pred, proc, cold_model)
        if not pred.list_check.ok:  # the list contradicts itself: listed, not judged
            for c in rows:
                c.judged, c.list_doubtful = False, True
                c.note = f"list figures doubtful: {pred.list_check.note}"
        if t.analytically_derived:  # computed by the list from another test: not a measurement
            for c in rows:
                c.judged, c.analytically_derived = False, True
                c.note = derived_note(t)
        for c in rows:
            c.in_sample = t.label in res.calibrated
            c.sample_unknown = t.label in res.sample_unknown
        res.comparisons.extend(rows)
    simulated = {p.test.label for p in res.predictions}
    res.sample_unknown = [k for k in res.sample_unknown if k in simulated]
    for k in [k for k in res.repeats if k not in simulated]:
        del res.repeats[k], res.calibrated[k]
    judge(res, veh, tests if reference is None else reference, method=model_uncertainty,
          draws=draws)
    return res


def none_runnable(val: EpaValidation, tests: str) -> None:
    """Refuse a selection of which the simulator can run no test (InputFileError naming the
    selector, what it matched and why each kind cannot run)."""
    from collections import Counter

    from vehval.errors import InputFileError

    by_reason: dict[str, Counter] = {}
    for sk in val.skipped:
        by_reason.setdefault(sk["reason"], Counter())[sk["description"]] += 1
    kinds = "; ".join(", ".join(f"{n} {d}" for d, n in c.items()) + f": {why}"
                      for why, c in by_reason.items())
    runnable = {"ftp75", "hwfet", "us06"}
    hint = ("select FTP-75, HWFET or US06 tests, e.g. add procedure=ftp75"
            if any(sk["procedure"] not in runnable for sk in val.skipped) else
            "select tests the list states on gasoline with their weight and road load")
    raise InputFileError(
        f"the selector '{tests}' matches {len(val.skipped)} test(s), none of which the "
        f"simulator can run ({kinds}); {hint}")
