"""QA level 3: measured versus calculated signals (Table 3 of SAE 2006-01-0667).

For every ``<base>_calc`` signal and every measured signal of the same base: mean absolute
difference, range of the measured signal, R² (squared correlation), relative difference
(mean absolute difference / range), slope of the fit ``measured = slope · calc + offset``.
Poor agreement is a warning on the measured signal; the calculated signal and its inputs
are named, since either side may be at fault.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vehval.equations.calc import CalcResult
from vehval.errors import SignalError
from vehval.nomenclature import registry
from vehval.qa.findings import Finding, Kind, Severity
from vehval.test import Test

#: Cumulative outputs: a drift shows in them, a correlation is meaningless.
CUMULATIVE = frozenset({"veh_energy_in", "eng_energy_out", "fuel_mass", "fuel_energy",
                        "ess_energy", "veh_dist"})


@dataclass
class Level3Options:
    r2_min: float = 0.8            # below: calc mismatch (warning)
    rel_max: float = 0.1           # mean abs diff above this x range: calc mismatch
    drift_blocks: int = 10         # residual medians over this many time blocks
    drift_min: float = 0.04        # drift of the residual above this x range: warning
    local_fraction: float = 0.2    # |measured - calc| above this x range ...
    local_min_s: float = 5.0       # ... for at least this long [s]: local mismatch


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

    def to_dict(self) -> dict:
        out = {}
        for k, v in self.__dict__.items():
            if isinstance(v, (float, np.floating)):
                out[k] = float(v) if np.isfinite(v) else None
            else:
                out[k] = v
        return out


def compare_calc(test: Test, measured: str, calculated: str, inputs: dict | None = None
                 ) -> CalcComparison | None:
    """Table-3 metrics of a measured signal against a calculated one (on the calc grid)."""
    c = test[calculated]
    m = test[measured].at(c.time)
    cv = c.values
    ok = np.isfinite(m) & np.isfinite(cv)
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
                          unit=c.unit, inputs=dict(inputs or {}))


def run_level3(test: Test, calc: CalcResult, opts: Level3Options | None = None
               ) -> tuple[list[CalcComparison], list[Finding]]:
    """Table 3 and its findings for every calculated signal with a measured counterpart."""
    opts = opts or Level3Options()
    reg = registry()
    rows: list[CalcComparison] = []
    findings: list[Finding] = []
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
            row = compare_calc(test, sig.name, cname, info.get("inputs"))
            if row is None:
                continue
            rows.append(row)
            if base in CUMULATIVE:
                continue
            findings.extend(local_mismatch(test, sig.name, cname, row.test_range, info, opts))
            drift = residual_drift(test, sig.name, cname, row.test_range, opts)
            if drift is not None:
                findings.append(drift)
            if np.isfinite(row.slope) and row.slope < 0 and np.isfinite(row.r2) and row.r2 > 0.25:
                findings.append(Finding(
                    sig.name, Kind.SIGN_FLIP, float(test[cname].time[0]), float(test[cname].time[-1]),
                    Severity.ERROR, f"{sig.name} is the mirror image of {cname} = {info['expr']} "
                    f"(slope {row.slope:.2f}, R² {row.r2:.2f}): sign convention reversed",
                    {"r2": row.r2, "slope": row.slope}, related=[cname] + list(info.get("inputs", {}).values())))
                continue
            bad_r2 = np.isfinite(row.r2) and row.r2 < opts.r2_min
            bad_rel = np.isfinite(row.rel_diff) and row.rel_diff > opts.rel_max
            if bad_r2 or bad_rel:
                ins = ", ".join(info.get("inputs", {}).values())
                findings.append(Finding(
                    sig.name, Kind.CALC_MISMATCH, float(test[cname].time[0]),
                    float(test[cname].time[-1]), Severity.WARNING,
                    f"{sig.name} disagrees with {cname} = {info['expr']} (R² {row.r2:.3f}, mean "
                    f"difference {row.mean_abs_diff:.4g} {row.unit} = {100 * row.rel_diff:.1f} % of "
                    f"its range); check it or the inputs ({ins})",
                    {"r2": row.r2, "mean_abs_diff": row.mean_abs_diff, "test_range": row.test_range,
                     "rel_diff": row.rel_diff, "slope": row.slope},
                    related=[cname] + list(info.get("inputs", {}).values())))
    return rows, findings


def local_mismatch(test: Test, measured: str, calculated: str, rng: float, info: dict,
                   opts: Level3Options) -> list[Finding]:
    """Stretches where the measured signal leaves its calculated value by more than
    ``local_fraction`` of its range for ``local_min_s`` or longer (stuck, dropped, local
    faults that a whole-test R² hides)."""
    from vehval.qa.findings import merge_runs, runs
    c = test[calculated]
    m_sig = test[measured]
    res = m_sig.at(c.time) - c.values
    if not rng > 0:
        return []
    bad = np.isfinite(res) & (np.abs(res) > opts.local_fraction * rng)
    min_s = max(opts.local_min_s * (2.0 if info.get("steady_state") else 1.0),
                3 * m_sig.sample_period)
    out = []
    for i0, i1 in merge_runs(runs(bad), c.time, 1.0):
        t0, t1 = float(c.time[i0]), float(c.time[i1])
        if t1 - t0 < min_s:
            continue
        dev = float(np.nanmax(np.abs(res[i0:i1 + 1])))
        out.append(Finding(measured, Kind.CALC_MISMATCH, t0, t1, Severity.WARNING,
                           f"{measured} departs from {calculated} by up to {dev:.4g} {c.unit} "
                           f"({100 * dev / rng:.0f} % of its range) from {t0:.1f} s to {t1:.1f} s",
                           {"max_deviation": dev, "test_range": rng, "duration_s": t1 - t0},
                           related=[calculated] + list(info.get("inputs", {}).values())))
    return out[:10]


def residual_drift(test: Test, measured: str, calculated: str, rng: float,
                   opts: Level3Options) -> Finding | None:
    """A slow drift of ``measured − calculated``: block medians trending monotonically."""
    c = test[calculated]
    res = test[measured].at(c.time) - c.values
    ok = np.isfinite(res)
    if ok.sum() < 10 * opts.drift_blocks or not rng > 0:
        return None
    t, r = c.time[ok], res[ok]
    blocks = np.array_split(np.arange(r.size), opts.drift_blocks)
    med = np.array([np.median(r[b]) for b in blocks])
    tb = np.array([t[b].mean() for b in blocks])
    total = med[-1] - med[0]
    if abs(total) < opts.drift_min * rng:
        return None
    steps = np.diff(med)
    if np.mean(np.sign(steps) == np.sign(total)) < 0.5 or np.corrcoef(tb, med)[0, 1] ** 2 < 0.5:
        return None
    start_i = int(np.argmax(np.abs(med - med[0]) > 0.25 * abs(total)))
    t0 = float(t[blocks[max(start_i - 1, 0)][0]])
    return Finding(measured, Kind.OFFSET, t0, float(t[-1]), Severity.WARNING,
                   f"{measured} drifts from {calculated} by {total:+.4g} {c.unit} over the test "
                   f"({100 * abs(total) / rng:.1f} % of its range): zero drift of the sensor?",
                   {"drift": float(total), "test_range": rng, "block_medians": med.tolist()},
                   related=[calculated])


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
