"""Several outputs as one unit: `identify -o V.yaml --report R.html` killed at any rename.

Was: a kill at its second rename left a new report beside the old vehicle file, and a
temporary that no later run removed.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from vehval.io.atomic import atomic_files, clean_stale_stages

HELPER = Path(__file__).with_name("killrun.py")
DEBRIS = re.compile(r"vehval-stage|vehval-tmp|\.tmp$")

#: Writes "<tag>" into two files (in two folders) through atomic_files, SIGKILLed just
#: before its K-th rename (0: never).
WRITER = textwrap.dedent("""
    import os, signal, sys
    from vehval.io.atomic import atomic_files
    k, tag, a, b = int(sys.argv[1]), sys.argv[2], sys.argv[3], sys.argv[4]
    n = [0]
    real = os.replace
    def replace(*args):
        n[0] += 1
        if n[0] == k:
            os.kill(os.getpid(), signal.SIGKILL)
        return real(*args)
    os.replace = replace
    with atomic_files([a, b]) as (sa, sb):
        sa.write_text(tag)
        sb.write_text(tag)
    print(n[0])
""")


def _env():
    return dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))


def _debris(*dirs: Path) -> list[str]:
    return [str(p) for d in dirs for p in d.iterdir() if DEBRIS.search(p.name)]


def test_atomic_files_killed_at_every_rename(tmp_path):
    a, b = tmp_path / "one" / "V.yaml", tmp_path / "two" / "R.html"

    def write(k, tag):
        return subprocess.run([sys.executable, "-c", WRITER, str(k), tag, str(a), str(b)],
                              capture_output=True, text=True, env=_env(), timeout=120)

    first = write(0, "old")
    assert first.returncode == 0, first.stderr
    steps = int(first.stdout)
    assert steps == 3                        # the commit record, then the two outputs
    mixed_seen = False
    for k in range(1, steps + 1):
        for f in (a, b):
            f.write_text("old")
        r = write(k, "new")
        assert r.returncode == -9, (k, r.stderr)
        mixed_seen |= a.read_text() != b.read_text()
        assert _debris(a.parent, b.parent)   # the killed run left its staging behind
        # what the next run on these outputs does first: drop or complete the killed one
        clean_stale_stages(a, b)
        assert a.read_text() == b.read_text(), k
        assert a.read_text() == ("old" if k == 1 else "new"), k
        assert _debris(a.parent, b.parent) == [], k
    assert mixed_seen                        # the case the commit record repairs


def test_atomic_files_error_writes_nothing(tmp_path):
    a, b = tmp_path / "V.yaml", tmp_path / "R.html"
    with pytest.raises(RuntimeError):
        with atomic_files([a, b]) as (sa, sb):
            sa.write_text("new")
            raise RuntimeError("failed half-way")
    with pytest.raises(FileNotFoundError):
        with atomic_files([a, b]) as (sa, sb):
            sa.write_text("only one")
    assert sorted(p.name for p in tmp_path.iterdir()) == []


@pytest.fixture(scope="module")
def conventional_test(tmp_path_factory):
    from vehval.cli import main

    d = tmp_path_factory.mktemp("conv")
    assert main(["synth", "--vehicle", "cruze_diesel_2014", "--cycle", "hwfet", "--seed", "1",
                 "-o", str(d / "v")]) == 0
    return next((d / "v").glob("*_d3.txt")), d / "v" / "template.yaml"


def _killrun(k, args):
    return subprocess.run([sys.executable, str(HELPER), str(k), *map(str, args)],
                          capture_output=True, text=True, env=_env(), timeout=600)


@pytest.mark.slow
def test_identify_killed_at_every_rename(tmp_path, conventional_test):
    f, tpl = conventional_test
    veh, rep = tmp_path / "V.yaml", tmp_path / "R.html"

    def args(name):
        return ["identify", f, "-t", tpl, "-o", veh, "--report", rep, "--name", name]

    def names():
        v = re.search(r"^name: (\S+)", veh.read_text(), re.M).group(1)
        r = re.search(r"Identification of (\w+)", rep.read_text()).group(1)
        return v, r

    # the second run counts the renames: a first run in a fresh environment may also rename
    # files of its own caches (the compiled kernels), which later runs do not
    for _ in range(2):
        first = _killrun(0, args("OLD"))
        assert first.returncode == 0, first.stderr
    steps = int(re.search(r"renames=(\d+)", first.stderr).group(1))
    assert steps >= 3
    for k in range(1, steps + 1):
        r = _killrun(k, args("NEW"))
        assert r.returncode == -9, (k, r.stderr)
        clean_stale_stages(veh, rep)         # what the next identify does first
        v, rp = names()
        assert v == rp, (k, v, rp)           # both old or both new, never a mix
        assert _debris(tmp_path) == [], k
    done = _killrun(0, args("LAST"))
    assert done.returncode == 0 and names() == ("LAST", "LAST")
    assert _debris(tmp_path) == []
