"""Resource guards: a huge column count, a stray timestamp, a 1 ns step and huge texts are
refused or repaired before any large allocation; the process always exits.

The CLI runs in a subprocess under a 1 GB address-space limit (RLIMIT_AS): a run that tried
to allocate the old 8.6 GB (10^6 columns) or 74.5 GiB (t = 1e9 s) would fail with an
internal error instead of the clear line or finding checked here.
"""

from __future__ import annotations

import json
import os
import resource
import subprocess
import sys

import pytest

from helpers.cli import TEMPLATE, write_d3
from vehval.errors import ConfigError
from vehval.io.template import load_template

LIMIT_BYTES = 1 << 30


def _limited():
    resource.setrlimit(resource.RLIMIT_AS, (LIMIT_BYTES, LIMIT_BYTES))


def _cli(args, cwd, limited: bool = True):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    return subprocess.run([sys.executable, "-m", "vehval", *map(str, args)], cwd=cwd,
                          capture_output=True, text=True, env=env, timeout=120,
                          preexec_fn=_limited if limited else None)


@pytest.fixture
def tmpl(tmp_path):
    p = tmp_path / "T.yaml"
    p.write_text(TEMPLATE)
    return p


def test_million_columns_refused_under_1gb(tmp_path, tmpl):
    """Was: 8.6 GB, error after 30 s, then the process never exited."""
    n = 10**6
    hdr = "Time[s]\t" + "\t".join(f"C{i}[V]" for i in range(n))
    ones = "\t".join("1" for _ in range(n))
    f = tmp_path / "wide_d3.txt"
    f.write_text(f"{hdr}\n0\t{ones}\n1\t{ones}\n")
    r = _cli(["qa", f, "-t", tmpl, "-o", tmp_path / "out"], tmp_path)
    assert r.returncode == 2, r.stderr[-500:]
    assert "1000001 columns" in r.stderr and r.stderr.count("\n") == 1
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("last_t", [1e9, 2e6])
def test_stray_last_timestamp_dropped_with_a_warning(tmp_path, tmpl, last_t):
    """Was: 74.5 GiB requested (internal MemoryError) at 1e9 s; 195 s and 13 GB at 2e6 s."""
    f = tmp_path / "s_d3.txt"
    write_d3(f, last_t=last_t)
    r = _cli(["qa", f, "-t", tmpl, "-o", tmp_path / "out", "--json"], tmp_path)
    assert r.returncode == 0, r.stderr[-800:]
    doc = json.loads(r.stdout)
    assert doc["test"]["duration_s"] < 100
    assert "stray timestamp" in r.stderr or any("stray timestamp" in n for n in doc["notes"])


def test_sparse_time_base_refused(tmp_path, tmpl):
    """Four samples spread over 1e9 s: not a test's time base (refused, no grid built)."""
    f = tmp_path / "sp_d3.txt"
    f.write_text("Time[s]\tDyno_Speed[mph]\tEngine_Speed[rpm]\n0\t1\t800\n3e8\t2\t800\n"
                 "6e8\t3\t800\n1e9\t4\t800\n")
    r = _cli(["qa", f, "-t", tmpl, "-o", tmp_path / "out"], tmp_path, limited=False)
    assert r.returncode == 2 and "spans" in r.stderr, r.stderr[-500:]


def test_nanosecond_step_is_a_clear_error(tmp_path, tmpl):
    """Was: a 1 ns time step failed with an internal error."""
    f = tmp_path / "ns_d3.txt"
    write_d3(f, dt=1e-9)
    r = _cli(["qa", f, "-t", tmpl, "-o", tmp_path / "out"], tmp_path, limited=False)
    assert r.returncode == 2 and "median step" in r.stderr, r.stderr[-500:]


def test_huge_description_refused_quickly(tmp_path):
    """Was: a 60 MB description took 78 s."""
    p = tmp_path / "T.yaml"
    p.write_text(TEMPLATE.replace("description: adversarial test template",
                                  "description: " + "x" * 6_000_000))
    with pytest.raises(ConfigError, match="too large"):
        load_template(p)
    p.write_text(TEMPLATE.replace("description: adversarial test template",
                                  "description: " + "x" * 100_000))
    with pytest.raises(ConfigError, match="description"):
        load_template(p)
