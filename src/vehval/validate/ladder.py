"""The validation ladder: steady speeds, then low-transient, then high-transient cycles.

A model is trusted step by step: first on steady-speed runs (component losses and road
load, little control), then on low-transient cycles (Japan 10-15, NEDC: the engine on/off
logic at gentle demands), then on high-transient cycles (UDDS, HWFET, US06: power limits,
regeneration, fast transients). Each test gets a verdict against user tolerances.

Error definitions (documented in docs/validation.md):

* fuel error [%] = 100 · |m_sim − m_test| / m_test (fuel mass over the test);
* SOC error [%] = 100 · |ΔSOC_sim − ΔSOC_test| / SOC_final,test, with ΔSOC = SOC_final −
  SOC_initial. The simulation starts at the measured initial SOC, so this is the relative
  error of the final SOC; it stays well defined on charge-sustaining tests where ΔSOC ≈ 0
  (a relative error of ΔSOC itself would blow up). The ΔSOC mismatch in SOC points
  (100 · |ΔSOC_sim − ΔSOC_test|) is reported alongside and may be bounded too.

**Verdict by the normalised error.** Each test's fuel mass gets
``En = (m_sim - m_test) / sqrt(U_model^2 + U_meas^2)`` (:func:`vehval.uncertainty.
normalised_error`, k = 2): U_meas combines the results stage's propagated U of the measured
fuel with the repeatability s_r of the test's procedure (packaged defaults,
:func:`vehval.uncertainty.defaults.cycle_precision`; the model is judged against tests of
the car it models); U_model is the vehicle's parameter ranges propagated to the cycle
(:mod:`vehval.sim.model_uncertainty`, given per test by the caller as a share). The verdict
of a test is ``consistent`` (|En| <= 1) or ``inconsistent``; ``passed`` is the secondary
check against the fixed tolerances, kept as it was. Several held-out tests get a set verdict
(:func:`vehval.uncertainty.set_verdict`).

A test the vehicle file was calibrated on (its provenance,
:func:`vehval.calibration.provenance.calibration_tests`) is marked in-sample: its verdict is
a fit, not a prediction; the summary counts held-out tests and in-sample ones apart.
"""

from __future__ import annotations

import math
import re
from dataclasses import asdict, dataclass, field
from typing import Any, Sequence

import numpy as np

from vehval.calibration.provenance import same_test
from vehval.errors import ConfigError
from vehval.jsonsafe import clean
from vehval.uncertainty import InsufficientDataError, normalised_error, set_verdict
from vehval.uncertainty.defaults import cycle_precision
from vehval.uncertainty.verdict import COVERAGE_K, measurement_uncertainty
from vehval.validate.compare import Comparison

RUNGS = ("steady", "low_transient", "high_transient", "other")
RUNG_LABELS = {"steady": "1 steady-state speeds", "low_transient": "2 low-transient cycles",
               "high_transient": "3 high-transient cycles", "other": "4 other tests"}

_LOW = ("japan1015", "1015", "nedc", "ece15", "ece", "eudc", "jc08")
_HIGH = ("udds", "ftp75", "ftp", "hwfet", "hwy", "us06", "la92", "sc03", "wltc", "wltc3b",
         "wltp", "artemis")


def rung_of(cycle: str) -> str:
    """Ladder rung of a cycle name: steady, low_transient, high_transient or other.

    Names are matched without case, spaces, dashes or underscores; a ``_measured`` suffix
    and a ``steady`` prefix are understood (``steady_60kph_300s``, ``steady:60kph``).
    """
    key = re.sub(r"[\s_\-:]", "", (cycle or "").lower()).removesuffix("measured")
    if key.startswith("steady") or key.startswith("cruise") or key.startswith("constant"):
        return "steady"
    for names, rung in ((_LOW, "low_transient"), (_HIGH, "high_transient")):
        if any(key == n or key.startswith(n) for n in names):
            return rung
    return "other"


@dataclass
class Tolerances:
    """Acceptance limits of the ladder (None disables a criterion).

    Attributes
    ----------
    fuel_pct : float
        Max relative fuel-mass error [%].
    soc_pct : float
        Max SOC error [%] (relative error of the final SOC, see the module docstring).
    soc_points : float or None
        Max ΔSOC mismatch [SOC points] (off by default).
    engine_on_agreement_min_pct : float or None
        Min share of time steps with the same engine state [%] (off by default).
    """

    fuel_pct: float | None = 5.0
    soc_pct: float | None = 5.0
    soc_points: float | None = None
    engine_on_agreement_min_pct: float | None = None

    @classmethod
    def from_mapping(cls, data: dict | None) -> "Tolerances":
        data = dict(data or {})
        unknown = sorted(set(data) - set(cls.__dataclass_fields__))
        if unknown:
            raise ConfigError(f"unknown tolerance(s) {', '.join(unknown)}: known are "
                              f"{', '.join(cls.__dataclass_fields__)}")
        for k, v in data.items():
            if v is not None and not (isinstance(v, (int, float)) and v >= 0):
                raise ConfigError(f"tolerance '{k}' must be a number >= 0 or null, got {v!r}")
        return cls(**data)


def errors_of(comp: Comparison) -> dict[str, float]:
    """The ladder's error figures of one comparison (see the module docstring) [%]."""
    tt, ts = comp.totals_test, comp.totals_sim
    fuel = abs(comp.fuel_error) * 100.0 if np.isfinite(comp.fuel_error) else math.nan
    d = comp.soc_delta_error
    sf = tt.get("soc_final", math.nan)
    soc = abs(d) / sf * 100.0 if (np.isfinite(d) and np.isfinite(sf) and sf > 0) else math.nan
    return {"fuel_pct": fuel, "soc_pct": soc,
            "soc_points": abs(d) * 100.0 if np.isfinite(d) else math.nan,
            "engine_on_agreement_pct": comp.on_agreement * 100.0,
            "fuel_test_kg": tt.get("fuel_mass_kg", math.nan),
            "fuel_sim_kg": ts.get("fuel_mass_kg", math.nan)}


@dataclass
class LadderEntry:
    """Verdict of one test."""

    test_id: str
    cycle: str
    rung: str
    errors: dict[str, float]
    passed: bool
    failures: list[str] = field(default_factory=list)
    in_sample: bool = False  # the vehicle file was calibrated on this test
    #: normalised error of the fuel mass (see the module docstring) and its parts
    en: float | None = None
    u_model_kg: float | None = None
    u_meas_kg: float | None = None
    s_r: float | None = None
    uninformative: bool | None = None
    consistent: bool | None = None
    verdict: str = "no En"   # consistent / inconsistent / no En (no fuel on one side)
    en_note: str = ""


def verdict(comp: Comparison, tol: Tolerances) -> tuple[bool, list[str], dict[str, float]]:
    """(passed, reasons for failure, errors) of one comparison against ``tol``.

    A criterion whose error cannot be computed (missing signal) fails with that reason.
    """
    err = errors_of(comp)
    fails = []
    for key, limit, op in (("fuel_pct", tol.fuel_pct, "max"), ("soc_pct", tol.soc_pct, "max"),
                           ("soc_points", tol.soc_points, "max"),
                           ("engine_on_agreement_pct", tol.engine_on_agreement_min_pct, "min")):
        if limit is None:
            continue
        v = err[key]
        if not np.isfinite(v):
            fails.append(f"{key}: cannot be computed (missing signal)")
        elif op == "max" and v > limit:
            fails.append(f"{key} = {v:.3g} > {limit:g}")
        elif op == "min" and v < limit:
            fails.append(f"{key} = {v:.3g} < {limit:g}")
    return not fails, fails, err


@dataclass
class LadderResult:
    """All tests on the ladder, ordered by rung."""

    entries: list[LadderEntry]
    tolerances: Tolerances
    #: test id -> parameters the vehicle file was calibrated on it
    calibrated: dict[str, list[str]] = field(default_factory=dict)
    #: bias, coverage and verdict of the held-out tests with an En (None: fewer than 3)
    set_verdict: dict[str, Any] | None = None
    set_verdict_note: str = ""

    def en_summary(self) -> str:
        """``held-out: 3/4 consistent (|En| <= 1); set: consistent with the data``."""
        held = [e for e in self.entries if not e.in_sample and e.en is not None]
        text = (f"held-out: {sum(bool(e.consistent) for e in held)}/{len(held)} consistent "
                "(|En| <= 1)")
        sv = self.set_verdict
        if sv is not None:
            from vehval.uncertainty import verdict_text

            text += "; " + verdict_text(sv)
        else:
            text += f"; no set verdict ({self.set_verdict_note})"
        return text

    def sample_counts(self) -> dict[str, int]:
        """Tests and passes, held-out and in-sample apart."""
        held = [e for e in self.entries if not e.in_sample]
        ins = [e for e in self.entries if e.in_sample]
        return {"n_held_out": len(held), "n_held_out_passed": sum(e.passed for e in held),
                "n_in_sample": len(ins), "n_in_sample_passed": sum(e.passed for e in ins)}

    def summary(self) -> str:
        """``held-out: 3/4 tests pass; in-sample (a fit, not a prediction): 1/1``."""
        n = self.sample_counts()
        text = f"held-out: {n['n_held_out_passed']}/{n['n_held_out']} tests pass"
        if n["n_in_sample"]:
            text += (f"; in-sample (the vehicle file was calibrated on them, a fit, not a "
                     f"prediction): {n['n_in_sample_passed']}/{n['n_in_sample']}")
        return text

    @property
    def passed(self) -> bool:
        return all(e.passed for e in self.entries)

    def rung_passed(self) -> dict[str, bool | None]:
        """Per rung: all tests passed (None: no test on that rung)."""
        out: dict[str, bool | None] = {}
        for r in RUNGS:
            es = [e for e in self.entries if e.rung == r]
            out[r] = all(e.passed for e in es) if es else None
        return out

    def highest_rung_passed(self) -> str | None:
        """The last rung reached with every lower populated rung passed (None: the first fails)."""
        best = None
        for r in RUNGS[:3]:
            ok = self.rung_passed()[r]
            if ok is None:
                continue
            if not ok:
                break
            best = r
        return best

    def _entries(self, test_id: str | None) -> list:
        return [e for e in self.entries if test_id is None or e.test_id == test_id]

    def tables(self, test_id: str | None = None) -> list[dict]:
        """The ladder table: every test, or the row of ``test_id`` (its own report)."""
        t = self.tolerances
        rows = [[RUNG_LABELS[e.rung], e.cycle, e.test_id, e.errors["fuel_pct"], e.errors["soc_pct"],
                 e.errors["soc_points"], e.errors["engine_on_agreement_pct"],
                 "pass" if e.passed else "FAIL: " + "; ".join(e.failures),
                 "in-sample" if e.in_sample else "held-out"] for e in self._entries(test_id)]
        return [{"title": "Validation ladder",
                 "columns": ["rung", "cycle", "test", "fuel error [%]", "SOC error [%]",
                             "ΔSOC error [points]", "engine state agreement [%]", "verdict",
                             "sample"],
                 "rows": rows,
                 "note": f"tolerances: fuel ≤ {t.fuel_pct} %, SOC ≤ {t.soc_pct} % (relative error of "
                         f"final SOC), ΔSOC ≤ {t.soc_points} points, engine agreement ≥ "
                         f"{t.engine_on_agreement_min_pct} % (None = not checked); "
                         f"{self.summary()}"}]

    def en_table(self, test_id: str | None = None) -> dict:
        """The verdict by the normalised error of the fuel mass, one row per test (or the
        row of ``test_id``, for its own report)."""
        rows = [[e.test_id, e.cycle, e.errors["fuel_sim_kg"], e.errors["fuel_test_kg"],
                 e.u_model_kg, e.u_meas_kg, e.s_r, e.en, e.verdict,
                 "in-sample" if e.in_sample else "held-out", e.en_note]
                for e in self._entries(test_id)]
        return {"title": "Verdict by the normalised error (fuel mass)",
                "columns": ["test", "cycle", "fuel sim [kg]", "fuel test [kg]",
                            "U_model [kg]", "U_meas [kg]", "s_r [-]", "En", "verdict",
                            "sample", "note"],
                "rows": rows,
                "note": "En = (m_sim - m_test) / sqrt(U_model² + U_meas²), k = 2; |En| ≤ 1 "
                        "is consistent; the fixed tolerances of the ladder above are the "
                        f"secondary check. {self.en_summary()}"}

    def to_dict(self) -> dict[str, Any]:
        return clean({"passed": self.passed, "tolerances": asdict(self.tolerances),
                       "rung_passed": self.rung_passed(),
                       "highest_rung_passed": self.highest_rung_passed(),
                       **self.sample_counts(), "calibration_tests": self.calibrated,
                       "entries": [asdict(e) for e in self.entries], "tables": self.tables(),
                       "set_verdict": self.set_verdict,
                       "set_verdict_note": self.set_verdict_note})


def judge_fuel(entry: LadderEntry, comp: Comparison, u_model_rel: float | None,
               family: str = "all") -> Any:
    """Set the En fields of ``entry`` from the fuel masses of ``comp``; the
    :class:`vehval.uncertainty.Comparison` (None when a fuel mass is missing)."""
    meas, model = entry.errors["fuel_test_kg"], entry.errors["fuel_sim_kg"]
    if not (np.isfinite(meas) and meas > 0 and np.isfinite(model)):
        entry.en_note = "no fuel mass on one side"
        return None
    prec, note = cycle_precision(comp.cycle, family)
    s_r = prec.s_r or 0.0
    u_rel = comp.uncertainty_rel.get("fuel_mass_kg")
    u_meas = measurement_uncertainty(meas, u_result=COVERAGE_K * (u_rel or 0.0) * meas,
                                     s_r=s_r)
    u_model = (u_model_rel or 0.0) * abs(model)
    c = normalised_error(model, meas, u_model, u_meas, label=entry.test_id)
    notes = [note] if note else []
    if u_rel is None:
        notes.append("no results-stage uncertainty of the measured fuel")
    if u_model_rel is None:
        notes.append("no model uncertainty (U_model = 0)")
    entry.en = None if not np.isfinite(c.en) else c.en
    entry.u_model_kg, entry.u_meas_kg, entry.s_r = u_model, u_meas, s_r
    entry.uninformative, entry.consistent = c.uninformative, c.consistent
    entry.verdict = "consistent" if c.consistent else "inconsistent"
    entry.en_note = "; ".join(notes)
    return c


def ladder(comparisons: Sequence[Comparison], tolerances: Tolerances | dict | None = None,
           rungs: dict[str, str] | None = None,
           calibrated: dict[str, list[str]] | None = None,
           u_model_rel: dict[str, float | None] | None = None,
           family: str = "all") -> LadderResult:
    """Place comparisons on the ladder and judge each against the tolerances.

    Parameters
    ----------
    comparisons : sequence of Comparison
        One per test (see :func:`vehval.validate.validation.validate_test`).
    tolerances : Tolerances or dict, optional
        Defaults: fuel and SOC within 5 %.
    rungs : dict, optional
        test id -> rung, overriding the classification by cycle name.
    calibrated : dict, optional
        test id -> parameters the vehicle file was calibrated on it
        (:func:`vehval.calibration.provenance.calibration_tests`): those tests are in-sample.
    u_model_rel : dict, optional
        test id -> relative expanded model uncertainty U_model / figure [-] (missing: 0).
    family : str
        Powertrain family of the packaged precision (``hybrid``, ``conventional``, ``all``).
    """
    tol = tolerances if isinstance(tolerances, Tolerances) else Tolerances.from_mapping(tolerances)
    entries, held = [], []
    for c in comparisons:
        rung = (rungs or {}).get(c.test_id) or rung_of(c.cycle)
        if rung not in RUNGS:
            raise ConfigError(f"test '{c.test_id}': unknown rung '{rung}' (use {', '.join(RUNGS)})")
        ok, fails, err = verdict(c, tol)
        e = LadderEntry(c.test_id, c.cycle, rung, err, ok, fails,
                        in_sample=same_test(c.test_id, calibrated or {}))
        judged = judge_fuel(e, c, (u_model_rel or {}).get(c.test_id), family)
        if judged is not None and not e.in_sample:
            held.append((judged, e.s_r or 0.0))
        entries.append(e)
    entries.sort(key=lambda e: (RUNGS.index(e.rung), e.cycle, e.test_id))
    res = LadderResult(entries, tol, dict(calibrated or {}))
    res.set_verdict, res.set_verdict_note = held_out_set_verdict(held)
    return res


def in_set_verdict(row: dict[str, Any]) -> bool:
    """A prediction counts in the set verdict: held out (not in the vehicle's own fit) and
    inside the identification's conditions (``outside_identification``: the test's start
    outside them). The one rule of `vehval predict`, cross-validation and the batch."""
    return not row.get("in_sample") and not row.get("outside_identification")


def held_out_set_verdict(judged: Sequence[tuple[Any, float]]
                         ) -> tuple[dict[str, Any] | None, str]:
    """Set verdict over held-out fuel comparisons: ``(SetVerdict.to_dict(), "")``, or
    ``(None, why)`` with fewer than 3.

    ``judged`` holds (:class:`vehval.uncertainty.Comparison`, s_r [-]) pairs; the set's s_r is
    their root mean square (the tests of one car and lab, see :func:`set_verdict`)."""
    try:
        s_r = math.sqrt(sum(s * s for _, s in judged) / len(judged)) if judged else 0.0
        return set_verdict([c for c, _ in judged], s_r=s_r).to_dict(), ""
    except InsufficientDataError as exc:
        return None, str(exc)
