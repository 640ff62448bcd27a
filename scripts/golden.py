"""Golden outputs: the JSON documents of the main commands on fixed inputs.

    python scripts/golden.py [--write] [--cases demo,cruze] [--golden DIR]

Runs, through the command line (in one process), `vehval qa`, `analyze`, `validate` and
`simulate` on

* ``demo``: the virtual test of ``make demo`` (2004 Prius on the UDDS, seed 7, default faults);
* ``cruze_<id>``: each Cruze D3 test of the shared real data (when present), with the template
  ``tests/qa/templates/cruze.yaml``;

and keeps findings.json, control.json, validation.json (+ metrics.json) and the simulation
summary, without the keys that name paths or times. ``--write`` stores them under
``tests/golden/`` (``make golden``); otherwise the documents are only computed
(``tests/test_golden.py`` compares them with the stored ones).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
GOLDEN = ROOT / "tests" / "golden"
CRUZE_TEMPLATE = ROOT / "tests" / "qa" / "templates" / "cruze.yaml"
#: Keys whose values depend on where or when a run happened, not on what it computed.
VOLATILE = {"outdir", "files", "elapsed_s", "vehicle_file", "origin", "started", "path",
            "vehval_version", "created", "source_file", "file", "template_file"}


def shared_real() -> Path:
    env = os.environ.get("VEHVAL_SHARED_DATA")
    base = Path(env) if env else ROOT.parent / "shared" / "data"
    return base / "real"


def cruze_files() -> list[Path]:
    d = shared_real() / "d3_2014_chevrolet_cruze_diesel"
    return sorted(d.glob("*Test Data.txt")) if d.is_dir() else []


def strip(value):
    """A copy without the volatile keys (recursively)."""
    if isinstance(value, dict):
        return {k: strip(v) for k, v in value.items() if k not in VOLATILE}
    if isinstance(value, list):
        return [strip(v) for v in value]
    return value


def _series(values: list) -> dict:
    nums = [float(v) for v in values if isinstance(v, (int, float)) and not isinstance(v, bool)]
    return {"n": len(values), "sum": sum(nums), "min": min(nums, default=None),
            "max": max(nums, default=None)}


def compact_figures(doc: dict) -> dict:
    """validation.json with each figure trace's x/y series reduced to n, sum, min, max
    (the overlays are megabytes; their totals still catch any change of a sample)."""
    figs = []
    for f in doc.get("figures") or []:
        data = (f.get("figure") or {}).get("data") or []
        figs.append({"title": f.get("title"),
                     "traces": [{"name": tr.get("name"),
                                 **{ax: _series(tr.get(ax) or []) for ax in ("x", "y")}}
                                for tr in data]})
    return dict(doc, figures=figs)


def _cli(args: list[str]) -> None:
    from vehval.cli import main

    rc = main([str(a) for a in args])
    if rc not in (0, 4):  # 4: computed, a result figure withheld for QA errors (docs/results.md)
        raise RuntimeError(f"vehval {' '.join(map(str, args))}: exit {rc}")


def _read(path: Path) -> dict:
    return strip(json.loads(path.read_text(encoding="utf-8")))


def run_case(name: str, files: list[Path], template: Path, work: Path,
             vehicle: str = "prius_2004") -> dict[str, dict]:
    """The golden documents of one test (command outputs read back from disk)."""
    out = work / name
    docs: dict[str, dict] = {}
    _cli(["qa", *files, "-t", template, "-o", out / "qa"])
    docs["findings"] = _read(out / "qa" / "findings.json")
    _cli(["analyze", *files, "-t", template, "-o", out / "analysis"])
    docs["control"] = _read(out / "analysis" / "control.json")
    _cli(["validate", *files, "-t", template, "--vehicle", vehicle, "-o", out / "validation"])
    docs["validation"] = compact_figures(_read(out / "validation" / "validation.json"))
    docs["metrics"] = _read(out / "validation" / "metrics.json")
    return docs


def demo(work: Path) -> dict[str, dict]:
    data = work / "virtual_test"
    _cli(["synth", "--vehicle", "prius_2004", "--cycle", "udds", "--seed", "7", "--faults",
          "default", "-o", data, "--force"])
    files = sorted(data.glob("*_d3.txt")) + sorted(data.glob("*_obd.csv"))
    docs = run_case("demo", files, data / "template.yaml", work)
    _cli(["simulate", "--vehicle", "prius_2004", "--cycle", "udds", "--charge-balance",
          "-o", work / "simulation"])
    docs["simulation"] = _read(work / "simulation" / "summary.json")
    return docs


def compute(cases: list[str], work: Path) -> dict[str, dict[str, dict]]:
    """Case name -> document name -> document."""
    out: dict[str, dict[str, dict]] = {}
    if "demo" in cases:
        out["demo"] = demo(work)
    if "cruze" in cases:
        for f in cruze_files():
            name = "cruze_" + f.name.split()[0]
            out[name] = run_case(name, [f], CRUZE_TEMPLATE, work)
    return out


def write(docs: dict[str, dict[str, dict]], golden: Path = GOLDEN) -> None:
    for case, by_name in docs.items():
        d = golden / case
        d.mkdir(parents=True, exist_ok=True)
        for name, doc in by_name.items():
            (d / f"{name}.json").write_text(json.dumps(doc, indent=1, sort_keys=True) + "\n",
                                            encoding="utf-8")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--write", action="store_true", help="store the documents as the goldens")
    ap.add_argument("--cases", default="demo,cruze", help="comma-separated: demo, cruze")
    ap.add_argument("--golden", type=Path, default=GOLDEN)
    a = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        docs = compute(a.cases.split(","), Path(tmp))
    if a.write:
        write(docs, a.golden)
    print(f"{len(docs)} case(s): {', '.join(docs)}" + (f" -> {a.golden}" if a.write else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main())
