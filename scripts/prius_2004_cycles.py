"""The 2004 Prius on five cycles, for the packaged file and for every change made to it.

Usage::

    python scripts/prius_2004_cycles.py [--dt 0.1] [--reference FILE] [--json] [--markdown]

Reads every committed version of ``src/vehval/data/vehicles/prius_2004.yaml`` from the
repository's history (``git log`` / ``git show``), finds which parameter values changed from
one version to the next (sources, uncertainties and the description are not values), and
simulates, with the present simulator, the first version and then each change applied in
turn on UDDS, HWFET, US06, Japan 10-15 and NEDC: charge balanced, unadjusted dyno figures,
SOC-corrected fuel economy [mpg] (J1711 energy method). A change that touches several
components is split per component (MG2, then MG1, then the rest) so that each one's effect is
seen. The last row is the file as it is in the working tree.

Changes of the simulator itself (not of the file) cannot be reverted by this script; they are
listed in docs/validation.md with what they do to the 2004 figures.

``--reference FILE`` (YAML: ``{cycle: {mpg: float, source: str}}``) adds a column per cycle
with the error of the present file against that figure. Without it, the references are the
ones built in below: the figures implied by the 2004 car's EPA label, with their source and
the rounding band of the label.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

from vehval.errors import ConfigError  # noqa: E402
from vehval.sim.simulate import simulate  # noqa: E402
from vehval.vehicle import load_vehicle  # noqa: E402
from vehval.vehicle.definition import Vehicle  # noqa: E402

VEHICLE = "src/vehval/data/vehicles/prius_2004.yaml"
CYCLES = ("udds", "hwfet", "us06", "japan1015", "nedc")
LABELS = {"udds": "UDDS", "hwfet": "HWFET", "us06": "US06", "japan1015": "Japan 10-15",
          "nedc": "NEDC"}
MPG = "fuel_economy_soc_corrected_mpg"
#: keys that describe a value rather than set it
NOT_VALUES = {"sources", "uncertainty", "description", "name"}
#: order in which the components of one change are applied
ORDER = ("mg2", "mg1", "controller", "engine", "battery", "boost", "body", "driveline",
         "planetary", "driver")

#: References in the project's sources. The EPA label of the 2004 car (60 city / 51 highway
#: under the label rules of the time: city = 0.90 x FTP-75, highway = 0.78 x HWFET; the label
#: rounds to 1 mpg, hence the band). The FTP-75 includes a cold start, so a hot UDDS should
#: beat it: it is a lower bound for the UDDS, not a like-for-like figure.
REFERENCE: dict[str, dict[str, Any]] = {
    "hwfet": {"mpg": 51 / 0.78, "band": [50.5 / 0.78, 51.5 / 0.78], "kind": "like for like",
              "source": "EPA label 2004 Prius, highway 51 mpg / 0.78 (label rule of the time)"},
    "udds": {"mpg": 60 / 0.90, "band": [59.5 / 0.90, 60.5 / 0.90],
             "kind": "lower bound (cold FTP-75)",
             "source": "EPA label 2004 Prius, city 60 mpg / 0.90 = FTP-75 with its cold start"},
}


def git(*args: str) -> str:
    """Output of ``git args`` run in the repository [text]."""
    try:
        out = subprocess.run(["git", *args], cwd=ROOT, check=True, capture_output=True,
                             text=True)
    except (OSError, subprocess.CalledProcessError) as exc:
        raise ConfigError(f"git {' '.join(args)} failed in {ROOT}: {exc}; run the script in a "
                          "git checkout of the project") from exc
    return out.stdout


def history() -> list[tuple[str, str, str]]:
    """(commit, date, subject) of every commit that changed the 2004 file, oldest first."""
    lines = git("log", "--reverse", "--format=%h\t%ad\t%s", "--date=short", "--", VEHICLE)
    return [tuple(ln.split("\t", 2)) for ln in lines.splitlines() if ln.strip()]  # type: ignore


def flat(veh: Vehicle) -> dict[str, str]:
    """Every parameter value of ``veh`` by dotted path, as text (for comparison)."""
    out: dict[str, str] = {}

    def rec(path: str, x: Any) -> None:
        if isinstance(x, dict):
            for k, y in x.items():
                if k not in NOT_VALUES:
                    rec(f"{path}.{k}" if path else k, y)
        else:
            out[path] = repr(x)

    rec("", veh.model_dump())
    return out


def versions(tmp: Path) -> tuple[list[tuple[str, str, Vehicle]], list[str]]:
    """(commit, subject, vehicle) of each committed version that the present schema loads,
    then the working tree's file; and a note per version it does not load."""
    out, skipped = [], []
    for commit, date, subject in history():
        path = tmp / f"prius_2004_{commit}.yaml"
        path.write_text(git("show", f"{commit}:{VEHICLE}"), encoding="utf-8")
        try:
            out.append((commit, f"{date} {subject}", load_vehicle(path)))
        except ConfigError as exc:
            reason = str(exc).split("invalid vehicle: ")[-1]
            skipped.append(f"{commit} ({date}): not loadable by the present schema: {reason}")
    out.append(("working tree", "the packaged file", load_vehicle(ROOT / VEHICLE)))
    return out, skipped


def steps(tmp: Path) -> tuple[list[dict[str, Any]], list[str]]:
    """The first loadable version, then each value change as a step (split per component);
    and the versions skipped."""
    vers, skipped = versions(tmp)
    first_commit, first_subject, veh = vers[0]
    out = [{"step": f"as built ({first_commit})", "commit": first_commit, "changed": [],
            "vehicle": veh}]
    for commit, subject, new in vers[1:]:
        old_vals, new_vals = flat(veh), flat(new)
        changed = sorted(k for k in set(old_vals) | set(new_vals)
                         if old_vals.get(k) != new_vals.get(k))
        if not changed:
            out.append({"step": f"{commit}: no value changed", "commit": commit,
                        "subject": subject, "changed": [], "vehicle": None})
            continue
        blocks = sorted({k.split(".")[0] for k in changed},
                        key=lambda b: ORDER.index(b) if b in ORDER else len(ORDER))
        for blk in blocks:
            keys = [k for k in changed if k.split(".")[0] == blk]
            veh = veh.model_copy(update={blk: getattr(new, blk)})
            veh.__dict__.pop("best_line", None)  # cached from the engine block
            out.append({"step": f"{commit}: {blk}", "commit": commit, "subject": subject,
                        "changed": keys, "vehicle": veh})
    return out, skipped


def run(veh: Vehicle, dt: float) -> dict[str, dict[str, float]]:
    """Charge-balanced figures of ``veh`` on the five cycles."""
    res = {}
    for cyc in CYCLES:
        s = simulate(veh, cyc, dt=dt, charge_balance=True).summary
        res[cyc] = {"mpg": float(s[MPG]), "soc_delta": float(s["soc_delta"]),
                    "engine_on_fraction": float(s["engine_on_fraction"]),
                    "trace_n_miss": int(s["trace_n_miss"])}
    return res


def table(rows: list[dict[str, Any]], ref: dict[str, dict[str, Any]]) -> str:
    """Markdown: one line per step, mpg per cycle and the change from the previous step."""
    head = "| step | changed | " + " | ".join(LABELS[c] for c in CYCLES) + " |"
    lines = [head, "|" + "---|" * (2 + len(CYCLES))]
    prev = None
    for r in rows:
        if r["figures"] is None:
            lines.append(f"| {r['step']} | - | " + " | ".join("=" for _ in CYCLES) + " |")
            continue
        cells = []
        for c in CYCLES:
            m = r["figures"][c]["mpg"]
            cells.append(f"{m:.2f}" if prev is None
                         else f"{m:.2f} ({100 * (m / prev[c]['mpg'] - 1):+.1f} %)")
        keys = ", ".join(r["changed"]) or "-"
        lines.append(f"| {r['step']} | {keys} | " + " | ".join(cells) + " |")
        prev = r["figures"]
    last = prev or {}
    cells = []
    for c in CYCLES:
        if c in ref and last:
            m = ref[c]["mpg"]
            err = 100 * (last[c]["mpg"] / m - 1)
            cells.append(f"{m:.1f} ({ref[c].get('kind', 'measured')}; model {err:+.1f} %)")
        else:
            cells.append("none in the project")
    lines.append("| reference | | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--dt", type=float, default=0.1, help="time step [s] (default 0.1)")
    ap.add_argument("--reference", type=Path, help="YAML {cycle: {mpg, source}} to compare with")
    ap.add_argument("--json", action="store_true", help="print JSON instead of Markdown")
    args = ap.parse_args(argv)
    ref = REFERENCE
    if args.reference is not None:
        import yaml

        ref = yaml.safe_load(args.reference.read_text(encoding="utf-8")) or {}
        bad = [c for c in ref if c not in CYCLES or "mpg" not in (ref[c] or {})]
        if bad:
            raise SystemExit(f"{args.reference}: entries {bad} are not among {CYCLES} with an "
                             "mpg key")
    with tempfile.TemporaryDirectory() as tmp:
        rows, skipped = steps(Path(tmp))
    for r in rows:
        veh = r.pop("vehicle")
        r["figures"] = None if veh is None else run(veh, args.dt)
    if args.json:
        print(json.dumps({"dt_s": args.dt, "cycles": list(CYCLES), "steps": rows,
                          "skipped": skipped, "reference": ref}, indent=1))
    else:
        print(table(rows, ref))
        for note in skipped:
            print(f"\n* skipped {note}", end="")
        for c, r in ref.items():
            print(f"\n* {LABELS[c]}: {r['mpg']:.1f} mpg, {r.get('kind', 'measured')}: "
                  f"{r['source']}", end="")
        print()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
