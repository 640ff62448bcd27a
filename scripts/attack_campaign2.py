"""Attack campaign II: hostile inputs by class, each case a real ``python -m vehval`` process.

    python scripts/attack_campaign2.py [--json OUT.json] [--jobs 2] [--class NAME ...]

A generator per class builds its cases (several variants each, seeded) in a temporary
folder; every case runs as a subprocess with a 60 s timeout (its process group is killed
then) and a 4 GiB address-space limit (1-2 GB in the memory class), and is classified with
the outcomes of ``scripts/attack_campaign.py`` plus ``breach``:

* ``breach``: the case's breach check holds (an outside file's content in the output or an
  outside file written; unescaped markup in a generated page; a report whose CSP allows
  ``'unsafe-inline'`` or ``'unsafe-eval'`` scripts);
* ``hang``: no answer within 60 s;
* ``internal error``: exit 3, killed by a signal, or ``Traceback`` / ``Exception ignored``
  / ``internal error`` in the output;
* ``clean error``: exit 2 (or 1 where the command reports failed tests) with an error line
  (and, where the case asks, the refusal names what it must, e.g. the memory needed);
* ``handled``: exit 0 with the expected finding or output;
* ``silently wrong``: exit 0 without the expected finding or refusal, or a refusal that does
  not say what it must.

The totals by class are in docs/robustness.md ("Campaign II").
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import re
import resource
import signal
import struct
import subprocess
import sys
import tempfile
from collections import Counter
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterator

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from attack_campaign import TEMPLATE, classify, write_d3  # noqa: E402

HANG_S = 60
#: address-space limit of every case that sets none: a bomb fails instead of taking the machine
LIMIT_AS = 4 * 2**30
KINDS = ["clean error", "handled", "internal error", "hang", "silently wrong", "breach"]
XSS = ("<svg onload=alert('X5S')>", "<script>alert('X5S')</script>",
       "</script><script>alert('X5S')</script>", "<img src=x onerror=alert('X5S')>")
XSS_MARKS = ("<svg onload=alert('x5s')", "<script>alert('x5s')", "<img src=x onerror=alert('x5s')")
SECRET = "SECRET-0UTS1DE-T0KEN"


@dataclass
class Case:
    """One attack: ``args`` of ``vehval``, what a correct answer looks like, checks after."""

    cls: str
    name: str
    args: list
    expect: str = "error"                # 'error' (a refusal) or 'ok' (exit 0 with ``must``)
    must: str = ""                       # text required in the output when exit 0
    refusal_must: str = ""               # text required in a refusal
    breach: Callable[[str], bool] = lambda text: False
    forbidden: Callable[[], bool] = lambda: False
    prepare: Callable[[], None] | None = None
    limit_as: int | None = None          # address-space limit of the process [bytes]
    cwd: Path | None = None
    env: dict = field(default_factory=dict)


# ----------------------------------------------------------------------------------------
# running and classifying


def run_case(case: Case) -> dict:
    """Run one case as ``python -m vehval``; its row with exit code, outcome and message."""
    if case.prepare is not None:
        try:
            case.prepare()
        except Exception as exc:  # noqa: BLE001 - a broken case is reported, not an outcome
            return {"class": case.cls, "case": case.name, "exit": None,
                    "outcome": "not run", "message": f"{type(exc).__name__}: {exc}"[:200]}
    env = {**os.environ, "PYTHONUNBUFFERED": "1", **case.env}
    env.pop("VEHVAL_DEBUG", None)
    lim = case.limit_as or LIMIT_AS

    def pre() -> None:
        if lim:
            resource.setrlimit(resource.RLIMIT_AS, (lim, lim))

    proc = subprocess.Popen([sys.executable, "-m", "vehval", *map(str, case.args)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            stdin=subprocess.DEVNULL, env=env, cwd=case.cwd,
                            start_new_session=True, preexec_fn=pre)
    try:
        out, err = proc.communicate(timeout=HANG_S)
        code: int | str = proc.returncode
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)  # the case's own process group
        out, err = proc.communicate()
        code = "hang"
    text = (out.decode("utf-8", "replace") + err.decode("utf-8", "replace"))
    outcome = classify2(case, code, text, err.decode("utf-8", "replace"))
    msg = text.strip().splitlines()[-1][:200] if text.strip() else ""
    return {"class": case.cls, "case": case.name, "exit": code, "outcome": outcome,
            "message": msg}


def classify2(case: Case, code, text: str, stderr: str) -> str:
    """Outcome of one case (see the module doc); the rest is attack_campaign.classify."""
    if case.breach(text):
        return "breach"
    if code == "hang":
        return "hang"
    if isinstance(code, int) and code < 0 or "Exception ignored" in stderr:
        return "internal error"
    out = classify(code, text, expect=case.expect, must=case.must, forbidden=case.forbidden)
    if out == "clean error" and case.refusal_must and case.refusal_must not in text:
        return "silently wrong"
    return out


def _html_breach(paths: list[Path]) -> Callable[[str], bool]:
    """Breach: a payload raw in a page, or a CSP allowing inline or eval'd scripts."""
    def check(text: str) -> bool:
        for p in paths:
            for f in ([p] if p.is_file() else sorted(p.rglob("*.html")) if p.is_dir() else []):
                html = f.read_text(encoding="utf-8", errors="replace")
                low = html.lower()
                if any(m in low for m in XSS_MARKS):
                    return True
                for csp in re.findall(r'content-security-policy"\s+content="([^"]*)"', low):
                    dirs = {d.split()[0]: d for d in csp.split(";") if d.split()}
                    script = dirs.get("script-src", dirs.get("default-src", ""))
                    if "'unsafe-inline'" in script or "'unsafe-eval'" in script:
                        return True
        return False
    return check


# ----------------------------------------------------------------------------------------
# inputs

EPA_HEADER = [
    "Model Year", "Vehicle Manufacturer Name", "Represented Test Veh Make",
    "Represented Test Veh Model", "Test Vehicle ID", "Test Veh Configuration #",
    "Test Veh Displacement (L)", "Rated Horsepower", "Equivalent Test Weight (lbs.)",
    "Axle Ratio", "N/V Ratio", "Test Number", "Test Originator", "Test Procedure Cd",
    "Test Procedure Description", "Test Fuel Type Cd", "Test Fuel Type Description",
    "CO2 (g/mi)", "RND_ADJ_FE", "FE_UNIT", "FE Bag 1", "FE Bag 2", "FE Bag 3", "FE Bag 4",
    "Target Coef A (lbf)", "Target Coef B (lbf/mph)", "Target Coef C (lbf/mph**2)",
    "Set Coef A (lbf)", "Set Coef B (lbf/mph)", "Set Coef C (lbf/mph**2)",
]
EPA_TEXT_COLUMNS = ["Vehicle Manufacturer Name", "Represented Test Veh Make",
                    "Represented Test Veh Model", "Test Vehicle ID", "Test Veh Configuration #",
                    "Test Number", "Test Originator", "Test Procedure Description",
                    "Test Fuel Type Description", "FE_UNIT"]


def epa_row(**over) -> dict:
    """A 2016 Prius HWFET row of an EPA Test Car List."""
    vals = ["2016", "Toyota", "TOYOTA", "PRIUS", "16-ZV1H", "2", "1.798", "96", "3375", "2.83",
            "20.0", "T1", "EPA", "3", "HWFE", "61", "Tier 2 Cert Gasoline", "125.4", "71.2",
            "MPG", "", "", "", "", "18.272", "0.29545", "0.013793", "5.829", "0.1", "0.01"]
    row = dict(zip(EPA_HEADER, vals))
    row.update(over)
    return row


def write_epa(path: Path, rows: list[dict], raw_tail: str = "") -> Path:
    """An EPA list (latin-1 is not needed for the payloads: UTF-8 ASCII), CR LF lines."""
    path.parent.mkdir(parents=True, exist_ok=True)
    lines = [",".join(EPA_HEADER)]
    for r in rows:
        cells = []
        for h in EPA_HEADER:
            v = str(r.get(h, ""))
            cells.append('"' + v.replace('"', '""') + '"' if ("," in v or '"' in v) else v)
        lines.append(",".join(cells))
    path.write_bytes(("\r\n".join(lines) + "\r\n" + raw_tail).encode("utf-8"))
    return path


def base_test(root: Path) -> tuple[Path, Path]:
    """A small valid D3 test and its template (made once per folder)."""
    d = root / "base"
    f, t = d / "in" / "run1_d3.txt", d / "T.yaml"
    if not f.is_file():
        write_d3(f)
        t.write_text(TEMPLATE)
    return f, t


def _text(path: Path, body: str) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(body, encoding="utf-8")
    return path


def _secret_in(text: str) -> bool:
    return SECRET in text


def _laughs(levels: int, width: int = 10, indent: str = "") -> str:
    """YAML anchors ``l0..l{levels}``, each a list of ``width`` aliases of the previous."""
    lines = [f"{indent}l0: &l0 [{', '.join(['lol'] * width)}]"]
    for k in range(1, levels + 1):
        lines.append(f"{indent}l{k}: &l{k} [{', '.join([f'*l{k - 1}'] * width)}]")
    return "\n".join(lines) + "\n"


# ----------------------------------------------------------------------------------------
# the classes


def report_xss(root: Path, rng: np.random.Generator) -> Iterator[Case]:
    """Hostile text in every text column of an EPA list and in template/vehicle/report text."""
    for i, col in enumerate(EPA_TEXT_COLUMNS):
        for j in (0, 1):
            pay = XSS[(2 * i + j) % len(XSS)]
            value = {"Represented Test Veh Model": f"PRIUS {pay}"}.get(col, f"x{pay}")
            d = root / "xss" / f"epa{i}_{j}"
            lst = d / "list.csv"
            out = d / "out"
            yield Case("report XSS", f"EPA list {col!r} = {pay[:24]}",
                       ["epa", "validate", lst, "--vehicle", "prius_2016", "--tests",
                        "model=PRIUS", "--dt", "1", "-o", out], expect="ok",
                       breach=_html_breach([out]),
                       prepare=lambda lst=lst, col=col, value=value: write_epa(
                           lst, [epa_row(**{col: value})]))
    f, t = base_test(root)
    for k, pay in enumerate(XSS[:3]):
        d = root / "xss" / f"tpl{k}"
        variants = {
            "template description": TEMPLATE.replace("vehicle:", f"description: \"{pay}\"\nvehicle:"),
            "channel reason": TEMPLATE.replace("unit: rpm}", f"unit: rpm, reason: \"{pay}\"}}"),
            "drop reason": TEMPLATE + f"selection:\n  drop: {{eng_spd_out_test: \"{pay}\"}}\n",
        }
        for what, body in variants.items():
            tp = d / f"{what.replace(' ', '_')}.yaml"
            out = d / what.replace(" ", "_")
            yield Case("report XSS", f"{what} = {pay[:24]}",
                       ["qa", f, "-t", tp, "-o", out, "--report"], expect="ok",
                       breach=_html_breach([out]),
                       prepare=lambda tp=tp, body=body: _text(tp, body))
    # a raw channel name in the data file (kept as an unmapped channel)
    for k, pay in enumerate(XSS[:2]):
        d = root / "xss" / f"raw{k}"
        data = d / "in" / "r_d3.txt"
        out = d / "out"

        def mk(data=data, pay=pay):
            write_d3(data)
            lines = data.read_text().splitlines()
            lines[0] += f"\t{pay}[V]"
            data.write_text("\n".join([lines[0]] + [x + "\t1.0" for x in lines[1:]]) + "\n")
        yield Case("report XSS", f"raw channel name {pay[:24]}",
                   ["qa", data, "-t", t, "-o", out, "--report"], expect="ok",
                   breach=_html_breach([out]), prepare=mk)
    # report title and a hostile vehicle name
    qa_dir = root / "xss" / "qa_base"
    for k, pay in enumerate(XSS[:2]):
        out = root / "xss" / f"title{k}.html"

        def mkqa(qa_dir=qa_dir):
            if not (qa_dir / "findings.json").is_file():
                subprocess.run([sys.executable, "-m", "vehval", "qa", f, "-t", t, "-o", qa_dir],
                               capture_output=True, timeout=300)
        yield Case("report XSS", f"report --title {pay[:24]}",
                   ["report", qa_dir, "--title", pay, "-o", out], expect="ok",
                   breach=_html_breach([out]), prepare=mkqa)
    src = Path(__file__).resolve().parents[1] / "src" / "vehval" / "data" / "vehicles"
    for k, pay in enumerate(XSS[:2]):
        d = root / "xss" / f"veh{k}"
        vy = d / "hostile.yaml"
        out = d / "sens"

        def mkv(vy=vy, pay=pay):
            body = (src / "prius_2004.yaml").read_text(encoding="utf-8")
            body = re.sub(r"(?m)^name:.*$", f"name: \"{pay}\"", body, count=1)
            _text(vy, body)
        yield Case("report XSS", f"vehicle name {pay[:24]} (sensitivity page)",
                   ["sensitivity", "--vehicle", vy, "--cycles", "udds", "--params",
                    "body.mass_kg", "-o", out], expect="ok", breach=_html_breach([out]),
                   prepare=mkv)


def catalog(root: Path, rng: np.random.Generator) -> Iterator[Case]:
    """Catalog queries reading or writing outside files, extensions, hostile views, huge work."""
    d = root / "catalog"
    outside = d / "outside"
    secret = outside / "secret.txt"
    db = d / "cat" / "catalog.duckdb"

    def mk():
        if db.is_file():
            return
        _text(secret, f"{SECRET}\n")
        _text(outside / "secret.csv", f"a\n{SECRET}\n")
        _text(outside / "secret.json", json.dumps({"a": SECRET}))
        from vehval.catalog import open_catalog

        with open_catalog(db):
            pass

    forms = {"absolute": str(secret), "relative": "../outside/secret.txt",
             "file URL": f"file://{secret}", "glob": str(outside / "secr*.txt")}
    readers = ["read_csv('{p}')", "read_csv_auto('{p}')", "read_text('{p}')",
               "read_blob('{p}')"]
    for rd in readers:
        for form, p in forms.items():
            sql = f"SELECT * FROM {rd.format(p=p)}"
            yield Case("catalog", f"{rd.split('(')[0]} of an outside file ({form})",
                       ["catalog", "query", sql, "--db", db], breach=_secret_in,
                       prepare=mk, cwd=d / "cat")
    yield Case("catalog", "glob() of an outside folder", [
        "catalog", "query", f"SELECT * FROM glob('{outside}/*')", "--db", db],
        breach=lambda text: "secret.txt" in text, prepare=mk)
    for k, stmt in enumerate(["COPY (SELECT 42) TO '{o}'", "COPY runs TO '{o}' (FORMAT csv)",
                              "EXPORT DATABASE '{o}'",
                              "COPY (SELECT 1) TO '{o}' (FORMAT parquet)"]):
        o = outside / f"written{k}"
        yield Case("catalog", stmt.split(" TO")[0].split(" '")[0][:30] + " to an outside path",
                   ["catalog", "query", stmt.format(o=o), "--db", db],
                   breach=lambda text, o=o: o.exists(), prepare=mk)
    for stmt in [f"ATTACH '{outside / 'other.duckdb'}' AS x", "ATTACH ':memory:' AS m",
                 "INSTALL httpfs", "LOAD httpfs", "SET enable_external_access = true",
                 f"SET allowed_directories = ['{outside}']", "SET lock_configuration = false",
                 "CREATE TABLE t AS SELECT 1", "PRAGMA enable_profiling"]:
        yield Case("catalog", stmt[:40], ["catalog", "query", stmt, "--db", db],
                   breach=lambda text: (outside / "other.duckdb").exists(), prepare=mk)
    yield Case("catalog", "now()", ["catalog", "query", "SELECT now()", "--db", db],
               expect="ok", prepare=mk)
    # bounded by --limit, the truncation said on stderr
    yield Case("catalog", "range(1e9) rows", ["catalog", "query",
               "SELECT * FROM range(1000000000)", "--db", db], expect="ok",
               must="showing the first", prepare=mk)
    yield Case("catalog", "10^12-row join", ["catalog", "query",
               "SELECT count(*) FROM range(1000000) a, range(1000000) b", "--db", db],
               prepare=mk)
    # a received catalog whose view reads an outside file
    for k, body in enumerate([f"SELECT * FROM read_text('{secret}')",
                              f"SELECT * FROM read_csv_auto('{outside / 'secret.csv'}')",
                              "SELECT * FROM range(1000000) a, range(1000000) b"]):
        hdb = d / f"received{k}" / "catalog.duckdb"

        def mkh(hdb=hdb, body=body):
            mk()
            if hdb.is_file():
                return
            import shutil

            import duckdb

            hdb.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy(db, hdb)
            con = duckdb.connect(str(hdb))
            con.execute(f"CREATE OR REPLACE VIEW latest_tests AS {body}")
            con.close()
        for cmd in (["catalog", "query", "SELECT * FROM latest_tests"], ["catalog", "summary"]):
            yield Case("catalog", f"received catalog, hostile view {k} ({cmd[1]})",
                       [*cmd, "--db", hdb], breach=_secret_in, prepare=mkh)


def bombs(root: Path, rng: np.random.Generator) -> Iterator[Case]:
    """YAML alias bombs, Parquet decompression bombs, a huge EPA list, hostile Parquet metadata."""
    d = root / "bombs"
    f, t = base_test(root)
    src = Path(__file__).resolve().parents[1] / "src" / "vehval" / "data" / "vehicles"
    for levels in (6, 8, 9):
        vy = d / f"veh{levels}.yaml"
        yield Case("bombs", f"vehicle YAML, 10^{levels} aliases",
                   ["simulate", "--vehicle", vy, "--dt", "1"],
                   prepare=lambda vy=vy, n=levels: _text(vy, (src / "prius_2004.yaml").read_text(
                       encoding="utf-8") + "bomb:\n" + _laughs(n, indent="  ")))
        ty = d / f"tpl{levels}.yaml"
        yield Case("bombs", f"template YAML, 10^{levels} aliases",
                   ["import", f, "-t", ty, "-o", d / f"x{levels}.parquet"],
                   prepare=lambda ty=ty, n=levels: _text(ty, _laughs(n) + TEMPLATE))
        fy = d / f"faults{levels}.yaml"
        yield Case("bombs", f"fault spec YAML, 10^{levels} aliases",
                   ["synth", "--cycle", "steady:30kph:20s", "--faults", fy, "-o",
                    d / f"synth{levels}"],
                   prepare=lambda fy=fy, n=levels: _text(fy, _laughs(n)))
        flow = " ".join(_laughs(levels).replace("\n", ", ").rstrip(", ").split())
        yield Case("bombs", f"--set value, 10^{levels} aliases",
                   ["simulate", "--dt", "1", "--set", f"controller.soc_target={{{flow}}}"])
    mk = d / "merge.yaml"
    yield Case("bombs", "template YAML, merge-key bomb",
               ["import", f, "-t", mk, "-o", d / "m.parquet"],
               prepare=lambda: _text(mk, _laughs(7) + "files:\n  - <<: {a: *l7}\n"
                                     + TEMPLATE.split("files:\n", 1)[1]))
    # Parquet decompression bombs: zeros, no dictionary, zstd
    for groups, rows in ((40, 10_000_000), (100, 10_000_000)):
        pb = d / f"bomb{groups}.parquet"

        def mkp(pb=pb, groups=groups, rows=rows):
            if pb.is_file():
                return
            import pyarrow as pa
            import pyarrow.parquet as pq

            tab = pa.table({"time": pa.array(np.zeros(rows)), "speed": pa.array(np.zeros(rows))})
            with pq.ParquetWriter(pb, tab.schema, compression="zstd", use_dictionary=False) as w:
                for _ in range(groups):
                    w.write_table(tab, row_group_size=rows)
        gb = groups * rows * 16 / 1e9
        yield Case("bombs", f"Parquet bomb {gb:.0f} GB (info)", ["info", pb], prepare=mkp)
        tp = d / "pq.yaml"
        yield Case("bombs", f"Parquet bomb {gb:.0f} GB (import)",
                   ["import", pb, "-t", tp, "-o", d / f"pb{groups}.parquet"],
                   prepare=lambda mkp=mkp, tp=tp: (mkp(), _text(tp, (
                       "files:\n  - source: dyno\n    format: parquet\n    time: {column: time}\n"
                       "    channels:\n      speed: {name: veh_spd_test, unit: m/s}\n"))))
    # sparse huge files: size budgets of the readers
    for kind, head in (("EPA list", ",".join(EPA_HEADER) + "\r\n"),
                       ("D3 text", "Time[s]\tDyno_Speed[mph]\n"), ("CSV", "time,speed\n")):
        p = d / f"huge_{kind.split()[0]}.{'csv' if kind != 'D3 text' else 'txt'}"

        def mks(p=p, head=head):
            p.parent.mkdir(parents=True, exist_ok=True)
            with open(p, "wb") as fh:
                fh.write(head.encode())
                fh.truncate(10 * 2**30)  # sparse: 10 GiB of NUL
        args = (["epa", "list", p] if kind == "EPA list" else ["info", p])
        yield Case("bombs", f"10 GiB {kind} (sparse)", args, prepare=mks)
    big = d / "big_list.csv"

    def mkbig():
        if not big.is_file():
            row = ",".join(epa_row().values()) + "\r\n"
            with open(big, "w", encoding="utf-8") as fh:
                fh.write(",".join(EPA_HEADER) + "\r\n")
                fh.write(row * 1_500_000)  # ~ 200 MB
    yield Case("bombs", "200 MB EPA list", ["epa", "list", big], prepare=mkbig)
    # hostile vehval metadata in a test Parquet
    good = d / "good.parquet"

    def mkgood():
        if not good.is_file():
            subprocess.run([sys.executable, "-m", "vehval", "import", f, "-t", t, "-o", good],
                           capture_output=True, timeout=300)

    def meta_variant(p: Path, edit: Callable[[dict], object]) -> Callable[[], None]:
        def mkm():
            mkgood()
            import pyarrow.parquet as pq

            tab = pq.read_table(good)
            meta = json.loads(tab.schema.metadata[b"vehval"])
            new = edit(meta)
            raw = new if isinstance(new, bytes) else json.dumps(new).encode()
            pq.write_table(tab.replace_schema_metadata({b"vehval": raw}), p)
        return mkm

    variants = {
        "metadata is a list": lambda m: [m],
        "metadata is a number": lambda m: 5,
        "groups is text": lambda m: {**m, "groups": "x"},
        "group n = 10^18": lambda m: {**m, "groups": {k: {**g, "n": 10**18}
                                                      for k, g in m["groups"].items()}},
        "group n = -1": lambda m: {**m, "groups": {k: {**g, "n": -1}
                                                   for k, g in m["groups"].items()}},
        "signals are numbers": lambda m: {**m, "groups": {k: {**g, "signals": [1, 2]}
                                                          for k, g in m["groups"].items()}},
        "meta is text": lambda m: {**m, "meta": "x"},
        "meta fields of wrong type": lambda m: {**m, "meta": {k: [1, {"a": None}]
                                                              for k in m["meta"]}},
        "100k-deep JSON": lambda m: b"[" * 100_000 + b"]" * 100_000,
        "invalid UTF-8": lambda m: b"\xff\xfe{" * 10,
    }
    for k, (what, edit) in enumerate(variants.items()):
        p = d / f"meta{k}.parquet"
        cmd = ["info", p] if k % 2 == 0 else ["report", p, "-o", d / f"meta{k}.html"]
        yield Case("bombs", f"test Parquet: {what} ({cmd[0]})", cmd, expect="ok",
                   prepare=meta_variant(p, edit))
    # deeply nested Parquet columns
    for depth in (64, 512):
        p = d / f"nested{depth}.parquet"

        def mkn(p=p, depth=depth):
            import pyarrow as pa
            import pyarrow.parquet as pq

            arr = pa.array([1.0, 2.0])
            for _ in range(depth):
                arr = pa.StructArray.from_arrays([arr], names=["x"])
            try:
                pq.write_table(pa.table({"time": [0.0, 1.0], "deep": arr}), p)
            except Exception:  # noqa: BLE001 - pyarrow refuses the depth: a garbage file then
                p.write_bytes(b"PAR1" + b"\0" * 64 + b"PAR1")
        yield Case("bombs", f"Parquet column nested {depth} deep", ["info", p], expect="ok",
                   prepare=mkn)


def _mdf_base(path: Path) -> bytes:
    if not path.is_file():
        from asammdf import MDF
        from asammdf import Signal as MSig

        t = np.arange(200) * 0.1
        mdf = MDF(version="4.10")
        mdf.append([MSig(samples=20 + 5 * np.sin(t), timestamps=t, name="Dyno_Speed", unit="mph"),
                    MSig(samples=1500 + 0 * t, timestamps=t, name="Engine_Speed", unit="rpm")])
        mdf.append([MSig(samples=60 + 0 * t[::10], timestamps=t[::10], name="SOC", unit="%")])
        path.parent.mkdir(parents=True, exist_ok=True)
        mdf.save(path, overwrite=True)
        mdf.close()
    return path.read_bytes()


def _link(data: bytes, block: int, k: int) -> tuple[int, int]:
    """``(file offset of link k of the block at ``block``, its value)``."""
    off = block + 24 + 8 * k
    return off, struct.unpack_from("<Q", data, off)[0]


def mdf4(root: Path, rng: np.random.Generator) -> Iterator[Case]:
    """MDF4 link cycles, links past the end, truncated and byte-flipped files."""
    d = root / "mdf4"
    base = d / "base.mf4"
    tp = d / "m.yaml"
    seeds = rng.integers(0, 2**31, size=40)

    def variant(p: Path, edit: Callable[[bytearray], None]) -> Callable[[], None]:
        def mk():
            data = bytearray(_mdf_base(base))
            edit(data)
            p.write_bytes(bytes(data))
            _text(tp, "files:\n  - source: can\n    channels:\n"
                  "      Dyno_Speed: {name: veh_spd_test}\n"
                  "      Engine_Speed: {name: eng_spd_out_test}\n")
        return mk

    def set_link(block_of: Callable[[bytes], int], k: int, target: Callable[[bytes, int], int]):
        def edit(data: bytearray) -> None:
            b = block_of(bytes(data))
            off, _ = _link(bytes(data), b, k)
            struct.pack_into("<Q", data, off, target(bytes(data), b))
        return edit

    hd = lambda data: 64  # noqa: E731 - the header block is at 64
    dg = lambda data: _link(data, 64, 0)[1]  # noqa: E731
    cg = lambda data: _link(data, dg(data), 1)[1]  # noqa: E731
    cn = lambda data: _link(data, cg(data), 1)[1]  # noqa: E731
    links = {
        "header's data group -> header": (hd, 0, lambda data, b: 64),
        "data group next -> itself": (dg, 0, lambda data, b: b),
        "data group next -> header": (dg, 0, lambda data, b: 64),
        "channel group next -> itself": (cg, 0, lambda data, b: b),
        "channel group's channel -> data group": (cg, 1, lambda data, b: dg(data)),
        "channel next -> itself": (cn, 0, lambda data, b: b),
        "data group's data -> header": (dg, 2, lambda data, b: 64),
        "header's data group past EOF": (hd, 0, lambda data, b: len(data) + 4096),
        "header's data group at 2^63": (hd, 0, lambda data, b: 2**63 - 8),
        "data group's channel group past EOF": (dg, 1, lambda data, b: len(data) + 8),
        "channel next past EOF": (cn, 0, lambda data, b: len(data) - 8),
        "data group's data past EOF": (dg, 2, lambda data, b: len(data) * 4),
    }
    for k, (what, (blk, li, tgt)) in enumerate(links.items()):
        p = d / f"link{k}.mf4"
        for cmd in (["info", p], ["import", p, "-t", tp, "-o", d / f"link{k}.parquet"]):
            yield Case("MDF4", f"{what} ({cmd[0]})", cmd, expect="ok",
                       prepare=variant(p, set_link(blk, li, tgt)))
    fractions = (0.0, 0.01, 0.05, 0.1, 0.25, 0.5, 0.75, 0.9, 0.99)
    for k, frac in enumerate(fractions):
        p = d / f"trunc{k}.mf4"

        def cut(data: bytearray, frac=frac) -> None:
            del data[max(int(len(data) * frac), 16):]
        cmd = ["info", p] if k % 2 == 0 else ["import", p, "-t", tp, "-o", d / f"t{k}.parquet"]
        yield Case("MDF4", f"truncated at {frac:.0%} ({cmd[0]})", cmd, expect="ok",
                   prepare=variant(p, cut))
    for k in range(13):
        p = d / f"flip{k}.mf4"
        n_flip = 1 + k % 8

        def flip(data: bytearray, s=int(seeds[k]), n_flip=n_flip) -> None:
            r = np.random.default_rng(s)
            for pos in r.integers(64, len(data), size=n_flip):
                data[pos] ^= int(r.integers(1, 256))
        cmd = ["info", p] if k % 2 == 0 else ["import", p, "-t", tp, "-o", d / f"f{k}.parquet"]
        yield Case("MDF4", f"{n_flip} flipped bytes, seed {int(seeds[k])} ({cmd[0]})", cmd,
                   expect="ok", prepare=variant(p, flip))


def option_bounds(root: Path, rng: np.random.Generator) -> Iterator[Case]:
    """Numeric options outside their range; a legal tiny dt that fits still runs."""
    d = root / "opts"
    f, t = base_test(root)
    lst = d / "list.csv"
    mkl = lambda: write_epa(lst, [epa_row()])  # noqa: E731
    for v in ("1e-6", "1e-9", "0", "-0.1", "nan", "inf", "2"):
        yield Case("option bounds", f"simulate --dt {v}", ["simulate", "--dt", v])
        if v in ("1e-6", "0", "nan", "2"):
            yield Case("option bounds", f"epa validate --dt {v}", [
                "epa", "validate", lst, "--vehicle", "prius_2016", "--tests", "model=PRIUS",
                "--dt", v], prepare=mkl)
    for v in ("1e-5", "0"):
        yield Case("option bounds", f"sensitivity --dt {v}", ["sensitivity", "--dt", v])
        yield Case("option bounds", f"validate --dt {v}", ["validate", f, "-t", t, "--dt", v,
                                                          "-o", d / "val"])
    yield Case("option bounds", "simulate --dt 0.001 (tiny, fits)", [
        "simulate", "--dt", "0.001", "--cycle", "steady:30kph:30s", "--json"],
        expect="ok", must="fuel_mass_kg")
    cyc = d / "long.csv"
    yield Case("option bounds", "simulate a 24 h cycle at dt 0.001 (memory)", [
        "simulate", "--cycle", cyc, "--dt", "0.001"], refusal_must="memory",
        prepare=lambda: _text(cyc, "time_s,speed_mps\n0,0\n86000,10\n"))
    yield Case("option bounds", "simulate --dt 0.001 under a 20 MB cap (memory)", [
        "simulate", "--dt", "0.001"], refusal_must="memory",
        env={"VEHVAL_MEMORY_CAP_MB": "20"})
    ta = d / "TA.yaml"
    mka = lambda: _text(ta, TEMPLATE + "accuracy:\n  veh_spd_test: {reading_pct: 0.5}\n"  # noqa: E731
                        "  eng_spd_out_test: {reading_pct: 1.0, offset: 5, unit: rpm}\n")
    for v in ("10000000", "1000000000", "-1", "99999999999999999999"):
        legal = {"expect": "ok", "must": "draws", "refusal_must": "memory"} if v == "10000000" else {}
        yield Case("option bounds", f"results --monte-carlo {v}", [
            "results", f, "-t", ta, "-o", d / f"res{v[:3]}", "--monte-carlo", v, "--json"],
            prepare=mka, **legal)
    for v in ("10000000", "100000", "-5"):
        yield Case("option bounds", f"sensitivity --monte-carlo {v}", [
            "sensitivity", "--monte-carlo", v, "--cycles", "udds"])
    for cmd in (["sensitivity", "--cycles", "udds", "--monte-carlo", "2"],
                ["synth", "--cycle", "steady:30kph:20s", "-o", d / "syn"],
                ["calibrate", f, "-t", t, "-o", d / "cal", "--maxiter", "1"]):
        for v in ("-1", str(2**32), str(2**64)):
            yield Case("option bounds", f"{cmd[0]} --seed {v}", [*cmd, "--seed", v])
    for v in ("-1", "1000000", "65"):
        yield Case("option bounds", f"batch -j {v}", [
            "batch", f.parent, "-t", t, "-o", d / "b", "-j", v, "-q"])
    for opt, v in (("--workers", "1000"), ("--workers", "-2"), ("--refine", "100"),
                   ("--refine", "-1")):
        yield Case("option bounds", f"epa calibrate {opt} {v}", [
            "epa", "calibrate", lst, "--vehicle", "prius_2016", "--tests", "model=PRIUS",
            "--param", "controller.soc_gain_w=1000,2000", opt, v], prepare=mkl)
    for opt, v in (("--popsize", "0"), ("--popsize", "1000000000"), ("--maxiter", "0"),
                   ("--maxiter", "1000000000")):
        yield Case("option bounds", f"calibrate {opt} {v}", [
            "calibrate", f, "-t", t, "-o", d / "cal", opt, v])
    for opt, v in (("--window", "0"), ("--window", "1e308"), ("--fuel-tol", "-5"),
                   ("--soc-tol", "nan"), ("--soc-points", "-1"), ("--smooth-hz", "0"),
                   ("--smooth-hz", "1e9")):
        yield Case("option bounds", f"validate {opt} {v}", [
            "validate", f, "-t", t, "-o", d / "val", opt, v])
    for v in ("-1", "1e12", "nan"):
        yield Case("option bounds", f"qa --max-offset {v}", [
            "qa", f, "-t", t, "-o", d / "qa", "--max-offset", v])
    for v in ("2", "-0.1", "nan"):
        yield Case("option bounds", f"simulate --soc-initial {v}", [
            "simulate", "--soc-initial", v])
    for v in ("-5", "99999"):
        yield Case("option bounds", f"epa list --year {v}", ["epa", "list", lst, "--year", v],
                   prepare=mkl)


def template_numbers(root: Path, rng: np.random.Generator) -> Iterator[Case]:
    """Units that overflow, absurd rates and scales, EPA lists that do not parse."""
    d = root / "tnum"
    f, t = base_test(root)
    for k, unit in enumerate(["Ym/ys*(Ym/ym)**20", "degC*(Ym/ym)**10", "m/s*1e308",
                              "km**400", "mph**-300", "1e309*m/s", "m/s/0", "degF**2",
                              "rpm*(Ym/ym)**40"]):
        tp = d / f"unit{k}.yaml"
        yield Case("template numbers", f"unit {unit}", [
            "import", f, "-t", tp, "-o", d / f"u{k}.parquet"],
            prepare=lambda tp=tp, unit=unit: _text(tp, TEMPLATE.replace(
                "unit: mph}", f"unit: '{unit}'}}")))
    data = d / "rate_d3.txt"
    for k, rate in enumerate(["1e-300", "1e300", "5e-324", "1e-320", "inf"]):
        tp = d / f"rate{k}.yaml"
        yield Case("template numbers", f"rate_hz {rate}", [
            "import", data, "-t", tp, "-o", d / f"r{k}.parquet"],
            prepare=lambda tp=tp, rate=rate: (write_d3(data), _text(tp, TEMPLATE.replace(
                "time: {column: Time, unit: s}", f"time: {{rate_hz: {rate}}}"))))
    for k, (key, val) in enumerate([("scale", "yes"), ("scale", "no"), ("scale", "'1e400'"),
                                    ("scale", ".nan"), ("scale", "1e308"),
                                    ("offset", "1e308"), ("scale", "[1, 2]")]):
        tp = d / f"scale{k}.yaml"
        yield Case("template numbers", f"{key}: {val}", [
            "import", f, "-t", tp, "-o", d / f"s{k}.parquet"],
            prepare=lambda tp=tp, key=key, val=val: _text(tp, TEMPLATE.replace(
                "unit: rpm}", f"unit: rpm, {key}: {val}}}")))
    for k, (what, tail) in enumerate([
            ("unclosed quote", '2016,"Toyota,TOYOTA,PRIUS\r\n'),
            ("unclosed quote at the end", '2016,Toyota,TOYOTA,"PRIUS'),
            ("131,073-char field", "2016,Toyota,TOYOTA," + "P" * 131_073 + "\r\n"),
            ("quoted 10^6-char field", '2016,Toyota,TOYOTA,"' + "P" * 1_000_000 + '"\r\n'),
            ("NUL byte in a field", "2016,Toyota,TOY\x00OTA,PRIUS\r\n"),
            ("10^5 columns", ",".join(["1"] * 100_000) + "\r\n")]):
        p = d / f"list{k}.csv"
        yield Case("template numbers", f"EPA list: {what}", ["epa", "list", p],
                   prepare=lambda p=p, tail=tail: write_epa(p, [epa_row()], raw_tail=tail))


def time_base(root: Path, rng: np.random.Generator) -> Iterator[Case]:
    """Time going backwards and repeated timestamps: a rate_irregular finding or a refusal."""
    d = root / "time"
    _, t = base_test(root)
    for k in range(12):
        p = d / f"t{k}" / "run_d3.txt"
        kind = ("backwards step", "repeated timestamp", "block of repeats", "descending")[k % 4]
        pos = int(rng.integers(50, 550))

        def mk(p=p, kind=kind, pos=pos):
            write_d3(p)
            lines = p.read_text().splitlines()
            rows = [r.split("\t") for r in lines[1:]]
            if kind == "backwards step":
                rows[pos][0] = f"{float(rows[pos][0]) - 5.0:.9g}"
            elif kind == "repeated timestamp":
                rows[pos][0] = rows[pos - 1][0]
            elif kind == "block of repeats":
                for i in range(pos, pos + 20):
                    rows[i][0] = rows[pos - 1][0]
            else:
                rows = rows[::-1]
            p.write_text("\n".join([lines[0]] + ["\t".join(r) for r in rows]) + "\n")
        yield Case("time base", f"{kind} at row {pos}", [
            "qa", p, "-t", t, "-o", d / f"qa{k}", "--json"], expect="ok",
            must="rate_irregular", prepare=mk)


def batch(root: Path, rng: np.random.Generator) -> Iterator[Case]:
    """Symlink loops, output inside a test folder, a tampered result on resume, zero rows."""
    d = root / "batch"
    _, t = base_test(root)
    for k, kind in enumerate(["self symlink", "two-folder loop", "symlink to /"]):
        src = d / f"loop{k}"

        def mk(src=src, kind=kind):
            if src.is_dir():
                return
            write_d3(src / "t1" / "run_d3.txt")
            if kind == "self symlink":
                (src / "loop").symlink_to(src / "loop")
            elif kind == "two-folder loop":
                (src / "a").mkdir()
                (src / "a" / "b").symlink_to(src / "a")
            else:
                (src / "root").symlink_to("/")
        yield Case("batch", kind, ["batch", src, "-t", t, "-o", d / f"out{k}", "-j", "0", "-q",
                                   "--no-report"], expect="ok", must="1 ok", prepare=mk)
    for k, sub in enumerate(["t1", "t2"]):
        src = d / f"in{k}"
        inputs = {}

        def mk2(src=src, inputs=inputs):
            if not src.is_dir():
                for s in ("t1", "t2"):
                    write_d3(src / s / "run_d3.txt")
            inputs.update({p: hashlib.sha256(p.read_bytes()).hexdigest()
                           for p in src.rglob("*_d3.txt")})
        yield Case("batch", f"-o DIR/{sub} (a test's own folder)", [
            "batch", src, "-t", t, "-o", src / sub, "-j", "0", "-q", "--no-report"],
            breach=lambda text, inputs=inputs: any(
                not p.is_file() or hashlib.sha256(p.read_bytes()).hexdigest() != h
                for p, h in inputs.items()), prepare=mk2)
    src, out = d / "resume", d / "resume_out"

    def first_run():
        if not out.is_dir():
            write_d3(src / "t1" / "run_d3.txt")
            subprocess.run([sys.executable, "-m", "vehval", "batch", src, "-t", t, "-o", out,
                            "-j", "0", "-q", "--no-report"], capture_output=True, timeout=600)
    for k, how in enumerate(["a number changed", "status failed -> ok", "not JSON"]):
        def tamper(how=how):
            first_run()
            res = next(out.rglob("result.json"))
            doc = res.read_text()
            if how == "a number changed":
                doc = re.sub(r'("fuel[^"]*": )(-?[0-9.e+-]+)', r"\g<1>123456.0", doc, count=1)
                if "123456" not in doc:
                    doc = doc.replace('"ok"', '"ok", "tampered": 1', 1)
            elif how == "status failed -> ok":
                doc = doc.replace('"ok"', '"failed"', 1)
            else:
                doc = "{not json"
            res.write_text(doc)
        yield Case("batch", f"tampered result.json on resume ({how})", [
            "batch", src, "-t", t, "-o", out, "-j", "0", "-q", "--no-report"],
            expect="ok", must="1 ok", prepare=tamper)
    for k, fmt in enumerate(["vehval", "plain"]):
        src = d / f"zero{k}"
        tp = d / f"zero{k}.yaml"

        def mkz(src=src, tp=tp, fmt=fmt):
            import pyarrow as pa
            import pyarrow.parquet as pq

            (src / "t1").mkdir(parents=True, exist_ok=True)
            tab = pa.table({"time": pa.array([], pa.float64()),
                            "speed": pa.array([], pa.float64())})
            if fmt == "vehval":
                tab = tab.replace_schema_metadata({b"vehval": json.dumps({
                    "format": "vehval-test", "format_version": 1, "meta": {},
                    "groups": {}}).encode()})
            pq.write_table(tab, src / "t1" / "run.parquet")
            _text(tp, "files:\n  - source: dyno\n    match: '*.parquet'\n    format: parquet\n"
                  "    time: {column: time}\n    channels:\n"
                  "      speed: {name: veh_spd_test, unit: m/s}\n")
        yield Case("batch", f"zero-row Parquet test ({fmt})", [
            "batch", src, "-t", tp, "-o", d / f"zout{k}", "-j", "0", "-q", "--no-report"],
            prepare=mkz)


def memory(root: Path, rng: np.random.Generator) -> Iterator[Case]:
    """A legal 10 h, 10 Hz test under an address-space limit: runs, or refused naming memory."""
    d = root / "memory"
    _, t = base_test(root)
    p = d / "long_d3.txt"
    mk = lambda: p.is_file() or write_d3(p, n=360_000, dt=0.1)  # noqa: E731
    for gb, cmd in ((1.0, "qa"), (1.0, "import"), (1.5, "qa"), (2.0, "qa"), (1.0, "results")):
        args = {"qa": ["qa", p, "-t", t, "-o", d / f"qa{gb}"],
                "import": ["import", p, "-t", t, "-o", d / f"imp{gb}.parquet"],
                "results": ["results", p, "-t", t, "-o", d / f"res{gb}"]}[cmd]
        yield Case("memory", f"10 h at 10 Hz, {cmd} under {gb:g} GB of address space", args,
                   expect="ok", refusal_must="memory", limit_as=int(gb * 2**30), prepare=mk)


CLASSES: dict[str, Callable[[Path, np.random.Generator], Iterator[Case]]] = {
    "report XSS": report_xss, "catalog": catalog, "bombs": bombs, "MDF4": mdf4,
    "option bounds": option_bounds, "template numbers": template_numbers,
    "time base": time_base, "batch": batch, "memory": memory,
}


def cases(root: Path, classes: list[str] | None = None, seed: int = 2) -> Iterator[Case]:
    """Every case of the selected classes (all by default); variants drawn from ``seed``."""
    for name, gen in CLASSES.items():
        if classes is None or name in classes:
            yield from gen(root, np.random.default_rng(seed))


def table(rows: list[dict]) -> str:
    """The totals table by class (markdown)."""
    out = [f"| class | tried | {' | '.join(KINDS)} |", "|---|---|" + "---|" * len(KINDS)]
    for g in dict.fromkeys(r["class"] for r in rows):
        c = Counter(r["outcome"] for r in rows if r["class"] == g)
        out.append(f"| {g} | {sum(c.values())} | " + " | ".join(str(c[k]) for k in KINDS) + " |")
    c = Counter(r["outcome"] for r in rows)
    out.append(f"| **total** | **{len(rows)}** | " + " | ".join(f"**{c[k]}**" for k in KINDS)
               + " |")
    return "\n".join(out)


def run_by_class(todo: list, jobs: int, run: Callable[[Any], dict]) -> list[dict]:
    """Run ``todo`` with ``run``, one class a worker (cases sharing a prepared input run in
    order within their class); every outcome other than a clean error or a handled case is
    printed to stderr as it comes."""
    by_class: dict[str, list] = {}
    for c in todo:
        by_class.setdefault(c.cls, []).append(c)

    def run_class(cs: list) -> list[dict]:
        rows = []
        for c in cs:
            r = run(c)
            rows.append(r)
            if r["outcome"] not in ("clean error", "handled"):
                print(f"{r['outcome']:15s} {r['class']}: {r['case']}: {r['message']}",
                      file=sys.stderr, flush=True)
        return rows

    with ThreadPoolExecutor(max_workers=max(jobs, 1)) as pool:
        results = list(pool.map(run_class, by_class.values()))
    return [r for rs in results for r in rs]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", type=Path, help="write every case and its outcome here")
    ap.add_argument("--jobs", type=int, default=2, help="cases run at once (default 2)")
    ap.add_argument("--class", dest="classes", action="append", choices=list(CLASSES),
                    help="run only this class (repeatable)")
    opts = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="vehval-attack2-") as tmp:
        rows = run_by_class(list(cases(Path(tmp), opts.classes)), opts.jobs, run_case)
    print("\n" + table(rows))
    if opts.json:
        opts.json.write_text(json.dumps(rows, indent=1, default=str))
    bad = sum(r["outcome"] not in ("clean error", "handled") for r in rows)
    return 0 if bad == 0 else 1


if __name__ == "__main__":
    os.environ.pop("VEHVAL_DEBUG", None)
    sys.exit(main())
