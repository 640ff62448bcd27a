"""Real sets judged by the normalised error: every table of docs/validation.md, "Real sets
judged by the normalised error", from the tool's own commands.

    python scripts/real_sets.py [--data DIR] [--only SET ...] [--workdir DIR]

SET: prius_2016, prius_2016_eco_rows, prius_c, camry, cruze, prius_2004. DIR holds
``real/`` and ``reference/`` (default: $VEHVAL_SHARED_DATA, else ../shared/data beside the
repository). A set whose data is absent is skipped with one line; nothing is fitted to a
reference (the 2004 Prius is simulated as packaged). Each set runs one command at a time:

* the EPA sets: ``vehval epa validate LIST --vehicle V --tests SELECTOR --json``;
* the Camry: ``vehval epa vehicle`` calibrated on its FTP-75 and UDDS dyno files, then
  ``vehval epa validate`` on its list rows;
* the Cruze: ``vehval identify ... --cross-validate --pairs -o pairs.json``;
* the 2004 Prius: ``vehval simulate --vehicle prius_2004 --cycle C --charge-balance --json``
  per cycle, U_model from :func:`vehval.sim.model_uncertainty.figure_uncertainty` (linear,
  dt 1 s) and En from :func:`vehval.uncertainty.judge_published`.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
SETS = ("prius_2016", "prius_2016_eco_rows", "prius_c", "camry", "cruze", "prius_2004")

#: The two 2004 references (reference/prius_2004/fuel_economy.md): cycle, published mpg and
#: the expanded uncertainty the source states (rounding, a limit taken as uniform: U = 2 h / sqrt 3).
ARGONNE = [("udds", 71.0), ("hwfet", 67.0), ("us06", 42.0), ("japan1015", 75.0),
           ("nedc", 69.0)]
ARGONNE_HALF = 0.5          # rounded to whole mpg [mpg]
EPA_LABEL = [("ftp75", 60 / 0.90), ("hwfet", 51 / 0.78)]
EPA_HALF = 0.8              # the label rounded to whole mpg, divided by 0.90 / 0.78 [mpg]


def vehval(*args: str, cwd: Path | None = None, check: bool = True) -> str:
    """Run one vehval command; its stdout (a failure stops the script with its message, or
    with ``check=False`` returns ``"ERROR: "`` and the message)."""
    env = dict(os.environ, PYTHONPATH=str(REPO / "src"))
    r = subprocess.run([sys.executable, "-m", "vehval", *args], capture_output=True,
                       text=True, env=env, cwd=cwd)
    if r.returncode != 0 and not check:
        return "ERROR: " + (r.stderr.strip().splitlines() or ["?"])[-1]
    if r.returncode != 0:
        sys.exit(f"vehval {' '.join(args)}: exit {r.returncode}: {r.stderr.strip()[-400:]}")
    return r.stdout


def fmt_verdict(sv: dict | None, note: str = "") -> str:
    if sv is None:
        return f"none ({note})"
    lo, hi = sv["mean_error_ci_pct"]
    clo, chi = sv["coverage_ci"]
    text = (f"{sv['verdict']}; n = {sv['n']}, mean error {sv['mean_error_pct']:+.2f} % "
            f"[{lo:+.2f}, {hi:+.2f}], the scatter explains {sv['bias_limit_pct']:.2f} %")
    if sv.get("different_source") and "bias_limit_s_r_pct" in sv:
        text += (f" (s_r alone {sv['bias_limit_s_r_pct']:.2f} %: "
                 f"{'beyond' if sv['beyond_s_r'] else 'within'})")
    text += (f"; |En| <= 1 for {sv['n_consistent']}/{sv['n']} (coverage "
             f"[{100 * clo:.0f}, {100 * chi:.0f}] %)")
    return text + "".join(f"; {n}" for n in sv["notes"])


def epa_table(doc: dict, title: str) -> None:
    """Whole-test figures (bags 3+4 when the whole test is not judged) with En; the bags'
    En range; the set verdicts."""
    print(f"\n### {title}\n")
    print("| test | by | procedure | figure | predicted / measured mpg | error | U_model / "
          "U_meas mpg | En | bags' En | sample |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    tests: dict[str, list] = {}
    for c in doc["comparisons"]:
        tests.setdefault(c["test"], []).append(c)
    for test, rows in tests.items():
        judged = [c for c in rows if c["judged"] and c.get("en") is not None]
        pick = next((c for c in judged if c["item"] == "overall"), None) or next(
            (c for c in judged if c["item"] == "bags 3+4"), None)
        if pick is None:
            continue
        bags = [c["en"] for c in judged if c is not pick and c["item"].startswith("bag")]
        span = f"{min(bags):+.2f} .. {max(bags):+.2f}" if bags else "-"
        sample = "in-sample" if pick["in_sample"] else "held-out"
        print(f"| {test} | {pick['originator']} | {pick['procedure']} | {pick['item']} | "
              f"{pick['predicted_mpg']:.1f} / {pick['measured_mpg']:.1f} | "
              f"{100 * pick['error']:+.1f} % | {pick['u_model']:.2f} / {pick['u_meas']:.2f} | "
              f"{pick['en']:+.2f}{'?' if pick['uninformative'] else ''} | {span} | {sample} |")
    for proc, f in sorted(doc["model_uncertainty"].items()):
        if f is not None:
            print(f"\nU_model {proc}: {100 * f['U_rel']:.2f} % ({f['method']})", end="")
    bases = sorted({c["precision"]["basis"] for c in doc["comparisons"] if c.get("precision")})
    print("\n\nU_meas: " + "; ".join(bases))
    print(f"\nset verdict (held-out): {fmt_verdict(doc['set_verdict'], doc['set_verdict_note'])}")
    if doc.get("set_verdict_all") is not None:
        print(f"\nset verdict (all tests, in-sample included): "
              f"{fmt_verdict(doc['set_verdict_all'], doc.get('set_verdict_all_note', ''))}")


def epa_set(lists: list[Path], vehicle: str, selector: str, title: str) -> dict | None:
    missing = [p for p in lists if not p.is_file()]
    if missing:
        print(f"\n{title}: skipped ({missing[0].name} not found)")
        return None
    out = vehval("epa", "validate", *map(str, lists), "--vehicle", vehicle, "--tests", selector,
                 "--json", check=False)
    if out.startswith("ERROR: "):
        print(f"\n### {title}\n\nnot judged: {out[7:]}")
        return None
    doc = json.loads(out)
    epa_table(doc, title)
    return doc


def prius_2016(data: Path, work: Path) -> None:
    lst = data / "real" / "epa_test_car_list" / "16tstcar.csv"
    epa_set([lst], "prius_2016", "model=PRIUS,year=2016",
            "prius_2016 on the 2016 PRIUS rows")


def prius_2016_eco_rows(data: Path, work: Path) -> None:
    lst = data / "real" / "epa_test_car_list" / "16tstcar.csv"
    for veh in ("prius_2016", "prius_2016_eco"):
        epa_set([lst], veh, "model=PRIUS Eco,year=2016", f"{veh} on the 2016 PRIUS Eco rows")


def prius_c(data: Path, work: Path) -> None:
    d = data / "real" / "epa_test_car_list"
    for name, year in (("16tstcar.csv", 2016), ("17tstcar.csv", 2017), ("19tstcar.csv", 2019)):
        epa_set([d / name], "prius_c", f"model=PRIUS c,year={year}",
                f"prius_c on the {year} PRIUS c rows ({name})")
    epa_set([d / "16tstcar.csv", d / "19tstcar.csv"], "prius_c", "model=PRIUS c",
            "prius_c on the PRIUS c rows of the 2016 and 2019 lists together")


CAMRY_TEMPLATE = ("template_version: 1\nfuel: gasoline_e0\nfiles:\n- source: dyno\n"
                  "  format: d3\n  time: {column: Time}\n  channels:\n"
                  "    Eng_FuelFlow_Direct_DI: {name: fuel_rate_test, unit: ccps}\n"
                  "    Dyno_Spd: {name: veh_spd_test, unit: mph}\n")


def camry(data: Path, work: Path) -> None:
    dyno = data / "real" / "d3_2018_toyota_camry_1hz_subset"
    lst = data / "real" / "epa_test_car_list" / "19tstcar.csv"
    if not dyno.is_dir() or not lst.is_file():
        print("\nCamry: skipped (the D3 Camry subset or 19tstcar.csv not found)")
        return
    tmpl, car = work / "camry_t.yaml", work / "camry.yaml"
    tmpl.write_text(CAMRY_TEMPLATE, encoding="utf-8")
    f = [str(dyno / f"6181101{k} Test Data.txt") for k in (1, 2, 3, 4)]
    out = vehval("epa", "vehicle", str(lst), "--make", "TOYOTA", "--model", "CAMRY XLE/XSE",
                 "--year", "2019", "--calibrate", f[0], "--calibrate", f[1], "--predict", f[2],
                 "--predict", f[3], "-t", str(tmpl), "--dt", "0.5", "-o", str(car))
    print("\n### Camry: `vehval epa vehicle` calibrated on the D3 FTP-75 and UDDS\n")
    print("\n".join("    " + line for line in out.splitlines()))
    epa_set([lst], str(car), "make=TOYOTA,model=CAMRY XLE/XSE,year=2019",
            "Camry (calibrated on its dyno files) on its 2019 list rows")


CRUZE_TESTS = ("61410013", "61410015", "61410016", "61410005", "61410004")


def cruze(data: Path, work: Path) -> None:
    d = data / "real" / "d3_2014_chevrolet_cruze_diesel"
    files = [d / f"{t} Test Data.txt" for t in CRUZE_TESTS]
    if not all(p.is_file() for p in files):
        print("\nCruze: skipped (the D3 Cruze tests not found)")
        return
    out = work / "pairs.json"
    vehval("identify", *map(str, files), "-t", str(REPO / "tests/qa/templates/cruze.yaml"),
           "--spec", str(REPO / "tests/identify/cruze_spec.yaml"), "--cross-validate",
           "--pairs", "-o", str(out))
    doc = json.loads(out.read_text(encoding="utf-8"))
    print("\n### Cruze: 30 pair predictions (`identify --cross-validate --pairs`)\n")
    print("| identified from | held-out test | cycle | measured / predicted g | error | "
          "U_model / U_meas g | En |")
    print("|---|---|---|---|---|---|---|")
    for r in doc["rows"]:
        if "error" in r and "predicted_g" not in r:
            print(f"| {' + '.join(r.get('identified_from', []))} | - | - | - | "
                  f"{r['error']} | - | - |")
            continue
        src = " + ".join(str(t).split()[0][-2:] for t in r["identified_from"])
        print(f"| {src} | {r['test']} | {r['cycle']} | {r['measured_g']:.1f} / "
              f"{r['predicted_g']:.1f} | {100 * r['error_rel']:+.1f} % | "
              f"{r['u_model_g']:.1f} / {r['u_meas_g']:.1f} | {r['en']:+.2f}"
              f"{'?' if r['uninformative'] else ''} |")
    print(f"\nset verdict: {fmt_verdict(doc.get('set_verdict'), doc.get('set_verdict_note', ''))}")


def prius_2004(data: Path, work: Path) -> None:
    ref = data / "reference" / "prius_2004" / "fuel_economy.md"
    if not ref.is_file():
        print("\nprius_2004: skipped (reference/prius_2004/fuel_economy.md not found)")
        return
    sys.path.insert(0, str(REPO / "src"))
    from vehval.sim.model_uncertainty import figure_uncertainty
    from vehval.uncertainty import judge_published, set_verdict

    cycles = sorted({c for c, _ in ARGONNE + EPA_LABEL})
    sim, u_rel = {}, {}
    for cyc in cycles:
        s = json.loads(vehval("simulate", "--vehicle", "prius_2004", "--cycle", cyc,
                              "--charge-balance", "--json"))
        sim[cyc] = s["fuel_economy_soc_corrected_mpg"]
        u_rel[cyc] = figure_uncertainty("prius_2004", cyc, method="linear").u_rel
    for name, ref_rows, half in (("Argonne's dyno tests (APRF, 2008 summary)", ARGONNE,
                                  ARGONNE_HALF),
                                 ("the EPA label (pre-2008 method, label / 0.90, 0.78)",
                                  EPA_LABEL, EPA_HALF)):
        print(f"\n### prius_2004 (as packaged, dt 0.1 s, charge balanced) against {name}\n")
        print("| cycle | simulated mpg | published mpg | error | U_model | U_stated | "
              "s_R (basis) | U_meas | En |")
        print("|---|---|---|---|---|---|---|---|---|")
        comps, srs, ss = [], [], []
        for cyc, mpg in ref_rows:
            u_stated = 2 * half / math.sqrt(3)
            cmp, b = judge_published(sim[cyc], mpg, u_model=u_rel[cyc] * sim[cyc], cycle=cyc,
                                     family="hybrid", u_stated=u_stated, label=cyc)
            comps.append(cmp)
            srs.append(b["s_r"])
            ss.append(b["s_R"])
            basis = f"{b['which']} {b['procedure']}" + (" (borrowed)" if b["note"] else "")
            print(f"| {cyc} | {sim[cyc]:.2f} | {mpg:.1f} | {100 * cmp.error:+.1f} % | "
                  f"{cmp.u_model:.2f} ({100 * u_rel[cyc]:.1f} %) | {u_stated:.2f} | "
                  f"{100 * b['s_R']:.2f} % ({basis}) | {cmp.u_meas:.2f} | {cmp.en:+.2f}"
                  f"{'?' if cmp.uninformative else ''} |")
        s_r = math.sqrt(sum(x * x for x in srs) / len(srs))
        s_big = math.sqrt(sum(x * x for x in ss) / len(ss))
        try:
            sv = set_verdict(comps, s_r=s_r, s_R=s_big, different_source=True).to_dict()
            sv["different_source"] = True
            print(f"\nset verdict: {fmt_verdict(sv)}")
        except Exception as exc:  # fewer than 3 figures: the count is the answer
            print(f"\nset verdict: none ({exc})")
    a, e = dict(ARGONNE), dict(EPA_LABEL)
    print("\nSpread between the two sources (EPA / Argonne - 1): FTP-75 (cold, EPA) against "
          f"UDDS (hot, Argonne) {100 * (e['ftp75'] / a['udds'] - 1):+.1f} %, HWFET "
          f"{100 * (e['hwfet'] / a['hwfet'] - 1):+.1f} %; model against each: "
          f"HWFET {100 * (sim['hwfet'] / a['hwfet'] - 1):+.1f} % (Argonne), "
          f"{100 * (sim['hwfet'] / e['hwfet'] - 1):+.1f} % (EPA).")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=None)
    ap.add_argument("--only", nargs="*", choices=SETS, default=list(SETS))
    ap.add_argument("--workdir", type=Path, default=None)
    a = ap.parse_args()
    data = a.data or Path(os.environ.get("VEHVAL_SHARED_DATA") or REPO.parent / "shared" / "data")
    if not data.is_dir():
        print(f"skipped: no shared data at {data} (give --data or VEHVAL_SHARED_DATA)")
        return 0
    with tempfile.TemporaryDirectory() as tmp:
        work = a.workdir or Path(tmp)
        work.mkdir(parents=True, exist_ok=True)
        for name in a.only:
            globals()[name](data, work)
    return 0


if __name__ == "__main__":
    sys.exit(main())
