"""A command that read CSV files exits 0 every time.

pyarrow's threaded CSV reader drops its last reference to the input on a worker thread,
sometimes after ``read_csv`` returned. An input that wraps a Python object (``bytes``) then
takes the GIL in its destructor on that thread; during interpreter shutdown Python ends the
thread and the C++ runtime aborts the process ("terminate called without an active
exception", exit 134, after the output was printed): about 1 run in 10-30 of `template check`
over the ten Cruze files on a loaded machine. The reader hands pyarrow a buffer Arrow owns
(:func:`vehval.io.arrow.arrow_owned`).
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pyarrow as pa
import pytest
from iohelpers import D3_TEMPLATE, d3_rows, write_d3

from vehval.io.arrow import arrow_owned
from vehval.io.delimited import read_delimited

HERE = Path(__file__).resolve().parent
REAL = Path(os.environ.get("VEHVAL_SHARED_DATA", HERE.parents[1] / ".." / "shared" / "data")) / "real"
CRUZE = REAL / "d3_2014_chevrolet_cruze_diesel"
CRUZE_TEMPLATE = HERE.parent / "qa" / "templates" / "cruze.yaml"
RUNS = 20


def test_the_csv_reader_gives_pyarrow_an_arrow_owned_buffer(tmp_path, monkeypatch):
    given = []
    real = pa.BufferReader

    def spy(obj):
        given.append(obj)
        return real(obj)

    monkeypatch.setattr(pa, "BufferReader", spy)
    raw = read_delimited(write_d3(tmp_path / "run_d3.txt"), fmt="d3")
    assert raw.data["Dyno_Speed"][-1] == 60.0
    assert len(given) == 1
    assert isinstance(given[0], pa.Buffer) and given[0].is_mutable   # allocated by Arrow


def test_arrow_owned_is_a_copy_holding_no_python_object():
    data = b"Time,Speed\n0,1\n" * 100
    before = sys.getrefcount(data)
    buf = arrow_owned(data)
    reader = pa.BufferReader(buf)
    assert sys.getrefcount(data) == before           # nothing refers to the bytes object
    assert reader.read() == data and buf.to_pybytes() == data
    assert arrow_owned(b"").size == 0


def _files(tmp_path) -> tuple[Path, list[Path]]:
    """The ten Cruze files and their template, else ten synthetic D3 files of 2000 s."""
    if CRUZE.is_dir():
        return CRUZE_TEMPLATE, sorted(CRUZE.glob("*Test Data.txt"))
    tpl = tmp_path / "T.yaml"
    tpl.write_text(D3_TEMPLATE, encoding="utf-8")
    rows = d3_rows(n=20_000)
    return tpl, [write_d3(tmp_path / f"run{i}_d3.txt", rows=rows) for i in range(10)]


@pytest.mark.slow
def test_template_check_exits_0_every_time(tmp_path):
    tpl, files = _files(tmp_path)
    codes = []
    for _ in range(RUNS):
        proc = subprocess.run([sys.executable, "-m", "vehval", "template", "check", str(tpl),
                               *map(str, files)], capture_output=True, text=True, timeout=300)
        codes.append(proc.returncode)
        assert proc.returncode == 0, (codes, proc.stderr[-2000:])
        assert "0 error(s)" in proc.stdout
