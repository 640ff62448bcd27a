"""Validation of a parallel hybrid on a test's traces (engine on/off, speed per gear, battery
energy, motor torque).

:func:`simulate_on_test` runs the vehicle over the test's own speed trace (a uniform grid of
``dt`` [s]) and returns test and model traces side by side; :func:`parallel_figures` turns
them into the figures docs/validation.md reports, over the whole test and over parts cut at
given times (e.g. the two HWFETs of a back-to-back run).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from vehval.analysis.parallel import gears_from_speeds, test_arrays
from vehval.constants import RPM_RAD_PER_S as RPM
from vehval.equations.engine_state import engine_running
from vehval.integrals import battery_power
from vehval.jsonsafe import clean

#: [m/s] measured speeds below this are standstill for the model's target (0.22 mph)
STANDING_MPS = 0.1
#: model signals kept beside the test's (base names of the ``_simu`` signals)
MODEL_SIGNALS = ("eng_on", "eng_spd_out", "mot_trq_out", "ess_pwr", "gb_gear", "veh_spd")


def simulate_on_test(veh, test, *, soc0: float, dt: float = 0.1, smooth_s: float = 1.0,
                     end_s: float | None = None) -> dict[str, np.ndarray]:
    """Test traces (``t``, ``veh_spd``, ``eng_spd_out``, ``mot_trq_out``, ``ess_curr``,
    ``ess_volt`` [SI]) and the model's (``sim_<base>``) on a uniform grid of ``dt`` [s] up to
    ``end_s`` (default: the end of the test), the model started at SOC ``soc0`` [-] and
    driven over the measured speed averaged over ``smooth_s`` [s] (sensor noise is no
    driver demand)."""
    from vehval.sim.simulate import architecture, make_grid, run_cycle

    a = test_arrays(test, ("veh_spd", "eng_spd_out", "whl_trq_out", "mot_trq_out", "ess_curr",
                           "ess_volt"))
    t0, t1 = float(a["t"][0]), float(a["t"][-1] if end_s is None else min(end_s, a["t"][-1]))
    t = t0 + np.arange(int(np.floor((t1 - t0) / dt + 1e-9)) + 1) * dt
    out = {"t": t}
    for k, x in a.items():
        if k != "t":
            out[k] = np.interp(t, a["t"], x)
    # a speed sensor's noise at standstill is no drive demand (it would restart the engine)
    # and the target is the measured speed over a centred ``smooth_s`` window
    n = max(int(round(smooth_s / dt)), 1)
    v = np.convolve(np.pad(out["veh_spd"], (n // 2, n - 1 - n // 2), mode="edge"),
                    np.ones(n) / n, mode="valid")
    target = np.where(v < STANDING_MPS, 0.0, v)
    grid = make_grid(veh, t, target, dt)
    sim, _ = run_cycle(veh, grid, soc0, True)
    col = architecture(veh).column
    for k in MODEL_SIGNALS:
        out[f"sim_{k}"] = sim[:, col[k]]
    return out


def _rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(x * x))) if x.size else float("nan")


def _part(veh, d: dict[str, np.ndarray], sel: np.ndarray, gear: np.ndarray) -> dict:
    dt = float(d["t"][1] - d["t"][0])
    on_t = engine_running(d["t"], d["eng_spd_out"])
    on_m = d["sim_eng_on"] > 0.5
    both = sel & on_t & on_m
    err = d["sim_eng_spd_out"] - d["eng_spd_out"]
    by_gear = {g: _rms(err[both & (gear == g)]) / RPM
               for g in range(1, len(veh.overall_ratios()) + 1) if (both & (gear == g)).sum() >= 20}
    p_t = battery_power(d["ess_volt"], d["ess_curr"])
    p_m = d["sim_ess_pwr"]
    wh = dt / 3600.0
    geared = sel & (gear > 0)
    return {
        "duration_s": float(sel.sum() * dt),
        "engine_on_agreement_pct": float(100 * np.mean(on_t[sel] == on_m[sel])),
        "engine_speed_rms_rpm": _rms(err[both]) / RPM,
        "engine_speed_rms_rpm_by_gear": by_gear,
        "battery_energy_test_wh": float(np.sum(p_t[sel]) * wh),
        "battery_energy_model_wh": float(np.sum(p_m[sel]) * wh),
        "battery_out_test_wh": float(np.sum(np.maximum(p_t[sel], 0)) * wh),
        "battery_out_model_wh": float(np.sum(np.maximum(p_m[sel], 0)) * wh),
        "battery_in_test_wh": float(-np.sum(np.minimum(p_t[sel], 0)) * wh),
        "battery_in_model_wh": float(-np.sum(np.minimum(p_m[sel], 0)) * wh),
        "motor_torque_rms_nm": _rms((d["sim_mot_trq_out"] - d["mot_trq_out"])[both]),
        "gear_agreement_pct": float(100 * np.mean(d["sim_gb_gear"][geared] == gear[geared]))
        if geared.any() else float("nan"),
    }


def parallel_figures(veh, d: dict[str, np.ndarray], cuts_s: tuple[float, ...] = (),
                     radius_m: float | None = None) -> dict[str, dict]:
    """Figures of :func:`simulate_on_test`'s traces: ``all`` and ``part_1``, ``part_2``...
    between the ``cuts_s`` [s]. Keys of each: engine on/off agreement [%], engine speed
    error RMS [rpm] (and per gear of the test, read from its speed ratio with ``radius_m``,
    default the vehicle's wheel radius), battery terminal energy net / out / in [Wh] test
    and model, motor torque error RMS [N·m] (engine running in both), gear agreement [%]."""
    r = veh.driveline.wheel_radius_m if radius_m is None else radius_m
    gear = gears_from_speeds(d["eng_spd_out"], d["veh_spd"] / r, veh.overall_ratios())
    t = d["t"]
    out = {"all": _part(veh, d, np.ones(t.size, bool), gear)}
    edges = [-np.inf, *cuts_s, np.inf]
    if cuts_s:
        for i in range(len(edges) - 1):
            out[f"part_{i + 1}"] = _part(veh, d, (t >= edges[i]) & (t < edges[i + 1]), gear)
    return out


#: Figures of a part shown in the report table: key -> (label, unit)
TABLE_FIGURES = {
    "engine_on_agreement_pct": ("engine on/off agreement", "%"),
    "engine_speed_rms_rpm": ("engine speed error RMS (engine on in both)", "rpm"),
    "battery_energy_model_wh": ("battery terminal energy, model", "Wh"),
    "battery_energy_test_wh": ("battery terminal energy, test", "Wh"),
    "battery_out_model_wh": ("battery energy out, model", "Wh"),
    "battery_out_test_wh": ("battery energy out, test", "Wh"),
    "battery_in_model_wh": ("battery energy in, model", "Wh"),
    "battery_in_test_wh": ("battery energy in, test", "Wh"),
    "motor_torque_rms_nm": ("motor torque error RMS (engine on in both)", "N·m"),
    "gear_agreement_pct": ("gear agreement", "%"),
}
#: Traces overlaid in the report: test key of :func:`simulate_on_test` -> base name
OVERLAY_TRACES = ("veh_spd", "eng_spd_out", "mot_trq_out")
#: One-at-a-time swings of the least-known inputs, relative to the model's own values:
#: label -> (what, factors). U_model of a figure is the root-sum-square over the swings of
#: half the figure's spread, read as k = 2.
SWINGS: dict[str, tuple[str, tuple[float, ...]]] = {
    "road load ±15 %": ("road_load", (0.85, 1.15)),
    "test mass ±5 %": ("mass", (0.95, 1.05)),
    "battery R ±30 %": ("battery_r", (0.7, 1.3)),
    "wheel radius ±1.5 %": ("radius", (0.985, 1.015)),
}
#: The battery energies judged by the normalised error (figure stem of :func:`_part`)
BATTERY_FIGURES = ("battery_out", "battery_in", "battery_energy")


def swung(veh: Any, what: str, factor: float) -> Any:
    """``veh`` with one least-known input scaled by ``factor`` (:data:`SWINGS`)."""
    b, body = veh.battery, veh.body
    change = {
        "road_load": {"body.road_load_a_n": factor * body.road_load_a_n,
                      "body.road_load_b_n_per_mps": factor * body.road_load_b_n_per_mps,
                      "body.road_load_c_n_per_mps2": factor * body.road_load_c_n_per_mps2},
        "mass": {"body.mass_kg": factor * body.mass_kg},
        "battery_r": {"battery.resistance_discharge_ohm": [factor * x for x in
                                                           b.resistance_discharge_ohm],
                      "battery.resistance_charge_ohm": [factor * x for x in
                                                        b.resistance_charge_ohm]},
        "radius": {"driveline.wheel_radius_m": factor * veh.driveline.wheel_radius_m},
    }[what]
    return veh.with_overrides(change)


def _leaves(d: dict, prefix: str = "") -> Any:
    for k, v in d.items():
        if isinstance(v, dict):
            yield from _leaves(v, f"{prefix}{k}.")
        else:
            yield f"{prefix}{k}", v


def model_uncertainty(figures_of: Any, veh: Any, base: dict,
                      swings: dict[str, list[Any]] | None = None) -> dict[str, float]:
    """U_model (k = 2) of every figure of ``base`` (``figures_of(vehicle)`` of ``veh``),
    flattened as ``part.figure``: the root-sum-square over the swings of half the figure's
    spread. ``swings``: label -> the vehicles (or override mappings) of that swing; default
    :data:`SWINGS` applied to ``veh``."""
    flat0 = dict(_leaves(base))
    acc = {k: 0.0 for k in flat0}
    chosen = swings if swings is not None else {
        label: [swung(veh, what, f) for f in fs] for label, (what, fs) in SWINGS.items()}
    for variants in chosen.values():
        vals = {k: [v] for k, v in flat0.items()}
        for var in variants:
            other = dict(_leaves(figures_of(veh.with_overrides(var) if isinstance(var, dict)
                                            else var)))
            for k in vals:
                if k in other:
                    vals[k].append(other[k])
        for k, xs in vals.items():
            acc[k] += (0.5 * (max(xs) - min(xs))) ** 2
    return {k: float(np.sqrt(x)) for k, x in acc.items()}


def battery_verdicts(figs: dict[str, dict], u_model: dict[str, float],
                     volt_v: float) -> dict[str, dict[str, dict[str, Any]]]:
    """En of the battery energies (:data:`BATTERY_FIGURES`) of every part of ``figs``:
    U_model from :func:`model_uncertainty`, the test's U from the class defaults of the
    battery current and voltage (gain limits in RSS; the current's offset limit over the
    part's duration at ``volt_v`` [V])."""
    from vehval.uncertainty.sensors import channel_accuracy
    from vehval.uncertainty.verdict import normalised_error

    ci, cv = channel_accuracy("ess_curr_test", None), channel_accuracy("ess_volt_test", None)
    gain = (ci.gain_limit ** 2 + cv.gain_limit ** 2) ** 0.5
    out: dict[str, dict[str, dict[str, Any]]] = {}
    for part, f in figs.items():
        off_wh = ci.offset_limit * volt_v * f["duration_s"] / 3600.0
        out[part] = {}
        for q in BATTERY_FIGURES:
            meas, model = f[f"{q}_test_wh"], f[f"{q}_model_wh"]
            u_meas = ((gain * abs(meas)) ** 2 + off_wh ** 2) ** 0.5
            if not (np.isfinite(meas) and np.isfinite(model)) or meas == 0.0:
                out[part][q] = {"en": None, "u_test_wh": u_meas, "consistent": None}
                continue
            c = normalised_error(model, meas, u_model[f"{part}.{q}_model_wh"], u_meas, label=q)
            out[part][q] = {"en": c.en, "u_test_wh": u_meas, "u_model_wh": c.u_model,
                            "consistent": c.consistent}
    return out


@dataclass
class ParallelValidation:
    """One parallel-hybrid test validated on its traces.

    Attributes
    ----------
    test_id : str
    vehicle : ParallelHybridVehicle
        The model as run (template mass and road load, caller overrides applied).
    overrides : dict
        Dotted parameters applied.
    soc_initial : float
        SOC [-] the model started from (the test's measured SOC, else the controller's
        target).
    figures : dict
        :func:`parallel_figures` of the whole test (``all``).
    overlays : DataFrame
        ``time`` and ``<base>_test`` / ``<base>_simu`` (SI) of the traces overlaid.
    notes : list of str
    verdicts : dict
        :func:`battery_verdicts` of the whole test (``all`` -> figure -> En, U).
    """

    test_id: str
    vehicle: Any
    overrides: dict[str, Any]
    soc_initial: float
    figures: dict[str, dict]
    overlays: pd.DataFrame
    notes: list[str] = field(default_factory=list)
    verdicts: dict[str, dict[str, dict[str, Any]]] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary (``validation.json`` of a parallel-hybrid test)."""
        return clean({
            "architecture": "parallel_hybrid", "test_id": self.test_id,
            "vehicle": self.vehicle.name, "vehicle_file": self.vehicle.file,
            "overrides": dict(self.overrides), "soc_initial": self.soc_initial,
            "figures": self.figures, "verdicts": self.verdicts, "notes": list(self.notes)})

    def verdict(self) -> dict[str, Any]:
        """The test's verdict: the normalised error of its net battery energy (the figure
        a charge-sustaining strategy is judged by), with the traces' agreement in ``text``."""
        f, v = self.figures["all"], self.verdicts.get("all", {}).get("battery_energy", {})
        meas, model = f["battery_energy_test_wh"], f["battery_energy_model_wh"]
        en = v.get("en")
        return {"figure": "battery_energy_wh", "en": en, "consistent": v.get("consistent"),
                "model": model, "measured": meas, "u_model": v.get("u_model_wh"),
                "u_meas": v.get("u_test_wh"), "s_r": 0.0, "text": (
                    f"battery net {model:.1f} Wh against {meas:.1f} Wh, engine on/off "
                    f"agreement {f['engine_on_agreement_pct']:.1f} %, gear "
                    f"{f['gear_agreement_pct']:.1f} %, engine speed RMS "
                    f"{f['engine_speed_rms_rpm']:.0f} rpm")}

    def tables(self) -> list[dict[str, Any]]:
        """Report tables: each figure of the whole test, and the battery energies' En."""
        f = self.figures["all"]
        rows = [[label, unit, f[k]] for k, (label, unit) in TABLE_FIGURES.items() if k in f]
        rows += [[f"engine speed error RMS, gear {g}", "rpm", x]
                 for g, x in f.get("engine_speed_rms_rpm_by_gear", {}).items()]
        en = [[q, f[f"{q}_model_wh"], f[f"{q}_test_wh"], v.get("u_model_wh"), v["u_test_wh"],
               v["en"]] for q, v in self.verdicts.get("all", {}).items()]
        return [{"title": f"Traces, model vs test ({self.test_id})",
                 "columns": ["figure", "unit", "value"], "rows": rows},
                {"title": f"Battery energy, model vs test ({self.test_id})",
                 "columns": ["figure", "model [Wh]", "test [Wh]", "U_model [Wh]",
                             "U_test [Wh]", "En"], "rows": en}]

    def payload(self, figures: bool = True) -> dict[str, Any]:
        """The report's validation section: ``{tables, figures, notes}``."""
        from vehval.validate.compare import overlay_figures

        figs = overlay_figures(self) if figures else []  # type: ignore[arg-type]  # reads .overlays only
        return {"tables": self.tables(), "figures": figs, "notes": list(self.notes)}


def validate_parallel_test(run: Any, *, dt: float = 0.1, overrides: dict | None = None,
                           **_: Any) -> ParallelValidation:
    """Simulate the run's parallel hybrid over its test's speed trace (QA's validated test)
    from the test's SOC and compare the traces (:func:`parallel_figures`).

    ``dt`` [s] is the simulation step; ``overrides`` dotted vehicle parameters applied after
    the template's mass and road load."""
    from vehval.conditions import TestConditions
    from vehval.validate.conditions import CONSTANT_OVERRIDES, initial_soc

    test = run.validated
    notes: list[str] = []
    cond = TestConditions.resolve(test, None, run.vehicle)
    applied = {path: cond[key] for key, path in CONSTANT_OVERRIDES.items()
               if (cond.source(key) or "").startswith("template")}
    applied.update(overrides or {})
    veh = run.vehicle.with_overrides(applied) if applied else run.vehicle
    soc0 = initial_soc(test)
    if soc0 is None:
        soc0 = float(veh.controller.soc_target)
        notes.append(f"no measured SOC: the model starts from the controller's target "
                     f"{soc0:.0%}")
    d = simulate_on_test(veh, test, soc0=soc0, dt=dt)
    overlays = pd.DataFrame({"time": d["t"], **{f"{b}_test": d[b] for b in OVERLAY_TRACES},
                             **{f"{b}_simu": d[f"sim_{b}"] for b in OVERLAY_TRACES}})
    figs = {"all": parallel_figures(veh, d)["all"]}

    def figures_of(v: Any) -> dict:
        return {"all": parallel_figures(v, simulate_on_test(v, test, soc0=soc0, dt=dt))["all"]}

    u_model = model_uncertainty(figures_of, veh, figs)
    volt = float(np.nanmedian(d["ess_volt"]))
    notes.append("U_model: half the spread over " + ", ".join(SWINGS) + ", root-sum-square "
                 "(k = 2); U_test: the class defaults of battery current and voltage at "
                 f"{volt:.0f} V")
    return ParallelValidation(test_id=str(test.meta.test_id), vehicle=veh, overrides=applied,
                              soc_initial=soc0, figures=figs, overlays=overlays, notes=notes,
                              verdicts=battery_verdicts(figs, u_model, volt))
