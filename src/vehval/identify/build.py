"""Identify a conventional car from dyno tests and write it as a vehicle file.

:func:`identify_conventional` runs road load -> gears, converter and shifts -> fuel map on
the given traces and returns an :class:`Identification` whose ``vehicle`` is a validated
:class:`~vehval.vehicle.ConventionalVehicle`. Every identified value's ``sources`` entry
names the tests it came from and its fit quality; values the data cannot give (full-load
curve above the measured envelope, inertias, efficiencies) name their documented source.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import yaml

from vehval.constants import RPM_RAD_PER_S as RPM
from vehval.fuels import known_fuels, resolve_fuel, table_fuel
from vehval.identify.conditions import identification_conditions, in_standard_cell, off_standard
from vehval.identify.fuelmap import ETA_MAX, FuelMapFit, engine_power
from vehval.identify.gears import (
    GearFit,
    assign_gears,
    converter_capacity,
    find_gears,
    lockup_speeds,
    shift_events,
    shift_lines,
)
from vehval.identify.losses import DragFit, fit_ac_load, fit_drag
from vehval.identify.roadload import RoadLoadFit, fit_road_load
from vehval.identify.spec import Assumptions, resolve
from vehval.identify.traces import IdentificationError, Trace, dead_fuel_channel
from vehval.identify.uncertainty import coverage_grid
from vehval.identify.warmup import WarmupFit, cold_start_state, fit_warmup, hot_partner
from vehval.io.atomic import write_text_atomic
from vehval.vehicle import ConventionalVehicle

MIN_DRIVE_S = 600.0  # [s] of moving data needed in total


@dataclass
class Identification:
    """Result of :func:`identify_conventional`."""

    vehicle: ConventionalVehicle = field(init=False)  # built from the fits' summary
    road_load: RoadLoadFit
    gears: GearFit
    fuel_map: FuelMapFit
    traces: list[Trace]
    gear_ratio_check: list[dict]
    shifts: list[tuple]
    drag: DragFit | None = None
    ac: dict | None = None
    warmup: WarmupFit | None = None
    assumptions: Assumptions | None = None
    coverage: dict | None = None
    conditions: dict | None = None
    #: tests left out of the fuel map, with why (:func:`.traces.dead_fuel_channel`)
    fuel_left_out: dict = field(default_factory=dict)

    def summary(self) -> dict:
        return {"assumptions": None if self.assumptions is None else self.assumptions.provenance,
                "coverage": self.coverage, "conditions": self.conditions,
                "tests": [t.test_id for t in self.traces], "fuel_left_out": self.fuel_left_out,
                "road_load": self.road_load.to_dict(),
                "gears": self.gears.to_dict(), "gear_ratio_check": self.gear_ratio_check,
                "fuel_map": self.fuel_map.to_dict(), "n_shifts": len(self.shifts),
                "drag": None if self.drag is None else self.drag.to_dict(), "ac": self.ac,
                "warmup": None if self.warmup is None else self.warmup.to_dict()}


def _check_inputs(traces: list[Trace]) -> None:
    if not traces:
        raise IdentificationError("identify: no test given")
    moving = sum(float(np.count_nonzero(t.v > 1.0)) * t.dt for t in traces)
    if moving < MIN_DRIVE_S:
        names = ", ".join(t.test_id for t in traces)
        raise IdentificationError(
            f"identify: {names} has only {moving:.0f} s of driving; the engine map needs at "
            f"least {MIN_DRIVE_S:.0f} s (give a longer test or a second one)")


def _fuel_table(fm: FuelMapFit, a: Assumptions):
    spd = [600.0, 750.0] + list(np.arange(1000.0, a.max_speed_rpm + 1, 250.0))
    trq = list(np.arange(0.0, max(a.full_load_nm) + 21, 20.0))
    table = [[round(float(fm.rate(np.array(s * RPM), np.array(t * s * RPM))) * 1e3, 5)
              for t in trq] for s in spd]
    tmax = list(np.interp(spd, a.full_load_rpm, a.full_load_nm))
    return [float(x) for x in spd], [float(x) for x in trq], table, [float(x) for x in tmax]


def _engine_fuel(trace: Trace, a: Assumptions) -> tuple[dict, dict]:
    """The engine's fuel keys and their sources: the test fuel (:func:`resolve_fuel` of the
    test: template ``fuel:``, else its constants), named when it is a fuel of the table."""
    fuel = trace.test_fuel or resolve_fuel(constants=trace.constants)
    rho = a.fuel_density_kg_per_m3 or (fuel.density_kg_per_m3 if fuel is not None else None)
    lhv = a.fuel_lhv_j_per_kg or (fuel.lhv_j_per_kg if fuel is not None else None)
    if not rho or not lhv:
        have = f"the fuel of the {fuel.origin} gives no " + (
            "density" if not rho else "LHV") if fuel is not None else "no fuel is declared"
        raise IdentificationError(f"identify: {trace.test_id}: {have}; declare the test fuel "
                                  "in the template ('fuel: diesel', a name of the fuel table, "
                                  "or constants fuel_density_kg_per_m3 and fuel_lhv_j_per_kg)")
    if fuel is not None and fuel.name in known_fuels():
        keys: dict = {"fuel": fuel.name}
        srcs = {"fuel": f"{fuel.origin} {fuel.name} (the test fuel)"}
        table = table_fuel(fuel.name)
        for key, prop, v in (("fuel_density_kg_per_m3", "density_kg_per_m3", rho),
                             ("fuel_lhv_j_per_kg", "lhv_j_per_kg", lhv)):
            if v != getattr(table, prop):
                keys[key] = float(v)
                srcs[key] = "given for the test, over the fuel table's"
        return keys, srcs
    return ({"fuel_density_kg_per_m3": float(rho), "fuel_lhv_j_per_kg": float(lhv)},
            {"fuel_density_kg_per_m3": "template constant (test fuel)",
             "fuel_lhv_j_per_kg": "template constant (test fuel)"})


def _gear_ratio_check(traces: list[Trace], gears: list[np.ndarray], locks: list[np.ndarray],
                      ratios: np.ndarray, rw: float) -> list[dict]:
    """Per gear: the identified ratio against the median of the locked samples [-]."""
    check = []
    for k, r in enumerate(ratios):
        rr = np.concatenate([t.w_eng[(g == k + 1) & lk] * rw / t.v[(g == k + 1) & lk]
                             for t, g, lk in zip(traces, gears, locks)])
        check.append({"gear": k + 1, "identified": float(r),
                      "data_median": float(np.median(rr)) if rr.size else None,
                      "rel_diff": float(np.median(rr) / r - 1) if rr.size else None,
                      "locked_samples": int(rr.size)})
    return check


def _body(rl: RoadLoadFit, tests: str, q: str) -> dict:
    """The ``body`` section: identified mass and road load with their 95 % intervals."""
    rv, ci = rl.values, rl.ci95
    return {
        "mass_kg": rv["mass_kg"], "road_load_a_n": rv["road_load_a_n"],
        "road_load_b_n_per_mps": rv["road_load_b_n_per_mps"],
        "road_load_c_n_per_mps2": max(rv["road_load_c_n_per_mps2"], 0.0),
        "aux_power_w": 0.0,
        "sources": {
            "mass_kg": f"identified (effective inertia) from {tests}: ±{ci['mass_kg']:.1f} kg (95 %), {q}",
            "road_load_a_n": f"identified from {tests}: ±{ci['road_load_a_n']:.1f} N (95 %), {q}",
            "road_load_b_n_per_mps": f"identified from {tests}: ±{ci['road_load_b_n_per_mps']:.2f} (95 %), {q}",
            "road_load_c_n_per_mps2": f"identified from {tests}: ±{ci['road_load_c_n_per_mps2']:.3f} (95 %), {q}",
            "aux_power_w": "engine-driven accessories are in engine_control.accessory_power_w",
        }}


def _engine_control(fm: FuelMapFit, a: Assumptions, tests: str, fq: str) -> dict:
    """The ``engine_control`` section: idle, fuel cut and overrun from the fuel model."""
    return {
        "idle_fuel_rate_g_per_s": fm.idle_fuel_kg_s * 1e3,
        "fuel_cut_min_speed_rpm": fm.fuel_cut_speed_rad_s / RPM,
        "overrun_fuel_rate_g_per_s": fm.overrun_fuel_kg_s * 1e3,
        "accessory_power_w": a.accessory_power_w,
        "ac_power_w": 0.0,
        "sources": {
            "ac_power_w": "no A/C test given: no A/C model",
            "idle_fuel_rate_g_per_s": f"identified (standing state of the fuel model) from {tests}: {fq}",
            "fuel_cut_min_speed_rpm": f"identified (best R² over 1.05-2 x idle) from {tests}",
            "overrun_fuel_rate_g_per_s": f"identified (overrun state of the fuel model) from {tests}",
            "accessory_power_w": a.source("accessory_power_w"),
        }}


def _driveline_and_driver(rw: float, a: Assumptions) -> dict:
    """The ``driveline`` and ``driver`` sections (engineering choices and the EPA tolerances)."""
    return {
        "driveline": {
            "final_drive_ratio": 1.0, "final_drive_efficiency": 1.0, "wheel_radius_m": rw,
            "wheel_inertia_kg_m2": 0.0, "brake_max_force_n": 15000.0,
            "sources": {
                "final_drive_ratio": "1: the identified gear ratios are engine-to-wheel ratios (the data cannot separate the final drive)",
                "final_drive_efficiency": "1: losses are in gearbox.efficiency",
                "wheel_radius_m": a.source("wheel_radius_m"),
                "wheel_inertia_kg_m2": "0: rotating inertia is in the identified effective mass",
                "brake_max_force_n": "engineering estimate: about 0.9 g at the test mass",
            }},
        "driver": {
            "response_time_s": 0.5, "ki_n_per_m": 50.0, "integrator_limit_n": 1500.0,
            "max_force_n": 12000.0, "tolerance_speed_mph": 2.0, "tolerance_time_s": 1.0,
            "sources": {
                "response_time_s": "engineering choice: speed errors corrected within about 0.5 s",
                "ki_n_per_m": "engineering choice", "integrator_limit_n": "engineering choice",
                "max_force_n": "engineering bound above the powertrain's tractive force",
                "tolerance_speed_mph": "EPA 40 CFR 86.115-78: ±2 mph",
                "tolerance_time_s": "EPA 40 CFR 86.115-78: within ±1 s",
            }},
    }


def _add_warmup(result: Identification, cold_trace: Trace, traces: list[Trace]) -> None:
    """The warm-up fuel of a cold start (:mod:`vehval.identify.warmup`) into the vehicle."""
    wf = result.warmup = fit_warmup(cold_trace, hot_partner(cold_trace, traces))
    eng = result.vehicle.engine
    eng.warmup_fuel_fraction = wf.fraction
    eng.warmup_time_constant_s = wf.time_constant_s
    eng.sources["warmup_fuel_fraction"] = eng.sources["warmup_time_constant_s"] = (
        wf.provenance())
    result.vehicle.identification = _jsonable(result.summary())


def _add_ac(result: Identification, ac_trace: Trace) -> None:
    """The A/C load of a test run with the A/C on into the vehicle."""
    ac = result.ac = fit_ac_load(result.vehicle, ac_trace)
    ctl = result.vehicle.engine_control
    ctl.ac_power_w = ac["ac_power_w"]
    ctl.sources["ac_power_w"] = (
        f"identified from {ac['test']} (A/C on), phases {', '.join(map(str, ac['phases']))}: "
        f"constant compressor power with which the model driving that test burns the "
        f"measured {ac['fuel_measured_g']:.1f} g (without it {ac['fuel_model_without_ac_g']:.1f} g)")
    result.vehicle.identification = _jsonable(result.summary())


def _cold_among(traces: list[Trace], left_out: dict[str, str],
                warm: list[Trace]) -> Trace | None:
    """A cold start among ``traces`` to identify the warm-up from (no ``--cold-test`` given):
    the first test left out of the warm map as a cold start in a standard cell, with fuel and
    a warm test of its cycle among ``warm``; None when there is none."""
    for t in traces:
        if (t.test_id in left_out and cold_start_state(t)[0] and in_standard_cell(t)
                and not dead_fuel_channel(t)
                and any(w.cycle and w.cycle == t.cycle for w in warm)):
            return t
    return None


def _fuel_traces(traces: list[Trace], gears: list[np.ndarray]
                 ) -> tuple[list[tuple[Trace, np.ndarray]], dict[str, str], str]:
    """The (trace, gears) pairs that fit the warm fuel map, the tests left out with why and
    the provenance text naming both. Left out: a test without fuel
    (:func:`.traces.dead_fuel_channel`), and, when the tests hold at least one standard warm
    test, every other test (:func:`.conditions.off_standard`: a cold start, a cell outside
    20-30 °C). Refused when no test has a fuel rate."""
    dead = {t.test_id: why for t in traces if (why := dead_fuel_channel(t))}
    if len(dead) == len(traces):
        raise IdentificationError("identify: no test with a fuel rate to fit the engine map: "
                                  + "; ".join(dead.values())
                                  + ": check that the fuel meter's channel is recorded and "
                                  "mapped to fuel_rate_test in the template")
    off = {t.test_id: why for t in traces if t.test_id not in dead and (why := off_standard(t))}
    if len(dead) + len(off) < len(traces):
        dead |= off
    fueled = [(t, g) for t, g in zip(traces, gears) if t.test_id not in dead]
    names = ", ".join(t.test_id for t, _ in fueled) + (
        f" (left out: {'; '.join(dead.values())})" if dead else "")
    return fueled, dead, names


def identify_conventional(traces: list[Trace], name: str = "identified_car",
                          assumptions: Assumptions | None = None, ac_trace: Trace | None = None,
                          cold_trace: Trace | None = None, declared: dict | None = None,
                          drag_evidence: bool = True) -> Identification:
    """Identify road load, gearbox, converter, shift schedule, driveline drag and fuel map
    from ``traces``; with ``cold_trace`` (a cold start on the cycle of one of ``traces``; else
    one among ``traces``, :func:`_cold_among`) the warm-up fuel
    (:mod:`vehval.identify.warmup`); with ``ac_trace`` (a test run with the A/C
    on) the A/C load, its model starting cold when that test does. What the data cannot
    separate comes from ``assumptions``, else from ``declared`` (:func:`.spec.load_spec`)
    and the generic scaling of :func:`.spec.resolve`."""
    _check_inputs(traces)
    fuel = traces[0].test_fuel or resolve_fuel(constants=traces[0].constants)
    a = assumptions or resolve(declared or {}, None if fuel is None else fuel.name,
                               _wheel_power_max(traces),
                               None if fuel is None else fuel.density_kg_per_m3)
    fuel_keys, fuel_sources = _engine_fuel(traces[0], a)
    tests = ", ".join(t.test_id for t in traces)
    rw = a.wheel_radius_m
    rl = fit_road_load(traces)
    gf = find_gears(traces, rw, a.gears)
    gl = [assign_gears(t, gf.ratios, rw, gf.locked_in_data[0]) for t in traces]
    gears, locks = [g for g, _ in gl], [lk for _, lk in gl]
    idle_w = float(np.median(np.concatenate([t.w_eng[(t.v < 0.05) & (t.w_eng > 30)]
                                             for t in traces])))
    v_cap = float(max(t.v.max() for t in traces)) + 10.0
    lock_v, lock_how = lockup_speeds(traces, gears, locks, len(gf.ratios), v_cap, gf.ratios, rw,
                                    gf.locked_in_data)
    k_tc, n_k = converter_capacity(traces, gears, locks, gf.ratios, rw, a.gearbox_efficiency,
                                   rl.lag_s)
    events = [e for t, g, lk in zip(traces, gears, locks)
              for e in shift_events(t, g, a.max_power_w, rl.lag_s, lk)]
    uz, uf, dz, df = shift_lines(events, gf.ratios, v_cap, a.max_speed_rpm * RPM, rw)
    shift_dur = _shift_time(traces, gears, locks)

    def power(t, g, drag):
        return engine_power(t, g, gf.ratios, rw, a.gearbox_efficiency, rl.lag_s,
                            a.accessory_power_w, a.engine_inertia_kg_m2, drag)

    fueled, dead, fuel_tests = _fuel_traces(traces, gears)
    cold_trace = cold_trace or _cold_among(traces, dead, [t for t, _ in fueled])
    drag, fm = fit_drag([t for t, _ in fueled], lambda d: [power(t, g, d) for t, g in fueled],
                        idle_w, rl.values["road_load_a_n"], rl.values["road_load_b_n_per_mps"],
                        a.driven_axle_loss_share, drag_evidence,
                        {"max_speed_rad_s": a.max_speed_rpm * RPM,
                         "lhv_j_per_kg": a.fuel_lhv_j_per_kg
                         or (None if fuel is None else fuel.lhv_j_per_kg)})
    pw = fm.points["p"]
    a.floor_full_load(float(np.percentile(pw / np.maximum(fm.points["w"], 1.0), 99.5)))
    spd, trq, table, tmax = _fuel_table(fm, a)
    check = _gear_ratio_check(traces, gears, locks, gf.ratios, rw)
    q = f"R² {rl.r2:.4f}, RMSE {rl.rmse_n:.0f} N, force lag {rl.lag_s:+.2f} s"
    fq = (f"R² {fm.r2:.3f} (10 Hz), {fm.r2_5s:.3f} (5 s means); meter delay {fm.delay_s:.1f} s,"
          f" lag {fm.tau_s:.1f} s")
    ratio_src = "; ".join(
        f"{i + 1}: {'cluster of ' + str(n) + ' locked samples, IQR ' + format(sp * 100, '.2f') + ' %' if lk else 'never locked: median launch ratio (converter slip included, upper bound)'}"
        for i, (n, sp, lk) in enumerate(zip(gf.samples, gf.spread, gf.locked_in_data)))
    veh = {
        "architecture": "conventional", "name": name,
        "description": f"identified by vehval from {tests}",
        "body": _body(rl, tests, q),
        "engine": {
            "speed_rpm": spd, "torque_nm": trq, "fuel_rate_g_per_s": table,
            "max_torque_nm": tmax, "max_power_w": a.max_power_w,
            "max_speed_rpm": a.max_speed_rpm, "idle_speed_rpm": idle_w / RPM,
            "fire_speed_rpm": 0.5 * idle_w / RPM, "motoring_torque_nm": a.motoring_torque_nm,
            "inertia_kg_m2": a.engine_inertia_kg_m2, **fuel_keys,
            "sources": {
                "speed_rpm": "grid chosen to cover idle to the maximum speed",
                "torque_nm": "grid chosen to cover the full-load curve",
                "fuel_rate_g_per_s": f"identified Willans surface (fuel = c0 + c1 w + c2 w² + (d0 + d1 w) P + e P², bounded up to the maximum speed: zero-power fuel not falling with speed, fuel per power at least 1 / ({ETA_MAX:g} LHV)) from {fuel_tests}: {fq}; measured engine power {fm.power_range_w[0] / 1e3:.1f}-{fm.power_range_w[1] / 1e3:.1f} kW, beyond it extrapolated",
                "max_torque_nm": a.source("full_load"),
                "max_power_w": a.source("rated_power_kw"),
                "max_speed_rpm": a.source("max_speed_rpm"),
                "idle_speed_rpm": f"identified: median engine speed standing still in {tests}",
                "fire_speed_rpm": "half the idle speed (not used: the engine never stops)",
                "motoring_torque_nm": a.source("motoring_torque_nm"),
                "inertia_kg_m2": a.source("engine_inertia_kg_m2"),
                **fuel_sources,
            }},
        "engine_control": _engine_control(fm, a, fuel_tests, fq),
        "gearbox": {
            "ratios": [float(r) for r in gf.ratios], "efficiency": a.gearbox_efficiency,
            "upshift_speed_mps": uz, "upshift_speed_full_load_mps": uf,
            "downshift_speed_mps": dz, "downshift_speed_full_load_mps": df,
            "shift_time_s": shift_dur,
            "drag_force_n": drag.force_n, "drag_force_n_per_mps": drag.force_n_per_mps,
            "sources": {
                "drag_force_n": f"from {fuel_tests} and the template's target coefficients: {drag.note}; "
                                + a.source("driven_axle_loss_share"),
                "drag_force_n_per_mps": f"identified with drag_force_n from {tests}",
                "ratios": f"identified: engine-to-wheel speed ratio clusters in {tests} (final drive included); {ratio_src}",
                "efficiency": a.source("gearbox_efficiency"),
                "upshift_speed_mps": f"identified from {sum(1 for e in events if e[1] == e[0] + 1)} observed upshifts in {tests} (line of speed on load)",
                "upshift_speed_full_load_mps": "identified with upshift_speed_mps (extrapolated to full load)",
                "downshift_speed_mps": f"identified from {sum(1 for e in events if e[1] == e[0] - 1)} observed downshifts in {tests}",
                "downshift_speed_full_load_mps": "identified with downshift_speed_mps (extrapolated to full load)",
                "shift_time_s": f"identified: median duration of the ratio change at upshifts in {tests}",
            }},
        "converter": {
            "capacity_nm_s2_per_rad2": k_tc, "lockup_speed_mps": lock_v,
            "sources": {
                "capacity_nm_s2_per_rad2": f"identified: median of T / (w_e (w_e - w_t)) over {n_k} open-converter samples in {tests}",
                "lockup_speed_mps": f"per gear, speed above which the converter is locked (fewest misclassified samples) in {tests} ({v_cap:.0f} = never locked): " + ", ".join(f"{k + 1}: {h}" for k, h in enumerate(lock_how)) + " (assumed: the identified gears' median lock-up engine speed)",
            }},
        **_driveline_and_driver(rw, a),
    }
    result = Identification(road_load=rl, gears=gf, fuel_map=fm, traces=traces, fuel_left_out=dead,
                            gear_ratio_check=check, shifts=events, drag=drag, assumptions=a,
                            coverage=coverage_grid(fm.points["w"], fm.points["p"],
                                                   traces[0].dt),
                            conditions=identification_conditions(traces, cold_trace, ac_trace,
                                                                frozenset(dead)))
    veh["identification"] = _jsonable(result.summary())
    result.vehicle = ConventionalVehicle.model_validate(veh)
    if cold_trace is not None:
        _add_warmup(result, cold_trace, [t for t, _ in fueled])
    if ac_trace is not None:
        _add_ac(result, ac_trace)
    return result


def _wheel_power_max(traces: list[Trace]) -> float:
    """Highest wheel power [W] of ``traces`` (99.9th percentile of force x speed)."""
    return float(max(np.percentile(t.force * t.v, 99.9) for t in traces))


def _shift_time(traces, gears, locks) -> float:
    """Median time [s] from the last locked sample in a gear to the first in the next."""
    durs = []
    for t, g, lk in zip(traces, gears, locks):
        idx = np.nonzero(lk)[0]
        for i, j in itertools.pairwise(idx):
            if g[j] == g[i] + 1 and j - i > 1:
                durs.append((j - i) * t.dt)
    durs = [d for d in durs if d <= 3.0]
    return float(np.median(durs)) if durs else 0.5


def _jsonable(x):
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, (np.floating, float)):
        return float(x)
    if isinstance(x, (np.integer, int)) and not isinstance(x, bool):
        return int(x)
    return x


def write_vehicle(veh: ConventionalVehicle, path: str | Path) -> Path:
    """Write ``veh`` as a vehicle YAML file (atomically)."""
    data = _jsonable(veh.model_dump(exclude_none=True))
    text = ("# Conventional vehicle identified by vehval from chassis-dyno data.\n"
            "# Every value's source (tests, fit quality, or documented estimate) is under "
            "'sources:'.\n" + yaml.safe_dump(data, sort_keys=False, allow_unicode=True, width=100))
    path = Path(path)
    write_text_atomic(path, text)
    return path
