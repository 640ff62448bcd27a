"""One output policy for every command that writes: an output is a regular file or absent
(a directory or absent where a directory is asked for). A device node, a FIFO, a socket or a
symbolic link to one of them given as an output, or an output that is one of the run's
inputs, is refused with one line naming the option and the path, exit 2, nothing written and
the node left as it was. The final rename of every atomic write re-checks its target.

Was: ``vehval epa vehicle LIST ... -o /dev/null`` run as root turned the machine's
/dev/null into a regular file; a FIFO given to ``identify -o``, ``import -o``, ``template
init --force -o``... was replaced; ``epa calibrate -o`` equal to its ``--vehicle`` overwrote
the input. Every node here is made by the test in its own temporary directory, never the
system's.
"""

from __future__ import annotations

import os
import shutil
import socket
import stat
from pathlib import Path

import pytest

from helpers.cli import run_cli, write_d3
from helpers.epa_lists import row, write_list
from vehval.errors import VehvalError
from vehval.io import atomic
from vehval.io.paths import check_output_path, output_problem

VEHICLES = Path(__file__).resolve().parents[2] / "src" / "vehval" / "data" / "vehicles"

# --------------------------------------------------------------------------- the nodes


def _make_node(kind: str, path: Path) -> Path:
    """Make a node of ``kind`` at ``path``: chr (a character device like /dev/null), fifo,
    socket, or link-chr / link-fifo (a symbolic link to one, beside it)."""
    if kind.startswith("link-"):
        real = _make_node(kind[5:], path.with_name(path.name + ".real"))
        os.symlink(real, path)
        return path
    if kind == "chr":
        try:
            os.mknod(path, 0o666 | stat.S_IFCHR, os.makedev(1, 3))
        except (PermissionError, OSError) as exc:
            pytest.skip(f"cannot make a device node here ({exc})")
    elif kind == "fifo":
        os.mkfifo(path)
    elif kind == "socket":
        old = os.getcwd()
        os.chdir(path.parent)          # a relative name: AF_UNIX paths are short
        try:
            with socket.socket(socket.AF_UNIX) as s:
                s.bind(path.name)
        finally:
            os.chdir(old)
    return path


_TESTS = {"chr": stat.S_ISCHR, "fifo": stat.S_ISFIFO, "socket": stat.S_ISSOCK}


def _still(kind: str, path: Path) -> bool:
    """Is the node at ``path`` still what :func:`_make_node` made?"""
    if kind.startswith("link-"):
        return path.is_symlink() and _TESTS[kind[5:]](os.stat(path).st_mode)
    return _TESTS[kind](os.lstat(path).st_mode)


def _tree(root: Path) -> dict[str, tuple]:
    """Every entry under ``root``: its kind, and its bytes for a regular file."""
    out: dict[str, tuple] = {}
    for p in sorted(root.rglob("*")):
        st = os.lstat(p)
        data = p.read_bytes() if stat.S_ISREG(st.st_mode) else None
        out[str(p.relative_to(root))] = (stat.S_IFMT(st.st_mode), data)
    return out


def _refused(rc: int, err: str, option: str, path: Path) -> None:
    assert rc == 2, err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("vehval: error:"), err
    assert lines[0].startswith(f"vehval: error: {option} ") and str(path) in lines[0], err
    assert "Traceback" not in err and "internal error" not in err


# --------------------------------------------------------------------------- the commands


@pytest.fixture
def inputs(tmp_path, small_test):
    """The inputs every command below reads: a small D3 test and its template, a second
    test, an EPA list and a vehicle file."""
    f, t = small_test
    f2 = f.with_name("run2_d3.txt")
    write_d3(f2)
    epa = write_list(tmp_path / "in" / "16tstcar.csv",
                     [row(number="T1", code=3, desc="HWFE", fe=71.2)])
    veh = tmp_path / "in" / "car.yaml"
    shutil.copy(VEHICLES / "prius_2016.yaml", veh)
    conv = shutil.copy(VEHICLES / "cruze_diesel_2014.yaml", tmp_path / "in" / "cruze.yaml")
    return {"f": f, "f2": f2, "t": t, "epa": epa, "veh": veh, "conv": Path(conv),
            "dir": f.parent,
            "tmp": tmp_path}


# name: (option in the message, a directory is asked for, args(inputs, output))
WRITERS = {
    "epa vehicle -o": ("-o", False, lambda i, x: [
        "epa", "vehicle", i["epa"], "--make", "TOYOTA", "--model", "PRIUS", "--year", "2016",
        "-o", x]),
    "epa calibrate -o": ("-o", False, lambda i, x: [
        "epa", "calibrate", i["epa"], "--vehicle", "prius_2016", "--tests", "model=PRIUS",
        "--param", "engine_min_power_w=9000,11000", "--refine", "0", "--workers", "1",
        "-o", x]),
    "epa validate -o": ("-o", True, lambda i, x: [
        "epa", "validate", i["epa"], "--vehicle", "prius_2016", "--tests", "model=PRIUS",
        "-o", x]),
    "identify -o": ("-o", False, lambda i, x: [
        "identify", i["f"], "-t", i["t"], "-o", x]),
    "identify --report": ("--report", False, lambda i, x: [
        "identify", i["f"], "-t", i["t"], "-o", i["tmp"] / "car.yaml", "--report", x]),
    "identify --cross-validate -o": ("-o", False, lambda i, x: [
        "identify", i["f"], i["f2"], "-t", i["t"], "--cross-validate", "-o", x]),
    "predict --report": ("--report", False, lambda i, x: [
        "predict", "prius_2004", i["f"], "-t", i["t"], "--report", x]),
    "import -o": ("-o", False, lambda i, x: ["import", i["f"], "-t", i["t"], "-o", x]),
    "template init -o": ("-o", False, lambda i, x: ["template", "init", i["f"], "-o", x]),
    "template init --force -o": ("-o", False, lambda i, x: [
        "template", "init", i["f"], "--force", "-o", x]),
    "report -o": ("-o", False, lambda i, x: ["report", i["dir"], "-o", x]),
    "qa -o": ("-o", True, lambda i, x: ["qa", i["f"], "-t", i["t"], "-o", x]),
    "results -o": ("-o", True, lambda i, x: ["results", i["f"], "-t", i["t"], "-o", x]),
    "analyze -o": ("-o", True, lambda i, x: ["analyze", i["f"], "-t", i["t"], "-o", x]),
    "validate -o": ("-o", True, lambda i, x: ["validate", i["f"], "-t", i["t"], "-o", x]),
    "calibrate -o": ("-o", True, lambda i, x: [
        "calibrate", i["f"], "-t", i["t"], "-o", x, "--maxiter", "1"]),
    "synth -o": ("-o", True, lambda i, x: ["synth", "--cycle", "steady:10mps:5s", "-o", x]),
    "simulate -o": ("-o", True, lambda i, x: [
        "simulate", "--cycle", "steady:10mps:5s", "-o", x]),
    "sensitivity -o": ("-o", True, lambda i, x: [
        "sensitivity", "--cycles", "hwfet", "--params", "vehicle.mass_kg", "-o", x]),
    "batch -o": ("-o", True, lambda i, x: [
        "batch", i["dir"], "-t", i["t"], "-o", x, "-j", "0"]),
    "epa fleet -o": ("-o", True, lambda i, x: [
        "epa", "fleet", i["epa"], "-o", x, "--workers", "1"]),
}

NODES = ["chr", "fifo", "socket", "link-chr", "link-fifo"]


@pytest.mark.parametrize("kind", NODES)
@pytest.mark.parametrize("cmd", sorted(WRITERS))
def test_an_output_never_replaces_a_device_fifo_or_socket(inputs, capsys, cmd, kind):
    option, _, args = WRITERS[cmd]
    node = _make_node(kind, inputs["tmp"] / "out" if kind != "socket" else inputs["tmp"] / "o")
    before = _tree(inputs["tmp"])
    rc, _, err = run_cli(args(inputs, node), capsys)
    _refused(rc, err, option, node)
    assert _still(kind, node), f"{cmd}: the {kind} was replaced"
    assert _tree(inputs["tmp"]) == before, f"{cmd}: a file was written or changed"


def test_every_output_option_is_covered():
    """Every option of the CLI that names an output is in WRITERS (a new writer fails here
    until it takes the output policy and a case above)."""
    import typer

    from vehval.cli import _register
    from vehval.cli.app import app

    _register()
    found = set()

    def walk(cmd, path):
        for name, sub in getattr(cmd, "commands", {}).items():
            walk(sub, [*path, name])
        for p in getattr(cmd, "params", []):
            if getattr(p, "is_flag", False) or p.param_type_name != "option":
                continue
            if {"-o", "--output", "--outdir", "--out", "--report"} & set(p.opts):
                found.add((" ".join(path), min(p.opts, key=len)))

    walk(typer.main.get_command(app), [])
    covered = {(c.rsplit(" ", 1)[0].replace(" --cross-validate", "").replace(" --force", ""),
                WRITERS[c][0]) for c in WRITERS}
    assert found == covered, (sorted(found - covered), sorted(covered - found))


# --------------------------------------------------------------------------- nodes inside


@pytest.mark.parametrize("kind", ["fifo", "link-chr"])
def test_a_node_where_a_command_writes_inside_its_directory(inputs, capsys, kind):
    """``analyze -o DIR`` writes DIR/control.json by itself and ``report -o R`` writes
    tables.xlsx beside R: a node there is refused too, naming it."""
    i = inputs
    out = i["tmp"] / "an"
    out.mkdir()
    node = _make_node(kind, out / "control.json")
    before = _tree(i["tmp"])
    rc, _, err = run_cli(["analyze", i["f"], "-t", i["t"], "-o", out], capsys)
    _refused(rc, err, "-o", node)
    assert _still(kind, node) and _tree(i["tmp"]) == before
    qa = i["tmp"] / "qa"
    assert run_cli(["qa", i["f"], "-t", i["t"], "-o", qa], capsys)[0] in (0, 4)
    rep = i["tmp"] / "rep"
    rep.mkdir()
    node = _make_node(kind, rep / "tables.xlsx")
    before = _tree(i["tmp"])
    rc, _, err = run_cli(["report", qa, "-o", rep / "report.html"], capsys)
    _refused(rc, err, "-o", node)
    assert _still(kind, node) and _tree(i["tmp"]) == before
    # the report's default place, beside the QA outputs
    node = _make_node(kind, qa / "report.html")
    before = _tree(i["tmp"])
    rc, _, err = run_cli(["report", qa], capsys)
    _refused(rc, err, "-o", node)
    assert _still(kind, node) and _tree(i["tmp"]) == before


# --------------------------------------------------------------------------- output = input


def _hard_link(src: Path, dst: Path) -> Path:
    os.link(src, dst)
    return dst


SAME = {
    # name: (option, args(inputs) -> (args, the input that must survive))
    "epa calibrate -o == --vehicle": ("-o", lambda i: ([
        "epa", "calibrate", i["epa"], "--vehicle", i["veh"], "--tests", "model=PRIUS",
        "--param", "engine_min_power_w=9000,11000", "--refine", "0", "--workers", "1",
        "-o", i["veh"]], i["veh"])),
    "epa vehicle -o == the list": ("-o", lambda i: ([
        "epa", "vehicle", i["epa"], "--make", "TOYOTA", "--model", "PRIUS", "--year", "2016",
        "-o", i["epa"]], i["epa"])),
    "import -o == a hard link of an input": ("-o", lambda i: ([
        "import", i["f"], "-t", i["t"], "-o", _hard_link(i["f"], i["tmp"] / "x.parquet")],
        i["f"])),
    "import -o == the template": ("-o", lambda i: ([
        "import", i["f"], "-t", i["t"], "-o", i["t"]], i["t"])),
    "template init --force -o == the data": ("-o", lambda i: ([
        "template", "init", i["f"], "--force", "-o", i["f"]], i["f"])),
    "template init --force -o == a link to the data": ("-o", lambda i: ([
        "template", "init", i["f"], "--force", "-o", _link(i["f"], i["tmp"] / "t.yaml")],
        i["f"])),
    "identify --report == the template": ("--report", lambda i: ([
        "identify", i["f"], "-t", i["t"], "-o", i["tmp"] / "v.yaml", "--report", i["t"]],
        i["t"])),
    "predict --report == the vehicle": ("--report", lambda i: ([
        "predict", i["conv"], i["f"], "-t", i["t"], "--report", i["conv"]], i["conv"])),
    "epa validate -o == the list's directory": ("-o", lambda i: ([
        "epa", "validate", i["dir"], "--vehicle", "prius_2016", "--tests", "model=PRIUS",
        "-o", i["dir"]], i["epa"])),
}


def _link(src: Path, dst: Path) -> Path:
    os.symlink(src, dst)
    return dst


@pytest.mark.parametrize("case", sorted(SAME))
def test_an_output_is_never_one_of_the_inputs(inputs, capsys, case):
    option, build = SAME[case]
    args, kept = build(inputs)
    out = Path(args[args.index(option) + 1])
    before = _tree(inputs["tmp"])
    rc, _, err = run_cli(args, capsys)
    _refused(rc, err, option, out)
    assert "also an input" in err
    assert _tree(inputs["tmp"]) == before and kept.is_file()


def test_epa_calibrate_with_a_separate_output_still_writes(inputs, capsys):
    """The refusal above is of the path, not of the command: -o beside --vehicle writes."""
    i = inputs
    out = i["tmp"] / "calibrated.yaml"
    rc, _, err = run_cli(["epa", "calibrate", i["epa"], "--vehicle", i["veh"], "--tests",
                          "model=PRIUS", "--param", "engine_min_power_w=9000,11000",
                          "--refine", "0", "--workers", "1", "-o", out], capsys)
    assert rc == 0, err
    assert out.is_file() and i["veh"].read_bytes() == (VEHICLES / "prius_2016.yaml").read_bytes()


# --------------------------------------------------------------------------- the policy


@pytest.mark.parametrize("kind", NODES)
def test_output_problem_names_the_node(tmp_path, kind):
    node = _make_node(kind, tmp_path / "n")
    for directory in (False, True):
        msg = output_problem(node, directory=directory)
        assert msg and "would replace it" in msg
        assert ("symbolic link" in msg) == kind.startswith("link-")
    with pytest.raises(VehvalError, match=r"^--report .*/n: is .*nothing was written"):
        check_output_path(node, "--report")


def test_output_problem_allows_files_directories_and_absent_paths(tmp_path):
    f = tmp_path / "f"
    f.write_text("x")
    d = tmp_path / "d"
    d.mkdir()
    os.symlink(f, tmp_path / "lf")
    os.symlink(tmp_path / "missing", tmp_path / "dangling")
    assert output_problem(f) is None and output_problem(tmp_path / "lf") is None
    assert output_problem(tmp_path / "new") is None and output_problem(tmp_path / "dangling") is None
    assert output_problem(d, directory=True) is None and output_problem(tmp_path / "new", directory=True) is None
    assert "not a directory" in output_problem(f, directory=True)
    assert "is a directory" in output_problem(d)


# --------------------------------------------------------------------------- commit time


@pytest.mark.parametrize("kind", ["fifo", "socket", "link-fifo", "chr"])
def test_atomic_path_rechecks_the_target_at_commit(tmp_path, kind):
    """A node that appears at the output path while the run computes is not renamed over."""
    target = tmp_path / "out.yaml"
    with pytest.raises(VehvalError, match="out.yaml: is .* the output was not written"):
        with atomic.atomic_path(target) as tmp:
            tmp.write_text("new")
            _make_node(kind, target)
    assert _still(kind, target)
    assert sorted(p.name for p in tmp_path.iterdir() if not p.name.endswith(".real")) == ["out.yaml"]


def test_atomic_files_rechecks_every_target_before_the_commit(tmp_path):
    a, b = tmp_path / "a.yaml", tmp_path / "b.html"
    a.write_text("old a")
    with pytest.raises(VehvalError, match="b.html: is a FIFO"):
        with atomic.atomic_files([a, b]) as staged:
            for s in staged:
                s.write_text("new")
            os.mkfifo(b)
    assert a.read_text() == "old a" and stat.S_ISFIFO(os.lstat(b).st_mode)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.yaml", "b.html"]


def test_atomic_dir_moving_files_rechecks_every_target(tmp_path):
    """``atomic_dir(whole=False)`` (a report into a folder the user chose) moves its files
    one by one: every target is checked before the first moves."""
    out = tmp_path / "rep"
    out.mkdir()
    with pytest.raises(VehvalError, match="tables.xlsx: is a FIFO"):
        with atomic.atomic_dir(out, whole=False) as stage:
            (stage / "report.html").write_text("new")
            (stage / "tables.xlsx").write_text("new")
            os.mkfifo(out / "tables.xlsx")
    assert sorted(p.name for p in out.iterdir()) == ["tables.xlsx"]
    assert stat.S_ISFIFO(os.lstat(out / "tables.xlsx").st_mode)


def test_atomic_dir_carries_a_fifo_over_without_opening_it(tmp_path, monkeypatch):
    """A FIFO in an output directory is carried over by a hard link; when it cannot be
    linked the commit stops (copying a FIFO or a device would block or never end)."""
    out = tmp_path / "qa"
    out.mkdir()
    os.mkfifo(out / "pipe")
    with atomic.atomic_dir(out) as stage:
        (stage / "findings.json").write_text("{}")
    assert stat.S_ISFIFO(os.lstat(out / "pipe").st_mode) and (out / "findings.json").is_file()

    def no_link(src, dst):
        raise OSError(18, "Invalid cross-device link")

    monkeypatch.setattr(atomic.os, "link", no_link)
    with pytest.raises(VehvalError, match="pipe: not a regular file"):
        with atomic.atomic_dir(out) as stage:
            (stage / "findings.json").write_text('{"new": 1}')
    assert (out / "findings.json").read_text() == "{}"
    assert stat.S_ISFIFO(os.lstat(out / "pipe").st_mode)
