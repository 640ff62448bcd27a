"""Every numeric option of every command is bounded by the one table (cli/options.py BOUNDS)
with its reason, and a run sized past the memory budget is refused with the memory it needs."""

from __future__ import annotations

import typing

import pytest

from helpers.cli import run_cli


def _numeric_options():
    import typer.main

    from vehval.cli import _register, app

    _register()

    def walk(cmd, path):
        if hasattr(cmd, "commands"):
            for name, sub in cmd.commands.items():
                yield from walk(sub, path + [name])
            return
        for p in cmd.params:
            ann = p.type_descriptor.annotation
            kinds = set(typing.get_args(ann)) | {ann}
            if kinds & {int, float}:
                yield " ".join(path), p

    return list(walk(typer.main.get_command(app), []))


def test_every_numeric_option_has_a_bound():
    from vehval.cli.options import BOUNDS

    opts = _numeric_options()
    assert len(opts) >= 20  # dt x5, seeds x3, workers x2, Monte Carlo x2, ...
    unbounded = [f"{c} {max(p.opts, key=len)}" for c, p in opts
                 if getattr(p.callback, "__qualname__", "") != "bounded.<locals>.callback"]
    assert not unbounded
    assert all(b.lo <= b.hi and b.reason for b in BOUNDS.values())


@pytest.mark.parametrize("args, text", [
    (["simulate", "--dt", "1e-6"], "--dt 1e-06: must be within [0.001, 1] s"),
    (["simulate", "--dt", "nan"], "--dt nan: must be within"),
    (["simulate", "--soc-initial", "2"], "state of charge is a fraction"),
    (["sensitivity", "--seed", "-1"], "--seed -1: must be within [0, 4294967295]"),
    (["sensitivity", "--monte-carlo", "10000000"], "one simulation per cycle"),
    (["results", "x", "-t", "y", "-o", "z", "--monte-carlo", "1000000000"], "GUM Supplement 1"),
    (["results", "x", "-t", "y", "-o", "z", "--monte-carlo", "2"],
     "--monte-carlo 2: must be 0 or within [100, 10000000] draws"),
    (["batch", "d", "-t", "t", "-o", "o", "-j", "-1"], "--workers -1: must be within [0, 64]"),
    (["epa", "validate", "x", "--vehicle", "v", "--tests", "t", "--dt", "1e-5"], "--dt 1e-05"),
    (["epa", "calibrate", "x", "--vehicle", "v", "--tests", "t", "--param", "a=1",
      "--refine", "9"], "--refine 9: must be within [0, 6] rounds"),
    (["synth", "--seed", str(2**40), "-o", "x"], "--seed 1099511627776"),
    (["qa", "x", "-t", "y", "-o", "z", "--max-offset", "-1"], "--max-offset -1.0"),
])
def test_out_of_bounds_refused_with_reason(capsys, args, text):
    rc, out, err = run_cli(args, capsys)
    assert rc == 2 and err.startswith("vehval: error: ") and text in err, err
    assert err.count("\n") == 1 and "Traceback" not in err


def test_budget_refuses_with_the_memory_needed(capsys, monkeypatch, tmp_path):
    monkeypatch.setenv("VEHVAL_MEMORY_CAP_MB", "20")
    rc, out, err = run_cli(["simulate", "--dt", "0.001", "-o", tmp_path / "o"], capsys)
    assert rc == 2 and "would need about 0.8 GiB of memory" in err, err
    assert "over the budget of 20 MiB" in err and "larger --dt" in err
    assert not (tmp_path / "o").exists()


def test_long_cycle_refused_before_allocation(capsys, tmp_path):
    cyc = tmp_path / "long.csv"
    cyc.write_text("time_s,speed_mps\n0,0\n86000,10\n")  # 24 h: 8.6e7 steps at 1 ms
    rc, out, err = run_cli(["simulate", "--cycle", cyc, "--dt", "0.001"], capsys)
    assert rc == 2 and "8.6e+07 samples" in err and "GiB of memory" in err, err


def test_tiny_dt_that_fits_still_runs(capsys):
    rc, out, err = run_cli(["simulate", "--dt", "0.001", "--cycle", "steady:30kph:20s",
                            "--json"], capsys)
    assert rc == 0 and '"dt_s": 0.001' in out, err


def test_budget_reads_the_address_space_limit():
    import resource

    from vehval.sim import budget

    soft, hard = resource.getrlimit(resource.RLIMIT_AS)
    assert budget.budget_bytes() <= budget.MEMORY_CAP_BYTES
    try:
        resource.setrlimit(resource.RLIMIT_AS, (2**40, hard))
        left = budget._address_space_left()
        assert left is not None and 0 < left < 2**40
        assert budget.budget_bytes() <= left // 2
    finally:
        resource.setrlimit(resource.RLIMIT_AS, (soft, hard))


def test_identify_option_bounds_equal_the_spec_file_ranges():
    # the command-line options and the spec file's keys accept the same values
    from vehval.cli.options import BOUNDS
    from vehval.identify.spec import _RANGES

    for key in ("rated_power_kw", "rated_speed_rpm", "peak_torque_nm", "displacement_l", "gears"):
        assert (BOUNDS[key].lo, BOUNDS[key].hi) == _RANGES[key], key
