"""Comparison of a test with its simulation: summary, per-component metrics, events, overlays.

:func:`compare` takes the measured test and a Test of ``_simu`` signals already placed on
the test's clock, reduces both with the same formulas over the same time grid and returns a
:class:`Comparison`: the summary table in the style of Figure 17 of SAE 2006-01-0667
(quantity, test, simulation, absolute and relative difference), pointwise metrics of every
component's effort and flow (MAD, RMSE, bias, R^2), positive and negative energies, engine
on/off agreement and start/stop events matched within a tolerance window.

When the measurement uncertainty of the test's results is known (the results stage,
:mod:`vehval.results`), each model-vs-test difference gets a verdict
(:func:`uncertainty_verdict`): ``within measurement uncertainty`` (|d| <= 2 u),
``model error`` (|d| > 3 u) or ``undecidable`` (in between, or u unknown).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from vehval.constants import RPM_RAD_PER_S
from vehval.equations.engine_state import ENGINE_ON_RPM
from vehval.errors import SignalError
from vehval.fuels import resolve_fuel
from vehval.jsonsafe import clean
from vehval.test import Test
from vehval.validate import metrics as M
from vehval.validate.quantities import (
    POWERS,
    engine_on,
    engine_on_method,
    on_grid,
    pick_signal,
    totals,
    uniform_grid,
)

if TYPE_CHECKING:
    import pandas as pd

#: Effort and flow signals compared pointwise: base name -> (label, display unit, scale SI->display).
COMPONENT_SIGNALS: dict[str, tuple[str, str, float]] = {
    "veh_spd": ("vehicle speed", "km/h", 3.6),
    "whl_trq_out": ("wheel torque", "N·m", 1.0),
    "eng_spd_out": ("engine speed", "rpm", 1.0 / RPM_RAD_PER_S),
    "eng_trq_out": ("engine torque", "N·m", 1.0),
    "eng_pwr_out": ("engine power", "kW", 1e-3),
    "fuel_rate": ("fuel rate", "g/s", 1e3),
    "gen_spd_out": ("generator speed", "rpm", 1.0 / RPM_RAD_PER_S),
    "gen_trq_out": ("generator torque", "N·m", 1.0),
    "gen_pwr_out": ("generator mech. power", "kW", 1e-3),
    "mot_spd_out": ("motor speed", "rpm", 1.0 / RPM_RAD_PER_S),
    "mot_trq_out": ("motor torque", "N·m", 1.0),
    "mot_pwr_out": ("motor mech. power", "kW", 1e-3),
    "ess_volt": ("battery voltage", "V", 1.0),
    "ess_curr": ("battery current", "A", 1.0),
    "ess_pwr": ("battery power", "kW", 1e-3),
    "ess_soc": ("battery SOC", "%", 100.0),
    "boost_volt_out": ("boost voltage", "V", 1.0),
}

#: Rows of the summary table: key in the totals, label, display unit, scale SI->display.
SUMMARY_ROWS: tuple[tuple[str, str, str, float], ...] = (
    ("fuel_mass_kg", "fuel mass", "g", 1e3),
    ("fuel_economy_mpg", "fuel economy", "mpg", 1.0),
    ("fuel_consumption_l_per_100km", "fuel consumption", "L/100 km", 1.0),
    ("fuel_energy_j", "fuel energy", "MJ", 1e-6),
    ("distance_m", "distance", "km", 1e-3),
    ("soc_initial", "initial SOC", "%", 100.0),
    ("soc_final", "final SOC", "%", 100.0),
    ("soc_delta", "SOC change", "% points", 100.0),
    ("engine_on_share", "engine on time", "%", 100.0),
    ("engine_starts", "engine starts", "-", 1.0),
    ("eng_pwr_out_pos_j", "engine output energy", "kJ", 1e-3),
    ("mot_pwr_out_pos_j", "motor propelling energy", "kJ", 1e-3),
    ("mot_pwr_out_neg_j", "motor regenerating energy", "kJ", 1e-3),
    ("gen_pwr_out_pos_j", "generator motoring energy", "kJ", 1e-3),
    ("gen_pwr_out_neg_j", "generator generating energy", "kJ", 1e-3),
    ("ess_pwr_pos_j", "battery discharge energy", "kJ", 1e-3),
    ("ess_pwr_neg_j", "battery charge energy", "kJ", 1e-3),
    ("whl_pwr_out_pos_j", "wheel propelling energy", "kJ", 1e-3),
    ("whl_pwr_out_neg_j", "wheel braking energy", "kJ", 1e-3),
)


#: Coverage factors of the verdicts: within when |d| <= K_WITHIN u, model error when |d| > K_ERROR u.
K_WITHIN = 2.0
K_ERROR = 3.0
#: Whole-test quantities that get a verdict when their uncertainty is known.
VERDICT_KEYS = ("fuel_mass_kg", "fuel_economy_mpg", "fuel_consumption_l_per_100km",
                "fuel_energy_j", "distance_m")


def uncertainty_verdict(test_value: float | None, sim_value: float | None,
                        u_test: float | None) -> dict[str, Any]:
    """Whether a model-vs-test difference is explained by the measurement uncertainty.

    Parameters
    ----------
    test_value, sim_value : float
        Measured and simulated value (same unit).
    u_test : float or None
        Standard uncertainty of the measured value (same unit); the simulation is exact
        for given inputs, so u(d) = u_test.

    Returns
    -------
    dict
        ``verdict`` (``within measurement uncertainty``: |d| <= 2 u, the difference may be
        measurement error alone; ``model error``: |d| > 3 u, beyond what the measurement
        explains at 99.7 %; ``undecidable``: 2 u < |d| <= 3 u, or u unknown), ``difference``
        (sim - test), ``U`` (2 u), ``ratio`` (|d| / u) and ``message`` with the numbers.
    """
    out: dict[str, Any] = {"difference": None, "U": None, "ratio": None}
    if test_value is None or sim_value is None or not (
            math.isfinite(test_value) and math.isfinite(sim_value)):
        return dict(out, verdict="undecidable", message="a value is missing")
    d = sim_value - test_value
    out["difference"] = d
    if u_test is None or not math.isfinite(u_test) or u_test <= 0:
        return dict(out, verdict="undecidable",
                    message=f"difference {d:+.4g}; measurement uncertainty unknown")
    ratio = abs(d) / u_test
    out.update(U=K_WITHIN * u_test, ratio=ratio)
    if ratio <= K_WITHIN:
        verdict = "within measurement uncertainty"
    elif ratio > K_ERROR:
        verdict = "model error"
    else:
        verdict = "undecidable"
    out.update(verdict=verdict, message=(f"difference {d:+.4g} against U = {K_WITHIN * u_test:.4g} "
                                         f"(k = 2): |d| = {ratio:.2f} u"))
    return out


@dataclass
class Comparison:
    """Result of :func:`compare` (all values SI unless a field says otherwise).

    Attributes
    ----------
    test_id, cycle : str
        Identity of the test.
    totals_test, totals_sim : dict
        Whole-test quantities of each side (see :func:`vehval.validate.quantities.totals`).
    signals : dict
        Pointwise metrics per base name (see :func:`vehval.validate.metrics.signal_metrics`).
    on_method : str or None
        Engine-on definition used on both sides (flag, speed or fuel).
    on_agreement : float
        Share of time steps with the same engine state [-].
    starts, stops : EventMatch or None
        Engine start and stop events matched within ``window_s``.
    overlays : pandas.DataFrame
        Time [s] and ``<base>_test`` / ``<base>_simu`` columns on the comparison grid (SI).
    notes : list of str
        What could not be compared and why.
    """

    test_id: str
    cycle: str
    totals_test: dict[str, Any]
    totals_sim: dict[str, Any]
    signals: dict[str, dict[str, float]]
    on_method: str | None
    on_agreement: float
    starts: M.EventMatch | None
    stops: M.EventMatch | None
    overlays: pd.DataFrame
    window_s: float = 2.0
    notes: list[str] = field(default_factory=list)
    #: Relative standard uncertainty of measured whole-test quantities (key -> u / value).
    uncertainty_rel: dict[str, float] = field(default_factory=dict)
    #: Where the uncertainty comes from (declared accuracies, class defaults...).
    uncertainty_basis: str = ""

    def verdicts(self) -> dict[str, dict[str, Any]]:
        """Verdict of every whole-test quantity with a known uncertainty (see
        :func:`uncertainty_verdict`)."""
        out = {}
        for key in VERDICT_KEYS:
            if key not in self.uncertainty_rel:
                continue
            a, b = self.totals_test.get(key), self.totals_sim.get(key)
            u = abs(a) * self.uncertainty_rel[key] if a is not None else None
            out[key] = uncertainty_verdict(a, b, u)
        return out

    # ------------------------------------------------------------------ headline errors
    @property
    def fuel_error(self) -> float:
        """Relative error of the fuel mass (sim - test) / test [-]."""
        return M.relative_error(self.totals_test["fuel_mass_kg"], self.totals_sim["fuel_mass_kg"])

    @property
    def soc_delta_error(self) -> float:
        """ΔSOC mismatch ``ΔSOC_sim - ΔSOC_test`` [fraction of full charge]."""
        return self.totals_sim["soc_delta"] - self.totals_test["soc_delta"]

    @property
    def soc_final_error(self) -> float:
        """Relative error of the final SOC (sim - test) / test [-]."""
        return M.relative_error(self.totals_test["soc_final"], self.totals_sim["soc_final"])

    # ------------------------------------------------------------------ tables
    def summary_rows(self) -> list[list[Any]]:
        """[quantity, unit, test, simulation, absolute difference, relative difference %]."""
        rows = []
        for key, label, unit, k in SUMMARY_ROWS:
            a, b = self.totals_test.get(key), self.totals_sim.get(key)
            if a is None or b is None or not (np.isfinite(a) or np.isfinite(b)):
                continue
            rel = M.relative_error(a, b)
            rows.append([label, unit, a * k, b * k, (b - a) * k,
                         rel * 100.0 if np.isfinite(rel) else float("nan")])
        return rows

    def signal_rows(self) -> list[list[Any]]:
        """[signal, unit, n, mean test, mean sim, MAD, RMSE, bias, R^2, NRMSE] in display units."""
        rows = []
        for base, m in self.signals.items():
            label, unit, k = COMPONENT_SIGNALS.get(base, (base, "SI", 1.0))
            rows.append([f"{label} ({base})", unit, m["n"], m["mean_test"] * k, m["mean_sim"] * k,
                         m["mad"] * k, m["rmse"] * k, m["bias"] * k, m["r2"], m["nrmse"]])
        return rows

    def energy_rows(self) -> list[list[Any]]:
        """[power, E+ test, E+ sim, rel. error + %, E- test, E- sim, rel. error - %] [kJ]."""
        rows = []
        for p in POWERS:
            kp, kn = f"{p}_pos_j", f"{p}_neg_j"
            if kp not in self.totals_test or kp not in self.totals_sim:
                continue
            r: list[Any] = [p]
            for key in (kp, kn):
                a, b = self.totals_test[key], self.totals_sim[key]
                rel = M.relative_error(a, b)
                r += [a * 1e-3, b * 1e-3, rel * 100 if np.isfinite(rel) else float("nan")]
            rows.append(r)
        return rows

    def event_rows(self) -> list[list[Any]]:
        rows = [["engine state agreement (time steps)", "%", self.on_agreement * 100.0, "", "", ""]]
        for name, ev in (("engine starts", self.starts), ("engine stops", self.stops)):
            if ev is not None:
                lag = (f"mean lag {ev.mean_lag_s:.2f} s" if np.isfinite(ev.mean_lag_s)
                       else "mean lag n/a (none matched)")
                rows.append([name, "count", ev.n_test, ev.n_sim, len(ev.pairs),
                             f"{ev.matched_share * 100:.1f} % matched within ±{ev.window_s:g} s, "
                             f"{lag}"])
        return rows

    def tables(self) -> list[dict]:
        """Report tables ``{title, columns, rows}``."""
        name = f" ({self.test_id})" if self.test_id else ""
        return [
            {"title": f"Test vs simulation summary{name}",
             "columns": ["quantity", "unit", "test", "simulation", "abs. difference", "rel. difference [%]"],
             "rows": self.summary_rows()},
            {"title": f"Engine on/off agreement{name}",
             "columns": ["quantity", "unit", "test", "simulation", "matched", "note"],
             "rows": self.event_rows(),
             "note": f"engine on defined by '{self.on_method}' on both sides"},
            {"title": f"Component effort and flow{name}",
             "columns": ["signal", "unit", "n", "mean test", "mean sim", "MAD", "RMSE", "bias", "R²", "NRMSE"],
             "rows": self.signal_rows()},
            {"title": f"Positive and negative energies{name}",
             "columns": ["power", "E+ test [kJ]", "E+ sim [kJ]", "E+ rel. [%]",
                         "E- test [kJ]", "E- sim [kJ]", "E- rel. [%]"],
             "rows": self.energy_rows()},
        ] + self._verdict_table(name)

    def _verdict_table(self, name: str) -> list[dict]:
        v = self.verdicts()
        if not v:
            return []
        units = {k: (label, unit, scale) for k, label, unit, scale in SUMMARY_ROWS}
        rows = []
        for key, r in v.items():
            label, unit, k = units.get(key, (key, "SI", 1.0))
            a, b = self.totals_test.get(key), self.totals_sim.get(key)
            rows.append([label, unit, None if a is None else a * k, None if b is None else b * k,
                         None if r["difference"] is None else r["difference"] * k,
                         None if r["U"] is None else r["U"] * k,
                         r["ratio"], r["verdict"]])
        return [{"title": f"Model against measurement uncertainty{name}",
                 "columns": ["quantity", "unit", "test", "simulation", "difference",
                             "U of the test (k = 2)", "|d| / u", "verdict"],
                 "rows": rows,
                 "note": ("within measurement uncertainty: |d| <= 2u; model error: |d| > 3u; "
                          "undecidable: in between. " + self.uncertainty_basis).strip()}]

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict (NaN become None)."""
        return clean({
            "test_id": self.test_id, "cycle": self.cycle,
            "fuel_error": self.fuel_error, "soc_delta_error": self.soc_delta_error,
            "soc_final_error": self.soc_final_error,
            "verdicts": self.verdicts(), "uncertainty_rel": dict(self.uncertainty_rel),
            "uncertainty_basis": self.uncertainty_basis,
            "totals_test": self.totals_test, "totals_sim": self.totals_sim,
            "signals": self.signals, "on_method": self.on_method, "on_agreement": self.on_agreement,
            "starts": self.starts.to_dict() if self.starts else None,
            "stops": self.stops.to_dict() if self.stops else None,
            "tables": self.tables(), "notes": self.notes,
        })


def compare(test: Test, sim: Test, *, dt: float | None = None, window_s: float = 2.0,  # noqa: PLR0913 - keyword options of the comparison, each with a default
            fuel: Any = None, fuel_density_kg_per_m3: float | None = None,
            fuel_lhv_j_per_kg: float | None = None,
            on_speed_rpm: float = ENGINE_ON_RPM, bases: tuple[str, ...] | None = None,
            uncertainty_rel: dict[str, float] | None = None,
            uncertainty_basis: str = "") -> Comparison:
    """Compare a measured test with a simulation on the test's clock.

    Parameters
    ----------
    test : Test
        Measured test (``_test`` signals, ``_calc`` as fallback).
    sim : Test
        Simulated signals ``<base>_simu`` on the same clock as the test [s].
    dt : float, optional
        Step of the comparison grid [s]; default the simulation's sample period.
    window_s : float
        Tolerance window for matching engine start/stop events [s].
    fuel : ResolvedFuel or Fuel, optional
        The test fuel (:func:`vehval.fuels.resolve_fuel`) for fuel economy [mpg] and fuel
        energy [J], the same on both sides; without it they are NaN.
    fuel_density_kg_per_m3, fuel_lhv_j_per_kg : float, optional
        Explicit fuel properties instead of ``fuel``.
    on_speed_rpm : float
        Engine-on speed threshold [rpm] when the engine state comes from engine speed.
    bases : tuple of str, optional
        Base names compared pointwise (default :data:`COMPONENT_SIGNALS`).
    uncertainty_rel : dict, optional
        Relative standard uncertainty (u / value) of the measured whole-test quantities
        (:data:`VERDICT_KEYS`), for the verdicts; none given: no verdict.
    uncertainty_basis : str
        Where that uncertainty comes from (shown with the verdicts).

    Raises
    ------
    SignalError
        If either side has no vehicle speed or their time spans do not overlap.
    """
    ts, ss = pick_signal(test, "veh_spd", "test"), pick_signal(sim, "veh_spd", "simu")
    if ts is None or ss is None:
        raise SignalError("comparison needs the vehicle speed on both sides "
                          f"({'veh_spd_test' if ts is None else 'veh_spd_simu'} is missing)")
    t0 = max(float(np.nanmin(ts.time)), float(np.nanmin(ss.time)))
    t1 = min(float(np.nanmax(ts.time)), float(np.nanmax(ss.time)))
    step = float(dt) if dt else (ss.sample_period if np.isfinite(ss.sample_period) else 0.1)
    if not t1 - t0 > step:
        raise SignalError(f"test ({ts.time[0]:g}..{ts.time[-1]:g} s) and simulation "
                          f"({ss.time[0]:g}..{ss.time[-1]:g} s) do not overlap in time")
    grid = uniform_grid(t0, t1, step)
    notes: list[str] = []
    method = engine_on_method(test, sim)
    if method is None:
        notes.append("no engine state, speed or fuel rate on both sides: engine on/off not compared")
    if fuel is None and (fuel_density_kg_per_m3 or fuel_lhv_j_per_kg):
        fuel = resolve_fuel(constants={"fuel_density_kg_per_m3": fuel_density_kg_per_m3,
                                       "fuel_lhv_j_per_kg": fuel_lhv_j_per_kg})
    kw: dict[str, Any] = dict(fuel=fuel, on_method=method, on_speed_rpm=on_speed_rpm)
    tot_t = totals(test, "test", grid, **kw)
    tot_s = totals(sim, "simu", grid, **kw)

    cols: dict[str, np.ndarray] = {"time": grid}
    sig_metrics: dict[str, dict[str, float]] = {}
    for base in bases or tuple(COMPONENT_SIGNALS):
        a, b = on_grid(test, base, "test", grid), on_grid(sim, base, "simu", grid)
        if a is None or b is None:
            if a is not None or b is not None:
                notes.append(f"{base}: only in the {'test' if a is not None else 'simulation'}")
            continue
        cols[f"{base}_test"], cols[f"{base}_simu"] = a, b
        sig_metrics[base] = M.signal_metrics(a, b)

    agreement, starts, stops = float("nan"), None, None
    # the method is one both sides support: both are arrays when it is set
    on_t = engine_on(test, "test", grid, method, on_speed_rpm) if method is not None else None
    on_s = engine_on(sim, "simu", grid, method, on_speed_rpm) if method is not None else None
    if on_t is not None and on_s is not None:
        cols["eng_on_test"], cols["eng_on_simu"] = on_t, on_s
        agreement = M.on_agreement(on_t, on_s)
        st_t, sp_t = M.on_off_events(grid, on_t)
        st_s, sp_s = M.on_off_events(grid, on_s)
        starts = M.match_events(st_t, st_s, window_s)
        stops = M.match_events(sp_t, sp_s, window_s)
    import pandas as pd

    overlays = pd.DataFrame(cols)
    return Comparison(test_id=test.meta.test_id, cycle=test.meta.cycle, totals_test=tot_t,
                      totals_sim=tot_s, signals=sig_metrics, on_method=method,
                      on_agreement=agreement, starts=starts, stops=stops, overlays=overlays,
                      window_s=window_s, notes=notes,
                      uncertainty_rel=dict(uncertainty_rel or {}),
                      uncertainty_basis=uncertainty_basis)


# ----------------------------------------------------------------------------- figures
FIGURE_GROUPS: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("Vehicle", ("veh_spd", "whl_trq_out")),
    ("Engine", ("eng_spd_out", "eng_trq_out", "fuel_rate")),
    ("Generator (MG1)", ("gen_spd_out", "gen_trq_out")),
    ("Motor (MG2)", ("mot_spd_out", "mot_trq_out")),
    ("Battery", ("ess_soc", "ess_curr", "ess_volt")),
)


def overlay_figures(comp: Comparison, max_points: int = 2500) -> list[dict]:
    """Plotly figure dicts (``{title, figure}``) overlaying test and simulation per component.

    Each figure stacks one panel per signal (display units), test in one colour and
    simulation in another; long series are thinned by a uniform stride to ``max_points``.
    """
    df = comp.overlays
    stride = max(1, int(math.ceil(len(df) / max_points)))
    t = df["time"].to_numpy()[::stride]
    out = []
    from vehval.figures import time_traces_figure

    for title, bases in FIGURE_GROUPS:
        present = [b for b in bases if f"{b}_test" in df and f"{b}_simu" in df]
        if not present:
            continue
        panels = []
        for base in present:
            label, unit, k = COMPONENT_SIGNALS.get(base, (base, "SI", 1.0))
            panels.append({"ylabel": f"{label} [{unit}]", "traces": [
                {"name": f"{label} {'test' if origin == 'test' else 'simulation'}", "t": t,
                 "y": df[f"{base}_{origin}"].to_numpy()[::stride] * k, "unit": unit,
                 "color": color, "dash": dash, "width": 1.2}
                for origin, color, dash in (("test", "#1f77b4", "solid"),
                                            ("simu", "#d62728", "dot"))]})
        fig = time_traces_figure(panels, row_height=220)
        fig["layout"]["title"] = {"text": f"{title}: test vs simulation"}
        out.append({"title": f"{title}: test vs simulation", "figure": fig})
    return out
