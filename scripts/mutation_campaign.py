"""Mutation campaign: unit and mapping mistakes in the template of each real test file.

    python scripts/mutation_campaign.py [--all] [--data DIR] [--json OUT.json] [--md OUT.md]

Each dataset (Cruze D3, Camry D3 1 Hz, Prius c OBD, Insight 10 Hz) is run once with its correct
template (the reference) and once per mutation (fuel in mg/s, kg/h, L/h, volume for mass, speed
in km/h vs mph and m/s, test mass in lb, force in lbf, rpm as rad/s, degC as degF, coolant as K,
kPa as Pa, swapped channels, wrong phase channel, shifted time base, wrong fuel, misspelled raw
channel). Every case runs ``vehval qa`` (in process) and is classified from its
``results.json`` and ``findings.json``:

* ``withheld+hint``: the figures the mistake touches are withheld (results.json ``withheld``
  when present, else an error finding on a signal they depend on: fuel rate, vehicle speed,
  phase channel, battery) and a finding's ``fix`` (or the refusal) names the probable fix;
* ``withheld, no hint``: withheld, but no finding names the expected fix;
* ``unaffected``: every stated figure is within its expanded uncertainty (k = 2) of the
  reference (``+hint`` when a finding also names the mistake);
* ``refused``: the command stopped with a vehval error naming the channel;
* ``BREACH``: a stated, not withheld figure differs from the reference by more than its
  expanded uncertainty: the mistake went through.

By default one file per dataset (the first of each list below); ``--all`` takes every file.
The table for docs/robustness.md is printed (``--md`` writes it).
"""

from __future__ import annotations

import argparse
import contextlib
import copy
import io
import json
import math
import os
import sys
import tempfile
import time
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

import yaml

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
DEFAULT_DATA = Path(os.environ.get("VEHVAL_SHARED_DATA") or REPO / ".." / "shared" / "data") / "real"
LB_KG = 0.45359237

#: Quantities of results.json and the signal families they depend on (the fallback used
#: when results.json has no ``withheld`` key).
DEPENDS = {
    "fuel": ("fuel_rate", "veh_spd", "test_phase"),
    "distance": ("veh_spd", "test_phase"),
    "speed": ("veh_spd", "test_phase"),
    "ess": ("ess_", "test_phase"),
}


def family(quantity: str) -> str:
    """The dependency family of a results quantity key."""
    if quantity.startswith(("fuel", "co2")):
        return "fuel"
    if quantity.startswith("ess"):
        return "ess"
    if "speed" in quantity:
        return "speed"
    return "distance"


CAMRY_TEMPLATE = {
    "template_version": 1,
    "description": "ANL D3 2018 Toyota Camry, 1 Hz subset (speed, direct fuel flow)",
    "fuel": "gasoline_e10",
    "files": [{"match": "*Test Data.txt", "source": "dyno", "format": "d3",
               "time": {"column": "Time", "unit": "s"},
               "channels": {"Eng_FuelFlow_Direct_DI": {"name": "fuel_rate_test", "unit": "ccps"},
                            "Dyno_Spd": {"name": "veh_spd_test", "unit": "mph"}}}],
}
INSIGHT_TEMPLATE = {
    "template_version": 1,
    "description": "ADVISOR sample 2000 Honda Insight, two HWFET, 10 Hz",
    "files": [{"match": "Hwy2x_*.txt", "source": "dyno", "format": "csv",
               "time": {"column": "time_s", "unit": "s"},
               "channels": {"speed_mph": {"name": "veh_spd_test", "unit": "mph"},
                            "batt_volts": {"name": "ess_volt_test", "unit": "V"},
                            "batt_amps": {"name": "ess_curr_test", "unit": "A"},
                            "eng_rpm": {"name": "eng_spd_out_test", "unit": "rpm"},
                            "axle_torque_nm": {"name": "whl_trq_out_test", "unit": "N*m"},
                            "derived_em_trq_nm": {"delete": True, "reason": "derived"}}}],
}


@dataclass
class Dataset:
    """One real dataset: its files, its correct template and the raw channel of each role."""

    name: str
    folder: str
    pattern: str
    template: Callable[[], dict]
    roles: dict[str, str]               # role -> raw channel key
    true_units: dict[str, str] = field(default_factory=dict)
    files: list[Path] = field(default_factory=list)


def _yaml(path: Path) -> Callable[[], dict]:
    return lambda: yaml.safe_load(path.read_text(encoding="utf-8"))


DATASETS = [
    Dataset("cruze", "d3_2014_chevrolet_cruze_diesel", "*Test Data.txt",
            _yaml(REPO / "tests" / "qa" / "templates" / "cruze.yaml"),
            {"fuel": "Fuel_Flow_Bench_Modal", "speed": "Dyno_Speed", "force": "Dyno_Tractive_Effort",
             "engine": "Engine_Speed", "temp": "Test_Cell_Temp", "coolant": "Engine_Coolant_Temp",
             "phase": "Phase_#", "other": "Test_Cell_RH", "mass": "test_mass_kg"}),
    Dataset("camry", "d3_2018_toyota_camry_1hz_subset", "*Test Data.txt",
            lambda: copy.deepcopy(CAMRY_TEMPLATE),
            {"fuel": "Eng_FuelFlow_Direct_DI", "speed": "Dyno_Spd"}),
    Dataset("prius_c", "obd_2014_toyota_prius_c", "output*.csv",
            _yaml(REPO / "tests" / "io" / "templates" / "prius_c_obd.yaml"),
            {"speed": "eng2vsp", "engine": "eng2rpm", "temp": "eng2At", "pressure": "eng2Ap",
             "coolant": "eng2cTmp", "other": "eng2Iat"}),
    Dataset("insight", "advisor_insight_hwfet_10hz", "Hwy2x_*.txt",
            lambda: copy.deepcopy(INSIGHT_TEMPLATE),
            {"speed": "speed_mph", "engine": "eng_rpm", "other": "batt_volts"}),
]


def _channels(tpl: dict) -> dict:
    return tpl["files"][0]["channels"]


def _unit(unit: str, role: str) -> Callable[[dict, Dataset, Path], Any]:
    def apply(tpl: dict, ds: Dataset, files: Path) -> Any:
        key = ds.roles.get(role)
        if key is None:
            return None
        spec = _channels(tpl)[key]
        if spec.get("unit") == unit:
            return None
        spec["unit"] = unit
        return tpl
    return apply


def _fuel_other_kind(tpl: dict, ds: Dataset, files: Path) -> Any:
    """A volume flow declared as a mass flow, or a mass flow as a volume flow."""
    key = ds.roles.get("fuel")
    if key is None:
        return None
    spec = _channels(tpl)[key]
    spec["unit"] = "g/s" if spec["unit"] == "ccps" else "ccps"
    return tpl


def _speed_other(tpl: dict, ds: Dataset, files: Path) -> Any:
    key = ds.roles["speed"]
    spec = _channels(tpl)[key]
    spec["unit"] = "km/h" if spec["unit"] == "mph" else "mph"
    return tpl


def _mass_lb(tpl: dict, ds: Dataset, files: Path) -> Any:
    c = tpl.get("constants") or {}
    if "test_mass_kg" not in c:
        return None
    c["test_mass_kg"] = round(float(c["test_mass_kg"]) / LB_KG, 1)
    return tpl


def _swap(tpl: dict, ds: Dataset, files: Path) -> Any:
    ch = _channels(tpl)
    a = ds.roles.get("speed")
    b = ds.roles.get("fuel") or ds.roles.get("engine")
    if a is None or b is None:
        return None
    ch[a], ch[b] = ch[b], ch[a]
    return tpl


def _wrong_phase(tpl: dict, ds: Dataset, files: Path) -> Any:
    ch = _channels(tpl)
    p, o = ds.roles.get("phase"), ds.roles.get("other")
    if p is None or o is None:
        return None
    ch[o], ch[p] = {"name": "test_phase_test"}, {"delete": True, "reason": "mutation"}
    return tpl


def _misspell(tpl: dict, ds: Dataset, files: Path) -> Any:
    ch = _channels(tpl)
    key = ds.roles.get("fuel") or ds.roles["speed"]
    bad = key[:-2] + key[-1] + key[-2]          # two last letters swapped
    ch[bad] = ch.pop(key)
    return tpl


def _wrong_fuel(tpl: dict, ds: Dataset, files: Path) -> Any:
    if ds.roles.get("fuel") is None:
        return None
    c = tpl.get("constants") or {}
    was_diesel = "fuel_density_kg_per_m3" in c and float(c["fuel_density_kg_per_m3"]) > 800
    for k in ("fuel_density_kg_per_m3", "fuel_lhv_j_per_kg"):
        c.pop(k, None)
    tpl["fuel"] = "gasoline_e10" if was_diesel or tpl.get("fuel") == "diesel" else "diesel"
    return tpl


def _shift_time(tpl: dict, ds: Dataset, files: Path) -> Any:
    """Every timestamp of the data file 7.3 s later (a copy is written)."""
    spec = tpl["files"][0]
    if "column" not in (spec.get("time") or {}):
        return None
    for f in sorted(files.iterdir()):
        lines = f.read_bytes().decode("utf-8", "replace").splitlines()
        sep = "\t" if "\t" in lines[0] else ","
        out = [lines[0]]
        for ln in lines[1:]:
            parts = ln.split(sep)
            try:
                parts[0] = repr(float(parts[0]) + 7.3)
            except ValueError:
                pass
            out.append(sep.join(parts))
        f.write_text("\n".join(out) + "\n", encoding="utf-8")
    return tpl


#: mutation -> (how, expected finding: (signal family, text in its fix or the refusal))
MUTATIONS: dict[str, tuple[Callable[[dict, Dataset, Path], Any], tuple[str, str] | None]] = {
    "fuel mg/s": (_unit("mg/s", "fuel"), ("fuel_rate", "@fuel")),
    "fuel kg/h": (_unit("kg/h", "fuel"), ("fuel_rate", "@fuel")),
    "fuel L/h": (_unit("L/h", "fuel"), ("fuel_rate", "@fuel")),
    "fuel volume/mass (ccps as g/s)": (_fuel_other_kind, ("fuel_rate", "@fuel")),
    "speed km/h vs mph": (_speed_other, ("veh_spd", "@speed")),
    "speed m/s": (_unit("m/s", "speed"), ("veh_spd", "@speed")),
    "test mass in lb": (_mass_lb, ("veh_frc_in", "test_mass_kg")),
    "force lbf": (_unit("lbf", "force"), ("veh_frc_in", "@force")),
    "engine rpm as rad/s": (_unit("rad/s", "engine"), ("eng_spd", "@engine")),
    "temperature degC as degF": (_unit("degF", "temp"), ("amb_temp", "@temp")),
    "coolant degC as K": (_unit("K", "coolant"), ("eng_temp_coolant", "@coolant")),
    "pressure kPa as Pa": (_unit("Pa", "pressure"), ("amb_pres", "@pressure")),
    "swapped channels": (_swap, ("veh_spd", "")),
    "wrong phase channel": (_wrong_phase, ("test_phase", "")),
    "shifted time base (+7.3 s)": (_shift_time, None),
    "wrong fuel": (_wrong_fuel, None),
    "misspelled raw channel": (_misspell, ("", "did you mean")),
}


def _flatten(doc: dict) -> dict[str, tuple[float, float | None]]:
    """Every stated figure of results.json: ``where/quantity`` -> (value, U)."""
    out: dict[str, tuple[float, float | None]] = {}

    def add(where: str, block: dict) -> None:
        unc = block.get("uncertainty") or {}
        for k, v in (block.get("values") or {}).items():
            if isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v):
                u = (unc.get(k) or {}).get("U")
                out[f"{where}/{k}"] = (float(v), None if u is None else float(u))
    if doc.get("test_total"):
        add("test_total", doc["test_total"])
    for p in doc.get("phases") or []:
        add(f"phase:{p.get('name')}", p)
    for c in doc.get("composites") or []:
        add(f"composite:{c.get('name')}", c)
    return out


def withheld(doc: dict, findings: list[dict]) -> set[str]:
    """Figures (``where/quantity``) withheld: from the ``withheld`` keys when results.json
    has them, else those depending on a signal with an error finding."""
    figures = _flatten(doc)
    blocks = [("test_total", doc.get("test_total") or {})]
    blocks += [(f"phase:{p.get('name')}", p) for p in doc.get("phases") or []]
    blocks += [(f"composite:{c.get('name')}", c) for c in doc.get("composites") or []]
    if any("withheld" in b for _, b in blocks):
        out: set[str] = set()
        for where, b in blocks:
            w = b.get("withheld")
            if w:
                qs = w.get("quantities") or list((b.get("values") or {}).keys())
                out |= {f"{where}/{q}" for q in qs}
        return out
    bad = {f["signal"] for f in findings if f.get("severity") == "error"}
    return {k for k in figures
            if any(s.startswith(DEPENDS[family(k.split("/", 1)[1])]) for s in bad)}


@dataclass
class Outcome:
    dataset: str
    file: str
    mutation: str
    outcome: str
    detail: str = ""
    breaches: list[str] = field(default_factory=list)


def run_qa(files: list[Path], tpl: dict, out: Path) -> tuple[int, str, dict, list[dict], list[str]]:
    """``vehval qa`` in process: exit code, stderr, results.json, findings, notes."""
    from vehval.cli import main

    out.mkdir(parents=True, exist_ok=True)
    tpath = out / "template.yaml"
    tpath.write_text(yaml.safe_dump(tpl, sort_keys=False), encoding="utf-8")
    err, sink = io.StringIO(), io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(sink):
        code = main(["qa", *map(str, files), "-t", str(tpath), "-o", str(out / "qa")])
    res = out / "qa" / "results.json"
    fnd = out / "qa" / "findings.json"
    doc = json.loads(res.read_text(encoding="utf-8")) if res.is_file() else {}
    fdoc = json.loads(fnd.read_text(encoding="utf-8")) if fnd.is_file() else {}
    return code, err.getvalue(), doc, list(fdoc.get("findings") or []), list(fdoc.get("notes") or [])


def expectation(mutation: str, tpl: dict, ds: Dataset) -> tuple[str, str] | None:
    """The finding a mutation should raise: (signal family, text of its fix); ``@role``
    stands for "in <the role's true unit>," from the correct template."""
    exp = MUTATIONS[mutation][1]
    if exp is None or not exp[1].startswith("@"):
        return exp
    unit = _channels(tpl)[ds.roles[exp[1][1:]]]["unit"]
    return exp[0], f"@{unit}"


def _same_unit(a: str | None, b: str) -> bool:
    from vehval.units import parse_unit

    try:
        return bool(a) and parse_unit(a) == parse_unit(b)
    except Exception:  # noqa: BLE001 - an unparsable spelling is not the unit
        return False


def classify(expect: tuple[str, str] | None, base: dict,
             run: tuple[int, str, dict, list[dict], list[str]]) -> tuple[str, str, list[str]]:
    """Outcome, detail and breaching figures of one case against the reference results."""
    code, err, doc, findings, notes = run
    if code not in (0, 4):
        line = err.strip().splitlines()[-1] if err.strip() else f"exit {code}"
        ok = expect is not None and expect[1].lstrip("@") in line
        return ("refused" + (" with hint" if ok else ""), line[:160], [])
    hinted = ""
    if expect is not None:
        fam, text = expect
        for f in findings:
            if f.get("severity") not in ("warning", "error") or not f["signal"].startswith(fam):
                continue
            if text.startswith("@"):                 # a unit hint: the probable unit is right
                ok = bool(f.get("fix")) and _same_unit(
                    (f.get("numbers") or {}).get("probable_unit"), text[1:])
            else:
                ok = text in (f.get("fix") or f.get("message", ""))
            if ok:
                hinted = f.get("fix") or f["message"][:120]
                break
        if not hinted and text:
            hinted = next((n for n in notes if text in n), "")
    held = withheld(doc, findings)
    ref, now = _flatten(base), _flatten(doc)
    breaches = []
    for k, (v, u) in now.items():
        if k not in ref or k in held:
            continue
        v0, u0 = ref[k]
        tol = max(u0 or 0.0, 1e-9 * max(1.0, abs(v0)))
        if k.endswith("_s") and not u0:
            # a phase duration placed from the identified cycle instead of the phase channel:
            # the regulatory schedules are given at 1 s steps, so boundaries agree within 1 s
            tol = max(tol, 1.0)
        if abs(v - v0) > tol:
            breaches.append(f"{k}: {v0:.5g} -> {v:.5g} (U {u0 if u0 is not None else 0:.3g})")
    touched = (held & set(ref)) | (set(ref) - set(now))    # withheld or no longer stated
    if breaches:
        return "BREACH", hinted, breaches
    if touched:
        return ("withheld+hint" if hinted else "withheld, no hint"), hinted, []
    return ("unaffected+hint" if hinted else "unaffected"), hinted, []


def campaign(data: Path, every: bool = False, only: list[str] | None = None,
             log: Callable[[str], None] = print, datasets: list[Dataset] | None = None,
             mutations: list[str] | None = None) -> list[Outcome]:
    """Run every mutation (or ``mutations``) on every dataset found under ``data``."""
    outcomes: list[Outcome] = []
    with tempfile.TemporaryDirectory(prefix="vehval-mut-") as tmp:
        root = Path(tmp)
        for ds in datasets or DATASETS:
            if only and ds.name not in only:
                continue
            files = sorted((data / ds.folder).glob(ds.pattern))
            if not files:
                log(f"{ds.name}: no files under {data / ds.folder}: skipped")
                continue
            for f in files if every else files[:1]:
                base = run_qa([f], ds.template(), root / ds.name / f.stem / "base")
                if base[0] not in (0, 4):
                    log(f"{ds.name} {f.name}: reference run failed: {base[1].strip()[-200:]}")
                    continue
                for mut, (how, _exp) in MUTATIONS.items():
                    if mutations and mut not in mutations:
                        continue
                    case = root / ds.name / f.stem / mut.replace(" ", "_").replace("/", "_")
                    copy_dir = case / "data"
                    copy_dir.mkdir(parents=True)
                    (copy_dir / f.name).write_bytes(f.read_bytes())
                    tpl = how(ds.template(), ds, copy_dir)
                    if tpl is None:
                        outcomes.append(Outcome(ds.name, f.name, mut, "n/a"))
                        continue
                    t0 = time.perf_counter()
                    run = run_qa([copy_dir / f.name], tpl, case)
                    kind, detail, breaches = classify(expectation(mut, ds.template(), ds),
                                                      base[2], run)
                    outcomes.append(Outcome(ds.name, f.name, mut, kind, detail, breaches))
                    log(f"{ds.name:8s} {f.stem[:18]:18s} {mut:32s} {kind:18s} "
                        f"{time.perf_counter() - t0:5.1f} s  {detail[:90]}"
                        + (f"  {breaches[:2]}" if breaches else ""))
    return outcomes


def table(outcomes: list[Outcome]) -> str:
    """Markdown table: mutations x datasets (outcome counts over the files run)."""
    names = [d.name for d in DATASETS if any(o.dataset == d.name for o in outcomes)]
    lines = ["| mutation | " + " | ".join(names) + " |", "|---" * (len(names) + 1) + "|"]
    for mut in MUTATIONS:
        cells = []
        for n in names:
            c = Counter(o.outcome for o in outcomes if o.dataset == n and o.mutation == mut)
            cells.append(", ".join(f"{k}" if v == 1 else f"{k} x{v}" for k, v in sorted(c.items()))
                         or "-")
        lines.append(f"| {mut} | " + " | ".join(cells) + " |")
    tot = Counter(o.outcome for o in outcomes)
    lines.append("")
    lines.append("Totals: " + ", ".join(f"{k} {v}" for k, v in sorted(tot.items())))
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=DEFAULT_DATA)
    ap.add_argument("--all", action="store_true", help="every file of each dataset")
    ap.add_argument("--dataset", action="append", help="only these datasets")
    ap.add_argument("--json", type=Path)
    ap.add_argument("--md", type=Path)
    args = ap.parse_args(argv)
    if not args.data.is_dir():
        print(f"no real data at {args.data}", file=sys.stderr)
        return 2
    outcomes = campaign(args.data, args.all, args.dataset)
    md = table(outcomes)
    print(md)
    if args.md:
        args.md.write_text(md + "\n", encoding="utf-8")
    if args.json:
        args.json.write_text(json.dumps([o.__dict__ for o in outcomes], indent=1), encoding="utf-8")
    return 1 if any(o.outcome == "BREACH" for o in outcomes) else 0


if __name__ == "__main__":
    sys.exit(main())
