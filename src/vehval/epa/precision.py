"""Repeatability and reproducibility measured on the EPA Test Car Lists.

Row matching is strict. Two rows are results of **one setting** when they share the test
vehicle ID, the configuration number, the procedure (:func:`procedure_key`: the FTP-75's
2-day and 3-day variants are one exhaust test), the equivalent test weight, the road-load
target and dynamometer set coefficients (A, B, C) and the test fuel code: every physical
input of a model is then the same. Before matching, rows are de-duplicated by test number
(a test listed under several represented models, or twice, counts once: the first row
read is kept); rows without a test number or a result cannot be checked and are left out,
and so are rows whose listed figures do not agree with themselves
(:func:`~vehval.epa.consistency.check_listed_figures`: a placeholder, a typing error, bags
that do not recombine to the whole-test figure). What is left of wild rows (an FTP-75 row
without bags holding a highway-like 40 mpg among 25 mpg repeats) is the outlier screening's
(:mod:`vehval.uncertainty.precision`).

* same lab, one setting, several tests -> a group of repeats for **s_r**;
* a setting tested by the EPA lab and by the manufacturer -> one lab pair for **s_R**
  (lab a = EPA, lab b = MFR; ``offset`` > 0: the EPA lab measures a higher fuel economy).

Few settings are tested by both labs under one configuration number (4 to 8 per procedure
on a list), so s_R is also estimated at a second level, ``vehicle``: the same test vehicle,
procedure, weight, coefficients and fuel, any configuration number, but the same axle ratio
and N/V ratio (the physical inputs of a model still agree). This ``s_R (vehicle)`` is the
wider of the two (EPA rows are often filed under another configuration number than the
manufacturer's), and the one a model of a car, not of one configuration, meets.

Results are the whole-test fuel economy ``RND_ADJ_FE``. Estimates are made per procedure
and powertrain family (:func:`powertrain_family`). The lists have no powertrain column; the
family is read from what the lists do state:

* ``electric``: the row's test fuel is electricity (code 62: battery-electric tests and the
  charge-depleting tests of plug-in hybrids);
* ``hybrid``: the test vehicle has an FTP-75 with a bag 4 result in the same list (the
  4-bag FTP the hybrid procedure prescribes; mild hybrids tested so are counted), or its
  model name carries a hybrid mark (:data:`HYBRID_MARKS`: a few hybrids are listed with a
  3-bag FTP);
* ``conventional``: every other row.
"""

from __future__ import annotations

import math
from collections import defaultdict
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any

from vehval.epa.consistency import check_listed_figures
from vehval.epa.procedures import procedure_key
from vehval.epa.reader import EpaTest
from vehval.epa.specs_rows import four_bag_ftp, hybrid_name_mark
from vehval.uncertainty import InsufficientDataError, LabPair, Precision
from vehval.uncertainty import repeatability as _repeatability
from vehval.uncertainty import reproducibility as _reproducibility

FAMILIES = ("conventional", "hybrid", "electric")
#: test fuel codes of electricity
ELECTRICITY_FUEL_CODES = frozenset({"62"})
def hybrid_vehicles(tests: Iterable[EpaTest]) -> set[str]:
    """Test vehicle IDs with a four-phase FTP-75 (a bag 4 result: the hybrid FTP;
    :func:`vehval.epa.specs_rows.four_bag_ftp`)."""
    return {t.vehicle_id for t in tests if four_bag_ftp(t)}


def powertrain_family(t: EpaTest, hybrids: set[str]) -> str:
    """``conventional``, ``hybrid`` or ``electric`` (rule in the module docstring);
    ``hybrids`` is :func:`hybrid_vehicles` of the same list."""
    if t.fuel_code in ELECTRICITY_FUEL_CODES:
        return "electric"
    if t.vehicle_id in hybrids or hybrid_name_mark(t.model):
        return "hybrid"
    return "conventional"


#: matching levels of the lab pairs (module docstring)
MATCH_LEVELS = ("strict", "vehicle")


def setting_key(t: EpaTest, match: str = "strict") -> tuple:
    """What makes two rows one setting (rounded to the lists' printed digits). ``strict``:
    with the configuration number; ``vehicle``: any configuration, same axle and N/V ratio.
    The procedure is always the third item."""
    common = (procedure_key(t), round(t.mass_kg, 1),
              round(t.target_a_n, 3), round(t.target_b_n_per_mps, 4),
              round(t.target_c_n_per_mps2, 5), round(t.set_a_n, 3),
              round(t.set_b_n_per_mps, 4), round(t.set_c_n_per_mps2, 5), t.fuel_code)
    if match == "strict":
        return (t.vehicle_id, t.config, *common)
    return (t.vehicle_id, "*", *common, t.axle_ratio, t.n_v_ratio)


@dataclass
class Dedup:
    """Rows kept after de-duplication and what was left out (counts)."""

    kept: list[EpaTest]
    duplicates: int = 0          # rows whose test number was already read
    conflicting: int = 0         # of those, rows whose result differs from the kept row's
    unnumbered: int = 0          # rows without a test number
    no_result: int = 0           # rows without a whole-test result
    inconsistent: int = 0        # listed figures that disagree with each other

    def to_dict(self) -> dict[str, int]:
        return {"kept": len(self.kept), "duplicates": self.duplicates,
                "conflicting": self.conflicting, "unnumbered": self.unnumbered,
                "no_result": self.no_result, "inconsistent": self.inconsistent}


def dedupe(tests: Iterable[EpaTest]) -> Dedup:
    """One row per test number (the first read); rows without number or result, and rows
    whose figures cannot be trusted (module docstring), left out."""
    seen: dict[str, EpaTest] = {}
    out = Dedup(kept=[])
    for t in tests:
        if not t.test_number:
            out.unnumbered += 1
            continue
        if not math.isfinite(t.fe) or t.fe <= 0:
            out.no_result += 1
            continue
        first = seen.get(t.test_number)
        if first is not None:
            out.duplicates += 1
            out.conflicting += not math.isclose(first.fe, t.fe, rel_tol=1e-9)
            continue
        seen[t.test_number] = t
        if not check_listed_figures(t).ok:
            out.inconsistent += 1
            continue
        out.kept.append(t)
    return out


@dataclass
class Samples:
    """Groups of same-lab repeats and EPA-vs-manufacturer pairs per (family, procedure)."""

    repeats: dict[tuple[str, str], list[tuple[float, ...]]] = field(
        default_factory=lambda: defaultdict(list))
    pairs: dict[tuple[str, str], list[LabPair]] = field(
        default_factory=lambda: defaultdict(list))
    pairs_vehicle: dict[tuple[str, str], list[LabPair]] = field(
        default_factory=lambda: defaultdict(list))
    rows: int = 0
    dedup: Dedup | None = None

    def cells(self) -> list[tuple[str, str]]:
        """(family, procedure) with any data, in family then procedure order."""
        keys = set(self.repeats) | set(self.pairs) | set(self.pairs_vehicle)
        return sorted(keys, key=lambda k: (FAMILIES.index(k[0]) if k[0] in FAMILIES else 9,
                                           k[1]))


def pool_families(samples: Samples, name: str = "all") -> Samples:
    """The same samples with every powertrain family pooled under ``name``."""
    out = Samples(rows=samples.rows, dedup=samples.dedup)
    for (_, proc), groups in samples.repeats.items():
        out.repeats[(name, proc)] += groups
    for src, dst in ((samples.pairs, out.pairs), (samples.pairs_vehicle, out.pairs_vehicle)):
        for (_, proc), pairs in src.items():
            dst[(name, proc)] += pairs
    return out


def collect(tests: Sequence[EpaTest]) -> Samples:
    """De-duplicate, match and group the rows of one list (or of several, pooled)."""
    d = dedupe(tests)
    hybrids = hybrid_vehicles(d.kept)
    s = Samples(rows=len(d.kept), dedup=d)
    for match, target in (("strict", s.pairs), ("vehicle", s.pairs_vehicle)):
        by_setting: dict[tuple, dict[str, list[EpaTest]]] = defaultdict(
            lambda: defaultdict(list))
        for t in d.kept:
            by_setting[setting_key(t, match)][t.originator].append(t)
        for key, labs in by_setting.items():
            first = next(iter(labs.values()))[0]
            cell = (powertrain_family(first, hybrids), key[2])
            if match == "strict":
                for orig, rows in labs.items():
                    if len(rows) > 1 and orig:
                        s.repeats[cell].append(tuple(r.fe for r in rows))
            if labs.get("EPA") and labs.get("MFR"):
                target[cell].append(LabPair(tuple(r.fe for r in labs["EPA"]),
                                            tuple(r.fe for r in labs["MFR"]),
                                            label=first.vehicle_id))
    return s


@dataclass(frozen=True)
class CellPrecision:
    """s_r and s_R of one powertrain family and procedure (None where refused)."""

    family: str
    procedure: str
    s_r: Precision | None
    s_R: Precision | None
    s_R_vehicle: Precision | None = None
    notes: tuple[str, ...] = ()
    counts: tuple[int, int, int] = (0, 0, 0)   # pairs of repeats, settings, settings (vehicle)

    def to_dict(self) -> dict[str, Any]:
        return {"family": self.family, "procedure": self.procedure,
                "s_r": self.s_r.to_dict() if self.s_r else None,
                "s_R": self.s_R.to_dict() if self.s_R else None,
                "s_R_vehicle": self.s_R_vehicle.to_dict() if self.s_R_vehicle else None,
                "available": {"s_r_pairs": self.counts[0], "s_R_settings": self.counts[1],
                              "s_R_vehicle_settings": self.counts[2]},
                "notes": list(self.notes)}


def estimate(samples: Samples, confidence: float = 0.95) -> list[CellPrecision]:
    """s_r and s_R per (family, procedure). An estimate from fewer than 3 pairs is refused
    (None, with the refusal and its count in ``notes``). The s_R correction uses the same
    cell's s_r, else the procedure's s_r over all families, else none (noted)."""
    by_proc: dict[str, list[tuple[float, ...]]] = defaultdict(list)
    for (_, proc), groups in samples.repeats.items():
        by_proc[proc] += groups
    out = []
    for fam, proc in samples.cells():
        notes: list[str] = []
        s_r = _try(lambda: _repeatability(samples.repeats.get((fam, proc), []),
                                          confidence=confidence, what=f"s_r {fam} {proc}"),
                   notes)
        ref = s_r.s if s_r else math.nan
        if s_r is None:
            pooled = _try(lambda: _repeatability(by_proc.get(proc, []), confidence=confidence,
                                                 what=f"s_r {proc}"), [])
            ref = pooled.s if pooled else 0.0
            notes.append(f"s_R corrected with the {proc} s_r of all families "
                         f"({100 * ref:.2f} %)" if pooled else "s_R without an s_r correction")
        s_R = _try(lambda: _reproducibility(samples.pairs.get((fam, proc), []), s_r=ref,
                                            confidence=confidence, what=f"s_R {fam} {proc}"),
                   notes)
        s_Rv = _try(lambda: _reproducibility(samples.pairs_vehicle.get((fam, proc), []),
                                             s_r=ref, confidence=confidence,
                                             what=f"s_R (vehicle) {fam} {proc}"), notes)
        counts = (sum(len(g) - 1 for g in samples.repeats.get((fam, proc), [])),
                  len(samples.pairs.get((fam, proc), [])),
                  len(samples.pairs_vehicle.get((fam, proc), [])))
        out.append(CellPrecision(fam, proc, s_r, s_R, s_Rv, tuple(notes), counts))
    return out


def _try(fn, notes: list[str]) -> Precision | None:
    try:
        return fn()
    except InsufficientDataError as exc:
        notes.append(str(exc))
        return None
