"""Control analysis of a parallel hybrid (engine and motor on one shaft): when the motor
assists, when it regenerates, when the engine stops.

Input: plain arrays on one time base (SI): vehicle speed [m/s], shaft (engine) speed
[rad/s], motor torque [N·m] (+ assist), shaft torque demand [N·m] (wheel torque over the
overall ratio of the engaged gear), SOC or battery current. The rules come back as
thresholds with their support (how many samples they explain, and how many contradict
them), the way ``vehval analyze`` states the power-split car's engine rule.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from vehval.equations.engine_state import engine_running

#: [N·m] motor torque beyond which a sample counts as assist (+) or regen (-)
ACTIVE_NM = 2.0
#: relative tolerance of a gear's overall ratio when gears are read from speeds [-]
GEAR_TOLERANCE = 0.04


@dataclass
class Rule:
    """One threshold rule: ``quantity`` ``op`` ``threshold`` (unit) explains ``support`` of
    the ``n`` samples it covers; ``contradicted`` samples break it."""

    name: str
    quantity: str
    op: str
    threshold: float
    unit: str
    support: float
    n: int
    contradicted: int

    def as_dict(self) -> dict:
        return asdict(self)


def gears_from_speeds(shaft_radps: np.ndarray, wheel_radps: np.ndarray,
                      overall_ratios: np.ndarray, tol: float = GEAR_TOLERANCE) -> np.ndarray:
    """Engaged gear (1-based) per sample from the shaft / wheel speed ratio; 0 where no gear's
    overall ratio is within ``tol`` (shifts, clutch slip, standstill)."""
    w = np.asarray(wheel_radps, float)
    ratio = np.divide(np.asarray(shaft_radps, float), w, out=np.zeros_like(w), where=w > 1.0)
    r = np.asarray(overall_ratios, float)
    err = np.abs(ratio[:, None] / r[None, :] - 1.0)
    best = np.argmin(err, axis=1)
    ok = err[np.arange(len(w)), best] <= tol
    return np.where(ok, best + 1, 0)


def _best_split(x: np.ndarray, on: np.ndarray) -> tuple[float, float, int]:
    """Threshold on ``x`` that best separates ``on`` (above) from off (below): (threshold,
    share of samples classified right, samples misclassified)."""
    if x.size == 0:
        return float("nan"), float("nan"), 0
    cand = np.unique(np.quantile(x, np.linspace(0.002, 0.998, 500)))
    best = (float("nan"), -1.0, 0)
    for c in cand:
        right = np.mean((x > c) == on)
        if right > best[1]:
            best = (float(c), float(right), int(np.sum((x > c) != on)))
    return best


def assist_regen_rules(t_dem: np.ndarray, t_mot: np.ndarray, v: np.ndarray,
                       gear: np.ndarray, engine_on: np.ndarray) -> dict:
    """Assist and regen rules of a log (engine running, a gear engaged).

    Returns ``assist_threshold`` / ``regen_threshold`` (shaft torque demand [N·m] as
    :class:`Rule`), ``regen_min_speed`` [m/s], ``assist_gears`` (share of samples with
    assist per gear) and the assist torque statistics (median, 99th percentile [N·m]).
    """
    sel = engine_on & (gear > 0)
    td, tm, vv, g = t_dem[sel], t_mot[sel], v[sel], gear[sel]
    assist = tm > ACTIVE_NM
    regen = tm < -ACTIVE_NM
    per_gear = {int(k): float(np.mean(assist[g == k])) for k in np.unique(g)}
    # the threshold is read in the gears that assist at all (a gear without assist, e.g.
    # 1st in the Insight, is its own rule: assist_share_by_gear)
    ga = np.isin(g, [k for k, share in per_gear.items() if share > 0])
    thr_a, sup_a, bad_a = _best_split(td[ga], assist[ga])
    thr_r, sup_r, bad_r = _best_split(-td, regen)
    spd_r = float(np.min(vv[regen])) if regen.any() else float("nan")
    return {
        "assist_threshold": Rule("assist", "shaft torque demand", ">", thr_a, "N·m", sup_a,
                                 int(ga.sum()), bad_a).as_dict(),
        "regen_threshold": Rule("regen", "shaft torque demand", "<", -thr_r, "N·m", sup_r,
                                int(td.size), bad_r).as_dict(),
        "regen_min_speed_mps": spd_r,
        "assist_share_by_gear": per_gear,
        "assist_torque_median_nm": float(np.median(tm[assist])) if assist.any() else 0.0,
        "assist_torque_p99_nm": float(np.quantile(tm[assist], 0.99)) if assist.any() else 0.0,
        "regen_torque_min_nm": float(np.min(tm[regen])) if regen.any() else 0.0,
    }


def engine_stop_rule(t: np.ndarray, v: np.ndarray, shaft_radps: np.ndarray,
                     accel: np.ndarray) -> dict:
    """Idle-stop conditions: every engine stop event (running -> stopped) with the speed
    [m/s] and acceleration [m/s²] at the stop, and the rule ``stop below v_max while
    decelerating`` with its support (the share of stops it explains)."""
    on = engine_running(t, shaft_radps)  # the package's one engine-on rule
    idx = np.flatnonzero(on[:-1] & ~on[1:]) + 1
    starts = np.flatnonzero(~on[:-1] & on[1:]) + 1
    events = [{"t_s": float(t[i]), "speed_mps": float(v[i]), "accel_mps2": float(accel[i])}
              for i in idx]
    decel = [e for e in events if e["accel_mps2"] <= 0.05]
    vmax = max((e["speed_mps"] for e in decel), default=float("nan"))
    return {
        "stops": events,
        "restarts": [{"t_s": float(t[i]), "speed_mps": float(v[i])} for i in starts],
        "rule": Rule("engine stop", "vehicle speed while decelerating", "<", vmax, "m/s",
                     len(decel) / len(events) if events else float("nan"), len(events),
                     len(events) - len(decel)).as_dict(),
        "engine_off_share": float(np.mean(~on)),
    }


def test_arrays(test, names: tuple[str, ...] = ("veh_spd", "eng_spd_out", "whl_trq_out",
                                                "mot_trq_out", "ess_curr", "ess_volt")
                ) -> dict[str, np.ndarray]:
    """The signals a parallel hybrid's analysis reads, measured first then calculated
    (:meth:`vehval.test.Test.best`), on the vehicle speed's time base (key ``t`` [s]).

    Raises :class:`~vehval.errors.SignalError` naming the first missing quantity."""
    from vehval.errors import SignalError

    spd = test.best("veh_spd")
    if spd is None:
        raise SignalError("the parallel-hybrid analysis needs the vehicle speed (veh_spd)")
    out = {"t": spd.time}
    for base in names:
        sig = test.best(base)
        if sig is None:
            raise SignalError(f"the parallel-hybrid analysis needs '{base}' (measured or "
                              "calculated); the test has none")
        out[base] = sig.at(spd.time)
    return out


@dataclass
class ParallelAnalysis:
    """The control analysis of one parallel-hybrid test (``vehval analyze``'s control.json).

    ``document`` holds ``architecture``, ``gear_share``, ``assist_regen`` and
    ``engine_stop`` (indexable as ``analysis["assist_regen"]``); ``findings`` the notes the
    flow adds (samples QA excluded), as dicts.
    """

    document: dict
    findings: list = field(default_factory=list)

    def __getitem__(self, key: str):
        return self.document[key]

    def to_dict(self) -> dict:
        """control.json: the document and the findings."""
        return {**self.document, "findings": list(self.findings)}

    def summary_lines(self) -> list[str]:
        """The analysis on screen: its kind, then the assist / regen and engine-stop rules."""
        ar, st = self.document["assist_regen"], self.document["engine_stop"]["rule"]
        lines = ["parallel hybrid, assist / regen / engine stop"]
        for key in ("assist_threshold", "regen_threshold"):
            r = ar[key]
            lines.append(f"  {r['name']} when {r['quantity']} {r['op']} {r['threshold']:.1f} "
                         f"N·m (explains {r['support']:.1%} of {r['n']} samples)")
        from vehval.display import format_value

        lines.append(f"  no regen below {format_value(ar['regen_min_speed_mps'], 'm/s', digits=3)}"
                     "; assist share by gear " + ", ".join(
                         f"{g}: {s:.0%}" for g, s in ar["assist_share_by_gear"].items()))
        lines.append(f"  engine stops below {format_value(st['threshold'], 'm/s', digits=3)} "
                     f"while decelerating ({st['n'] - st['contradicted']} of {st['n']} stops)")
        idle = self.document.get("idle_battery_power", {}).get("median_w")
        if idle is not None:
            lines.append(f"  battery power while the motor idles: median {idle:.0f} W")
        strategy = self.document.get("strategy") or {}
        if strategy:
            lines.append("  the log's strategy as controller parameters: "
                         + ", ".join(f"{k}={v}" for k, v in strategy.items()))
        return lines


def analyze_parallel(test, veh) -> ParallelAnalysis:
    """Control analysis of a parallel-hybrid test with its vehicle file (gear ratios, wheel
    radius, gearbox efficiency: the shaft torque demand is the wheel torque through them): the assist / regen rules and the engine-stop rule (as :func:`assist_regen_rules`
    and :func:`engine_stop_rule` return them), under ``assist_regen`` and ``engine_stop``."""
    a = test_arrays(test, ("veh_spd", "eng_spd_out", "whl_trq_out", "mot_trq_out"))
    r = veh.driveline.wheel_radius_m
    ratios = veh.overall_ratios()
    v, w = a["veh_spd"], a["eng_spd_out"]
    gear = gears_from_speeds(w, v / r, ratios)
    ok = gear > 0
    eff = veh.gearbox.efficiency * veh.driveline.final_drive_efficiency
    t_wh = a["whl_trq_out"]
    t_dem = np.where(ok, np.where(t_wh >= 0, t_wh / eff, t_wh * eff)
                     / np.r_[np.nan, ratios][gear], np.nan)  # at the shaft, as the model's
    dt = np.gradient(a["t"])
    acc = np.gradient(v) / np.where(dt > 0, dt, np.nan)
    n = max(int(round(1.0 / max(float(np.nanmedian(dt)), 1e-3))), 1)
    acc = np.convolve(np.nan_to_num(acc), np.ones(n) / n, mode="same")  # 1 s mean
    doc: dict[str, Any] = {
        "architecture": "parallel_hybrid",
        "gear_share": {int(g): float(np.mean(gear == g)) for g in range(len(ratios) + 1)},
        "assist_regen": assist_regen_rules(t_dem[ok], a["mot_trq_out"][ok], v[ok], gear[ok],
                                           engine_running(a["t"], w)[ok]),
        "engine_stop": engine_stop_rule(a["t"], v, w, acc),
    }
    doc["idle_battery_power"] = idle_battery_power(test, a["t"], t_dem,
                                                   engine_running(a["t"], w) & ok,
                                                   doc["assist_regen"])
    doc["strategy"] = strategy_from_rules(doc)
    return ParallelAnalysis(doc)


def idle_battery_power(test, t: np.ndarray, t_dem: np.ndarray, running: np.ndarray,
                       rules: dict) -> dict:
    """Battery terminal power [W] while the motor idles by the log's own rules: engine
    running, a gear engaged, shaft torque demand between the regen and the assist
    threshold. ``median_w`` (None without battery voltage and current) over ``n`` samples:
    the accessories' net draw on the pack (a car that covers them by a small charge
    torque reads about 0)."""
    from vehval.integrals import battery_power

    volt, curr = test.best("ess_volt"), test.best("ess_curr")
    if volt is None or curr is None:
        return {"median_w": None, "n": 0, "why": "no battery voltage and current"}
    lo, hi = rules["regen_threshold"]["threshold"], rules["assist_threshold"]["threshold"]
    with np.errstate(invalid="ignore"):
        sel = running & (t_dem > lo) & (t_dem < hi)
    p = battery_power(volt.at(t), curr.at(t))[sel]
    p = p[np.isfinite(p)]
    return {"median_w": float(np.median(p)) if p.size else None, "n": int(p.size)}


def strategy_from_rules(doc: dict) -> dict:
    """Controller parameters (``controller.<key>`` of a ``parallel_hybrid`` vehicle file)
    that state the log's own rules: the assist and regen thresholds [N·m of shaft torque
    demand], the lowest gear that assists, the lowest regen speed [m/s], the engine-stop
    speed [m/s] and, when the battery was measured, an inverter off while the motor idles
    with the accessories' net draw [W] the log shows then (never below 0). A rule the log
    does not show (no stop, no regen) is left out: the vehicle file's value stays."""
    ar, stop = doc["assist_regen"], doc["engine_stop"]["rule"]
    out: dict = {}
    if np.isfinite(ar["assist_threshold"]["threshold"]):
        out["assist_threshold_nm"] = round(max(ar["assist_threshold"]["threshold"], 0.0), 1)
    gears = [g for g, share in ar["assist_share_by_gear"].items() if share > 0.0]
    if gears:
        out["assist_min_gear"] = int(min(gears))
    if np.isfinite(ar["regen_threshold"]["threshold"]):
        out["regen_threshold_nm"] = round(min(ar["regen_threshold"]["threshold"], 0.0), 1)
    if np.isfinite(ar["regen_min_speed_mps"]):
        out["regen_min_speed_mps"] = round(ar["regen_min_speed_mps"], 2)
    if stop["n"] and np.isfinite(stop["threshold"]):
        out["engine_stop_speed_mps"] = round(stop["threshold"], 2)
    idle = doc["idle_battery_power"]["median_w"]
    if idle is not None:
        out["motor_off_when_idle"] = True
        out["electrical_aux_power_w"] = round(max(idle, 0.0), 1)
    return out
