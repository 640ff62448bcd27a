"""Whole-run atomicity: kill -9 at every rename of `qa -o OUT --report` leaves OUT wholly
old or wholly new, and the next run removes the staging folders the killed runs left."""

from __future__ import annotations

import hashlib
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from helpers.cli import write_d3

HELPER = Path(__file__).with_name("killrun.py")


def _state(d: Path) -> dict:
    return {str(p.relative_to(d)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(d.rglob("*")) if p.is_file()} if d.exists() else {}


def _run(k: int, args: list) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    return subprocess.run([sys.executable, str(HELPER), str(k), *map(str, args)],
                          capture_output=True, text=True, env=env, timeout=300)


@pytest.mark.slow
def test_kill_at_every_rename_leaves_old_or_new(tmp_path, small_test):
    f, t = small_test
    out = tmp_path / "OUT"
    args = ["qa", f, "-t", t, "-o", out, "--report"]
    first = _run(0, args)
    assert first.returncode == 0, first.stderr
    old = _state(out)
    # the new run differs from the old one: other data
    write_d3(f, n=700)
    ref_dir = tmp_path / "REF"
    ref = _run(0, ["qa", f, "-t", t, "-o", ref_dir, "--report"])
    steps = int(re.search(r"renames=(\d+)", ref.stderr).group(1))
    new_names = set(_state(ref_dir))
    assert steps >= 3 and new_names == set(old)
    for k in range(1, steps + 1):
        r = _run(k, args)
        assert r.returncode == -9, (k, r.returncode, r.stderr)
        now = _state(out)
        if now != old:
            assert set(now) == new_names and now != old, (k, sorted(now))
            # wholly new: every file differs from the old run (no mix of old and new)
            mixed = [n for n in now if n in ("findings.json", "validated.parquet")
                     and now[n] == old[n]]
            assert not mixed, (k, mixed)
            old = now
    stale = [p for p in tmp_path.iterdir() if p.name.startswith(".OUT.")]
    assert stale, "the killed runs left staging folders (the case to clean)"
    done = _run(0, args)
    assert done.returncode == 0
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".OUT.")]
