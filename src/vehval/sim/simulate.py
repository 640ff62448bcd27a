"""The simulator's front door: run a vehicle over a drive cycle or a test plan.

``simulate(vehicle, cycle)`` returns a :class:`SimResult` whose ``test`` holds the
``<base>_simu`` signals on the uniform grid (source ``simu``) and whose ``summary`` holds
fuel, distance, fuel economy (raw and SOC-corrected), SOC, engine use, trace following
and the energy balance.

Everything that runs a compiled loop goes through this module: the architecture registry
(:data:`ARCHITECTURES`, the vehicle file's ``architecture`` -> how to pack, run and
summarise it), the cold start (:attr:`Grid.cold_start`), the one charge balance
(:func:`charge_balance`, tolerance :data:`BALANCE_TOL`, at most :data:`BALANCE_MAX_ITER`
secant steps), single runs (:func:`run_cycle`) and test plans whose runs carry the battery
charge from one to the next (:func:`run_plan`, :func:`balanced_plan`,
:func:`plan_summary`). No module outside :mod:`vehval.sim` touches the kernels, their
packing or their layouts.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

import numpy as np

from vehval.cycles import Cycle, load_cycle
from vehval.errors import ConfigError
from vehval.fuels import fuel_consumption_l_per_100km, fuel_economy_mpg, fuel_volume_m3
from vehval.numba_cache import compile_notice
from vehval.sim.bev import bev_maps, bev_param_vector, summarise_bev
from vehval.sim.bev_kernel import run_bev
from vehval.sim.conventional import conv_maps, conv_param_vector, summarise_conventional
from vehval.sim.conventional_kernel import CONV_SIGNALS, CONV_SUMMARY, run_conventional
from vehval.sim.grid import Grid, check_dt, cycle_grid, make_grid, time_grid
from vehval.sim.kernel import run
from vehval.sim.layout import BEV_SIGNALS, BEV_SUMMARY, SIGNALS, SUMMARY
from vehval.sim.packing import pack
from vehval.sim.parallel import par_maps, par_param_vector, summarise_parallel
from vehval.sim.parallel_kernel import PAR_SIGNALS, PAR_SUMMARY, run_parallel
from vehval.test import Signal, Test, TestMeta
from vehval.vehicle import Vehicle, load_vehicle
from vehval.vehicle.maps import best_line_efficiency

__all__ = ["ARCHITECTURES", "BALANCE_MAX_ITER", "BALANCE_TOL", "CHARGE_BALANCE_TOL",
           "Architecture", "Grid", "SimResult", "architecture", "balanced_plan",
           "charge_balance", "check_dt", "physics_warnings", "cycle_grid", "make_grid", "plan_summary",
           "run_cycle", "run_once", "run_plan", "simulate", "summarise", "time_grid"]

CHARGE_BALANCE_TOL = 0.005  # [-] |SOC_end - SOC_start| accepted by charge_balance
#: [-] |SOC_end - SOC_start| the charge-balance iteration aims at (inside the accepted
#: tolerance; the J1711 basis of an EPA comparison)
BALANCE_TOL = 0.002
#: secant steps of the charge balance after the first run, at most
BALANCE_MAX_ITER = 12
_check_dt = check_dt  # former name, kept for callers


@dataclass
class SimResult:
    """Result of one simulation.

    Attributes
    ----------
    test : Test
        ``<base>_simu`` signals (SI, source ``simu``) on the uniform time grid.
    summary : dict
        Scalar results (see :func:`summarise`).
    vehicle : Vehicle
        The vehicle actually simulated (overrides applied).
    cycle : Cycle
        The drive cycle.
    dt : float
        Step [s].
    """

    test: Test
    summary: dict[str, Any]
    vehicle: Vehicle
    cycle: Cycle
    dt: float
    iterations: list[tuple[float, float]] = field(default_factory=list)

    def frame(self):
        """The signals as a pandas DataFrame indexed by time [s]."""
        import pandas as pd
        first = next(iter(self.test))
        return pd.DataFrame({s.name: s.values for s in self.test},
                            index=pd.Index(first.time, name="time"))


def run_once(veh: Vehicle, t: np.ndarray, vt: np.ndarray, dt: float, soc0: float,
             record: bool = True, cold_start: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Run the compiled loop once; returns (signals[n, len(signals)], summary vector).
    ``cold_start``: the run starts with a cold engine (the vehicle's cold-start model)."""
    return run_cycle(veh, make_grid(veh, t, vt, dt, cold_start), soc0, record)


def energy_balance_fuel_kg(fuel_kg: float, battery_j: float, lhv_j_per_kg: float,
                           engine_efficiency: float, path_efficiency: float) -> float:
    """The simulator's SOC correction, the **energy-balance correction** [kg].

    The net battery energy ``battery_j`` (chemical, positive when discharged) is converted
    to the fuel the engine would have burned to supply it through the path:
    ``m + ΔE / (LHV · η_eng · η_path)``, never below zero. It applies to every run, however
    small ``ΔE``, with the run's own engine efficiency: a model's energy bookkeeping.

    It is not the results stage's **SAE J1711 NEC correction**
    (:func:`vehval.results.soc.soc_correction`) of a measured test, which leaves a result
    within 1 % net energy change uncorrected and otherwise corrects with a stated
    charge-balance factor or a regression over several tests. The summary keys
    ``*_soc_corrected_*`` of a simulation hold this energy-balance correction.
    """
    return max(fuel_kg + battery_j / (lhv_j_per_kg * engine_efficiency * path_efficiency), 0.0)


def summarise(veh: Vehicle, ys: np.ndarray, soc0: float) -> dict[str, Any]:
    """Summary dict from the accumulator vector of :func:`vehval.sim.kernel.run`.

    The SOC-corrected fuel economy is the energy-balance correction
    (:func:`energy_balance_fuel_kg`, docs/simulation.md), with ``η_eng`` the cycle-average
    engine efficiency (the best-line efficiency when the engine did not run) and ``η_path``
    the engine-to-battery path efficiency of the vehicle file.
    """
    s = {k: float(v) for k, v in zip(SUMMARY, ys)}
    e = veh.engine
    rho, lhv = e.fuel_density_kg_per_m3, e.fuel_lhv_j_per_kg
    dist = s["distance_m"]
    fuel = s["fuel_mass_kg"]

    def mpg(mass_kg: float) -> float:
        return fuel_economy_mpg(dist, fuel_volume_m3(mass_kg, rho), empty=float("inf"))

    def l100(mass_kg: float) -> float:
        return fuel_consumption_l_per_100km(fuel_volume_m3(mass_kg, rho), dist)

    eta_eng = s["eng_out_energy_j"] / s["fuel_energy_j"] if s["fuel_energy_j"] > 0 else 0.0
    if eta_eng <= 0.0:  # no engine use: the best efficiency on the engine's line
        eta_eng = best_line_efficiency(veh.engine, veh.best_line)
    d_e = s["ess_chem_energy_j"]
    fuel_corr = energy_balance_fuel_kg(fuel, d_e, lhv, eta_eng,
                                       veh.controller.soc_correction_path_efficiency)
    sinks = (s["eng_loss_j"] + s["mot_loss_j"] + s["gen_loss_j"] + s["boost_loss_j"]
             + s["aux_energy_j"] + s["ess_loss_j"] + s["fd_loss_j"] + s["brake_energy_j"]
             + s["road_energy_j"] + s["lock_loss_j"] + s["ke_end_j"] - s["ke_start_j"])
    sources = s["fuel_energy_j"] + s["ess_chem_energy_j"] + s["unmet_energy_j"]
    scale = max(s["fuel_energy_j"] + abs(s["ess_chem_energy_j"]), s["road_energy_j"], 1.0)
    dur = s["duration_s"]
    s.update({
        "distance_m": dist,
        "fuel_economy_mpg": mpg(fuel),
        "fuel_consumption_l_per_100km": l100(fuel),
        "soc_initial": float(soc0),
        "soc_delta": s["soc_final"] - soc0,
        "ess_net_energy_j": d_e,
        "engine_mean_efficiency": float(eta_eng),
        "fuel_mass_soc_corrected_kg": fuel_corr,
        "fuel_economy_soc_corrected_mpg": mpg(fuel_corr),
        "fuel_consumption_soc_corrected_l_per_100km": l100(fuel_corr),
        "engine_on_fraction": s["eng_on_time_s"] / dur if dur > 0 else 0.0,
        "engine_starts": int(round(s["engine_starts"])),
        "trace_n_miss": int(round(s["trace_n_miss"])),
        "state_switches": int(round(s["state_switches"])),
        "energy_balance_residual_j": sources - sinks,
        "energy_balance_rel": (sources - sinks) / scale,
    })
    return s


def simulate(vehicle: Any, cycle: Cycle | str | Path, dt: float = 0.1,
             soc_initial: float | None = None, charge_balance: bool = False,
             cold_start: bool = False, **overrides: Any) -> SimResult:
    """Simulate ``vehicle`` over ``cycle``.

    Parameters
    ----------
    vehicle : Vehicle, name or path
        Vehicle (see :func:`vehval.vehicle.load_vehicle`).
    cycle : Cycle, name or path
        Drive cycle (see :func:`vehval.cycles.load_cycle`).
    dt : float
        Step [s], in (0, 1].
    soc_initial : float, optional
        Initial SOC [-]; default the controller's SOC target.
    charge_balance : bool
        Iterate the initial SOC (secant method) until the final SOC is within 0.5 % SOC
        of the initial one; ``summary['charge_balance_iterations']`` tells how many runs.
    cold_start : bool
        Start with a cold engine: the vehicle's cold-start model applies (warm-up fuel
        ``engine.warmup_*``; a hybrid also holds the engine on for
        ``controller.cold_start_engine_on_s``).
    **overrides
        Parameter overrides by dotted path, e.g. ``**{"controller.soc_target": 0.55}``
        or ``controller__soc_target=0.55``.
    """
    veh = load_vehicle(vehicle).with_overrides(overrides)
    cyc = load_cycle(cycle)
    dt = check_dt(dt)
    grid = cycle_grid(veh, cyc, dt, cold_start)
    if grid.t.size < 2:
        raise ConfigError(f"cycle '{cyc.name}' is shorter than one step of {dt:g} s")
    arch = architecture(veh)
    iters: list[tuple[float, float]] = []
    soc0 = float("nan")
    if arch.has_battery:
        bt = veh.battery
        soc0 = arch.start_soc(veh) if soc_initial is None else float(soc_initial)
        if not (bt.soc_min <= soc0 <= bt.soc_max):
            raise ConfigError(f"soc_initial = {soc0:g} is outside the battery window "
                              f"[{bt.soc_min:g}, {bt.soc_max:g}] of {veh.file or veh.name}")
        if charge_balance and not arch.charge_sustaining:
            raise ConfigError(f"{veh.file or veh.name}: charge balance applies to a "
                              f"charge-sustaining hybrid; a {arch.name} vehicle runs "
                              "charge-depleting (drop --charge-balance)")
        if charge_balance:
            soc0, _, iters = balanced_plan(veh, [grid], soc0, record=False)
    out, ys = arch.run(veh, grid, soc0, True)
    summary = arch.summarise(veh, ys, soc0)
    summary.update({"vehicle": veh.name, "cycle": cyc.name, "dt_s": dt})
    if arch.has_battery:
        summary.update({"charge_balanced": bool(charge_balance and abs(summary["soc_delta"])
                                                <= CHARGE_BALANCE_TOL),
                        "charge_balance_iterations": len(iters)})
    else:
        summary["architecture"] = arch.name
    summary["cold_start"] = bool(cold_start)
    summary["warnings"] = physics_warnings(summary)
    meta = TestMeta(test_id=f"simu_{veh.name}_{cyc.name}", vehicle=veh.name, cycle=cyc.name,
                    notes=[f"vehval {arch.label}, dt = {dt:g} s"], synthetic=True)
    test = Test(meta=meta)
    for k, base in enumerate(arch.signals):
        test.add(Signal.standard(f"{base}_simu", grid.t, out[:, k], source="simu"))
    return SimResult(test=test, summary=summary, vehicle=veh, cycle=cyc, dt=dt, iterations=iters)


# ------------------------------------------------------------------ architectures


@dataclass(frozen=True)
class Architecture:
    """How the front door runs one powertrain architecture.

    Attributes
    ----------
    name : str
        The vehicle file's ``architecture`` value.
    label : str
        What the simulated test's notes call the run.
    signals, summary_keys : tuple of str
        Columns of the recorded signals and entries of the summary vector of its loop.
    run : callable
        ``run(vehicle, grid, soc0, record) -> (signals, summary vector)``: pack the vehicle
        (with the grid's cold start) and run the compiled loop once.
    summarise : callable
        ``summarise(vehicle, summary vector, soc0) -> dict``.
    cold_start_model : callable
        ``cold_start_model(vehicle) -> bool``: whether a cold start differs from a hot one.
    soc_final : int or None
        Summary index of the final SOC [-]; None for a powertrain without a battery.
    charge_sustaining : bool
        Whether the battery is charge-sustaining (a hybrid: charge balance applies); a
        battery-electric car runs charge-depleting.
    initial_soc : callable or None
        ``initial_soc(vehicle) -> SOC [-]`` a run starts from by default; None: the
        controller's SOC target (a hybrid).
    """

    name: str
    label: str
    signals: tuple[str, ...]
    summary_keys: tuple[str, ...]
    run: Callable[[Any, Grid, float, bool], tuple[np.ndarray, np.ndarray]]
    summarise: Callable[[Any, np.ndarray, float], dict[str, Any]]
    cold_start_model: Callable[[Any], bool]
    soc_final: int | None = None
    charge_sustaining: bool = True
    initial_soc: Callable[[Any], float] | None = None

    def start_soc(self, veh: Any) -> float:
        """The SOC [-] a run of ``veh`` starts from by default."""
        if self.initial_soc is not None:
            return float(self.initial_soc(veh))
        return float(veh.controller.soc_target)

    @property
    def has_battery(self) -> bool:
        """Whether the powertrain has a traction battery (SOC, charge balance)."""
        return self.soc_final is not None

    @property
    def column(self) -> dict[str, int]:
        """Signal base name -> column of the recorded signals."""
        return {n: i for i, n in enumerate(self.signals)}


def _run_power_split(veh: Vehicle, grid: Grid, soc0: float,
                     record: bool) -> tuple[np.ndarray, np.ndarray]:
    p = pack(veh, soc0, grid.cold_start)
    compile_notice("kernel", "run", "power-split simulation kernel")
    out = np.zeros((grid.t.size if record else 1, len(SIGNALS)))
    return out, run(grid.vt, grid.lo, grid.hi, grid.dt, p.prm, p.maps, out, record)


def _run_conventional(veh: Any, grid: Grid, soc0: float,
                      record: bool) -> tuple[np.ndarray, np.ndarray]:
    out = np.zeros((grid.t.size if record else 1, len(CONV_SIGNALS)))
    compile_notice("conventional_kernel", "run_conventional", "conventional simulation kernel")
    ys = run_conventional(grid.vt, grid.lo, grid.hi, grid.dt,
                          conv_param_vector(veh, grid.cold_start), *conv_maps(veh),  # type: ignore[call-arg]  # numba Dispatcher stub
                          out, record)
    return out, ys


def _run_parallel(veh: Any, grid: Grid, soc0: float,
                  record: bool) -> tuple[np.ndarray, np.ndarray]:
    out = np.zeros((grid.t.size if record else 1, len(PAR_SIGNALS)))
    compile_notice("parallel_kernel", "run_parallel", "parallel-hybrid simulation kernel")
    ys = run_parallel(grid.vt, grid.lo, grid.hi, grid.dt,
                      par_param_vector(veh, soc0, grid.cold_start), *par_maps(veh),  # type: ignore[call-arg]  # numba Dispatcher stub
                      out, record)
    return out, ys


def _run_bev(veh: Any, grid: Grid, soc0: float,
             record: bool) -> tuple[np.ndarray, np.ndarray]:
    out = np.zeros((grid.t.size if record else 1, len(BEV_SIGNALS)))
    compile_notice("bev_kernel", "run_bev", "battery-electric simulation kernel")
    ys = run_bev(grid.vt, grid.lo, grid.hi, grid.dt, bev_param_vector(veh, soc0),  # type: ignore[call-arg]  # numba Dispatcher stub
                 *bev_maps(veh), out, record)
    return out, ys


def _power_split_cold_model(veh: Vehicle) -> bool:
    return veh.engine.warmup_fuel_fraction > 0.0 or veh.controller.cold_start_engine_on_s > 0.0


#: the vehicle file's ``architecture`` -> how to run it
ARCHITECTURES: dict[str, Architecture] = {
    "power_split": Architecture(
        name="power_split", label="forward-looking simulation", signals=SIGNALS,
        summary_keys=SUMMARY, run=_run_power_split, summarise=summarise, cold_start_model=_power_split_cold_model,
        soc_final=SUMMARY.index("soc_final")),
    "conventional": Architecture(
        name="conventional", label="forward-looking conventional simulation",
        signals=CONV_SIGNALS, summary_keys=CONV_SUMMARY, run=_run_conventional,
        summarise=lambda v, ys, s0: summarise_conventional(v, ys),
        cold_start_model=lambda v: v.engine.warmup_fuel_fraction > 0.0),
    "parallel_hybrid": Architecture(
        name="parallel_hybrid", label="forward-looking parallel-hybrid simulation",
        signals=PAR_SIGNALS, summary_keys=PAR_SUMMARY, run=_run_parallel,
        summarise=lambda v, ys, s0: summarise_parallel(v, ys, s0, energy_balance_fuel_kg),
        cold_start_model=lambda v: v.engine.warmup_fuel_fraction > 0.0,
        soc_final=PAR_SUMMARY.index("soc_final")),
    "battery_electric": Architecture(
        name="battery_electric", label="forward-looking battery-electric simulation",
        signals=BEV_SIGNALS, summary_keys=BEV_SUMMARY, run=_run_bev, summarise=summarise_bev,
        cold_start_model=lambda v: False, soc_final=BEV_SUMMARY.index("soc_final"),
        charge_sustaining=False, initial_soc=lambda v: v.charger.soc_initial),
}


def architecture(veh: Any) -> Architecture:
    """The registry entry of ``veh``'s architecture (ConfigError naming an unknown one)."""
    name = getattr(veh, "architecture", "power_split")
    try:
        return ARCHITECTURES[name]
    except KeyError:
        raise ConfigError(f"{getattr(veh, 'file', None) or getattr(veh, 'name', '?')}: no "
                          f"simulation for architecture {name!r} (known: "
                          f"{', '.join(ARCHITECTURES)})") from None


def run_cycle(veh: Any, grid: Grid, soc0: float = float("nan"),
              record: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """Run ``veh`` once over ``grid`` from SOC ``soc0`` [-] (ignored without a battery).

    Returns the recorded signals (``architecture(veh).signals`` columns; one empty row
    when not ``record``) and the summary vector (``summary_keys``)."""
    return architecture(veh).run(veh, grid, soc0, record)


# ------------------------------------------------------------------ plans, charge balance


def charge_balance(soc_error: Callable[[float], tuple[float, Any]], soc0: float, lo: float,
                   hi: float, iters: list[tuple[float, float]] | None = None
                   ) -> tuple[float, Any, list[tuple[float, float]]]:
    """Secant iteration on the initial SOC until SOC_end - SOC_start is within
    :data:`BALANCE_TOL` (at most :data:`BALANCE_MAX_ITER` steps after the first run).

    Parameters
    ----------
    soc_error : callable
        ``soc_error(soc_start) -> (soc_end - soc_start [-], payload)``.
    soc0 : float
        First initial SOC tried [-].
    lo, hi : float
        Window of the initial SOC [-].
    iters : list, optional
        Receives (soc_start, soc_end - soc_start) of every run.

    Returns
    -------
    (soc_start, payload, iters) of the balanced run, or of the best run when the iteration
    does not reach the tolerance.
    """
    iters = [] if iters is None else iters
    xa = soc0
    fa, pa = soc_error(xa)
    iters.append((xa, fa))
    if abs(fa) <= BALANCE_TOL:
        return xa, pa, iters
    best = (abs(fa), xa, pa)
    xb = min(max(xa + fa, lo), hi)
    for _ in range(BALANCE_MAX_ITER):
        fb, pb = soc_error(xb)
        iters.append((xb, fb))
        if abs(fb) < best[0]:
            best = (abs(fb), xb, pb)
        if abs(fb) <= BALANCE_TOL:
            return xb, pb, iters
        slope = (fb - fa) / (xb - xa) if xb != xa else -1.0
        if slope >= -1e-3:  # SOC regulation makes f decrease with x; fall back to fixed point
            slope = -1.0
        xa, fa = xb, fb
        xb = min(max(xb - fb / slope, lo), hi)
    return best[1], best[2], iters


def run_plan(veh: Any, grids: list[Grid], soc0: float = float("nan"),
             record: bool = True) -> list[tuple[np.ndarray, np.ndarray]]:
    """Run the grids one after the other, each starting from the SOC the previous one ended
    with (clamped to the battery window); returns (signals, summary vector) per run."""
    arch = architecture(veh)
    res = []
    soc = soc0
    for g in grids:
        if arch.has_battery:
            soc = min(max(soc, veh.battery.soc_min), veh.battery.soc_max)
        out, ys = arch.run(veh, g, soc, record)
        res.append((out, ys))
        if arch.has_battery:
            soc = float(ys[arch.soc_final])
    return res


def balanced_plan(veh: Any, grids: list[Grid], soc0: float | None = None,
                  record: bool = True):
    """:func:`run_plan` with the initial SOC iterated (:func:`charge_balance`) until the
    whole plan ends where it started.

    Parameters
    ----------
    soc0 : float, optional
        First initial SOC tried [-]; default the controller's SOC target.

    Returns
    -------
    (soc_start, runs, iters)
        Initial SOC [-] (NaN without a battery: nothing to balance, one plain run), the
        runs of :func:`run_plan` and the (soc_start, soc_end - soc_start) of every try.
    """
    arch = architecture(veh)
    if not arch.has_battery:
        return float("nan"), run_plan(veh, grids, record=record), []
    if not arch.charge_sustaining:  # charge-depleting: nothing to balance, one plain run
        start = arch.start_soc(veh) if soc0 is None else float(soc0)
        return start, run_plan(veh, grids, start, record=record), []
    k = arch.soc_final

    def err(x: float):
        runs = run_plan(veh, grids, x, record)
        return float(runs[-1][1][k]) - x, runs

    start = arch.start_soc(veh) if soc0 is None else float(soc0)
    bt = veh.battery
    return charge_balance(err, start, bt.soc_min + 0.02, bt.soc_max - 0.02)


def plan_summary(veh: Any, runs: list[tuple[np.ndarray, np.ndarray]],
                 soc0: float) -> dict[str, Any]:
    """Summary of a whole plan: the runs' accumulators added, the final SOC the last run's."""
    arch = architecture(veh)
    ys = np.sum([r[1] for r in runs], axis=0)
    if arch.has_battery:
        ys[arch.soc_final] = runs[-1][1][arch.soc_final]
    return arch.summarise(veh, ys, soc0)


def physics_warnings(summary: dict[str, Any]) -> list[str]:
    """What in a run's summary is not physical (the model ran on regardless): a battery
    state of charge outside 0-100 % (a capacity too small for the cycle), or energy the
    battery could not deliver at its power limit booked as unmet (more than 0.1 % of the
    energy moved). Empty for a sound run."""
    out = []
    soc = [float(v) for k in ("soc_initial", "soc_final", "soc_min_seen", "soc_max_seen")
           if isinstance(v := summary.get(k), (int, float)) and math.isfinite(v)]
    if soc and (min(soc) < 0.0 or max(soc) > 1.0):
        from vehval.display import percent

        out.append(f"the battery's state of charge left 0-100 % (lowest {percent(min(soc))}, "
                   f"highest {percent(max(soc))}): the figures are not physical; check "
                   "battery.capacity_ah")
    unmet = float(summary.get("unmet_energy_j") or 0.0)
    moved = abs(float(summary.get("ess_chem_energy_j") or 0.0)) + abs(
        float(summary.get("fuel_energy_j") or 0.0))
    if moved > 0 and unmet > 1e-3 * moved:
        from vehval.display import percent

        out.append(f"{percent(unmet / moved)} of the energy moved was beyond the battery's power "
                   "limit (booked as unmet): the figures count energy the battery cannot give")
    return out
