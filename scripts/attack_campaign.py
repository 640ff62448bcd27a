"""Attack campaign: hostile inputs through the vehval CLI, tallied like a penetration test.

    python scripts/attack_campaign.py [--json OUT.json]

Every case builds its input in a temporary folder, runs ``vehval.cli.main`` in this process
(SIGALRM turns a run longer than HANG_S into a hang; the address space is limited to
LIMIT_GB so a runaway allocation fails instead of swapping) and is classified:

* ``clean error``: exit 2 (or 1 where the command reports failed tests) with one
  ``vehval: error:`` line and nothing written where the case forbids it;
* ``handled``: exit 0 and the expected finding or refusal is in the output (a stray
  timestamp dropped with a warning, an impossible channel flagged and not selected...);
* ``internal error``: exit 3 or an exception out of ``main``;
* ``hang``: no answer within HANG_S;
* ``silently wrong``: exit 0 without the expected finding, or a forbidden file written.

The cases: every command of the README given a directory, a PDF, PNG, XLSX or ZIP, or an
unreadable file where a data file is expected; hostile option values; and each attack of
the hardening issue (impossible data, resources, paths, YAML, expressions). The totals are
in docs/robustness.md.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import resource
import signal
import sys
import tempfile
import zipfile
from collections import Counter
from pathlib import Path
from typing import Callable

import numpy as np

HANG_S = 60
LIMIT_GB = 3

TEMPLATE = """\
template_version: 1
vehicle: prius_2004
files:
  - source: dyno
    match: "*_d3.txt"
    time: {column: Time, unit: s}
    channels:
      Dyno_Speed: {name: veh_spd_test, unit: mph}
      Engine_Speed: {name: eng_spd_out_test, unit: rpm}
      Batt_Volt: {name: ess_volt_test, unit: V}
      Cell_Temp: {name: amb_temp_test, unit: degC}
"""


def write_d3(path: Path, n: int = 600, dt: float = 0.1, last_t: float | None = None,
             volt: float | None = None, temp: float | None = None) -> Path:
    """A small D3-style test: time [s], speed [mph], engine speed [rpm], voltage, temperature."""
    path.parent.mkdir(parents=True, exist_ok=True)
    t = np.arange(n) * dt
    if last_t is not None:
        t[-1] = last_t
    v = 20 + 10 * np.sin(t / 10)
    e = 1200 + 300 * np.sin(t / 7)
    u = np.full(n, volt) if volt is not None else 201 + np.sin(t)
    c = np.full(n, temp) if temp is not None else 22 + 0.01 * t
    rows = ["Time[s]\tDyno_Speed[mph]\tEngine_Speed[rpm]\tBatt_Volt[V]\tCell_Temp[C]"]
    rows += [f"{a:.9g}\t{b:.4f}\t{d:.2f}\t{x:.3f}\t{y:.3f}" for a, b, d, x, y in zip(t, v, e, u, c)]
    path.write_text("\n".join(rows) + "\n")
    return path


class Hang(Exception):
    pass


def _alarm(signum, frame):
    raise Hang


def run(args: list) -> tuple[int | str, str]:
    """``(exit code or 'internal'/'hang', stdout + stderr)`` of one in-process CLI run."""
    from vehval.cli import main

    out, err = io.StringIO(), io.StringIO()
    signal.signal(signal.SIGALRM, _alarm)
    signal.alarm(HANG_S)
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            code: int | str = main([str(a) for a in args])
    except Hang:
        code = "hang"
    except BaseException as exc:  # noqa: BLE001 - anything out of main is an internal error
        code = "internal"
        err.write(f"{type(exc).__name__}: {exc}")
    finally:
        signal.alarm(0)
    return code, out.getvalue() + err.getvalue()


def classify(code, text: str, *, expect: str = "error", must: str = "",
             forbidden: Callable[[], bool] = lambda: False) -> str:
    """Outcome of one case; ``expect`` is ``error`` (a refusal) or ``ok`` (handled with
    ``must`` in the output)."""
    if code == "hang":
        return "hang"
    if code == "internal" or code == 3 or "Traceback" in text or "internal error" in text:
        return "internal error"
    if forbidden():
        return "silently wrong"
    said_error = "error" in text.lower() or "failed" in text.lower()
    if expect == "error":
        if code in (1, 2) and said_error:
            return "clean error"
        return "silently wrong"
    if code == 0 and (not must or must in text):
        return "handled"
    if code in (1, 2) and said_error:
        return "clean error"
    return "silently wrong"


def non_data(kind: str, path: Path) -> Path:
    if kind == "pdf":
        path.write_bytes(b"%PDF-1.4\n1 0 obj<<>>endobj\n")
    elif kind == "png":
        path.write_bytes(b"\x89PNG\r\n\x1a\n" + b"\0" * 64)
    else:
        with zipfile.ZipFile(path, "w") as z:
            z.writestr("[Content_Types].xml", "<Types/>")
    return path


COMMANDS = {
    "info": lambda f, t, o: ["info", f],
    "template init": lambda f, t, o: ["template", "init", f, "-o", o / "new.yaml"],
    "template check": lambda f, t, o: ["template", "check", t, f],
    "import": lambda f, t, o: ["import", f, "-t", t, "-o", o / "x.parquet"],
    "qa": lambda f, t, o: ["qa", f, "-t", t, "-o", o / "qa"],
    "results": lambda f, t, o: ["results", f, "-t", t, "-o", o / "res"],
    "analyze": lambda f, t, o: ["analyze", f, "-t", t, "-o", o / "an"],
    "validate": lambda f, t, o: ["validate", f, "-t", t, "-o", o / "val"],
    "calibrate": lambda f, t, o: ["calibrate", f, "-t", t, "-o", o / "cal", "--maxiter", "1"],
    "identify": lambda f, t, o: ["identify", f, "-t", t, "--architecture", "conventional",
                                 "-o", o / "veh.yaml"],
    "report": lambda f, t, o: ["report", f, "-o", o / "rep.html"],
    "epa list": lambda f, t, o: ["epa", "list", f],
    "epa tests": lambda f, t, o: ["epa", "tests", f, "--make", "Toyota"],
}

HOSTILE = ["", "..", "../../etc/passwd", "/dev/zero", "udds\x00", "a" * 5000,
           "'; DROP TABLE runs;--", "<a href='http://203.0.113.7'>x</a>", "nan", "-1e309",
           "steady:1e9kph:1e9s", "é漢字"]


def _figures(html: Path) -> list[str]:
    """The JSON of every figure embedded in a report."""
    import re

    return re.findall(r'<script type="application/json" id="fig-[^"]*">(.*?)</script>',
                      html.read_text(encoding="utf-8"), flags=re.S)


def cases(root: Path):  # noqa: PLR0915 - the list of cases, one statement each
    from vehval.io.template import CYCLE_NAME

    """Yield ``(group, name, args, classify-kwargs)`` for every case."""
    d = root / "base"
    f = write_d3(d / "in" / "run1_d3.txt")
    t = d / "T.yaml"
    t.write_text(TEMPLATE)
    # 1. every command x a wrong kind of input
    for cmd, build in COMMANDS.items():
        for bad in ("directory", "pdf", "png", "xlsx", "zip", "missing"):
            c = root / "paths" / f"{cmd.replace(' ', '_')}_{bad}"
            (c / "out").mkdir(parents=True)
            if bad == "directory":
                x = c / "adir_d3.txt"
                x.mkdir()
            elif bad == "missing":
                x = c / "nothing_d3.txt"
            else:
                x = non_data(bad, c / "doc_d3.txt")
            yield "wrong input", f"{cmd} / {bad}", build(x, t, c / "out"), {}
    # 2. hostile option values
    for i, v in enumerate(HOSTILE):
        o = root / "opts" / str(i)
        yield "option values", f"simulate --cycle {v[:20]!r}", ["simulate", "--cycle", v,
                                                               "--json"], {}
        yield "option values", f"simulate --dt {v[:20]!r}", ["simulate", "--cycle", "udds",
                                                            "--dt", v], {}
        yield "option values", f"vehicle show {v[:20]!r}", ["vehicle", "show", v], {}
        # a valid cycle name is a label recorded in the catalog: accepted
        label = {"expect": "ok", "must": "1 ok"} if CYCLE_NAME.fullmatch(v) else {}
        yield "option values", f"batch --cycle {v[:20]!r}", [
            "batch", d / "in", "-t", t, "-o", o / "b", "-j", "0", "--cycle", v, "-q"], label
        yield "option values", f"qa --max-offset {v[:20]!r}", [
            "qa", f, "-t", t, "-o", o / "qa", "--max-offset", v], {}
    # 3. the attacks of the hardening issue
    a = root / "attacks"
    s = write_d3(a / "volt" / "v_d3.txt", volt=99999.0, temp=-9999.0)
    yield "impossible data", "battery 99999 V and ambient -9999 C stuck", [
        "qa", s, "-t", t, "-o", a / "volt" / "qa", "--json"], {
        "expect": "ok", "must": "outside the plausible range"}
    s = write_d3(a / "big" / "wide_d3.txt", n=2)
    s.write_text("Time[s]\t" + "\t".join(f"C{i}[V]" for i in range(10**6)) + "\n0\t"
                 + "\t".join("1" for _ in range(10**6)) + "\n")
    yield "resources", "10^6 columns", ["qa", s, "-t", t, "-o", a / "big" / "qa"], {}
    s = write_d3(a / "stray" / "s_d3.txt", last_t=1e9)
    yield "resources", "one timestamp at 1e9 s", ["qa", s, "-t", t, "-o", a / "stray" / "qa"], {
        "expect": "ok"}
    s = write_d3(a / "ns" / "n_d3.txt", n=50, dt=1e-9)
    yield "resources", "1 ns time step", ["qa", s, "-t", t, "-o", a / "ns" / "qa"], {}
    big = a / "desc" / "T.yaml"
    big.parent.mkdir(parents=True)
    big.write_text(TEMPLATE.replace("vehicle:", f"description: {'x' * 60_000_000}\nvehicle:"))
    yield "resources", "60 MB description", ["qa", f, "-t", big, "-o", a / "desc" / "qa"], {}
    yield "paths", "import -o its own input", ["import", f, "-t", t, "-o", f], {}
    q = a / "final" / "qa"
    q.mkdir(parents=True)
    (q / "template_final.yaml").write_text(TEMPLATE)
    yield "paths", "qa -t OUT/template_final.yaml", [
        "qa", f, "-t", q / "template_final.yaml", "-o", q], {}
    dup = a / "dup" / "T.yaml"
    dup.parent.mkdir(parents=True)
    dup.write_text(TEMPLATE + "      Dyno_Speed: {name: veh_spd_test, unit: km/h}\n")
    yield "silent", "duplicate YAML key", ["import", f, "-t", dup, "-o", a / "dup" / "x.parquet"], {}
    inf = a / "inf" / "T.yaml"
    inf.parent.mkdir(parents=True)
    inf.write_text(TEMPLATE.replace("unit: rpm}", "unit: rpm, scale: .inf}"))
    yield "silent", "template scale .inf", ["import", f, "-t", inf, "-o", a / "inf" / "x.parquet"], {}
    yield "silent", "vehicle mass 1e308", ["simulate", "--cycle", "udds", "--set",
                                           "body.mass_kg=1e308", "--json"], {}
    deep = a / "deep" / "T.yaml"
    deep.parent.mkdir(parents=True)
    deep.write_text("a: " + "[" * 20000 + "]" * 20000 + "\n")
    yield "internal", "20k-deep YAML", ["import", f, "-t", deep, "-o", a / "deep" / "x.parquet"], {}
    dj = a / "deepjson" / "validation.json"
    dj.parent.mkdir(parents=True)
    dj.write_text("[" * 20000 + "]" * 20000)
    yield "internal", "20k-deep JSON", ["report", d / "in", "--validation", dj, "-o",
                                        a / "deepjson" / "r.html"], {}
    cyc = a / "cycle" / "long.csv"
    cyc.parent.mkdir(parents=True)
    cyc.write_text("time_s,speed_mps\n0,0\n1e9,10\n")
    yield "resources", "cycle spanning 1e9 s", ["simulate", "--cycle", cyc, "--json"], {}
    hv = a / "hostile" / "validation.json"
    hv.parent.mkdir(parents=True)
    url = "http://203.0.113.7/x"
    hv.write_text(json.dumps({"tables": [], "figures": [{"title": f"<a href='{url}'>t</a>",
        "figure": {"data": [{"type": "scattergeo"}, {"type": "scatter", "y": [1, 2]}],
                   "layout": {"images": [{"source": f"{url}.png"}],
                              "annotations": [{"text": f"<a href='{url}'>a</a>"}]}}}]}))
    rep = a / "hostile" / "r.html"
    run(["qa", f, "-t", t, "-o", a / "hostile" / "qa"])  # the report's QA input
    yield "report", "hostile validation.json (external image, link, CDN geo trace)", [
        "report", a / "hostile" / "qa", "--validation", hv, "-o", rep], {
        "expect": "ok", "forbidden": lambda: not rep.is_file() or not _figures(rep) or any(
            x in fig for fig in _figures(rep) for x in (url, "scattergeo", "href"))}
    m = a / "missing"
    write_d3(m / "t1" / "run_d3.txt")
    two = m.parent / "T2.yaml"
    two.write_text(TEMPLATE + "  - source: obd\n    match: '*_obd.csv'\n"
                   "    time: {column: Time, unit: s}\n    channels:\n"
                   "      Speed: {name: veh_spd_obd_test, unit: km/h}\n")
    yield "batch", "test folder missing one of the template's files", [
        "batch", m, "-t", two, "-o", a / "missing_out", "-j", "0", "-q", "--no-report"], {}
    b = a / "batch"
    write_d3(b / "t1" / "run_d3.txt")
    yield "paths", "batch OUTDIR inside its input (twice)", [
        "batch", b, "-t", t, "-o", b / "out", "-j", "0", "-q", "--no-report"], {
        "expect": "ok", "must": "1 ok"}
    yield "paths", "batch OUTDIR inside its input (rerun)", [
        "batch", b, "-t", t, "-o", b / "out", "-j", "0", "-q", "--no-report"], {
        "expect": "ok", "must": "0 failed"}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", type=Path, help="write every case and its outcome here")
    opts = ap.parse_args()
    lim = LIMIT_GB * 1024**3
    resource.setrlimit(resource.RLIMIT_AS, (lim, lim))
    rows = []
    with tempfile.TemporaryDirectory(prefix="vehval-attack-") as tmp:
        for group, name, args, kw in cases(Path(tmp)):
            code, text = run(args)
            outcome = classify(code, text, **kw)
            rows.append({"group": group, "case": name, "exit": code, "outcome": outcome,
                         "message": text.strip().splitlines()[-1][:200] if text.strip() else ""})
            if outcome not in ("clean error", "handled"):
                print(f"{outcome:15s} {group}: {name}: {rows[-1]['message']}", file=sys.stderr)
    kinds = ["clean error", "handled", "internal error", "hang", "silently wrong"]
    print(f"\n| group | tried | {' | '.join(kinds)} |\n|---|---|" + "---|" * len(kinds))
    for g in dict.fromkeys(r["group"] for r in rows):
        c = Counter(r["outcome"] for r in rows if r["group"] == g)
        print(f"| {g} | {sum(c.values())} | " + " | ".join(str(c[k]) for k in kinds) + " |")
    c = Counter(r["outcome"] for r in rows)
    print(f"| **total** | **{len(rows)}** | " + " | ".join(f"**{c[k]}**" for k in kinds) + " |")
    if opts.json:
        opts.json.write_text(json.dumps(rows, indent=1, default=str))
    return 0 if c["internal error"] + c["hang"] + c["silently wrong"] == 0 else 1


if __name__ == "__main__":
    os.environ.pop("VEHVAL_DEBUG", None)
    sys.exit(main())
