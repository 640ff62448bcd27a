"""Validate a battery-electric model against one test: its simulation on the test's own
speed trace, mass and road load compared with the test's traces, DC energy and SAE J1634
figures.

The measured side is the results stage's (:func:`vehval.results.compute_results`): the DC
energy per phase and for the whole test (``ess_energy_net_j``, terminal V x I, with its
expanded uncertainty) and the J1634 figures from it (:mod:`vehval.results.j1634`). The model
side is the same integral of the simulated terminal voltage x current over the same phase
segments, and :func:`vehval.results.j1634.j1634_scope` on it. Each energy and J1634 figure
carries the normalised error En (:mod:`vehval.uncertainty`): U_meas from the result's own
uncertainty and the cycle's repeatability (packaged precision, family ``electric``), U_model
from the relative bound the caller gives (with its source).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from vehval.integrals import battery_power, cumulative
from vehval.jsonsafe import clean
from vehval.uncertainty import COVERAGE_K
from vehval.uncertainty.defaults import cycle_precision
from vehval.uncertainty.verdict import measurement_uncertainty, normalised_error
from vehval.validate.conditions import CONSTANT_OVERRIDES, speed_trace
from vehval.validate.metrics import signal_metrics
from vehval.validate.quantities import pick_signal

#: Traces compared: base name -> (label, SI unit); tables state them in the user's display
#: unit (:func:`vehval.display.to_display`).
TRACES = {"veh_spd": ("vehicle speed", "m/s"), "ess_curr": ("battery current", "A"),
          "ess_volt": ("battery voltage", "V")}
#: J1634 figures judged, from :func:`vehval.results.j1634.j1634_scope`.
J1634_FIGURES = ("dc_wh_per_mile", "ac_kwh_per_100km", "mpge")


@dataclass
class BevValidation:
    """One battery-electric test validated.

    Attributes
    ----------
    test_id, cycle : str
    vehicle : BatteryElectricVehicle
        The model as run (template mass and road load applied).
    overrides : dict
        Dotted parameters applied from the template constants and the caller.
    traces : dict
        Base name -> :func:`vehval.validate.metrics.signal_metrics` (SI units).
    energy : list of dict
        Per scope (phases, ``test``): DC energy model / test [Wh], error [%], En.
    j1634 : list of dict
        Per scope and figure: model, test, error [%], En.
    u_model_rel : float
        Relative expanded uncertainty (k = 2) of the model's energy [-]; ``u_model_source``.
    overlays : DataFrame
        ``time`` and ``<base>_test`` / ``<base>_simu`` on the simulation's grid (SI).
    notes : list of str
    """

    test_id: str
    cycle: str
    vehicle: Any
    overrides: dict[str, Any]
    traces: dict[str, dict[str, float]]
    energy: list[dict[str, Any]]
    j1634: list[dict[str, Any]]
    u_model_rel: float
    u_model_source: str
    overlays: pd.DataFrame
    sim_summary: dict[str, Any] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    #: the cycle's repeatability [-] the measured figures were judged with
    s_r: float = 0.0

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary (``validation.json`` of a battery-electric test)."""
        return clean({
            "architecture": "battery_electric", "test_id": self.test_id, "cycle": self.cycle,
            "vehicle": self.vehicle.name, "vehicle_file": self.vehicle.file,
            "overrides": dict(self.overrides), "traces": self.traces, "energy": self.energy,
            "j1634": self.j1634, "u_model_rel": self.u_model_rel,
            "u_model_source": self.u_model_source, "notes": list(self.notes),
            "sim_summary": {k: v for k, v in self.sim_summary.items()
                            if isinstance(v, (int, float, str, bool))}})

    def verdict(self) -> dict[str, Any]:
        """The test's verdict: the normalised error of its whole-test DC battery energy,
        with its SAE J1634 MPGe in ``text``."""
        e = next((r for r in self.energy if r["scope"] == "test"), {})
        m = next((r for r in self.j1634 if r["scope"] == "test" and r["figure"] == "mpge"), {})
        text = (f"DC energy {e['model_wh']:.0f} Wh against {e['test_wh']:.0f} Wh"
                if e else "no whole-test DC energy")
        if m.get("error_pct") is not None:
            text += f", MPGe {m['model']:.1f} against {m['test']:.1f}"
        return {"figure": "dc_energy_wh", "en": e.get("en"), "consistent": e.get("consistent"),
                "model": e.get("model_wh"), "measured": e.get("test_wh"),
                "u_model": e.get("U_model"), "u_meas": e.get("U_meas"), "s_r": self.s_r,
                "text": text}

    def tables(self) -> list[dict[str, Any]]:
        """Report tables: traces (RMS error), DC energy per scope, J1634 figures."""
        from vehval.display import to_display

        tr = []
        for b, m in self.traces.items():   # RMS and bias scale by the display unit's factor
            (k,), unit = to_display(np.array([1.0]), TRACES[b][1], signal=b)
            tr.append([TRACES[b][0] + f" [{unit}]", m["rmse"] * k, m["bias"] * k, m["r2"]])
        en = [[r["scope"], r["model_wh"], r["test_wh"], r["error_pct"], r["en"]]
              for r in self.energy]
        jf = [[r["scope"], r["figure"], r["model"], r["test"], r["error_pct"], r["en"]]
              for r in self.j1634]
        return [
            {"title": f"Traces, model vs test ({self.test_id})",
             "columns": ["signal", "RMS error", "bias (model - test)", "R²"], "rows": tr},
            {"title": f"DC battery energy, model vs test ({self.test_id})",
             "columns": ["scope", "model [Wh]", "test [Wh]", "error [%]", "En"], "rows": en},
            {"title": f"SAE J1634 figures, model vs test ({self.test_id})",
             "columns": ["scope", "figure", "model", "test", "error [%]", "En"], "rows": jf}]

    def payload(self, figures: bool = True) -> dict[str, Any]:
        """The report's validation section: ``{tables, figures, notes}``."""
        from vehval.validate.compare import overlay_figures

        figs = overlay_figures(self) if figures else []  # type: ignore[arg-type]  # reads .overlays only
        return {"tables": self.tables(), "figures": figs,
                "notes": list(self.notes)}


def _judge(model: float, measured: float, u_rel_meas: float | None, s_r: float,
           u_model_rel: float, label: str) -> dict[str, Any]:
    """Error [%] and En of one figure (NaN-safe: no En when a side is missing or zero)."""
    out: dict[str, Any] = {"model": model, "test": measured, "error_pct": None, "en": None,
                           "U_model": None, "U_meas": None}
    if not (math.isfinite(model) and math.isfinite(measured)) or measured == 0.0:
        return out
    u_meas = measurement_uncertainty(measured, u_result=abs((u_rel_meas or 0.0) * measured),
                                     s_r=s_r)
    c = normalised_error(model, measured, u_model_rel * abs(model), u_meas, label=label)
    out.update(error_pct=100.0 * c.error, en=c.en if math.isfinite(c.en) else None,
               U_model=c.u_model, U_meas=c.u_meas, consistent=c.consistent)
    return out


def _on_grid(test: Any, base: str, t: np.ndarray) -> np.ndarray | None:
    sig = pick_signal(test, base, "test")
    if sig is None:
        return None
    ok = np.isfinite(sig.time) & np.isfinite(sig.values)
    if ok.sum() < 2:
        return None
    v = np.interp(t, sig.time[ok], sig.values[ok], left=np.nan, right=np.nan)
    return np.asarray(v, float)


def _integral(t: np.ndarray, y: np.ndarray, segments: list[tuple[float, float]]) -> float:
    """∫ y dt over record-time segments (cumulative trapezoid, interpolated at the ends)."""
    ok = np.isfinite(y)
    t, y = t[ok], y[ok]
    if t.size < 2:
        return math.nan
    c = cumulative(t, y)
    return float(sum(np.interp(b, t, c) - np.interp(a, t, c) for a, b in segments))


def validate_bev_test(run: Any, *, dt: float = 0.1, smooth_hz: float | None = None,
                      overrides: dict | None = None, u_model_rel: float,
                      u_model_source: str) -> BevValidation:
    """Simulate the run's battery-electric vehicle on its test and compare.

    Parameters
    ----------
    run : vehval.workflow.TestRun
        The test (QA's validated test, its results) and its ``vehicle``.
    dt : float
        Simulation step [s].
    smooth_hz : float, optional
        Low-pass cut-off of the measured speed given to the driver [Hz].
    overrides : dict, optional
        Dotted vehicle parameters (applied after the template's mass and road load).
    u_model_rel : float
        Relative expanded uncertainty (k = 2) of the model's energy figures [-];
        ``u_model_source`` says where it comes from.
    """
    from vehval.conditions import TestConditions
    from vehval.results.j1634 import j1634_scope
    from vehval.sim.simulate import simulate

    test = run.validated
    res = run.results().results
    cyc, notes = speed_trace(test, smooth_hz)
    cond = TestConditions.resolve(test, None, run.vehicle)
    applied = {path: cond[key] for key, path in CONSTANT_OVERRIDES.items()
               if (cond.source(key) or "").startswith("template")}
    applied.update(overrides or {})
    veh = run.vehicle.with_overrides(applied) if applied else run.vehicle
    sim = simulate(veh, cyc, dt=dt)
    st = sim.test
    t = st["veh_spd_simu"].time
    cols: dict[str, np.ndarray] = {"time": t}
    traces = {}
    for base in TRACES:
        meas = _on_grid(test, base, t)
        if meas is None:
            notes.append(f"no measured {base}_test: its trace is not compared")
            continue
        cols[f"{base}_test"], cols[f"{base}_simu"] = meas, st[f"{base}_simu"].values
        traces[base] = signal_metrics(meas, st[f"{base}_simu"].values)
    p_sim = battery_power(st["ess_volt_simu"].values, st["ess_curr_simu"].values)
    v_sim = st["veh_spd_simu"].values
    prec, pnote = cycle_precision(test.meta.cycle or cyc.name, "electric")
    s_r = float(prec.s_r or 0.0)
    if pnote:
        notes.append(pnote)
    eta = veh.charger.efficiency
    j_test = (res.j1634 or {}).get("scopes", {})
    energy, jrows = [], []
    scopes = [(p.name, p.segments) for p in res.phases] + [("test", [(float(t[0]),
                                                                     float(t[-1]))])]
    for scope, segs in scopes:
        dc_test = res.values.get(scope, {}).get("ess_energy_net_j")
        if dc_test is None:
            continue
        dc_model = _integral(t, p_sim, segs)
        u = (res.uncertainty.get(scope, {}).get("ess_energy_net_j") or {}).get("U")
        u_rel = abs(u / dc_test) if u is not None and dc_test else None
        row = _judge(dc_model / 3600.0, dc_test / 3600.0, u_rel, s_r, u_model_rel,
                     f"{scope} DC energy")
        energy.append({"scope": scope, "model_wh": row.pop("model"),
                       "test_wh": row.pop("test"), **row})
        fig_model = j1634_scope(dc_model, _integral(t, v_sim, segs), eta)
        for name in J1634_FIGURES:
            if scope in j_test:
                jrows.append({"scope": scope, "figure": name, **_judge(
                    fig_model[name], j_test[scope][name], j_test[scope].get(
                        "U_rel_dc_energy"), s_r, u_model_rel, f"{scope} {name}")})
    if j_test and (res.j1634 or {}).get("charger_efficiency") != eta:
        notes.append(f"AC figures: the model's charger efficiency {eta:g}, the test's "
                     f"{res.j1634['charger_efficiency']:g} ({j_test.get('test', {}).get('ac_basis', '')})")
    notes.append(f"U_model {100 * u_model_rel:.0f} % (k = {COVERAGE_K:g}): {u_model_source}")
    if applied:
        notes.append("parameters applied: " + ", ".join(f"{k} = {v:g}" for k, v in applied.items()))
    return BevValidation(
        test_id=test.meta.test_id, cycle=cyc.name, vehicle=veh, overrides=applied,
        traces=traces, energy=energy, j1634=jrows, u_model_rel=u_model_rel,
        u_model_source=u_model_source, overlays=pd.DataFrame(cols),
        sim_summary=dict(sim.summary), notes=notes, s_r=s_r)
