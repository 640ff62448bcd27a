"""Hypothesis on CLI argument values: any value given to an option ends in a result or one
clear error line, never an internal error (exit 3), a traceback or a hang.

The commands run in-process (``vehval.cli.main``); the values are mostly hostile (empty,
control characters, huge or non-finite numbers, path tricks, SQL, markup) with the odd valid
one, so the few examples that do run stay short.
"""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from vehval.cli import main

from .helpers import FUZZ, no_hang

TEMPLATE = """template_version: 1
files:
  - source: dyno
    format: d3
    time: {column: Time, unit: s}
    channels:
      Dyno_Speed: {name: veh_spd_test, unit: mph}
      Fuel_Flow: {name: fuel_rate_test, unit: g/s}
"""


def _write_test(path) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    rows = ["Time[s]\tDyno_Speed[mph]\tFuel_Flow[g/s]"]
    rows += [f"{t}\t{30 * math.sin(math.pi * t / 59) ** 2:.4f}\t{0.1 + t / 600:.4f}"
             for t in range(60)]
    path.write_text("\n".join(rows) + "\n", encoding="utf-8")

HOSTILE = st.sampled_from(["", " ", "-", "--", "..", "../../etc/passwd", "/dev/zero", "nul",
                           "udds\x00", "a" * 5000, "'; DROP TABLE runs;--", "<script>x</script>",
                           "%s%n", "${HOME}", "nan", "inf", "-1e309", "1e309", "0", "-0",
                           "steady:0kph:0s", "steady:1e9kph:1e9s", "udds,udds", ",", "é漢字"])
TEXT = st.one_of(HOSTILE, st.text(min_size=0, max_size=40))
NUMBER = st.one_of(st.floats(allow_nan=True, allow_infinity=True).map(repr),
                   st.integers(min_value=-10**12, max_value=10**12).map(str), HOSTILE)


def _run(capsys, *args: str) -> tuple[int, str]:
    with no_hang():
        code = main([str(a) for a in args])
    out = capsys.readouterr()
    text = out.out + out.err
    assert code != 3, f"internal error for {args!r}: {text[-400:]}"
    assert "Traceback" not in text, text[-400:]
    if code == 2:  # a user error is one line saying what is wrong
        assert out.err.strip(), f"exit 2 without a message for {args!r}"
    return code, text


@FUZZ
@given(cycle=TEXT, dt=NUMBER, soc=NUMBER)
def test_simulate_options(capsys, cycle, dt, soc):
    if cycle in ("udds", "hwfet", "us06") and _finite_positive(dt):
        dt = "1.0"  # a valid run stays short
    _run(capsys, "simulate", "--vehicle", "prius_2004", "--cycle", cycle, "--dt", dt,
         "--soc-initial", soc, "--json")


@FUZZ
@given(vehicle=TEXT, cycle=TEXT, steps=TEXT)
def test_batch_options(capsys, tmp_path_factory, vehicle, cycle, steps):
    root = tmp_path_factory.mktemp("b")
    _write_test(root / "in" / "t1" / "run.txt")
    (root / "T.yaml").write_text(TEMPLATE, encoding="utf-8")
    _run(capsys, "batch", root / "in", "-t", root / "T.yaml", "-o", root / "out",
         "--vehicle", vehicle, "--cycle", cycle, "--steps", steps, "--workers", "0", "-q",
         "--no-report")


@FUZZ
@given(name=TEXT)
def test_vehicle_show_and_cycles(capsys, name):
    _run(capsys, "vehicle", "show", name)
    _run(capsys, "cycles", "show", name)


@FUZZ
@given(cycles=TEXT, params=TEXT, mc=NUMBER)
def test_sensitivity_options(capsys, tmp_path_factory, cycles, params, mc):
    if cycles.strip() and "," not in cycles and not params.strip():
        params = "nothing.such"  # keep the odd valid run from simulating every parameter
    _run(capsys, "sensitivity", "--vehicle", "prius_2004", "--cycles", cycles, "--params",
         params, "--monte-carlo", mc, "--dt", "2", "-o", tmp_path_factory.mktemp("s") / "o")


def _finite_positive(x: str) -> bool:
    try:
        v = float(x)
    except ValueError:
        return False
    return math.isfinite(v) and v > 0


@pytest.mark.parametrize("args", [
    ("vehicle", "show", "/dev/zero"),                 # was: MemoryError (read without end)
    ("simulate", "--vehicle", "/dev/zero", "--cycle", "udds"),
    ("vehicle", "show", "a" * 5000),                  # was: OSError 'File name too long'
    ("simulate", "--vehicle", "prius_2004", "--cycle", "b" * 5000),
])
def test_found_by_fuzzing(capsys, args):
    code, text = _run(capsys, *args)
    assert code == 2 and "error" in text
