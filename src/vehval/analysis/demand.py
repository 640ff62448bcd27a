"""The inputs of the engine on/off rule, rebuilt from measured signals.

The supervisory controller decides on the *driver's demand*, which a test does not record.
What it records is the power the powertrain *delivered* (dyno tractive force x speed), the
speed and the battery signals. This module turns those into the rule's inputs the way a
test engineer would:

* **State of charge** (:func:`estimate_soc`): the SOC-regulation term is steep (150 kW per
  unit SOC in the 2004 Prius file: 0.1 % of SOC is 150 W of demand), so the coarse logged
  SOC (OBD: 0.5 % steps, 1 Hz) is refined by coulomb counting the battery current (10 Hz),
  anchored to the logged SOC by least squares with a fitted current-sensor bias. A current
  whose sign contradicts the SOC trend is reversed, with a finding.
* **Wheel power demand** (:func:`rule_demand`): delivered tractive power, except

  - its timing: the force recorded at a sample was delivered over the interval before it
    and trails through the transducer's lag, while the controller decides on the demand for
    the interval ahead. The delay of the force behind the force the speed trace needs is
    measured by correlation (:func:`force_delay_steps`, one sample on the virtual dyno's
    10 Hz files) and the delivered power is taken that many samples ahead;
  - while braking, the inertial demand ``(m·a + A + B·v + C·v²)·v`` when it is more
    negative (the friction brakes' share does not pass through the powertrain's tractive
    force);
  - around every engine start and stop (from the sample before the engine speed began to
    move to ``post_s`` after the observed switch, :func:`transition_windows`) the
    delivered power is disturbed by the switch itself: MG1 cranks the engine up (or pulls
    it down), its reaction through the planetary gear and the battery power it draws move
    the wheel force, the battery may reach its discharge limit and cap MG2, and the driver's
    speed control answers the resulting speed error. The controller had already decided,
    so these samples do not measure the demand it decided on;
  - while the measured battery power is at its discharge limit (vehicle file, as a function
    of SOC) the delivered power is capped below the demand.

  Disturbed samples hold the last undisturbed value.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from vehval.analysis.inputs import Finding
from vehval.constants import RPM_RAD_PER_S
from vehval.integrals import cumulative


@dataclass
class SocEstimate:
    """State of charge on the analysis grid and how it was obtained.

    Attributes
    ----------
    soc : ndarray
        SOC [-] (NaN where unknown).
    method : str
        ``coulomb counting ...``, ``measured ...`` or ``none``.
    info : dict
        Fit figures: capacity [Ah], current bias [A], residual RMS [-], flipped sign.
    findings : list of Finding
    """

    soc: np.ndarray
    method: str
    info: dict = field(default_factory=dict)
    findings: list[Finding] = field(default_factory=list)


def _fill_gaps(t: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, int]:
    """Linear interpolation over NaN samples; returns (filled, number filled)."""
    ok = np.isfinite(x)
    if ok.all() or not ok.any():
        return x.copy(), int((~ok).sum()) if ok.any() else 0
    return np.interp(t, t[ok], x[ok]), int((~ok).sum())


def quantisation_step(x: np.ndarray) -> float | None:
    """Smallest step between distinct finite values (the signal's resolution), or None."""
    u = np.unique(x[np.isfinite(x)])
    if u.size < 3:
        return None
    d = np.diff(u)
    d = d[d > 1e-9]
    return float(np.min(d)) if d.size else None


def estimate_soc(t: np.ndarray, soc_meas: np.ndarray, curr: np.ndarray | None = None,
                 capacity_ah: float | None = None, *, min_points: int = 30,
                 max_rms: float = 0.01, curr_label: str = "the battery current",
                 resolution: float | None = None) -> SocEstimate:
    """SOC from the logged SOC, refined by coulomb counting the battery current.

    Model: ``soc(t) = s0 + b·t - Q(t) / (3600·C)`` with ``Q = ∫ I dt`` [A·s] (current > 0
    discharging), fitted by least squares to the logged SOC samples; ``b`` absorbs a
    current-sensor bias (``bias = b·3600·C`` [A]). ``C`` [Ah] is the vehicle's capacity,
    or fitted when unknown. A negative fitted ``1/C`` means the current's sign is reversed
    (charge reads positive): it is flipped, with a finding.

    Parameters
    ----------
    t : ndarray
        Uniform time grid [s].
    soc_meas : ndarray
        Logged SOC [-] on the grid (NaN where unknown).
    curr : ndarray, optional
        Battery current [A] on the grid (> 0 discharging).
    capacity_ah : float, optional
        Battery capacity [Ah] (vehicle file); fitted when None.
    min_points : int
        Fewer finite SOC samples than this and no fit is attempted.
    max_rms : float
        Coulomb counting is rejected when the fit residual RMS exceeds this [-].
    curr_label : str
        What the current is (signal name or formula), for the method text and findings.
    resolution : float, optional
        Resolution of the logged SOC [-] (its quantisation step), when known; the
        acceptable residual is then at least 1.5 x step/sqrt(12) (the quantisation noise).

    Returns
    -------
    SocEstimate
    """
    soc_meas = np.asarray(soc_meas, float)
    ok = np.isfinite(soc_meas)
    findings: list[Finding] = []
    if ok.sum() < min_points:
        return SocEstimate(soc_meas.copy() if ok.any() else np.full(t.size, np.nan),
                           "measured" if ok.any() else "none", {"samples": int(ok.sum())})
    step = resolution
    measured = SocEstimate(soc_meas.copy(), "measured (logged SOC, linear interpolation)",
                           {"resolution": step})
    if curr is None or np.isfinite(curr).sum() < 0.9 * t.size:
        return measured
    i_f, n_filled = _fill_gaps(t, np.asarray(curr, float))
    q = cumulative(t, i_f)
    tt = t - t[0]
    y = soc_meas[ok]
    a = np.stack([np.ones(ok.sum()), tt[ok], -q[ok]], axis=1)
    coef, *_ = np.linalg.lstsq(a, y, rcond=None)
    flipped = False
    if coef[2] < 0:
        flipped = True
        q = -q
        coef[2] = -coef[2]
    if capacity_ah is None or capacity_ah <= 0:
        if coef[2] <= 0:
            return measured
        cap = 1.0 / (3600.0 * coef[2])
        if not 0.5 <= cap <= 500.0:
            measured.findings.append(Finding("warning", "state of charge", (
                f"coulomb counting rejected: fitted capacity {cap:.3g} Ah is implausible")))
            return measured
        cap_src = "fitted"
        c = coef
        pred = c[0] + c[1] * tt - c[2] * q
    else:
        cap = float(capacity_ah)
        cap_src = "vehicle file"
        a2 = np.stack([np.ones(ok.sum()), tt[ok]], axis=1)
        c2, *_ = np.linalg.lstsq(a2, y + q[ok] / (3600.0 * cap), rcond=None)
        pred = c2[0] + c2[1] * tt - q / (3600.0 * cap)
        c = np.array([c2[0], c2[1], 1.0 / (3600.0 * cap)])
    rms = float(np.sqrt(np.mean((pred[ok] - y) ** 2)))
    info = {"capacity_ah": round(cap, 4), "capacity_source": cap_src,
            "fitted_capacity_ah": round(1.0 / (3600.0 * coef[2]), 4) if coef[2] > 0 else None,
            "current_bias_a": round(float(c[1] * 3600.0 * cap), 4), "residual_rms": round(rms, 5),
            "resolution_logged": step, "current_gap_samples_filled": n_filled,
            "current_sign_reversed": flipped}
    # a quantised SOC alone leaves a residual of step/sqrt(12)
    limit = max(max_rms, 1.5 * (step or 0.0) / np.sqrt(12.0))
    if rms > limit:
        findings.append(Finding("warning", "state of charge", (
            f"coulomb counting rejected: residual {rms:.4f} against the logged SOC exceeds "
            f"{limit:.4g}; the logged SOC is used")))
        measured.findings.extend(findings)
        measured.info.update(rejected_coulomb_counting=info)
        return measured
    if flipped:
        findings.append(Finding("warning", "battery current", (
            f"battery current ({curr_label}) is positive while the SOC rises (charging reads "
            "positive): its sign is reversed for coulomb counting (check the clamp "
            "orientation)")))
    method = (f"coulomb counting of {curr_label} anchored to the logged SOC "
              f"(least squares: offset and current bias {info['current_bias_a']:+.3f} A; "
              f"capacity {cap:.3g} Ah, {cap_src}; residual RMS {rms:.4f})")
    return SocEstimate(np.clip(pred, 0.0, 1.0), method, info, findings)


def power_sign_check(t: np.ndarray, soc: np.ndarray, ess_pwr: np.ndarray,
                     min_swing: float = 0.005) -> tuple[np.ndarray, list[Finding]]:
    """Battery power with its sign checked against the SOC trend.

    Discharging (power > 0) must lower the SOC: the SOC is regressed on the discharged
    energy ``∫P dt``; a positive slope means the power's sign is reversed (e.g. computed
    from a reversed current clamp). Needs an SOC swing of at least ``min_swing``.

    Returns
    -------
    (ess_pwr, findings) : the (possibly sign-corrected) power [W] and findings.
    """
    p = np.asarray(ess_pwr, float)
    ok = np.isfinite(soc)
    if ok.sum() < 30 or np.isfinite(p).sum() < 0.9 * p.size or np.ptp(soc[ok]) < min_swing:
        return p, []
    e = cumulative(t, np.where(np.isfinite(p), p, 0.0))
    tt = t - t[0]
    a = np.stack([np.ones(ok.sum()), tt[ok], e[ok]], axis=1)
    coef, *_ = np.linalg.lstsq(a, soc[ok], rcond=None)
    res = soc[ok] - a @ coef
    a0 = a[:, :2]
    c0, *_ = np.linalg.lstsq(a0, soc[ok], rcond=None)
    res0 = soc[ok] - a0 @ c0
    # reversed only when the energy term explains the SOC clearly, with the wrong sign
    if coef[2] > 0 and np.sum(res ** 2) < 0.5 * np.sum(res0 ** 2):
        return -p, [Finding("warning", "battery power", (
            "battery power rises while the SOC rises (charging reads as discharging): its "
            "sign is reversed for the analysis (likely a reversed current clamp)"))]
    return p, []


def hold_last(x: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """``x`` with the samples under ``mask`` (and NaN samples) replaced by the last valid
    value before them (leading ones stay NaN)."""
    y = np.asarray(x, float).copy()
    y[np.asarray(mask, bool)] = np.nan
    ok = np.isfinite(y)
    idx = np.where(ok, np.arange(y.size), -1)
    np.maximum.accumulate(idx, out=idx)
    out = np.where(idx >= 0, y[np.maximum(idx, 0)], np.nan)
    return out


def force_delay_steps(v: np.ndarray, frc: np.ndarray, dt: float, consts: dict[str, float],
                      max_steps: int = 3) -> int | None:
    """Delay [samples] of a measured tractive force behind the force the speed trace needs.

    The force the vehicle needed over the interval after sample ``i`` is
    ``m·(v[i+1] - v[i])/dt + A + B·v + C·v²``; the measured force (transducer lag, sample
    timing) trails it. The delay is the shift ``d`` in ``0..max_steps`` that maximises the
    correlation of ``frc[i + d]`` with it (speeds above 1 m/s). ``None`` without a mass or
    with too few samples.
    """
    mass = consts.get("test_mass_kg")
    v = np.asarray(v, float)
    frc = np.asarray(frc, float)
    if not mass or v.size < 50:
        return None
    rl = consts.get("road_load_a_n", 0.0) + consts.get("road_load_b_n_per_mps", 0.0) * v + \
        consts.get("road_load_c_n_per_mps2", 0.0) * v * v
    need = np.concatenate([mass * np.diff(v) / dt, [np.nan]]) + rl
    best, arg = -2.0, None
    for d in range(max_steps + 1):
        f = np.concatenate([frc[d:], np.full(d, np.nan)])
        sel = np.isfinite(f) & np.isfinite(need) & (v > 1.0)
        if sel.sum() < 50:
            return None
        c = float(np.corrcoef(f[sel], need[sel])[0, 1])
        if c > best:
            best, arg = c, d
    return arg


@dataclass
class Demand:
    """Wheel power demand for the engine on/off rule.

    Attributes
    ----------
    p : ndarray
        Demand [W] (> 0 propelling).
    disturbed : ndarray of bool
        Samples replaced by the last undisturbed value.
    info : dict
        Counts and the rules used.
    """

    p: np.ndarray
    disturbed: np.ndarray
    info: dict


def transition_windows(on: np.ndarray, eng_spd: np.ndarray | None, dt: float, *,
                       max_back_s: float = 1.5, min_step_rpm: float = 20.0
                       ) -> list[tuple[int, int, str]]:
    """Where each observed engine start and stop began: ``(k_begin, k_observed, kind)``.

    The observed state switches when the engine speed crosses the detection thresholds; the
    controller commanded the switch just before the speed began moving monotonically towards
    them (MG1 cranking the engine up, or pulling it down). ``k_begin`` walks back from the
    observed switch while the speed keeps changing by more than ``min_step_rpm`` per sample
    in the same direction, at most ``max_back_s``: it is the last sample before the move.
    ``k_observed - k_begin`` is the spin-up / spin-down delay.
    """
    on = np.asarray(on, bool)
    idx = np.nonzero(on[1:] != on[:-1])[0] + 1
    rpm = None if eng_spd is None else np.asarray(eng_spd, float) / RPM_RAD_PER_S
    kmax = max(round(max_back_s / dt), 0)
    out = []
    for k in idx:
        kind = "start" if on[k] else "stop"
        kb = k
        if rpm is not None and np.isfinite(rpm[k]):
            sgn = 1.0 if kind == "start" else -1.0
            while (kb > 0 and k - kb < kmax and np.isfinite(rpm[kb - 1])
                   and sgn * (rpm[kb] - rpm[kb - 1]) > min_step_rpm):
                kb -= 1
        out.append((int(kb), int(k), kind))
    return out


def rule_demand(t: np.ndarray, v: np.ndarray, a: np.ndarray, p_delivered: np.ndarray,  # noqa: PLR0913 - seven aligned signals of the test plus the rule's tuning options
                eng_on: np.ndarray, ess_pwr: np.ndarray, consts: dict[str, float], *,
                eng_spd: np.ndarray | None = None, pdis_lim: np.ndarray | None = None,
                pre_s: float = 0.0, post_s: float = 1.0, limit_tol_w: float = 400.0,
                inertial_braking: bool = True, lead_steps: int = 0) -> Demand:
    """Wheel power demand [W] for the rule from delivered power, speed and battery power.

    Parameters
    ----------
    t, v, a : ndarray
        Time [s], speed [m/s], acceleration [m/s²] on the uniform grid.
    p_delivered : ndarray
        Delivered wheel power [W] (tractive force x speed, or its best substitute).
    eng_on : ndarray of bool
        Observed engine state (its switches locate the start and stop transients).
    ess_pwr : ndarray
        Battery power [W] (> 0 discharging).
    consts : dict
        ``test_mass_kg``, ``road_load_a_n``, ``road_load_b_n_per_mps``,
        ``road_load_c_n_per_mps2`` (inertial demand while braking).
    eng_spd : ndarray, optional
        Engine speed [rad/s]: locates where each transient began (see
        :func:`transition_windows`); without it the window starts at the observed switch.
    pdis_lim : ndarray, optional
        Battery discharge power limit [W] on the grid (vehicle file at the SOC).
    pre_s, post_s : float
        The transient window runs from ``pre_s`` before the transient began to ``post_s``
        after the observed switch [s].
    limit_tol_w : float
        Battery power within this of its discharge limit counts as limited [W].
    inertial_braking : bool
        Use the inertial demand while braking when it is more negative.
    lead_steps : int
        Samples by which the delivered power trails the controller's demand
        (:func:`force_delay_steps`): the demand at a sample is the delivered power that many
        samples later, and the transient windows start that much earlier (minus the one
        sample the controller itself needs to act).

    Returns
    -------
    Demand
    """
    dt = float(np.median(np.diff(t))) if t.size > 1 else 1.0
    k_lead = max(int(lead_steps), 0)
    p = np.asarray(p_delivered, float).copy()
    if k_lead:
        p = np.concatenate([p[k_lead:], np.full(k_lead, np.nan)])
    info: dict[str, Any] = {"basis": "delivered wheel power", "lead_s": round(k_lead * dt, 6)}
    mass = consts.get("test_mass_kg")
    if inertial_braking and mass and np.any(np.isfinite(a)):
        fa = consts.get("road_load_a_n", 0.0)
        fb = consts.get("road_load_b_n_per_mps", 0.0)
        fc = consts.get("road_load_c_n_per_mps2", 0.0)
        p_in = (mass * a + np.where(v > 0.05, fa + fb * v + fc * v * v, 0.0)) * v
        brake = np.isfinite(p_in) & (p_in < 0) & (~np.isfinite(p) | (p_in < p))
        p[brake] = p_in[brake]
        info["braking"] = (f"while braking, (m·a + A + B·v + C·v²)·v with m = {mass:g} kg when "
                           "more negative than the delivered power (friction brakes)")
        info["braking_samples"] = int(brake.sum())
    wins = transition_windows(eng_on, eng_spd, dt)
    k_pre = round(pre_s / dt)
    k_post = max(round(post_s / dt), 1)
    disturbed = np.zeros(t.size, bool)
    for kb, k, _ in wins:
        disturbed[max(kb - k_pre - max(k_lead - 1, 0), 0):min(k + k_post + 1, t.size)] = True
    n_tr = int(disturbed.sum())
    n_lim = 0
    if pdis_lim is not None and np.any(np.isfinite(ess_pwr)):
        lim = np.asarray(pdis_lim, float)
        at_lim = np.isfinite(ess_pwr) & np.isfinite(lim) & (lim > 0) & (ess_pwr >= lim - limit_tol_w)
        if k_lead:
            at_lim = np.concatenate([at_lim[k_lead:], np.zeros(k_lead, bool)])
        n_lim = int(at_lim.sum())
        disturbed |= at_lim
    delays = {kind: [round((k - kb) * dt, 3) for kb, k, kd in wins if kd == kind]
              for kind in ("start", "stop")}
    info.update(engine_starts=len(delays["start"]), engine_stops=len(delays["stop"]),
                transient_window_s=[-float(pre_s) if pre_s else 0.0, float(post_s)],
                transient_samples=n_tr,
                battery_limited_samples=n_lim,
                median_spin_up_s=float(np.median(delays["start"])) if delays["start"] else None,
                median_spin_down_s=float(np.median(delays["stop"])) if delays["stop"] else None,
                battery_limit_rule=(f"battery power within {limit_tol_w:g} W of its discharge "
                                    "limit" if pdis_lim is not None else "no limit known"))
    out = hold_last(p, disturbed)
    # leading NaN (disturbed from the first sample): keep the delivered value
    lead = ~np.isfinite(out) & np.isfinite(p)
    out[lead] = p[lead]
    return Demand(out, disturbed, info)
