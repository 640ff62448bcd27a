"""Felt speed: the progress reporting of long library work, the CLI bar, and the one-line
message while the simulation kernel compiles on a first run."""

from __future__ import annotations

import io
import os
import subprocess
import sys
from pathlib import Path

import pytest

from vehval import numba_cache, progress

SRC = Path(__file__).resolve().parents[1] / "src"


class Collect:
    def __init__(self):
        self.total = self.done = 0

    def add(self, steps):
        self.total += steps

    def advance(self, steps=1):
        self.done += steps


def test_reports_reach_the_listener_only_inside_its_block():
    progress.add(3)          # nobody listens: no effect, no error
    progress.advance()
    c = Collect()
    with progress.listening(c):
        progress.add(4)
        progress.advance(2)
        progress.advance()
    progress.advance()
    assert (c.total, c.done) == (4, 3)


def test_bar_is_quiet_under_json_and_off_a_terminal():
    from vehval.cli.progress import bar, enabled

    assert enabled(as_json=True) is False
    assert enabled() is sys.stderr.isatty()
    c = Collect()
    with progress.listening(c), bar("x", as_json=True):
        progress.add(2)               # the bar's "no listener" hides the outer one
    assert c.total == 0


def test_bar_drawn_with_rich_follows_the_steps(capsys):
    from vehval.cli.progress import bar

    with bar("work", show=True):
        progress.add(3)
        for _ in range(3):
            progress.advance()
    assert "Traceback" not in capsys.readouterr().err


@pytest.mark.slow
def test_sensitivity_reports_its_steps():
    from vehval.sim.sensitivity import sensitivity

    c = Collect()
    with progress.listening(c):
        sensitivity("prius_2004", ["udds"], ["body.aux_power_w"], dt=1.0, workers=1)
    assert c.total == 2 and c.done == 2          # base run and variants of one cycle


def test_compile_notice_once_and_only_without_a_cached_kernel(tmp_path, monkeypatch):
    monkeypatch.setattr(numba_cache, "_announced", set())
    buf = io.StringIO()
    assert numba_cache.compile_notice("kernel", "run", "test kernel", stream=buf,
                                      directory=tmp_path)
    assert buf.getvalue().count("\n") == 1 and "compiling the test kernel" in buf.getvalue()
    assert not numba_cache.compile_notice("kernel", "run", "test kernel", stream=buf,
                                          directory=tmp_path)          # once per process
    monkeypatch.setattr(numba_cache, "_announced", set())
    (tmp_path / "sim_0").mkdir()
    (tmp_path / "sim_0" / "kernel.run-57.py311.nbi").write_bytes(b"")
    assert not numba_cache.compile_notice("kernel", "run", "test kernel", stream=buf,
                                          directory=tmp_path)          # cached: silent


@pytest.mark.slow
def test_first_simulation_after_install_says_it_compiles(tmp_path):
    """A fresh cache: the first run prints the line on stderr, the second does not."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(SRC), *sys.path]),
               VEHVAL_NUMBA_CACHE=str(tmp_path / "cache"))
    cmd = [sys.executable, "-m", "vehval", "simulate", "--vehicle", "cruze_diesel_2014",
           "--cycle", "udds", "--json"]
    first = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=600)
    assert first.returncode == 0, first.stderr[-2000:]
    assert "compiling the conventional simulation kernel" in first.stderr
    assert first.stdout.lstrip().startswith("{")                       # stdout stays JSON
    second = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=600)
    assert second.returncode == 0 and "compiling" not in second.stderr
