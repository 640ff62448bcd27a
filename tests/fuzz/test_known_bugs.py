"""Minimal reproductions of bugs the fuzz tests found (in vehval.io and vehval.vehicle).

An open bug is a strict xfail: it documents the bug and turns into a failure (XPASS) the
moment the bug is fixed, so the marker is then removed and the case stays as a regression
test (every case below was fixed that way; none is open now).
"""

from __future__ import annotations

import numpy as np
import pytest

from vehval.errors import VehvalError
from vehval.io.readers import read_raw


def test_utf32_text_auto_format_gives_vehval_error(tmp_path):
    """Was: detect_format let _csv.Error escape on NUL-laden text (UTF-32). Fixed."""
    p = tmp_path / "u32.txt"
    p.write_bytes("Time[s]\tSpeed[mph]\r\n0\t1\r\n".encode("utf-32"))
    try:
        read_raw(p, "auto")
    except VehvalError:
        pass


def test_unknown_encoding_gives_vehval_error(tmp_path):
    """Was: LookupError from codecs.lookup in decode_bytes. Fixed."""
    p = tmp_path / "a.txt"
    p.write_bytes(b"Time[s]\tSpeed[mph]\n0\t1\n")
    with pytest.raises(VehvalError):
        read_raw(p, "auto", encoding="no-such-codec")


@pytest.mark.parametrize("rows", [1, 2])
def test_empty_last_cell_in_last_row_is_kept(tmp_path, rows):
    """Was: the body was rstripped of tabs, so an empty last cell made the last row look
    truncated and it was silently dropped. Fixed."""
    p = tmp_path / "e.txt"
    body = "".join(f"{i}\t12.5\t\r\n" for i in range(rows))
    p.write_bytes(("Time[s]\tSpeed[mph]\tEmpty[A]\r\n" + body).encode())
    t = read_raw(p, "auto")
    assert t.data["Speed"].tolist() == [12.5] * rows
    assert np.isnan(t.data["Empty"]).all()


def test_non_utf8_vehicle_file_gives_vehval_error(tmp_path):
    """Was: UnicodeDecodeError escaped load_vehicle. Fixed."""
    vehicle = pytest.importorskip("vehval.vehicle")
    p = tmp_path / "v.yaml"
    p.write_bytes(b"name: \xff\xfe bad\n")
    with pytest.raises(VehvalError):
        vehicle.load_vehicle(p)
