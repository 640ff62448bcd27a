"""Shared virtual tests for tests/synth (generated once per session: the simulator compiles
with numba on first use).

The cycle is the first 240 s of the UDDS: idle, the first hills up to ~90 km/h, so the
engine starts and stops and the battery charges and discharges; short enough to keep the
suite fast.
"""

from __future__ import annotations

import json
from pathlib import Path

import pandas as pd
import pytest

from vehval.cycles import Cycle, load_cycle
from vehval.synth import make_virtual_test

SHORT_S = 240.0


def short_cycle() -> Cycle:
    """The first ``SHORT_S`` seconds of the UDDS."""
    udds = load_cycle("udds")
    keep = udds.time_s <= SHORT_S
    return Cycle.from_trace(udds.time_s[keep], udds.speed_mps[keep], "udds240",
                            description="first 240 s of the UDDS")


class Virtual:
    """A generated virtual test with its truth, clean signals and paths loaded."""

    def __init__(self, outdir: Path, out) -> None:
        self.dir = outdir
        self.out = out
        self.truth = json.loads(out.truth_path.read_text(encoding="utf-8"))
        frame = pd.read_parquet(out.clean_path)
        self.grid = frame["time"].to_numpy()
        self.clean = {c: frame[c].to_numpy() for c in frame.columns if c != "time"}

    @property
    def d3(self) -> Path:
        return self.out.files[0]

    @property
    def obd(self) -> Path:
        return self.out.files[1]


def _make(tmp_path_factory, name: str, **kw) -> Virtual:
    outdir = tmp_path_factory.mktemp(name) / "vt"
    out = make_virtual_test(vehicle="prius_2004", cycle=short_cycle(), outdir=outdir, **kw)
    return Virtual(outdir, out)


@pytest.fixture(scope="session")
def virtual_none(tmp_path_factory) -> Virtual:
    """Short virtual test without faults (files on the true clock)."""
    return _make(tmp_path_factory, "vt_none", seed=7, faults="none")


@pytest.fixture(scope="session")
def virtual_default(tmp_path_factory) -> Virtual:
    """Short virtual test with the default fault mix."""
    return _make(tmp_path_factory, "vt_default", seed=7, faults="default")


@pytest.fixture(scope="session")
def virtual_default_again(tmp_path_factory) -> Virtual:
    """Same settings as ``virtual_default``, in another directory (determinism)."""
    return _make(tmp_path_factory, "vt_default2", seed=7, faults="default")
