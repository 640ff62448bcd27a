"""Attack campaign III: outputs that replace devices, a workbench reading through symlinks,
figures stated wrong without a word, unbounded grids, internal errors, the EPA reader, an
exit crash.

    python scripts/attack_campaign3.py [--json OUT.json] [--jobs 2] [--class NAME ...]

A generator per class builds its cases (seeded variants) in a temporary folder. Each case is
a real ``python -m vehval`` process (60 s timeout, 4 GiB address-space limit), a real HTTP
request against a ``vehval serve`` the campaign starts on 127.0.0.1, or a headless Chromium
page load (the GET-writes-from-another-port case). Outcomes and their rules are in
``scripts/attack3_common.py``; the classes:

* **outputs**: every writing command given a device node (made with ``os.mknod`` in the
  campaign's own folder, never the system's), a FIFO, a socket, or an output equal to an
  input; breach: the node replaced by a regular file, the input overwritten;
* **workbench** (``scripts/attack3_web.py``): symlinks out of the workspace in a test folder,
  ``serve /`` and the home folder, a GET that writes, a POST from another port, bad query
  parameters and bodies, an empty folder, a symlink loop, 3,000 files;
* **silent figures** (``scripts/attack3_figures.py``): the Cruze HWFET (real file when
  present, and a virtual dyno test) with fuel and speed scale, density, fuel dropouts,
  road-load constants, Monte Carlo draws, in-sample predictions, duplicate grids, a mass in
  pounds, calibration starts out of bounds;
* **hangs**: ``epa calibrate`` grids of 5,000 values or 60^3 settings;
* **internal**: absurd tyre sizes, a start file nested 50,000 deep, a ``--scheduler`` that is
  not Dask, a FIFO in a batch folder;
* **EPA reader**: byte-order mark, line endings, rows differing only in test number, a true
  duplicate, analytically derived rows, an axle ratio of 0;
* **exit crash**: ``template check`` over several files, repeated.

The totals by class are in docs/robustness.md ("Campaign III").
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import socket
import stat
import sys
import tempfile
import threading
from collections import Counter
from pathlib import Path
from typing import Callable, Iterator

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from attack3_common import KINDS, Case, never, run_case  # noqa: E402
from attack3_inputs import (  # noqa: E402
    CRUZE_REAL,
    CRUZE_TEMPLATE,
    SEDAN_HEADER,
    VEHICLES,
    base_write,
    d3_of,
    once,
    prius_list,
    run_vehval,
    sedan_rows,
    sedan_tests,
    sha,
    synth,
    write_list,
)
from attack_campaign2 import EPA_HEADER, _text, base_test, epa_row, run_by_class  # noqa: E402

# ----------------------------------------------------------------------------------------
# outputs

NODE_TEST = {"device": stat.S_ISCHR, "FIFO": stat.S_ISFIFO, "socket": stat.S_ISSOCK}
NODE_REFUSAL = r"device|fifo|pipe|socket|special|not a regular file|regular file"
SAME_REFUSAL = r"input|same file|overwrit|itself|is also|same path"


def can_mknod() -> bool:
    """True when this process may make a character device node (root, CAP_MKNOD)."""
    with tempfile.TemporaryDirectory() as d:
        try:
            os.mknod(Path(d) / "n", 0o666 | stat.S_IFCHR, os.makedev(1, 3))
            return True
        except (PermissionError, OSError):
            return False


def make_node(path: Path, kind: str) -> None:
    """A device node (the null device's numbers, in our own folder), FIFO or socket."""
    path.parent.mkdir(parents=True, exist_ok=True)
    if path.exists() or path.is_symlink():
        path.unlink()
    if kind == "device":
        os.mknod(path, 0o666 | stat.S_IFCHR, os.makedev(1, 3))
    elif kind == "FIFO":
        os.mkfifo(path)
    else:  # a socket file: bound in a short folder (108-byte limit), moved into place
        with tempfile.TemporaryDirectory(prefix="s") as d:
            s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
            s.bind(str(Path(d) / "s"))
            s.close()
            os.rename(Path(d) / "s", path)


def replaced(path: Path, kind: str) -> bool:
    """The node at ``path`` is gone or no longer a node of its kind."""
    try:
        return not NODE_TEST[kind](os.lstat(path).st_mode)
    except FileNotFoundError:
        return True


def outputs(root: Path, rng: np.random.Generator) -> Iterator[Case]:
    """Every writing command given a device node, a FIFO, a socket, or one of its inputs."""
    d = root / "outputs"
    f, t = base_test(root)
    kinds = ["device", "FIFO", "socket"] if can_mknod() else ["FIFO", "socket"]
    vhw = lambda: synth(root, "cruze_diesel_2014", "hwfet")  # noqa: E731
    vud = lambda: synth(root, "cruze_diesel_2014", "udds")  # noqa: E731
    pl = root / "_lists" / "prius.csv"  # made by prius_list() when a case runs
    sed = root / "_sedan"
    qa_dir = d / "qa_base"

    def mkqa():
        if not (qa_dir / "findings.json").is_file():
            run_vehval("qa", f, "-t", t, "-o", qa_dir)

    commands: dict[str, tuple[Callable[[Path], list], Callable[[], object]]] = {
        "epa vehicle -o": (lambda x: ["epa", "vehicle", sed / "19tstcar.csv", "--make", "MAKER",
                                      "--model", "SEDAN XLE", "--year", "2019", "-o", x],
                           lambda: sedan_tests(root)),
        "identify -o": (lambda x: ["identify", d3_of(vhw()), "-t", vhw() / "template.yaml",
                                   "-o", x], vhw),
        "identify --report": (lambda x: ["identify", d3_of(vhw()), "-t",
                                         vhw() / "template.yaml", "-o", d / "id_ok.yaml",
                                         "--report", x], vhw),
        "identify --cross-validate -o": (lambda x: [
            "identify", d3_of(vhw()), d3_of(vud()), "-t", vhw() / "template.yaml",
            "--cross-validate", "-o", x], lambda: (vhw(), vud())),
        "predict --report": (lambda x: ["predict", "cruze_diesel_2014", d3_of(vhw()), "-t",
                                        vhw() / "template.yaml", "--report", x], vhw),
        "epa calibrate -o": (lambda x: [
            "epa", "calibrate", pl, "--vehicle", "prius_2016", "--tests",
            "model=PRIUS,procedure=hwfet", "--param", "engine_min_power_w=9000,11000",
            "--refine", "0", "--workers", "1", "--dt", "1", "-o", x],
            lambda: prius_list(root)),
        "import -o": (lambda x: ["import", f, "-t", t, "-o", x], lambda: None),
        "template init --force -o": (lambda x: ["template", "init", f, "--force", "-o", x],
                                     lambda: None),
        "report -o": (lambda x: ["report", qa_dir, "-o", x], mkqa),
    }
    names = {"epa vehicle -o": "v.yaml", "identify -o": "v.yaml", "identify --report": "r.html",
             "identify --cross-validate -o": "cv.json", "predict --report": "p.html",
             "epa calibrate -o": "cal.yaml", "import -o": "t.parquet",
             "template init --force -o": "t.yaml", "report -o": "report.html"}
    for k, (what, (args, need)) in enumerate(commands.items()):
        for kind in rng.permutation(kinds):
            node = d / f"c{k}{kind[0]}" / names[what]  # no refusal keyword in the path
            case = Case("outputs", f"{what} a {kind}", [], refusal_must=NODE_REFUSAL,
                        breach=lambda text, node=node, kind=kind: replaced(node, kind))

            def prep(case=case, node=node, kind=kind, need=need, args=args):
                need()  # inputs are made when the case runs, not when it is listed
                make_node(node, kind)
                case.args = args(node)
            case.prepare = prep
            yield case
    # commands writing a folder, given a node
    for k, (what, args) in enumerate({
            "qa -o": lambda x: ["qa", f, "-t", t, "-o", x],
            "results -o": lambda x: ["results", f, "-t", t, "-o", x],
            "synth -o": lambda x: ["synth", "--cycle", "steady:30kph:20s", "-o", x]}.items()):
        kind = str(rng.choice(kinds))
        node = d / f"dc{k}{kind[0]}" / "out"
        yield Case("outputs", f"{what} (a folder) a {kind}", args(node),
                   refusal_must=NODE_REFUSAL + "|not a directory",
                   breach=lambda text, node=node, kind=kind: replaced(node, kind),
                   prepare=lambda node=node, kind=kind: make_node(node, kind))
    yield from _same_as_input(root, d, f, t, vhw)


def _same_as_input(root: Path, d: Path, f: Path, t: Path, vhw) -> Iterator[Case]:
    """An output path equal to one of the command's inputs: refused, the input unchanged."""
    def guarded(name: str, args: Callable[[Path, Path], list], src: Callable[[], Path],
                other: Callable[[], Path] | None = None) -> Case:
        folder = d / "eq" / "".join(ch for ch in name if ch.isalnum())[:40]
        held: dict = {}

        def prep():
            folder.mkdir(parents=True, exist_ok=True)
            s = src()
            inp = folder / s.name
            shutil.copyfile(s, inp)
            held["input"], held["sha"] = inp, sha(inp)
            if other is not None:
                o = other()
                shutil.copyfile(o, folder / o.name)
                held["other"] = folder / o.name
        case = Case("outputs", name, [], refusal_must=SAME_REFUSAL,
                    breach=lambda text: sha(held["input"]) != held["sha"], prepare=prep)

        def build():
            case.args = args(held["input"], held.get("other", held["input"]))
        case.prepare = lambda: (prep(), build())
        return case

    yield guarded("epa calibrate -o equal to its --vehicle", lambda inp, _: [
        "epa", "calibrate", prius_list(root), "--vehicle", inp, "--tests",
        "model=PRIUS,procedure=hwfet", "--param", "engine_min_power_w=9000,11000",
        "--refine", "0", "--workers", "1", "--dt", "1", "-o", inp],
        lambda: VEHICLES / "prius_2016.yaml")
    yield guarded("import -o equal to its data file", lambda inp, _: [
        "import", inp, "-t", t, "-o", inp], lambda: f)
    yield guarded("import -o equal to its template", lambda inp, data: [
        "import", data, "-t", inp, "-o", inp], lambda: t, other=lambda: f)
    yield guarded("template init --force -o equal to its data file", lambda inp, _: [
        "template", "init", inp, "--force", "-o", inp], lambda: f)
    yield guarded("identify -o equal to its template", lambda inp, data: [
        "identify", data, "-t", inp, "-o", inp], lambda: vhw() / "template.yaml",
        other=lambda: d3_of(vhw()))
    yield guarded("identify --report equal to its data file", lambda inp, tpl: [
        "identify", inp, "-t", tpl, "-o", d / "eq" / "id.yaml", "--report", inp],
        lambda: d3_of(vhw()), other=lambda: vhw() / "template.yaml")
    yield guarded("epa vehicle -o equal to its list", lambda inp, _: [
        "epa", "vehicle", inp, "--make", "MAKER", "--model", "SEDAN XLE", "--year", "2019",
        "-o", inp], lambda: sedan_tests(root) / "19tstcar.csv")


# ----------------------------------------------------------------------------------------
# hangs

def states_estimate(text: str) -> bool:
    """An estimate of the run time stated (the kernel compilation's 'about 20 s' aside)."""
    return any(re.search(r"estimat|would take|will take|expected (run )?time|"
                         r"\d+(\.\d+)? ?(s|min|h|hours?|minutes?)\b", line, re.I)
               and "compiling" not in line for line in text.splitlines())
GRID_REFUSAL = r"grid|settings|evaluations|combinations|values|simulations"


def hangs(root: Path, rng: np.random.Generator) -> Iterator[Case]:
    """``epa calibrate`` grids too large to run: refused, or an estimate stated up front."""
    def values(lo: float, hi: float, n: int) -> str:
        return ",".join(f"{v:.6g}" for v in np.linspace(lo, hi, n) + rng.uniform(0, 1e-3))

    grids = {
        "5,000-value grid": [f"soc_gain_w={values(10000, 60000, 5000)}"],
        "10,000-value grid": [f"engine_min_power_w={values(8000, 11000, 10000)}"],
        "60^3 grid": [f"soc_gain_w={values(10000, 60000, 60)}",
                      f"engine_min_power_w={values(8000, 11000, 60)}",
                      f"min_on_time_s={values(2, 8, 60)}"],
        "100^2 grid": [f"soc_gain_w={values(10000, 60000, 100)}",
                       f"engine_min_power_w={values(8000, 11000, 100)}"],
    }
    for what, params in grids.items():
        for refine, workers in (("0", "1"), ("2", "2"))[: 2 if what.startswith(("5", "60")) else 1]:
            args = ["epa", "calibrate", root / "_lists" / "prius.csv", "--vehicle", "prius_2016",
                    "--tests", "model=PRIUS,procedure=hwfet", "--refine", refine,
                    "--workers", workers, "--dt", "1"]
            for p in params:
                args += ["--param", p]
            yield Case("hangs", f"epa calibrate {what} (--refine {refine}, --workers {workers})",
                       args, expect="ok", must=states_estimate, estimate_ok=True,
                       refusal_must=GRID_REFUSAL, prepare=lambda: prius_list(root))


# ----------------------------------------------------------------------------------------
# internal errors

class GarbageServer:
    """A loopback TCP server that is not Dask: garbage, silence, HTTP, or a closed socket."""

    def __init__(self, mode: str, payload: bytes) -> None:
        self.mode, self.payload = mode, payload
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.listen(16)
        self.port = self.sock.getsockname()[1]
        self.alive = True
        threading.Thread(target=self._serve, daemon=True).start()
        SERVERS.append(self)

    def _serve(self) -> None:
        held = []
        while self.alive:
            try:
                conn, _ = self.sock.accept()
            except OSError:
                return
            try:
                if self.mode == "garbage":
                    conn.sendall(self.payload)
                elif self.mode == "http":
                    conn.sendall(b"HTTP/1.1 200 OK\r\nContent-Length: 2\r\n\r\nok")
                elif self.mode == "close":
                    conn.close()
                    continue
                held.append(conn)  # silent: kept open, never answered
            except OSError:
                pass

    def stop(self) -> None:
        self.alive = False
        self.sock.close()


#: Helper servers started by cases (stopped by :func:`stop_servers`).
SERVERS: list = []


def stop_servers() -> None:
    while SERVERS:
        SERVERS.pop().stop()


def internal(root: Path, rng: np.random.Generator) -> Iterator[Case]:
    """Absurd tyre sizes, a deep start file, a scheduler that is not Dask, a FIFO test."""
    d = root / "internal"
    vhw = lambda: synth(root, "cruze_diesel_2014", "hwfet")  # noqa: E731
    prius = lambda: synth(root, "prius_2004", "udds", seed=7)  # noqa: E731
    _PLACEHOLDERS["internal"] = {
        "{hw}": lambda: d3_of(vhw()), "{tpl}": lambda: vhw() / "template.yaml",
        "{pd3}": lambda: d3_of(prius()), "{pobd}": lambda: next(prius().glob("*_obd.csv")),
        "{ptpl}": lambda: prius() / "template.yaml"}
    for k, tyre in enumerate(["999/99 R99", "0/50 R17", "225/0 R17", "225/50 R0",
                              "99999/99 R17", "225/50 R1e9"]):
        yield Case("internal", f"identify --tyre {tyre!r}", [
            "identify", "{hw}", "-t", "{tpl}", "--tyre", tyre, "-o", d / f"t{k}.yaml"],
            refusal_must=r"tyre|tire")
    for k, (what, body) in enumerate([
            ("a list nested 50,000 deep", '{"controller": ' + "[" * 50_000 + "]" * 50_000 + "}"),
            ("a mapping nested 50,000 deep", '{"controller": ' + '{"a": ' * 50_000 + "1"
             + "}" * 50_000 + "}"),
            ("a list nested 10^6 deep", "[" * 1_000_000 + "]" * 1_000_000)]):
        sp = d / f"start{k}.json"
        yield Case("internal", f"calibrate --start {what}", [
            "calibrate", "--test", "{pd3},{pobd}", "-t", "{ptpl}", "-o", d / f"cal{k}",
            "--start", sp, "--params", "controller.engine_on_power_w", "--maxiter", "1",
            "--popsize", "1"], refusal_must=r"deep|nest|depth",
            prepare=lambda sp=sp, body=body: _text(sp, body))
    _, t = base_test(root)
    for k, mode in enumerate(["garbage", "silent", "http", "close"]):
        payload = rng.bytes(4096) if mode == "garbage" else b""
        holder: dict = {}
        src = d / "sched_in"
        case = Case("internal", f"batch --scheduler at a loopback server that is not Dask ({mode})",
                    [], refusal_must=r"scheduler|dask", expect="error")

        def prep(case=case, mode=mode, payload=payload, holder=holder, k=k):
            once(src / "t1" / "run_d3.txt", lambda p: base_write(p))
            srv = GarbageServer(mode, payload)
            holder["srv"] = srv
            case.args = ["batch", src, "-t", t, "-o", d / f"sched_out{k}", "-q", "--no-report",
                         "--scheduler", f"tcp://127.0.0.1:{srv.port}"]
        case.prepare = prep
        yield case
    for k, where in enumerate(["the only data file of a test", "beside a valid test",
                               "a single-file test in a flat folder"]):
        src = d / f"fq{k}"

        def mkf(src=src, k=k):
            if src.is_dir():
                shutil.rmtree(src)
            if k == 0:
                (src / "t1").mkdir(parents=True)
                os.mkfifo(src / "t1" / "run_d3.txt")
            elif k == 1:
                base_write(src / "t1" / "run_d3.txt")
                (src / "t2").mkdir(parents=True)
                os.mkfifo(src / "t2" / "run_d3.txt")
            else:
                base_write(src / "a_d3.txt")
                os.mkfifo(src / "b_d3.txt")
        yield Case("internal", f"a FIFO in a batch folder ({where})", [
            "batch", src, "-t", t, "-o", d / f"fq_out{k}", "-j", "0", "-q", "--no-report"],
            refusal_must=r"fifo|pipe|not a regular file|special file", prepare=mkf)


#: Per class: placeholders in case arguments (``{hw}``) and the functions making their
#: inputs, called when the case runs (inputs are made then, not when cases are listed).
_PLACEHOLDERS: dict[str, dict[str, Callable[[], Path]]] = {}


def resolve(case: Case) -> Case:
    """Wrap ``case.prepare`` so that placeholder arguments are filled before it runs."""
    if not any(isinstance(a, str) and a.startswith("{") and "}" in a for a in case.args):
        return case
    inner = case.prepare

    def prep():
        table = _PLACEHOLDERS[case.cls]
        out = []
        for a in case.args:
            if isinstance(a, str):
                for key, make in table.items():
                    if a == key:
                        a = make()
                        break
                    if key in a:
                        a = a.replace(key, str(make()))
            out.append(a)
        case.args = out
        if inner is not None:
            inner()
    case.prepare = prep
    return case


# ----------------------------------------------------------------------------------------
# EPA reader

EPA_FULL_HEADER = EPA_HEADER[:12] + ["Analytically Derived FE?"] + EPA_HEADER[12:]


def epa_reader(root: Path, rng: np.random.Generator) -> Iterator[Case]:
    """Lists as published (BOM, any line end), rows the reader must keep apart or report."""
    d = root / "epa"
    rows = [epa_row(), epa_row(**{"Test Number": "T2", "Test Procedure Cd": "21",
                                  "Test Procedure Description": "Federal fuel 2-day exhaust",
                                  "RND_ADJ_FE": "54.0"})]
    for bom in (True, False):
        for nl_name, nl in (("CR LF", "\r\n"), ("LF", "\n"), ("CR", "\r")):
            if not bom and nl_name == "CR LF":
                continue  # the campaign II lists
            p = d / f"list_{int(bom)}_{nl_name.replace(' ', '')}.csv"
            what = ("UTF-8 BOM, " if bom else "") + f"{nl_name} line ends"
            for cmd in (["epa", "list", p], ["epa", "tests", p, "--model", "PRIUS"]):
                yield Case("EPA reader", f"{cmd[1]}: {what}", cmd, expect="ok",
                           must=r"PRIUS" if cmd[1] == "list" else r"\bT1\b.*\bT2\b",
                           refusal_must=never,  # a list as published: no refusal is right
                           prepare=lambda p=p, bom=bom, nl=nl: write_list(
                               p, rows, EPA_HEADER, newline=nl, bom=bom))
    # rows differing only in test number: every number kept
    for k in range(3):
        nums = [f"HCRX{int(x)}" for x in rng.choice(10**8, size=2 + k, replace=False)]
        p = d / f"numbers{k}.csv"
        yield Case("EPA reader", f"{len(nums)} rows differing only in test number", [
            "epa", "tests", p, "--model", "PRIUS", "--json"], expect="ok", refusal_must=never,
            must=lambda text, nums=nums: all(n in text for n in nums),
            prepare=lambda p=p, nums=nums: write_list(
                p, [epa_row(**{"Test Number": n}) for n in nums], EPA_HEADER))
    # a true duplicate: reported, never silently merged
    for cmd in ("tests", "list"):
        p = d / f"dup_{cmd}.csv"
        yield Case("EPA reader", f"a true duplicate row (epa {cmd})", [
            "epa", cmd, p, "--model", "PRIUS"], expect="ok", must=r"duplicat",
            refusal_must=r"duplicat", prepare=lambda p=p: write_list(
                p, [epa_row(), epa_row(), rows[1]], EPA_HEADER))
    # analytically derived rows are not tests: epa validate does not judge them
    for k, flag in enumerate(["Yes", "Y"]):
        p = d / f"adfe{k}.csv"
        derived = {**epa_row(**{"Test Number": "AD1", "RND_ADJ_FE": "69.9"}),
                   "Analytically Derived FE?": flag}
        yield Case("EPA reader", f"an analytically derived row ({flag!r}) in epa validate", [
            "epa", "validate", p, "--vehicle", "prius_2016", "--tests", "model=PRIUS",
            "--dt", "1", "-o", d / f"derived_out{k}"], expect="ok", must=_derived_not_judged,
            prepare=lambda p=p, derived=derived: write_list(
                p, [{**epa_row(), "Analytically Derived FE?": "No"}, derived],
                EPA_FULL_HEADER))
    # an axle ratio of 0 is a value, not an empty cell
    p = d / "axle0.csv"
    yield Case("EPA reader", "an axle ratio of 0 (epa vehicle)", [
        "epa", "vehicle", p, "--make", "MAKER", "--model", "SEDAN XLE", "--year", "2019",
        "-o", d / "axle0.yaml"],
        refusal_must=lambda text: "axle" in text.lower() and "empty" not in text.lower(),
        prepare=lambda: write_list(p, sedan_rows(**{"Axle Ratio": "0"}), SEDAN_HEADER))


def _derived_not_judged(text: str) -> bool:
    """The analytically derived row AD1 is named as such and not judged as a test."""
    judged = re.search(r"^AD1\b.*\byes\s*$", text, re.M | re.I)
    return judged is None and re.search(r"analytically derived", text, re.I) is not None


# ----------------------------------------------------------------------------------------
# exit crash

def exit_crash(root: Path, rng: np.random.Generator) -> Iterator[Case]:
    """``template check`` over several files, repeated: exit 0 every time (134: a crash)."""
    d = root / "crash"
    vhw = lambda: synth(root, "cruze_diesel_2014", "hwfet")  # noqa: E731
    for n_files, repeat in ((3, 10), (int(rng.integers(5, 9)), 10)):
        folder = d / f"v{n_files}"

        def mk(folder=folder, n_files=n_files):
            src = d3_of(vhw())
            for i in range(n_files):
                if not (folder / f"run{i}_d3.txt").is_file():
                    folder.mkdir(parents=True, exist_ok=True)
                    shutil.copyfile(src, folder / f"run{i}_d3.txt")
        case = Case("exit crash", f"template check over {n_files} virtual files x{repeat}", [],
                    expect="ok", repeat=repeat)

        def prep(case=case, folder=folder, mk=mk, n_files=n_files):
            mk()
            case.args = ["template", "check", vhw() / "template.yaml",
                         *[folder / f"run{i}_d3.txt" for i in range(n_files)]]
        case.prepare = prep
        yield case
    real = sorted(CRUZE_REAL.glob("*Test Data.txt")) if CRUZE_REAL.is_dir() else []
    if len(real) >= 2:
        # the crash came in about 1 run of 20 to 50 on this machine
        yield Case("exit crash", f"template check over the {len(real)} Cruze files x40",
                   ["template", "check", CRUZE_TEMPLATE, *real], expect="ok", repeat=40)


# ----------------------------------------------------------------------------------------

def _classes() -> dict[str, Callable[[Path, np.random.Generator], Iterator[Case]]]:
    from attack3_figures import silent_figures
    from attack3_web import workbench

    return {"outputs": outputs, "workbench": workbench, "silent figures": silent_figures,
            "hangs": hangs, "internal": internal, "EPA reader": epa_reader,
            "exit crash": exit_crash}


CLASSES = _classes()


def cases(root: Path, classes: list[str] | None = None, seed: int = 3) -> Iterator[Case]:
    """Every case of the selected classes (all by default); variants drawn from ``seed``."""
    for name, gen in CLASSES.items():
        if classes is None or name in classes:
            for c in gen(root, np.random.default_rng(seed)):
                yield resolve(c)


def table(rows: list[dict]) -> str:
    """The totals table by class (markdown), the columns of issue 37's acceptance."""
    out = [f"| class | tried | {' | '.join(KINDS)} |", "|---|---|" + "---|" * len(KINDS)]
    for g in dict.fromkeys(r["class"] for r in rows):
        c = Counter(r["outcome"] for r in rows if r["class"] == g)
        out.append(f"| {g} | {sum(c.values())} | " + " | ".join(str(c[k]) for k in KINDS) + " |")
    c = Counter(r["outcome"] for r in rows)
    out.append(f"| **total** | **{len(rows)}** | " + " | ".join(f"**{c[k]}**" for k in KINDS)
               + " |")
    if c["not run"]:
        out.append(f"\n{c['not run']} case(s) not run (their input could not be made)")
    return "\n".join(out)


def run_all(todo: list[Case], jobs: int) -> list[dict]:
    """Run the cases, one class per worker (cases of a class share inputs and servers), then
    stop the servers the cases started."""
    try:
        return run_by_class(todo, jobs, run_case)
    finally:
        from attack3_web import stop_workbenches

        stop_workbenches()
        stop_servers()


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", type=Path, help="write every case and its outcome here")
    ap.add_argument("--jobs", type=int, default=2, help="classes run at once (default 2)")
    ap.add_argument("--class", dest="classes", action="append", choices=list(CLASSES),
                    help="run only this class (repeatable)")
    opts = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="vehval-attack3-") as tmp:
        rows = run_all(list(cases(Path(tmp), opts.classes)), opts.jobs)
    print("\n" + table(rows))
    if opts.json:
        opts.json.write_text(json.dumps(rows, indent=1, default=str))
    bad = sum(r["outcome"] not in ("clean error", "handled") for r in rows)
    return 0 if bad == 0 else 1


if __name__ == "__main__":
    os.environ.pop("VEHVAL_DEBUG", None)
    sys.exit(main())
