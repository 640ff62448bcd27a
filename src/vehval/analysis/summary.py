"""``analyze``: the whole control-strategy analysis of one test, and its control.json."""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np

from vehval.analysis.braking import braking_split
from vehval.analysis.demand import (
    estimate_soc,
    force_delay_steps,
    power_sign_check,
    quantisation_step,
    rule_demand,
)
from vehval.analysis.events import event_table
from vehval.analysis.inputs import Finding, pick_signal, prepare_inputs
from vehval.analysis.modes import (
    MODES,
    classify_modes,
    detect_engine_on,
    mode_shares,
    run_lengths,
    timeline,
)
from vehval.analysis.operating import (
    current_histogram,
    operating_points,
    power_histogram_by_mode,
)
from vehval.analysis.replay import base_params, rule_vector, score_rule
from vehval.analysis.soc import fit_soc_regulation
from vehval.analysis.thresholds import ESTIMATED, fit_rule, lag_grids
from vehval.jsonsafe import clean
from vehval.test import Test, is_hybrid

CONTROL_VERSION = 1


@dataclass
class AnalysisResult:
    """Everything the control-strategy analysis found; :meth:`to_dict` is control.json."""

    test_id: str
    controller: dict
    uncertainty: dict
    rule_agreement: float | None
    events: list
    modes: dict
    soc_regulation: dict
    operating_points: dict
    braking: dict
    findings: list
    engine: dict = field(default_factory=dict)
    rule: dict = field(default_factory=dict)
    inputs: dict = field(default_factory=dict)
    replay_inputs: dict = field(default_factory=dict, repr=False)

    def replay_agreement(self, params: dict) -> float | None:
        """Agreement of the rule with ``params`` replayed on this test's rebuilt inputs.

        Keys missing from ``params`` take the values the estimate used
        (``rule["replay_params"]``); the start / stop delays are searched over the same
        grids as in the estimate. Used to score a known (e.g. true) parameter set on the
        same demand, speed and SOC. ``None`` when no rule was estimated.
        """
        ri = self.replay_inputs
        if not ri:
            return None
        full = dict(self.rule.get("replay_params", {}))
        full.update({k: float(v) for k, v in params.items() if k in full})
        prm = rule_vector(full)
        dt = ri["dt"]
        la, lb = ri["lags"]
        return max(score_rule(ri["p"], ri["v"], ri["soc"], ri["pdis_av"], ri["aux_w"], dt, prm,
                              ri["state0"], ri["obs"], ri["valid"], int(a), int(b))
                   for a in la for b in lb)

    def to_dict(self) -> dict:
        return clean({
            "control_version": CONTROL_VERSION, "test_id": self.test_id,
            "controller": self.controller, "uncertainty": self.uncertainty,
            "rule_agreement": self.rule_agreement, "rule": self.rule, "engine": self.engine,
            "events": self.events, "modes": self.modes, "soc_regulation": self.soc_regulation,
            "operating_points": self.operating_points, "braking": self.braking,
            "findings": self.findings, "inputs": self.inputs, "report": self.report()})

    def report(self) -> dict:
        """Section for the HTML report: {title, tables, figures (plotly dicts)}."""
        rows = [[k, v, self.uncertainty.get(k, {}).get("low"), self.uncertainty.get(k, {}).get("high")]
                for k, v in self.controller.items()]
        for k, b in self.rule.get("bounds", {}).items():
            rows.append([k, "not identified", b.get("low"), b.get("high")])
        tables = [
            {"title": "Estimated controller parameters", "columns": ["key", "estimate", "low", "high"],
             "rows": rows},
            {"title": "Operating modes", "columns": ["mode", "time [s]", "share"],
             "rows": [[m, d["time_s"], d["share"]] for m, d in self.modes.get("shares", {}).items()
                      if d["time_s"] > 0]},
            {"title": "Engine on/off events", "columns": ["type", "time [s]", "speed [m/s]",
                                                          "wheel power [W]", "SOC", "cause"],
             "rows": [[e["type"], e["time_s"], e["speed_mps"], e["wheel_power_w"], e["soc"], e["cause"]]
                      for e in self.events[:200]]},
            {"title": "Findings", "columns": ["kind", "signal", "message"],
             "rows": [[f["kind"], f["signal"], f["message"]] for f in self.findings]},
        ]
        from vehval.figures import bar_figure, markers_figure

        figs = []
        hist = self.operating_points.get("power_by_mode", {})
        if "edges_w" in hist:
            centers = [(a + b) / 2e3 for a, b in zip(hist["edges_w"][:-1], hist["edges_w"][1:])]
            figs.append(bar_figure([{"name": m, "x": centers, "y": c}
                                    for m, c in hist["counts"].items()],
                                   title="Engine power by mode", stacked=True,
                                   xlabel="engine power [kW]", ylabel="steps"))
        cur = self.braking.get("current_during_regen", {})
        if "edges_a" in cur:
            centers = [(a + b) / 2 for a, b in zip(cur["edges_a"][:-1], cur["edges_a"][1:])]
            figs.append(bar_figure([{"x": centers, "y": cur["counts"]}],
                                   title="Battery current during regenerative braking",
                                   xlabel="current [A]", ylabel="steps"))
        ev = [e for e in self.events if e["type"] == "on"]
        if ev:
            from vehval.display import to_display

            v, vu = to_display(np.array([e["speed_mps"] for e in ev], float), "m/s")
            p, pu = to_display(np.array([e["total_demand_w"] for e in ev], float), "W")
            figs.append(markers_figure([{"name": "engine starts", "x": v, "y": p}],
                                       title="Conditions at engine starts",
                                       xlabel=f"speed [{vu}]", ylabel=f"total demand [{pu}]"))
        return {"title": "Control strategy", "tables": tables, "figures": figs}


def _battery_limits(soc: np.ndarray, vehicle: Any) -> tuple:
    """(available discharge power, discharge limit, charge limit) [W] at the SOC, or Nones."""
    if vehicle is None or not np.any(np.isfinite(soc)):
        return None, None, None
    b = vehicle.battery
    s = np.where(np.isfinite(soc), soc, vehicle.controller.soc_target)
    pd = np.interp(s, b.soc, b.discharge_power_limit_w)
    pc = np.interp(s, b.soc, b.charge_power_limit_w)
    return pd - vehicle.controller.battery_discharge_margin_w, pd, pc


def _state_of_charge(test: Test, inp: Any, vehicle: Any, base: dict,
                     findings: list[Finding]) -> tuple[Any, float | None]:
    """State of charge (coulomb counting anchored to the logged SOC) and the logged SOC's
    resolution [-]; a warning when that resolution blurs the SOC-regulation demand."""
    soc_sig = pick_signal(test, "ess_soc")
    res_step = quantisation_step(soc_sig.values) if soc_sig is not None else None
    curr, curr_label = inp.ess_curr, inp.sources.get("battery current", "battery current")
    if not inp.has("ess_curr") and inp.has("ess_pwr") and inp.has("ess_volt"):
        # e.g. the QA dropped the current channel but kept the battery power
        with np.errstate(divide="ignore", invalid="ignore"):
            curr = np.where(inp.ess_volt > 1.0, inp.ess_pwr / inp.ess_volt, np.nan)
        curr_label = f"{inp.sources['battery power']} / {inp.sources['battery voltage']}"
    se = estimate_soc(inp.t, inp.soc, curr,
                      vehicle.battery.capacity_ah if vehicle is not None else None,
                      curr_label=curr_label, resolution=res_step)
    findings.extend(se.findings)
    if (res_step and res_step >= 0.002 and se.method.startswith("measured") and soc_sig is not None
            and base["soc_gain_w"] > 0):
        findings.append(Finding("warning", soc_sig.name, (
            f"logged SOC resolution {res_step:.3g} and no usable battery current: the SOC-"
            f"regulation demand is known only to ±{0.5 * res_step * base['soc_gain_w']:.0f} W")))
    return se, res_step


class _RuleFit(NamedTuple):
    """The engine on/off rule of a hybrid (empty parts when it was not estimated)."""

    agreement: float | None
    controller: dict
    uncertainty: dict
    rule: dict
    events: list
    demand: dict
    replay_inputs: dict


def _engine_rule(test: Test, inp: Any, vehicle: Any, es: Any, soc: np.ndarray,
                 ess_pwr: np.ndarray, base: dict, aux: float, limits: tuple[Any, Any],
                 findings: list[Finding]) -> _RuleFit:
    """Fit and replay the engine on/off rule of a hybrid (its estimated controller
    parameters and their uncertainty); the event table of every car. ``limits`` are the
    available and the limiting discharge power [W] of :func:`_battery_limits`."""
    pdis_av, pd_lim = limits
    controller: dict = {}
    uncertainty: dict = {}
    agree = None
    rule: dict = {}
    n_switch = int(np.sum(es.on[1:] != es.on[:-1]))
    demand_info: dict = {}
    replay_inputs: dict = {}
    # the engine on/off rule is a hybrid's: a conventional car's engine runs while it drives
    hybrid = _is_hybrid_drive(test, vehicle, es, inp)
    if hybrid and es.valid.any() and inp.has("p_whl") and n_switch >= 2:
        lead = None
        if inp.sources.get("tractive force"):
            with np.errstate(divide="ignore", invalid="ignore"):
                frc = np.where(inp.v > 0.5, inp.p_whl / inp.v, np.nan)
            lead = force_delay_steps(inp.v, frc, inp.dt, inp.consts)
        dem = rule_demand(inp.t, inp.v, inp.a, inp.p_whl, es.on, ess_pwr, inp.consts,
                          eng_spd=inp.eng_spd, pdis_lim=pd_lim, lead_steps=lead or 0)
        demand_info = dem.info
        lag_center = (dem.info.get("median_spin_up_s"), dem.info.get("median_spin_down_s"))
        from vehval.numba_cache import compile_notice

        compile_notice("supervisor", "replay_rule", "engine-rule replay kernel")
        fit = fit_rule(es.on, es.valid, dem.p, inp.v, soc, inp.dt, base, aux_w=aux,
                       pdis_av=pdis_av, lag_center_s=lag_center)
        controller.update(fit.estimated)
        uncertainty.update({k: fit.uncertainty[k] for k in fit.uncertainty})
        agree = round(fit.agreement, 5)
        src = f"vehicle file ({vehicle.name})" if vehicle is not None and getattr(vehicle, "name", None) \
            else ("vehicle file" if vehicle is not None else "generic default (no vehicle)")
        rule = {"lag_s": fit.lag_s, "bounds": fit.bounds, "notes": fit.notes,
                "replay_params": fit.params, "plausible_ranges": fit.ranges,
                "fixed": {k: {"value": v, "source": src} for k, v in fit.params.items()
                          if k not in fit.estimated and k not in fit.bounds and k not in ESTIMATED},
                "run_durations_s": fit.runs}
        events = event_table(inp.t, es.on, es.valid, inp.v, dem.p, soc, ess_pwr,
                             fit.params, aux, fit.lag_s["start"])
        for n in fit.notes:
            findings.append(Finding("warning", "engine state", n))
        def f64(x):
            return np.ascontiguousarray(x, dtype=np.float64)

        valid = es.valid & np.isfinite(inp.v)
        replay_inputs = {
            "p": f64(dem.p), "v": f64(inp.v), "soc": f64(soc), "dt": float(inp.dt),
            "aux_w": aux, "obs": np.ascontiguousarray(es.on), "valid": np.ascontiguousarray(valid),
            "state0": bool(es.on[np.argmax(valid)]) if valid.any() else False,
            "lags": lag_grids(inp.dt, lag_center_s=lag_center),
            "pdis_av": f64(np.full(inp.n, np.inf) if pdis_av is None
                           else np.where(np.isfinite(pdis_av), pdis_av, np.inf))}
    elif not hybrid:
        findings.append(Finding("info", "engine state", CONVENTIONAL_NOTE))
        events = event_table(inp.t, es.on, es.valid, inp.v, inp.p_whl, soc, ess_pwr,
                             base, aux, 0.0)
    else:
        findings.append(Finding("warning", "engine state",
                                "engine on/off rule not estimated: needs engine speed or fuel rate, "
                                "a wheel power demand and at least one engine start and stop "
                                f"(found {n_switch} switch(es))"))
        events = event_table(inp.t, es.on, es.valid, inp.v, inp.p_whl, soc, ess_pwr,
                             base, aux, 0.0)
    return _RuleFit(agree, controller, uncertainty, rule, events, demand_info, replay_inputs)


def analyze(test: Test, vehicle: Any = None, constants: dict | None = None, *,  # noqa: PLR0915 - the analysis steps in order, each one a few lines
            dt: float | None = None) -> AnalysisResult:
    """Control-strategy analysis of a test.

    Parameters
    ----------
    test : Test
        Imported (ideally QA-validated) test; ``_test`` then ``_calc`` signals are used.
    vehicle : Vehicle or str, optional
        Gives the fixed controller parameters (hold times, SOC regulation and conditions,
        auxiliary load, battery limits and capacity), the fuel map for the best-efficiency
        line and default constants.
    constants : dict, optional
        Constants overriding the test's (mass, road load, wheel radius).
    dt : float, optional
        Analysis grid step [s] (default: the speed signal's period, at least 0.1 s).

    Returns
    -------
    AnalysisResult
    """
    if isinstance(vehicle, str):
        from vehval.vehicle import load_vehicle
        vehicle = load_vehicle(vehicle)
    inp = prepare_inputs(test, vehicle, constants, dt)
    findings: list[Finding] = list(inp.findings)
    es = detect_engine_on(inp.t, inp.eng_spd, inp.fuel_rate)
    aux = float(vehicle.body.aux_power_w) if vehicle is not None else 0.0
    base = base_params(vehicle)
    se, res_step = _state_of_charge(test, inp, vehicle, base, findings)
    soc = se.soc
    ess_pwr, f_sign = power_sign_check(inp.t, soc, inp.ess_pwr)
    findings.extend(f_sign)
    pdis_av, pd_lim, pc_lim = _battery_limits(soc, vehicle)
    eng_pwr = inp.eng_spd * inp.eng_trq
    codes = classify_modes(inp.v, inp.p_whl, es.on, ess_pwr, eng_pwr)
    _starts, _lengths, vals = run_lengths(es.on)
    engine = {"method": es.method, "on_share": float(np.mean(es.on[es.valid])) if es.valid.any() else None,
              "starts": int(np.sum(vals[1:])) if vals.size else 0,
              "valid_share": float(np.mean(es.valid))}
    soc_reg = fit_soc_regulation(soc, ess_pwr, es.on & es.valid, inp.p_whl, inp.dt)
    soc_reg["engine_on_share_by_soc"] = _on_by_soc(soc, es.on, es.valid)
    soc_reg["soc_source"] = se.method
    soc_reg["soc_resolution"] = res_step
    controller: dict = {}
    uncertainty: dict = {}
    if soc_reg.get("fitted") and "soc_target" in soc_reg and soc_reg.get("r2", 0) > 0.3:
        soc_reg["battery_side_gain_w"] = soc_reg.pop("soc_gain_w")
        controller["soc_target"] = round(soc_reg["soc_target"], 4)
        uncertainty["soc_target"] = {"method": "robust linear fit of battery power against SOC "
                                     "in steady engine-on propulsion (zero crossing; biased by "
                                     "the auxiliary load and losses)", "r2": soc_reg["r2"]}
    fit = _engine_rule(test, inp, vehicle, es, soc, ess_pwr, base, aux, (pdis_av, pd_lim),
                       findings)
    controller.update(fit.controller)
    uncertainty.update(fit.uncertainty)
    agree, rule, events = fit.agreement, fit.rule, fit.events
    demand_info, replay_inputs = fit.demand, fit.replay_inputs
    regen_mask = codes == MODES.index("regen_braking")
    op = operating_points(inp.eng_spd, inp.eng_trq, es.on, inp.dt, vehicle, ess_pwr, pd_lim, pc_lim)
    op["power_by_mode"] = power_histogram_by_mode(eng_pwr, codes, es.on)
    brk = braking_split(inp.v, inp.a, inp.p_whl, ess_pwr, inp.brk_frc, aux_w=aux,
                        path_efficiency=base["electric_drive_efficiency"])
    brk["current_during_regen"] = current_histogram(inp.ess_curr, regen_mask)
    if not np.any(np.isfinite(ess_pwr)) and inp.has("ess_curr"):
        # no voltage: the regen current histogram still needs braking steps
        brake = np.isfinite(inp.a) & (inp.a < -0.3) & (inp.v > 1.0) & ~es.on
        brk["current_during_decel_engine_off"] = current_histogram(inp.ess_curr, brake)
    modes = {"codes": list(MODES), "timeline": timeline(inp.t, codes), "shares": mode_shares(codes, inp.dt)}
    return AnalysisResult(
        test_id=test.meta.test_id, controller=controller, uncertainty=uncertainty,
        rule_agreement=agree, events=events, modes=modes, soc_regulation=soc_reg,
        operating_points=op, braking=brk, findings=[f.to_dict() for f in findings], engine=engine,
        rule=rule, inputs={"dt_s": inp.dt, "duration_s": float(inp.t[-1] - inp.t[0]) if inp.n else 0.0,
                           "sources": inp.sources, "soc": {"method": se.method, **se.info},
                           "demand": demand_info},
        replay_inputs=replay_inputs)


#: Engine-off time while moving [s] (above ``ELECTRIC_DRIVE_MIN_MPS``) that shows a hybrid
#: when neither a vehicle file nor a battery, motor or generator signal says so.
ELECTRIC_DRIVE_MIN_S, ELECTRIC_DRIVE_MIN_MPS = 5.0, 2.0


#: The analysis' finding when it judges the drive a conventional car's (the CLI reads it).
CONVENTIONAL_NOTE = ("engine on/off rule not estimated: a conventional vehicle (its vehicle "
                     "file says so, or no battery, motor or generator signal and the engine runs "
                     "whenever the car moves)")


def judged_conventional(findings: list) -> bool:
    """Whether :func:`_is_hybrid_drive` judged the drive conventional (from the findings)."""
    return any((f.get("message") if isinstance(f, dict) else getattr(f, "message", None))
               == CONVENTIONAL_NOTE for f in findings)


def _is_hybrid_drive(test: Test, vehicle: Any, es: Any, inp: Any) -> bool:
    """A hybrid: the vehicle file says so, or a hybrid-component signal, or the engine stays
    off for a while as the car moves (no conventional car drives with its engine stopped)."""
    if getattr(vehicle, "architecture", None) is not None or is_hybrid(test):
        return is_hybrid(test, vehicle)
    moving_off = es.valid & ~es.on & (np.nan_to_num(inp.v) > ELECTRIC_DRIVE_MIN_MPS)
    return float(np.sum(moving_off)) * float(inp.dt) >= ELECTRIC_DRIVE_MIN_S


def _on_by_soc(soc: np.ndarray, on: np.ndarray, valid: np.ndarray) -> list[dict]:
    """Engine-on share per 2 %-SOC bin (the SOC window the strategy keeps)."""
    ok = np.isfinite(soc) & valid
    if not ok.any():
        return []
    edges = np.arange(np.floor(np.min(soc[ok]) * 50) / 50, np.max(soc[ok]) + 0.02, 0.02)
    out = []
    for lo, hi in itertools.pairwise(edges):
        sel = ok & (soc >= lo) & (soc < hi)
        if sel.sum():
            out.append({"soc": [round(float(lo), 3), round(float(hi), 3)],
                        "on_share": float(np.mean(on[sel])), "n": int(sel.sum())})
    return out
