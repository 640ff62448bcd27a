"""Hostile inputs to every raw reader: a RawTable or a VehvalError, nothing else, no hang."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from vehval.errors import VehvalError
from vehval.io.readers import read_raw

from .helpers import FUZZ, check_table, csv_text, d3_text, outcome, parquet_bytes

EXTS = [".txt", ".csv", ".tsv", ".mf4", ".parquet", ".dat"]


def _read(tmp_path, name: str, data: bytes, fmt: str = "auto"):
    p = tmp_path / name
    p.write_bytes(data)
    res = outcome(read_raw, p, fmt)
    if not isinstance(res, VehvalError):
        check_table(res)
    return res


@FUZZ
@given(data=st.binary(max_size=2048), ext=st.sampled_from(EXTS),
       fmt=st.sampled_from(["auto", "d3", "csv", "mdf4", "parquet"]))
def test_random_bytes(tmp_path, data, ext, fmt):
    _read(tmp_path, "f" + ext, data, fmt)


@FUZZ
@given(cut=st.floats(0.0, 1.0), delim=st.sampled_from(["\t", ",", ";"]),
       eol=st.sampled_from(["\n", "\r\n"]))
def test_truncated_text(tmp_path, cut, delim, eol):
    """A valid D3/CSV file cut anywhere: either read (fewer rows) or a clear error."""
    for name, text in (("t.txt", d3_text(delim=delim, eol=eol)), ("t.csv", csv_text(delim=delim))):
        raw = text.encode("utf-8")
        res = _read(tmp_path, name, raw[: int(cut * len(raw))])
        if not isinstance(res, VehvalError) and res.time_name is not None:
            t = res.data[res.time_name]
            assert t.size <= raw.count(b"\n")


@FUZZ
@given(cut=st.floats(0.0, 0.999), flips=st.lists(st.tuples(st.floats(0, 0.999), st.integers(0, 255)),
                                                 max_size=4))
def test_truncated_or_mutated_mdf(tmp_path, mdf_bytes, cut, flips):
    raw = bytearray(mdf_bytes[: max(1, int(cut * len(mdf_bytes)))] if not flips else mdf_bytes)
    for pos, byte in flips:
        raw[int(pos * len(raw))] = byte
    _read(tmp_path, "m.mf4", bytes(raw))


@FUZZ
@given(cut=st.floats(0.0, 0.999), flips=st.lists(st.tuples(st.floats(0, 0.999), st.integers(0, 255)),
                                                 max_size=4))
def test_truncated_or_mutated_parquet(tmp_path, cut, flips):
    good = parquet_bytes()
    raw = bytearray(good[: max(1, int(cut * len(good)))] if not flips else good)
    for pos, byte in flips:
        raw[int(pos * len(raw))] = byte
    _read(tmp_path, "p.parquet", bytes(raw))


@FUZZ
@given(enc=st.sampled_from(["utf-8", "utf-8-sig", "utf-16", "utf-16-le", "utf-16-be", "latin-1",
                            "cp1252", "utf-32"]),
       declared=st.sampled_from([None, "utf-8", "latin-1", "utf-16", "ascii", "cp1252",
                                 "no-such-codec"]))
def test_wrong_encodings(tmp_path, enc, declared):
    """A D3 file with a non-ASCII unit in any encoding, read with a right or wrong declared one."""
    raw = d3_text(n=10).encode(enc)
    p = tmp_path / "e.txt"
    p.write_bytes(raw)
    kw = {} if declared is None else {"encoding": declared}
    res = outcome(read_raw, p, "auto", **kw)
    if not isinstance(res, VehvalError):
        check_table(res)
        if declared is None and enc in ("utf-8", "utf-8-sig", "utf-16"):
            # detected encodings must give the right numbers back
            assert res.time_name is not None
            assert np.allclose(res.data[res.time_name][:3], [-0.5, -0.4, -0.3])


_WEIRD = st.sampled_from(["1e308", "1e400", "-1e400", "nan", "NaN", "inf", "-inf", "Infinity",
                          "", " ", "1" * 400, "0x1F", "1,5", "--1", "1e", ".", "∞", "null", "1.0.0"])


@FUZZ
@given(cells=st.lists(st.lists(_WEIRD, min_size=5, max_size=5), min_size=1, max_size=6),
       delim=st.sampled_from(["\t", ","]))
def test_huge_nan_inf_empty_cells(tmp_path, cells, delim):
    lines = [delim.join(["Time[s]", "A[V]", "B[A]", "C[rpm]", "D[mph]"])]
    lines += [delim.join([f"{i * 0.1:g}"] + row[1:]) for i, row in enumerate(cells)]
    res = _read(tmp_path, "w.txt", ("\n".join(lines) + "\n").encode())
    if not isinstance(res, VehvalError):
        assert all(np.asarray(v).size == len(cells) for v in res.data.values())


@FUZZ
@given(n=st.integers(0, 2), empty_col=st.booleans(), delim=st.sampled_from(["\t", ",", ";"]))
def test_one_row_and_empty_columns(tmp_path, n, empty_col, delim):
    lines = [delim.join(["Time[s]", "Speed[mph]", "Empty[A]"])]
    for i in range(n):
        lines.append(delim.join([f"{i}", "12.5", "" if empty_col else "3"]))
    res = _read(tmp_path, "o.txt", ("\n".join(lines) + "\n").encode())
    if not isinstance(res, VehvalError) and n:
        assert res.data["Speed"].tolist() == [12.5] * n
        if empty_col:
            assert np.isnan(res.data["Empty"]).all()


@FUZZ
@given(rows=st.integers(0, 2), special=st.sampled_from([np.nan, np.inf, -np.inf, 1e308, 0.0]),
       empty=st.booleans())
def test_parquet_special_values(tmp_path, rows, special, empty):
    import pyarrow as pa

    cols = {"time": np.arange(rows, dtype=float), "x": np.full(rows, special)}
    if empty:
        cols["nothing"] = pa.nulls(rows, pa.float64())
    try:
        raw = parquet_bytes(cols)
    except Exception:  # noqa: BLE001 - pyarrow refusing to build it is not the reader's case
        pytest.skip("pyarrow cannot write this table")
    _read(tmp_path, "s.parquet", raw)


def test_missing_file_and_directory(tmp_path):
    for p in (tmp_path / "absent.txt", tmp_path):
        for fmt in ("auto", "d3", "csv", "mdf4", "parquet"):
            assert isinstance(outcome(read_raw, p, fmt), VehvalError)


IMPORT_TEMPLATE = """template_version: 1
files:
  - match: "*.txt"
    source: dyno
    format: auto
    time: {column: Time, unit: s}
    channels:
      Dyno_Speed: {name: veh_spd_test, unit: mph}
      Engine_Speed: {name: eng_spd_out_test, unit: rpm}
      Bty_Curr: {name: ess_curr_test, unit: A, invalid_values: [-3]}
      Cell_Temp: {name: amb_temp_test, unit: degC}
"""


@FUZZ
@given(edits=st.lists(st.tuples(st.integers(1, 30), st.integers(0, 4), _WEIRD), max_size=5),
       cut=st.one_of(st.none(), st.floats(0, 1)))
def test_import_with_template_on_damaged_d3(tmp_path, edits, cut):
    """The whole import (reader + template + SI conversion) on damaged files: a Test whose
    signals are 1-D float arrays on increasing time, or a VehvalError."""
    from vehval.io.importer import import_test

    tmpl = tmp_path / "t.yaml"
    tmpl.write_text(IMPORT_TEMPLATE, encoding="utf-8")
    rows = [ln.split("\t") for ln in d3_text(n=30, eol="\n").splitlines()]
    for r, c, val in edits:
        rows[r][c] = val
    raw = ("\n".join("\t".join(r) for r in rows) + "\n").encode()
    if cut is not None:
        raw = raw[: int(cut * len(raw))]
    p = tmp_path / "run.txt"
    p.write_bytes(raw)
    res = outcome(import_test, [p], tmpl)
    if isinstance(res, VehvalError):
        return
    for sig in res:
        assert sig.time.ndim == 1 and sig.time.shape == sig.values.shape
        assert np.all(np.diff(sig.time) > 0), f"{sig.name}: time not increasing"
