"""Paths: every command of the README given a directory for a file, a file for a directory,
an existing file or directory as output, an unreadable file or a non-data document answers
with one clear line and exit 2, writes nothing and modifies no input; ids from metadata never
escape the output directory; an output never overwrites an input or the template in use."""

from __future__ import annotations

import hashlib
import os
import zipfile

import pytest

from helpers.cli import run_cli
from vehval.io.paths import sanitize_id


def _snapshot(root):
    return {str(p.relative_to(root)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(root.rglob("*")) if p.is_file()}


def _non_data(kind, path):
    if kind == "pdf":
        path.write_bytes(b"%PDF-1.4\n%\xe2\xe3\xcf\xd3\n1 0 obj<<>>endobj\n")
    elif kind == "png":
        path.write_bytes(b"\x89PNG\r\n\x1a\n" + b"\0" * 64)
    elif kind in ("xlsx", "zip"):
        with zipfile.ZipFile(path, "w") as z:
            z.writestr("[Content_Types].xml", "<Types/>")
    return path


def _deny_reading(monkeypatch, path):
    """Opening ``path`` fails with EACCES, as it does for a non-root user after chmod 0."""
    import builtins
    import errno
    import io

    real = io.open
    denied = os.path.realpath(path)

    def guarded(file, *args, **kw):
        if isinstance(file, (str, bytes, os.PathLike)) and os.path.realpath(file) == denied:
            raise PermissionError(errno.EACCES, os.strerror(errno.EACCES), str(file))
        return real(file, *args, **kw)

    monkeypatch.setattr(builtins, "open", guarded)
    monkeypatch.setattr(io, "open", guarded)


# command builders: (name, args(f, t, out)) where f is the data file, t the template
COMMANDS = {
    "info": lambda f, t, o: ["info", f],
    "template init": lambda f, t, o: ["template", "init", f, "-o", o / "new.yaml"],
    "template check": lambda f, t, o: ["template", "check", t, f],
    "import": lambda f, t, o: ["import", f, "-t", t, "-o", o / "x.parquet"],
    "qa": lambda f, t, o: ["qa", f, "-t", t, "-o", o / "qa"],
    "analyze": lambda f, t, o: ["analyze", f, "-t", t, "-o", o / "an"],
    "validate": lambda f, t, o: ["validate", f, "-t", t, "-o", o / "val"],
    "calibrate": lambda f, t, o: ["calibrate", f, "-t", t, "-o", o / "cal", "--maxiter", "1"],
    "epa list": lambda f, t, o: ["epa", "list", f],
    "epa tests": lambda f, t, o: ["epa", "tests", f, "--make", "Toyota"],
    "epa validate": lambda f, t, o: ["epa", "validate", f, "--vehicle", "prius_2016",
                                     "--tests", "Toyota/Prius", "-o", o / "epa"],
    "results": lambda f, t, o: ["results", f, "-t", t, "-o", o / "res"],
    "identify": lambda f, t, o: ["identify", f, "-t", t, "--architecture", "conventional",
                                 "-o", o / "veh.yaml"],
    "predict": lambda f, t, o: ["predict", "prius_2004", f, "-t", t],
    "report": lambda f, t, o: ["report", f, "-o", o / "rep.html"],
}


def _check_clean(rc, out, err, before, root, name):
    assert rc == 2, (name, rc, out, err)
    lines = [ln for ln in err.strip().splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("vehval: error:"), (name, err)
    assert "Traceback" not in err and "internal error" not in err
    assert _snapshot(root) == before, name


@pytest.mark.parametrize("cmd", sorted(COMMANDS))
@pytest.mark.parametrize("bad", ["directory", "pdf", "png", "xlsx", "zip", "unreadable"])
def test_bad_data_file(tmp_path, small_test, capsys, monkeypatch, cmd, bad):
    f, t = small_test
    out = tmp_path / "out"
    out.mkdir()
    if bad == "directory":
        f = tmp_path / "in" / "adir_d3.txt"
        f.mkdir()
    elif bad == "unreadable":
        f.chmod(0)
    else:
        f = _non_data(bad, tmp_path / "in" / "doc_d3.txt")
    before = _snapshot(tmp_path)
    if bad == "unreadable" and os.geteuid() == 0:  # root reads every file: emulate EACCES
        _deny_reading(monkeypatch, f)
    rc, o, e = run_cli(COMMANDS[cmd](f, t, out), capsys)
    monkeypatch.undo()
    _check_clean(rc, o, e, before, tmp_path, f"{cmd}/{bad}")
    if bad in ("pdf", "png", "xlsx", "zip"):
        # predict and identify refuse the template's hybrid vehicle before they open a file
        # (identify still names the file); report names what it takes
        assert f.name in e or cmd == "predict"
        if cmd == "identify":
            assert "this is a hybrid" in e
        elif cmd not in ("predict", "report"):
            assert "is a" in e and "not a" in e


@pytest.mark.parametrize("cmd", ["template check", "import", "qa", "analyze", "validate"])
def test_template_is_a_directory(tmp_path, small_test, capsys, cmd):
    f, _ = small_test
    t = tmp_path / "tdir"
    t.mkdir()
    before = _snapshot(tmp_path)
    rc, o, e = run_cli(COMMANDS[cmd](f, t, tmp_path), capsys)
    _check_clean(rc, o, e, before, tmp_path, cmd)
    assert "directory" in e


@pytest.mark.parametrize("cmd", ["qa", "analyze", "validate", "calibrate"])
def test_output_dir_is_an_existing_file(tmp_path, small_test, capsys, cmd):
    f, t = small_test
    o = tmp_path / "o"
    o.mkdir()
    name = {"qa": "qa", "analyze": "an", "validate": "val", "calibrate": "cal"}[cmd]
    (o / name).write_text("keep me")
    before = _snapshot(tmp_path)
    rc, out, e = run_cli(COMMANDS[cmd](f, t, o), capsys)
    _check_clean(rc, out, e, before, tmp_path, cmd)
    assert "not a directory" in e


@pytest.mark.parametrize("args", [
    lambda o: ["simulate", "--cycle", "steady:10mps:5s", "-o", o / "file.txt"],
    lambda o: ["synth", "--cycle", "steady:10mps:5s", "-o", o / "file.txt"],
])
def test_output_dir_is_a_file_for_sim_and_synth(tmp_path, capsys, args):
    (tmp_path / "file.txt").write_text("keep me")
    before = _snapshot(tmp_path)
    rc, o, e = run_cli(args(tmp_path), capsys)
    _check_clean(rc, o, e, before, tmp_path, "sim")


@pytest.mark.parametrize("cmd", ["import", "template init"])
def test_output_file_is_an_existing_directory(tmp_path, small_test, capsys, cmd):
    f, t = small_test
    d = tmp_path / "d"
    d.mkdir()
    args = (["import", f, "-t", t, "-o", d] if cmd == "import"
            else ["template", "init", f, "-o", d, "--force"])
    before = _snapshot(tmp_path)
    rc, o, e = run_cli(args, capsys)
    _check_clean(rc, o, e, before, tmp_path, cmd)


def test_batch_outdir_is_a_file_and_input_is_a_file(tmp_path, small_test, capsys):
    f, t = small_test
    (tmp_path / "o.txt").write_text("x")
    before = _snapshot(tmp_path)
    rc, o, e = run_cli(["batch", tmp_path / "in", "-t", t, "-o", tmp_path / "o.txt", "-j", "0"],
                       capsys)
    _check_clean(rc, o, e, before, tmp_path, "batch -o file")
    rc, o, e = run_cli(["batch", f, "-t", t, "-o", tmp_path / "b", "-j", "0"], capsys)
    _check_clean(rc, o, e, before, tmp_path, "batch FILE")


def test_report_output_is_a_directory(tmp_path, capsys):
    d = tmp_path / "d"
    d.mkdir()
    before = _snapshot(tmp_path)
    rc, o, e = run_cli(["report", d, "-o", d], capsys)
    _check_clean(rc, o, e, before, tmp_path, "report")


def test_import_refuses_to_overwrite_its_input(tmp_path, small_test, capsys):
    """Was: `vehval import A B -t T -o A` replaced the raw input with Parquet, exit 0."""
    f, t = small_test
    before = _snapshot(tmp_path)
    rc, o, e = run_cli(["import", f, "-t", t, "-o", f], capsys)
    _check_clean(rc, o, e, before, tmp_path, "import -o input")
    assert "also an input" in e


def test_qa_refuses_to_overwrite_the_template_in_use(tmp_path, small_test, capsys):
    """Was: `qa -o DIR` overwrote a DIR/template_final.yaml given as -t."""
    f, t = small_test
    out = tmp_path / "qa"
    out.mkdir()
    final = out / "template_final.yaml"
    final.write_text(t.read_text())
    before = _snapshot(tmp_path)
    rc, o, e = run_cli(["qa", f, "-t", final, "-o", out], capsys)
    _check_clean(rc, o, e, before, tmp_path, "qa -t OUT/template_final.yaml")


@pytest.mark.parametrize("bad,expected", [("..", "test"), (".", "test"), ("../../etc", "etc"),
                                          ("a/b\\c", "a_b_c"), ("", "test"), ("x" * 300, "x" * 120),
                                          ("Prius c #3", "Prius_c_3"), (".hidden", "hidden")])
def test_sanitize_id(bad, expected):
    assert sanitize_id(bad) == expected


def test_metadata_test_id_cannot_escape_the_output(tmp_path, small_test, capsys):
    """Was: a Parquet test whose metadata test_id is '..' made `validate --report` write
    report.html and tables.xlsx above -o."""
    import json

    import pyarrow.parquet as pq

    f, t = small_test
    pqf = tmp_path / "in" / "t.parquet"
    assert run_cli(["import", f, "-t", t, "-o", pqf], capsys)[0] == 0
    table = pq.read_table(pqf)
    meta = dict(table.schema.metadata)
    key = next(k for k in meta if k == b"vehval")
    doc = json.loads(meta[key])
    doc["meta"]["test_id"] = ".."
    meta[key] = json.dumps(doc).encode()
    pq.write_table(table.replace_schema_metadata(meta), pqf)
    pqf2 = tmp_path / "in" / "t2.parquet"
    pq.write_table(table.replace_schema_metadata(meta), pqf2)
    out = tmp_path / "deep" / "val"
    before = {p for p in tmp_path.rglob("*")}
    rc, o, e = run_cli(["validate", pqf, pqf2, "-o", out, "--no-qa", "--report"], capsys)
    created = {p for p in tmp_path.rglob("*")} - before
    assert all(p == out.parent or out in p.parents or p == out for p in created), \
        sorted(map(str, created))
