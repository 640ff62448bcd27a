"""QA level 3: measured versus calculated signals (Table 3 of SAE 2006-01-0667).

For every ``<base>_calc`` signal and every measured signal of the same base: mean absolute
difference, range of the measured signal, R² (squared correlation), relative difference
(mean absolute difference / range), slope of the fit ``measured = slope · calc + offset``.
Poor agreement is a warning on the measured signal; the calculated signal and its inputs
are named, since either side may be at fault.

Relations marked ``steady_state`` (the planetary torque balance, equations 1-2) leave out
the inertia torques of the engine/carrier and generator, which reach 100-200 N·m while the
engine starts or changes speed. Their Table-3 row is computed on the quasi-steady samples
only: engine speed changing by at most ``steady_acc_max`` (20 rad/s², about 190 rpm/s, i.e.
an inertia torque of about 4 N·m with the Prius engine), ±``steady_pad_s`` around any
faster change (see :func:`quasi_steady_mask`).

A calculation fed by a slow input (a 1 Hz OBD torque in a 10 Hz grid) is exact only at that
input's sample instants; between them it follows a straight line the real quantity did not
take. When the slowest signal of a comparison (the measured signal or any measured input,
followed through intermediate ``_calc`` signals) is sampled more than twice as slowly as the
grid, the comparison uses the grid points nearest to its samples
(:func:`slow_sample_mask`). The row's ``samples`` field says which samples were used.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from vehval.display import percent
from vehval.equations.calc import CalcResult
from vehval.errors import SignalError
from vehval.jsonsafe import finite_or_none
from vehval.nomenclature import registry
from vehval.qa.findings import Finding, Kind, Severity, delta_units, untrusted_mask
from vehval.test import Test

#: Cumulative outputs: a drift shows in them, a correlation is meaningless.
CUMULATIVE = frozenset({"veh_energy_in", "eng_energy_out", "fuel_mass", "fuel_energy",
                        "ess_energy", "veh_dist"})


@dataclass
class Level3Options:
    r2_min: float = 0.8            # below: calc mismatch (warning)
    rel_max: float = 0.1           # mean abs diff above this x range: calc mismatch
    drift_blocks: int = 10         # residual medians over this many time blocks
    drift_min: float = 0.04        # drift of the residual above this x range: warning ...
    drift_min_significant: float = 0.015  # ... or above this x range when it is also
    drift_se_k: float = 20.0       # ... above this many standard errors of a block median
    local_fraction: float = 0.2    # |measured - calc| above this x range ...
    local_min_s: float = 5.0       # ... for at least this long [s]: local mismatch
    steady_acc_max: float = 20.0   # quasi-steady: |d(engine speed)/dt| below this [rad/s^2]
    steady_pad_s: float = 0.5      # ... and not within this of a faster change [s]
    steady_min_fraction: float = 0.2  # fewer quasi-steady samples: use all samples


@dataclass
class CalcComparison:
    """One row of Table 3."""

    base: str
    measured: str
    calculated: str
    n: int
    mean_abs_diff: float
    test_range: float
    rel_diff: float
    r2: float
    slope: float
    offset: float
    unit: str
    inputs: dict
    samples: str = "all"           # "all" or "quasi-steady" (steady-state relations)
    # cumulative uncertainty (vehval.qa.uncertainty): signed mean of measured - calculated
    # [unit], expanded U (k = 2) of each side's mean [unit], En, the sensors' accuracies
    mean_diff: float = float("nan")
    u_measured: float = float("nan")
    u_calculated: float = float("nan")
    en: float = float("nan")
    accuracy: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        return {k: finite_or_none(v) for k, v in self.__dict__.items()}


def quasi_steady_mask(test: Test, grid: np.ndarray, acc_max: float = 20.0,
                      pad_s: float = 0.5) -> np.ndarray | None:
    """Samples of ``grid`` where the engine (carrier) speed is quasi-steady.

    The engine speed is the preferred measured ``eng_spd_out`` signal (facility first),
    else ``eng_spd_out_calc``; it is averaged over 0.5 s, differentiated, and a sample is
    quasi-steady when ``|dω/dt| <= acc_max`` [rad/s²] everywhere within ``pad_s`` [s].
    Missing speed samples count as steady (nothing is known against them).

    Returns
    -------
    numpy.ndarray of bool or None
        ``None`` when the test has no engine speed.
    """
    from scipy.ndimage import maximum_filter1d, uniform_filter1d

    sig = test.best("eng_spd_out", ("test", "calc"))
    if sig is None or grid.size < 3:
        return None
    w = sig.at(grid)
    ok = np.isfinite(w)
    if ok.sum() < 3:
        return None
    dt = float(np.median(np.diff(grid)))
    w = np.interp(grid, grid[ok], w[ok])
    n_avg = max(1, round(0.5 / dt))
    acc = np.gradient(uniform_filter1d(w, n_avg, mode="nearest"), grid)
    fast = np.abs(acc) > acc_max
    n_pad = 2 * max(0, round(pad_s / dt)) + 1
    fast = maximum_filter1d(fast.astype(np.uint8), n_pad, mode="nearest") > 0
    return ~fast


def measured_inputs(name: str, computed: dict, depth: int = 0) -> set[str]:
    """Measured signals a ``_calc`` signal was computed from, through other ``_calc`` ones."""
    out: set[str] = set()
    if depth > 20:
        return out
    for inp in computed.get(name, {}).get("inputs", {}).values():
        if inp.endswith("_calc"):
            out |= measured_inputs(inp, computed, depth + 1)
        else:
            out.add(inp)
    return out


def slow_sample_mask(test: Test, names: set[str], grid: np.ndarray,
                     ratio: float = 2.0) -> tuple[np.ndarray | None, str | None]:
    """Grid points nearest to the samples of the slowest of ``names``.

    Returns ``(mask, name)``, or ``(None, None)`` when no signal is sampled more than
    ``ratio`` times more slowly than the grid.
    """
    if grid.size < 2:
        return None, None
    dt = float(np.median(np.diff(grid)))
    periods = {n: test[n].sample_period for n in names if n in test}
    periods = {n: p for n, p in periods.items() if np.isfinite(p)}
    if not periods:
        return None, None
    slow = max(sorted(periods), key=lambda n: periods[n])  # ties: the first name, not set order
    if periods[slow] <= ratio * dt:
        return None, None
    t = test[slow].time
    t = t[(t >= grid[0] - 0.5 * dt) & (t <= grid[-1] + 0.5 * dt)]
    mask = np.zeros(grid.size, bool)
    mask[np.clip(np.round((t - grid[0]) / dt).astype(int), 0, grid.size - 1)] = True
    return mask, slow


def compare_calc(test: Test, measured: str, calculated: str, inputs: dict | None = None,
                 mask: np.ndarray | None = None, samples: str = "selected"
                 ) -> CalcComparison | None:
    """Table-3 metrics of a measured signal against a calculated one (on the calc grid).

    ``mask`` (bool on the calc grid) restricts the samples compared (quasi-steady samples
    for steady-state relations, the slow input's sample instants); ``samples`` names them.
    """
    c = test[calculated]
    m = test[measured].at(c.time)
    cv = c.values
    ok = np.isfinite(m) & np.isfinite(cv)
    if mask is not None:
        ok &= mask
    if ok.sum() < 5:
        return None
    m, cv = m[ok], cv[ok]
    rng = float(np.max(m) - np.min(m))
    mad = float(np.mean(np.abs(m - cv)))
    dm, dc = m - m.mean(), cv - cv.mean()
    smm, scc = float((dm * dm).sum()), float((dc * dc).sum())
    r = float((dm * dc).sum() / np.sqrt(smm * scc)) if smm > 0 and scc > 0 else float("nan")
    slope = float((dm * dc).sum() / scc) if scc > 0 else float("nan")
    return CalcComparison(base=registry().parse(measured).base, measured=measured,
                          calculated=calculated, n=int(ok.sum()), mean_abs_diff=mad,
                          test_range=rng, rel_diff=mad / rng if rng > 0 else float("nan"),
                          r2=r * r if np.isfinite(r) else float("nan"), slope=slope,
                          offset=float(m.mean() - slope * cv.mean()) if np.isfinite(slope) else float("nan"),
                          unit=c.unit, inputs=dict(inputs or {}),
                          samples="all" if mask is None else samples)


def run_level3(test: Test, calc: CalcResult, opts: Level3Options | None = None,  # noqa: C901 - the level-3 comparison and its exclusions for every calculated signal
               findings_before: list[Finding] | None = None,
               accuracy: Mapping[str, Any] | None = None
               ) -> tuple[list[CalcComparison], list[Finding]]:
    """Table 3 and its findings for every calculated signal with a measured counterpart.

    ``findings_before`` (QA1/QA2 findings): the samples where a measured input of a
    calculation, or the measured signal itself, has its own warning or error are left out of
    that comparison, so that a stuck wheel torque does not hide (or fake) a drift of the
    engine torque, and a problem already reported for a span is not reported again for the
    whole test; when that leaves less than half of the samples, every sample is used and
    the findings name the untrusted inputs (the pipeline then demotes them to info).
    ``accuracy`` (template ``accuracy:``): the sensors' accuracies behind each row's En
    (:mod:`vehval.qa.uncertainty`; undeclared: the class default).
    """
    from vehval.qa.uncertainty import Accuracies, CalcChain, calc_uncertainty

    opts = opts or Level3Options()
    acc = Accuracies(accuracy)
    chain = CalcChain(test, calc)
    before = list(findings_before or [])
    reg = registry()
    rows: list[CalcComparison] = []
    findings: list[Finding] = []
    steady: np.ndarray | None = None
    if any(info.get("steady_state") for info in calc.computed.values()):
        steady = quasi_steady_mask(test, calc.grid, opts.steady_acc_max, opts.steady_pad_s)
        if steady is not None and steady.mean() < opts.steady_min_fraction:
            steady = None
    for cname, info in calc.computed.items():
        base = cname[:-len("_calc")]
        for sig in test:
            try:
                p = reg.parse(sig.name)
            except SignalError:
                continue
            if p.base != base or p.origin != "test":
                continue
            if sig.name in info.get("inputs", {}).values():
                continue
            mask, label = _row_mask(test, sig.name, cname, calc, steady)
            excluded = False
            if before:
                bad = untrusted_mask(measured_inputs(cname, calc.computed) | {sig.name},
                                     calc.grid, before)
                if bad.any() and (~bad).mean() >= 0.5:
                    mask = ~bad if mask is None else mask & ~bad
                    label = "inputs trusted" if label == "all" else f"{label}, inputs trusted"
                    excluded = True
            row = compare_calc(test, sig.name, cname, info.get("inputs"), mask, label)
            if row is not None and row.n < 20 and mask is not None:
                mask, excluded = None, False
                row = compare_calc(test, sig.name, cname, info.get("inputs"))
            if row is None:
                continue
            calc_uncertainty(test, calc, row, mask, acc, measured_inputs(cname, calc.computed),
                             chain)
            rows.append(row)
            if base in CUMULATIVE:
                continue
            new = _row_findings(test, sig.name, cname, info, row, opts, mask)
            if excluded:
                # the untrusted inputs' spans were left out: nothing to blame on them
                for f in new:
                    f.numbers["input_findings_excluded"] = True
                    if f.kind == Kind.CALC_MISMATCH:
                        f.message += " (samples where the inputs have their own findings left out)"
            findings.extend(new)
    return rows, findings


def _row_findings(test: Test, measured: str, cname: str, info: dict, row: CalcComparison,
                  opts: Level3Options, mask: np.ndarray | None) -> list[Finding]:
    """Findings of one Table-3 comparison: local mismatch, drift, sign flip, mismatch."""
    out: list[Finding] = []
    out.extend(local_mismatch(test, measured, cname, row.test_range, info, opts, mask))
    drift = residual_drift(test, measured, cname, row.test_range, opts, mask)
    if drift is not None:
        out.append(drift)
    if np.isfinite(row.slope) and row.slope < 0 and np.isfinite(row.r2) and row.r2 > 0.25:
        out.append(Finding(
            measured, Kind.SIGN_FLIP, float(test[cname].time[0]), float(test[cname].time[-1]),
            Severity.ERROR, f"{measured} is the mirror image of {cname} = {info['expr']} "
            f"(slope {row.slope:.2f}, R² {row.r2:.2f}): sign convention reversed",
            {"r2": row.r2, "slope": row.slope}, related=[cname] + list(info.get("inputs", {}).values())))
        return out
    bad_r2 = np.isfinite(row.r2) and row.r2 < opts.r2_min
    bad_rel = np.isfinite(row.rel_diff) and row.rel_diff > opts.rel_max
    if bad_r2 or bad_rel:
        ins = ", ".join(info.get("inputs", {}).values())
        out.append(Finding(
            measured, Kind.CALC_MISMATCH, float(test[cname].time[0]),
            float(test[cname].time[-1]), Severity.WARNING,
            f"{measured} disagrees with {cname} = {info['expr']} (R² {row.r2:.3f}, mean "
            f"difference {delta_units(measured, row.unit)(row.mean_abs_diff)} = {percent(row.rel_diff)} of "
            f"its range); check it or the inputs ({ins})",
            {"r2": row.r2, "mean_abs_diff": row.mean_abs_diff, "test_range": row.test_range,
             "rel_diff": row.rel_diff, "slope": row.slope},
            related=[cname] + list(info.get("inputs", {}).values())))
    return out


def _row_mask(test: Test, measured: str, calculated: str, calc: CalcResult,
              steady: np.ndarray | None) -> tuple[np.ndarray | None, str]:
    """Samples of the calc grid a Table-3 comparison uses, and their description."""
    info = calc.computed[calculated]
    mask, parts = None, []
    if info.get("steady_state") and steady is not None:
        mask, parts = steady, ["quasi-steady"]
    slow, name = slow_sample_mask(test, measured_inputs(calculated, calc.computed) | {measured},
                                  calc.grid)
    if slow is not None:
        mask = slow if mask is None else mask & slow
        parts.append(f"at the samples of {name}")
    return mask, ", ".join(parts) or "all"


def local_mismatch(test: Test, measured: str, calculated: str, rng: float, info: dict,
                   opts: Level3Options, mask: np.ndarray | None = None) -> list[Finding]:
    """Stretches where the measured signal leaves its calculated value by more than
    ``local_fraction`` of its range for ``local_min_s`` or longer (stuck, dropped, local
    faults that a whole-test R² hides). ``mask``: calc-grid samples to judge (others are
    ignored, gaps between judged samples do not break a stretch)."""
    from vehval.qa.findings import merge_runs, runs
    c = test[calculated]
    m_sig = test[measured]
    res = m_sig.at(c.time) - c.values
    t = c.time
    if mask is not None:
        t, res = t[mask], res[mask]
    if not rng > 0 or t.size < 2:
        return []
    bad = np.isfinite(res) & (np.abs(res) > opts.local_fraction * rng)
    min_s = max(opts.local_min_s * (2.0 if info.get("steady_state") else 1.0),
                3 * m_sig.sample_period)
    gap = 1.0 if mask is None else max(1.0, 2.0 * float(np.median(np.diff(t))))
    out = []
    for i0, i1 in merge_runs(runs(bad), t, gap):
        t0, t1 = float(t[i0]), float(t[i1])
        if t1 - t0 < min_s:
            continue
        dev = float(np.nanmax(np.abs(res[i0:i1 + 1])))
        out.append(Finding(measured, Kind.CALC_MISMATCH, t0, t1, Severity.WARNING,
                           f"{measured} departs from {calculated} by up to {delta_units(measured, c.unit)(dev)} "
                           f"({100 * dev / rng:.0f} % of its range) from {t0:.1f} s to {t1:.1f} s",
                           {"max_deviation": dev, "test_range": rng, "duration_s": t1 - t0},
                           related=[calculated] + list(info.get("inputs", {}).values())))
    return out[:10]


def residual_drift(test: Test, measured: str, calculated: str, rng: float,
                   opts: Level3Options, mask: np.ndarray | None = None) -> Finding | None:
    """A slow drift of ``measured − calculated``: medians over ``drift_blocks`` time blocks
    following a straight-line trend (R² >= 0.5) whose change over the test is the drift
    (over the ``mask`` samples of the calc grid when given).

    Reported when the drift exceeds ``drift_min`` (4 %) of the measured range, or
    ``drift_min_significant`` (1.5 %) of it while also exceeding ``drift_se_k`` (20) standard
    errors of a block median: a precise relation (wheel torque against tractive force x
    radius) reveals a zero drift that is small against a large range. On the clean virtual
    tests (8 cycles, 3 seeds) no residual trend exceeds 2.8 % of the range or 7 standard errors.
    """
    c = test[calculated]
    res = test[measured].at(c.time) - c.values
    ok = np.isfinite(res)
    if mask is not None:
        ok &= mask
    if ok.sum() < 5 * opts.drift_blocks or not rng > 0:
        return None
    t, r = c.time[ok], res[ok]
    like = _road_load_terms(test, measured, t)
    fitted: dict[str, float] = {}
    if like is not None:
        # compare like with like: the dyno applies its *set* coefficients, the calculation
        # uses the *target* ones; their difference (the car's own losses on the rolls,
        # dA + dB v + dC v^2) and an inertia mismatch (dm a) depend on speed and
        # acceleration, not on time. Fit them with the time trend and keep only the trend.
        x = np.column_stack([np.ones(t.size), like, t - t[0]])
        coef = np.linalg.lstsq(x, r, rcond=None)[0]
        r = r - like @ coef[1:4]
        fitted = {"offset_a_n": float(coef[0]), "offset_b_n_per_mps": float(coef[1]),
                  "offset_c_n_per_mps2": float(coef[2]), "inertia_offset_kg": float(coef[3])}
    blocks = np.array_split(np.arange(r.size), opts.drift_blocks)
    med = np.array([np.median(r[b]) for b in blocks])
    tb = np.array([t[b].mean() for b in blocks])
    # drift = the straight-line trend of the block medians over the test (end points of
    # noisy medians, e.g. 19 samples a block of a 1 Hz comparison, would over- or undershoot)
    slope_fit = np.polyfit(tb - tb[0], med, 1)[0] if np.ptp(tb) > 0 else 0.0
    total = float(slope_fit * (t[-1] - t[0]))
    # standard error of a block median: scatter of the residual about its block medians
    dev = np.concatenate([r[b] - m for b, m in zip(blocks, med)])
    se = 1.2533 * 1.4826 * float(np.median(np.abs(dev))) / np.sqrt(min(len(b) for b in blocks))
    big = abs(total) >= opts.drift_min * rng
    sure = abs(total) >= opts.drift_min_significant * rng and abs(total) >= opts.drift_se_k * se
    if not (big or sure):
        return None
    if np.corrcoef(tb, med)[0, 1] ** 2 < 0.5:      # a trend, not scatter
        return None
    start_i = int(np.argmax(np.abs(med - med[0]) > 0.25 * abs(total)))
    t0 = float(t[blocks[max(start_i - 1, 0)][0]])
    like_note = (" (beyond the speed- and acceleration-dependent difference of set and target "
                 "road load and inertia, fitted and removed)" if fitted else "")
    return Finding(measured, Kind.OFFSET, t0, float(t[-1]), Severity.WARNING,
                   f"{measured} drifts from {calculated} by {delta_units(measured, c.unit)(total, signed=True)} over the test "
                   f"({percent(abs(total) / rng)} of its range){like_note}: zero drift of "
                   "the sensor?",
                   {"drift": float(total), "test_range": rng, "block_medians": med.tolist(),
                    "median_se": se, **fitted},
                   related=[calculated])


def _road_load_terms(test: Test, measured: str, t: np.ndarray) -> np.ndarray | None:
    """Speed v, v^2 and acceleration a at ``t`` (columns) when ``measured`` is the tractive
    force compared with the road-load equation (``veh_frc_in``), else None."""
    if not measured.startswith("veh_frc_in"):
        return None
    spd = test.best("veh_spd", ("test",))
    if spd is None or t.size < 10:
        return None
    v = spd.at(t)
    grid_v = spd.at(spd.time)
    acc = np.gradient(grid_v, spd.time) if spd.time.size > 2 else np.zeros(spd.time.size)
    # acceleration smoothed over about 1 s (the speed's noise is not the car's)
    n = max(1, int(round(1.0 / max(spd.sample_period, 1e-3))))
    acc = np.convolve(acc, np.ones(n) / n, mode="same") if n > 1 else acc
    a = np.interp(t, spd.time, acc)
    out = np.column_stack([v, v * v, a])
    return out if np.isfinite(out).all() else None


def run_checks(test: Test, calc: CalcResult) -> tuple[list[dict], list[Finding]]:
    """Balance checks declared in the calculation file (``lhs ≈ rhs``)."""
    rows, findings = [], []
    for name, chk in calc.checks.items():
        a, b = chk["lhs"], chk["rhs"]
        ok = np.isfinite(a) & np.isfinite(b)
        if ok.sum() < 10:
            continue
        a, b = a[ok], b[ok]
        da, db = a - a.mean(), b - b.mean()
        den = np.sqrt((da * da).sum() * (db * db).sum())
        r = float((da * db).sum() / den) if den > 0 else float("nan")
        slope = float((da * db).sum() / (db * db).sum()) if (db * db).sum() > 0 else float("nan")
        row = {"check": name, "expr": chk["text"], "blame": chk["blame"], "n": int(ok.sum()),
               "r2": r * r if np.isfinite(r) else None, "r": r if np.isfinite(r) else None,
               "slope": slope if np.isfinite(slope) else None,
               "mean_abs_diff": float(np.mean(np.abs(a - b)))}
        rows.append(row)
        t = calc.grid[ok]
        nums = {k: row[k] for k in ("r2", "r", "slope", "mean_abs_diff")}
        related = list(chk["inputs"].values())
        if np.isfinite(r) and r < -0.5:
            findings.append(Finding(chk["blame"], Kind.SIGN_FLIP, float(t[0]), float(t[-1]),
                                    Severity.ERROR,
                                    f"{name}: {chk['text']} holds with the opposite sign (r {r:.2f}); "
                                    f"{chk['blame']} probably has its sign convention reversed",
                                    nums, related=related))
        elif not (np.isfinite(r) and r * r >= chk["r2_min"]):
            findings.append(Finding(chk["blame"], Kind.CALC_MISMATCH, float(t[0]), float(t[-1]),
                                    Severity.WARNING,
                                    f"{name}: {chk['text']} does not hold (R² {r * r:.2f}); check "
                                    f"{chk['blame']} and the other inputs", nums, related=related))
    return rows, findings
