"""Run the forward-looking simulation of a vehicle over a drive cycle.

``simulate(vehicle, cycle)`` returns a :class:`SimResult` whose ``test`` holds the
``<base>_simu`` signals on the uniform grid (source ``simu``) and whose ``summary`` holds
fuel, distance, fuel economy (raw and SOC-corrected), SOC, engine use, trace following
and the energy balance.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from vehval.constants import GALLON_US_M3 as GALLON_M3
from vehval.constants import MILE_M
from vehval.cycles import Cycle, load_cycle
from vehval.errors import ConfigError
from vehval.sim.budget import check_samples
from vehval.sim.driver import MPH, tolerance_band
from vehval.sim.kernel import run
from vehval.sim.layout import SIGNALS, SUMMARY
from vehval.sim.packing import pack
from vehval.test import Signal, Test, TestMeta
from vehval.vehicle import Vehicle, load_vehicle

CHARGE_BALANCE_TOL = 0.005  # [-] |SOC_end - SOC_start| accepted by charge_balance
_BALANCE_TOL_ITER = 0.004  # [-] iteration target, inside the accepted tolerance


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


#: float64 values per time step of a recorded run: grid, target, tolerance band, the
#: recorded signals and their copies in the result (measured peak: about 37 at dt 0.01 s)
GRID_COLUMNS = 8 + 2 * len(SIGNALS)


def time_grid(cycle: Cycle, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Uniform grid [s] over the cycle and the target speed [m/s] on it (linear); refused
    (:class:`vehval.sim.budget.MemoryBudgetError`) when a recorded run on it would not fit
    the memory budget."""
    t0 = float(cycle.time_s[0])
    span = float(cycle.time_s[-1]) - t0
    check_samples(np.floor(span / dt + 1e-9) + 1, GRID_COLUMNS,
                  f"a simulation of '{cycle.name}' ({span:g} s) at dt = {dt:g} s",
                  "use a larger --dt")
    n = int(np.floor(span / dt + 1e-9)) + 1
    t = t0 + dt * np.arange(n)
    return t, np.interp(t, cycle.time_s, cycle.speed_mps)


def _check_dt(dt: float) -> float:
    try:
        dt = float(dt)
    except (TypeError, ValueError):
        raise ConfigError(f"dt must be a number of seconds, got {dt!r}") from None
    if not (0.0 < dt <= 1.0):
        raise ConfigError(f"dt = {dt:g} s is outside (0, 1] s; use e.g. 0.1 or 1.0")
    return dt


def run_once(veh: Vehicle, t: np.ndarray, vt: np.ndarray, dt: float, soc0: float,
             record: bool = True, cold_start: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Run the compiled loop once; returns (signals[n, len(SIGNALS)], summary vector).
    ``cold_start``: the run starts with a cold engine (the vehicle's cold-start model)."""
    p = pack(veh, soc0, cold_start)
    lo, hi = tolerance_band(t, vt, veh.driver.tolerance_speed_mph * MPH,
                            veh.driver.tolerance_time_s)
    out = np.zeros((t.size if record else 1, len(SIGNALS)))
    ys = run(vt, lo, hi, dt, p.prm, p.maps, out, record)
    return out, ys


def summarise(veh: Vehicle, ys: np.ndarray, soc0: float) -> dict[str, Any]:
    """Summary dict from the accumulator vector of :func:`vehval.sim.kernel.run`.

    The SOC-corrected fuel economy follows the energy method of SAE J1711 (see
    docs/simulation.md): the net battery energy ``ΔE`` (chemical, positive when
    discharged) is converted to the fuel the engine would have burned to supply it,
    ``Δm = ΔE / (LHV · η_eng · η_path)``, with ``η_eng`` the cycle-average engine
    efficiency and ``η_path`` the engine-to-battery path efficiency of the vehicle file.
    """
    s = {k: float(v) for k, v in zip(SUMMARY, ys)}
    e = veh.engine
    rho, lhv = e.fuel_density_kg_per_m3, e.fuel_lhv_j_per_kg
    dist = s["distance_m"]
    fuel = s["fuel_mass_kg"]

    def mpg(mass_kg: float) -> float:
        gal = mass_kg / rho / GALLON_M3
        return float(dist / MILE_M / gal) if gal > 0 else float("inf")

    def l100(mass_kg: float) -> float:
        return float(mass_kg / rho * 1e3 / (dist / 1e5)) if dist > 0 else float("nan")

    eta_eng = s["eng_out_energy_j"] / s["fuel_energy_j"] if s["fuel_energy_j"] > 0 else 0.0
    if eta_eng <= 0.0:  # no engine use: best map efficiency
        p, w, tq = veh.best_line
        eta_eng = 0.35
    d_e = s["ess_chem_energy_j"]
    fuel_corr = max(fuel + d_e / (lhv * eta_eng * veh.controller.soc_correction_path_efficiency),
                    0.0)
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


def simulate(vehicle: Vehicle | str | Path, cycle: Cycle | str | Path, dt: float = 0.1,
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
    dt = _check_dt(dt)
    t, vt = time_grid(cyc, dt)
    if t.size < 2:
        raise ConfigError(f"cycle '{cyc.name}' is shorter than one step of {dt:g} s")
    if veh.architecture == "conventional":
        return _simulate_conventional(veh, cyc, t, vt, dt, cold_start)
    bt = veh.battery
    soc0 = veh.controller.soc_target if soc_initial is None else float(soc_initial)
    if not (bt.soc_min <= soc0 <= bt.soc_max):
        raise ConfigError(f"soc_initial = {soc0:g} is outside the battery window "
                          f"[{bt.soc_min:g}, {bt.soc_max:g}] of {veh.file or veh.name}")
    iters: list[tuple[float, float]] = []
    if charge_balance:
        soc0 = _balance(veh, t, vt, dt, soc0, iters, cold_start)
    out, ys = run_once(veh, t, vt, dt, soc0, record=True, cold_start=cold_start)
    summary = summarise(veh, ys, soc0)
    summary.update({"vehicle": veh.name, "cycle": cyc.name, "dt_s": dt,
                    "trace_max_miss_mps": summary["trace_max_miss_mps"],
                    "charge_balanced": bool(charge_balance and abs(summary["soc_delta"])
                                            <= CHARGE_BALANCE_TOL),
                    "charge_balance_iterations": len(iters), "cold_start": bool(cold_start)})
    meta = TestMeta(test_id=f"simu_{veh.name}_{cyc.name}", vehicle=veh.name, cycle=cyc.name,
                    notes=[f"vehval forward-looking simulation, dt = {dt:g} s"], synthetic=True)
    test = Test(meta=meta)
    for k, base in enumerate(SIGNALS):
        test.add(Signal.standard(f"{base}_simu", t, out[:, k], source="simu"))
    return SimResult(test=test, summary=summary, vehicle=veh, cycle=cyc, dt=dt, iterations=iters)


def _simulate_conventional(veh, cyc: Cycle, t: np.ndarray, vt: np.ndarray,
                           dt: float, cold_start: bool = False) -> SimResult:
    """Conventional powertrain (no battery: SOC options do not apply)."""
    from vehval.sim.conventional import run_conventional_once, summarise_conventional
    from vehval.sim.conventional_kernel import CONV_SIGNALS
    out, ys = run_conventional_once(veh, t, vt, dt, cold_start=cold_start)
    summary = summarise_conventional(veh, ys)
    summary.update({"vehicle": veh.name, "cycle": cyc.name, "dt_s": dt,
                    "architecture": "conventional", "cold_start": bool(cold_start)})
    meta = TestMeta(test_id=f"simu_{veh.name}_{cyc.name}", vehicle=veh.name, cycle=cyc.name,
                    notes=[f"vehval forward-looking conventional simulation, dt = {dt:g} s"],
                    synthetic=True)
    test = Test(meta=meta)
    for k, base in enumerate(CONV_SIGNALS):
        test.add(Signal.standard(f"{base}_simu", t, out[:, k], source="simu"))
    return SimResult(test=test, summary=summary, vehicle=veh, cycle=cyc, dt=dt)


def _balance(veh: Vehicle, t, vt, dt, soc0: float, iters: list,
             cold_start: bool = False) -> float:
    """Secant iteration on the initial SOC so that SOC_end - SOC_start -> 0."""
    lo, hi = veh.battery.soc_min + 0.02, veh.battery.soc_max - 0.02
    xa = soc0
    fa = run_once(veh, t, vt, dt, xa, False, cold_start)[1][SUMMARY.index("soc_final")] - xa
    iters.append((xa, fa))
    if abs(fa) <= _BALANCE_TOL_ITER:
        return xa
    xb = min(max(xa + fa, lo), hi)
    best = (abs(fa), xa)
    for _ in range(12):
        fb = run_once(veh, t, vt, dt, xb, False, cold_start)[1][SUMMARY.index("soc_final")] - xb
        iters.append((xb, fb))
        best = min(best, (abs(fb), xb))
        if abs(fb) <= _BALANCE_TOL_ITER:
            return xb
        slope = (fb - fa) / (xb - xa) if xb != xa else -1.0
        if slope >= -1e-3:  # SOC regulation makes f decrease with x; fall back to fixed point
            slope = -1.0
        xa, fa = xb, fb
        xb = min(max(xb - fb / slope, lo), hi)
    return best[1]
