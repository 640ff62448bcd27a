"""Minimal reproductions of bugs the fuzz tests found in other modules (owner: H1, vehval.io).

Each is a strict xfail: it documents the bug, and turns into a failure (XPASS) the moment
the bug is fixed, so the marker is then removed and the case stays as a regression test.
The property tests in test_fuzz_readers.py keep these inputs out of their strategies until
then, so the rest of the contract stays enforced.
"""

from __future__ import annotations

import numpy as np
import pytest

from vehval.errors import VehvalError
from vehval.io.readers import read_raw


@pytest.mark.xfail(strict=True, raises=Exception,
                   reason="H1 bug: detect_format lets _csv.Error escape on NUL-laden text "
                          "(UTF-32 file) instead of an InputFileError")
def test_utf32_text_auto_format_gives_vehval_error(tmp_path):
    p = tmp_path / "u32.txt"
    p.write_bytes("Time[s]\tSpeed[mph]\r\n0\t1\r\n".encode("utf-32"))
    try:
        read_raw(p, "auto")
    except VehvalError:
        pass


@pytest.mark.xfail(strict=True, raises=Exception,
                   reason="H1 bug: an unknown encoding name raises LookupError from "
                          "codecs.lookup in decode_bytes instead of a VehvalError")
def test_unknown_encoding_gives_vehval_error(tmp_path):
    p = tmp_path / "a.txt"
    p.write_bytes(b"Time[s]\tSpeed[mph]\n0\t1\n")
    try:
        read_raw(p, "auto", encoding="no-such-codec")
    except VehvalError:
        pass


@pytest.mark.xfail(strict=True,
                   reason="H1 bug: read_delimited rstrips b'\\r\\n\\t ' from the body, so a last "
                          "row whose last cell is empty (tab-delimited) loses its trailing tab, "
                          "is taken for a truncated line and silently dropped (or, as the only "
                          "row, rejected as 'truncated file')")
@pytest.mark.parametrize("rows", [1, 2])
def test_empty_last_cell_in_last_row_is_kept(tmp_path, rows):
    p = tmp_path / "e.txt"
    body = "".join(f"{i}\t12.5\t\r\n" for i in range(rows))
    p.write_bytes(("Time[s]\tSpeed[mph]\tEmpty[A]\r\n" + body).encode())
    t = read_raw(p, "auto")
    assert t.data["Speed"].tolist() == [12.5] * rows
    assert np.isnan(t.data["Empty"]).all()
