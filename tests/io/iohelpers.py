"""Helpers for the import tests (importable as ``iohelpers``: tests/io is on sys.path)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

D3_HEADER = ["Time[sec]", "Dyno_Speed[mph]", "Engine_Speed[rpm]", "Cell_Temp[F]", "Phase_#"]


def d3_rows(n: int = 50, t0: float = -1.0, dt: float = 0.1) -> list[list[float]]:
    """Rows of a small D3-like table: speed ramps 0..60 mph, engine 3000 rpm, 77 °F."""
    rows = []
    for i in range(n):
        rows.append([round(t0 + i * dt, 3), 60.0 * i / (n - 1), 3000.0, 77.0, float(i >= n // 2)])
    return rows


def write_d3(path: Path, rows=None, header=None, delim: str = "\t", eol: str = "\r\n",
             prefix: bytes = b"", encoding: str = "utf-8") -> Path:
    """Write a D3-style text file and return its path."""
    rows = d3_rows() if rows is None else rows
    header = D3_HEADER if header is None else header
    lines = [delim.join(header)] + [delim.join(repr(v) if isinstance(v, float) else str(v)
                                               for v in r) for r in rows]
    path.write_bytes(prefix + (eol.join(lines) + eol).encode(encoding))
    return path


D3_TEMPLATE = """\
template_version: 1
description: test template
constants: {test_mass_kg: 1295, fuel_density_kg_per_m3: 745}
files:
  - source: dyno
    format: auto
    time: {column: Time, unit: s}
    channels:
      Dyno_Speed: {name: veh_spd_test, unit: mph}
      Engine_Speed: {name: eng_spd_out_test, unit: rpm}
      Cell_Temp: {name: amb_temp_test, unit: degF}
      Phase_#: {delete: true, reason: not needed}
"""



def assert_clean_failure(code: int, out: str, err: str, *needles: str) -> None:
    """A user error: non-zero exit, one ``vehval: error:`` message, no traceback."""
    assert code != 0
    assert "Traceback" not in out + err
    assert "vehval: error:" in err, err
    for n in needles:
        assert n in err, f"{n!r} not in {err!r}"


def sine(n: int) -> np.ndarray:
    return np.sin(np.arange(n) * 0.1)
