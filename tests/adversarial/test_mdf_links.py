"""MDF4 block links: loops and links outside the file or to the wrong block are refused
before asammdf follows them, naming the link (and the channel); no second traceback."""

from __future__ import annotations

import os
import struct
import subprocess
import sys

import numpy as np
import pytest

from vehval.errors import InputFileError
from vehval.io.mdf import read_mdf


@pytest.fixture(scope="module")
def mdf_ok(tmp_path_factory):
    from asammdf import MDF
    from asammdf import Signal as MSig
    t10, t1 = np.arange(0, 20, 0.1), np.arange(0, 20, 1.0)
    mdf = MDF(version="4.10")
    mdf.append([MSig(samples=3 * t10, timestamps=t10, name="Dyno_Speed", unit="mph"),
                MSig(samples=800 + 0 * t10, timestamps=t10, name="Engine_Speed", unit="rpm")])
    mdf.append([MSig(samples=0.6 + 0 * t1, timestamps=t1, name="SOC", unit="%")])
    path = tmp_path_factory.mktemp("mdf") / "ok.mf4"
    mdf.save(path, overwrite=True)
    mdf.close()
    return path.read_bytes()


def _link(b: bytes, block: int, k: int) -> int:
    return struct.unpack_from("<Q", b, block + 24 + 8 * k)[0]


def _patched(tmp_path, b: bytes, block: int, k: int, value: int, name: str):
    x = bytearray(b)
    struct.pack_into("<Q", x, block + 24 + 8 * k, value)
    p = tmp_path / name
    p.write_bytes(bytes(x))
    return p


def test_valid_file_passes(tmp_path, mdf_ok):
    p = tmp_path / "ok.mf4"
    p.write_bytes(mdf_ok)
    assert set(read_mdf(p).names) == {"Dyno_Speed", "Engine_Speed", "SOC"}


def test_data_group_link_back_to_header_refused(tmp_path, mdf_ok):
    """Was: `import` and every reader looped forever."""
    p = _patched(tmp_path, mdf_ok, 64, 0, 64, "loop.mf4")
    with pytest.raises(InputFileError, match="first-data-group link points to byte 64, a 'HD' "
                                             "block where a DG block is expected"):
        read_mdf(p)


def test_data_group_loop_refused(tmp_path, mdf_ok):
    dg = _link(mdf_ok, 64, 0)
    p = _patched(tmp_path, mdf_ok, dg, 0, dg, "loop2.mf4")
    with pytest.raises(InputFileError, match="form a loop"):
        read_mdf(p)


def test_channel_link_past_the_end_names_the_channel(tmp_path, mdf_ok):
    """Was: the channels after it were dropped with a 'not in the file' warning only."""
    dg = _link(mdf_ok, 64, 0)
    cg = _link(mdf_ok, dg, 1)
    cn = _link(mdf_ok, cg, 1)
    p = _patched(tmp_path, mdf_ok, cn, 0, len(mdf_ok) + 1000, "past.mf4")
    with pytest.raises(InputFileError, match=r"next-channel link of channel '\w+' points to "
                                             r"byte [\d,]+, outside the file"):
        read_mdf(p)


def test_channel_name_link_to_wrong_block(tmp_path, mdf_ok):
    dg = _link(mdf_ok, 64, 0)
    cg = _link(mdf_ok, dg, 1)
    cn = _link(mdf_ok, cg, 1)
    p = _patched(tmp_path, mdf_ok, cn, 2, dg, "name.mf4")
    with pytest.raises(InputFileError, match="name link of .* a 'DG' block"):
        read_mdf(p)


def _cli(args, cwd):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    return subprocess.run([sys.executable, "-m", "vehval", *map(str, args)], cwd=cwd,
                          capture_output=True, text=True, env=env, timeout=120)


def test_corrupt_files_one_line_no_traceback_at_exit(tmp_path, mdf_ok):
    """In a real process (asammdf's __del__ runs at exit): exactly one line, exit 2."""
    dg = _link(mdf_ok, 64, 0)
    files = [_patched(tmp_path, mdf_ok, 64, 0, 64, "a.mf4"),
             _patched(tmp_path, mdf_ok, dg, 0, dg, "b.mf4")]
    for cut in (0.5, 0.9):
        p = tmp_path / f"cut{cut}.mf4"
        p.write_bytes(mdf_ok[: int(len(mdf_ok) * cut)])
        files.append(p)
    for f in files:
        r = _cli(["info", f], tmp_path)
        assert r.returncode == 2, r.stderr[-400:]
        assert r.stderr.count("\n") == 1 and "Exception ignored" not in r.stderr, r.stderr
