"""Through the virtual dyno's files: import (+QA), validate, CLI; variability of repeats."""

from __future__ import annotations

import json

import numpy as np
import pytest

from vehval.cli import main
from vehval.validate import validate_test, variability
from vehval.validate.loading import group_args, load_one

synth = pytest.importorskip("vehval.synth")


@pytest.fixture(scope="module")
def repeats(tmp_path_factory):
    """Five virtual repeats of ECE-15 (no faults), differing only in the sensor-noise seed."""
    root = tmp_path_factory.mktemp("repeats")
    dirs = []
    for seed in range(5):
        out = root / f"rep{seed}"
        synth.make_virtual_test("prius_2004", "ece15", seed=seed, faults="none", outdir=out)
        dirs.append(out)
    return dirs


def _hand_totals(test, dt=0.1):
    """Fuel mass [kg] and SOC change [-] by hand, with the documented grid and formulas."""
    spd = test["veh_spd_test"]
    n = int(np.floor((spd.time[-1] - spd.time[0]) / dt + 1e-9)) + 1
    grid = spd.time[0] + dt * np.arange(n)
    fr = test["fuel_rate_test"]
    f = np.interp(grid, fr.time, fr.values, left=np.nan, right=np.nan)
    fuel = np.trapezoid(np.nan_to_num(f), grid)
    soc = [s for s in test.signals.values() if s.name.startswith("ess_soc")][0]
    sg = np.interp(grid, soc.time, soc.values, left=np.nan, right=np.nan)
    ok = np.flatnonzero(np.isfinite(sg))
    return fuel, sg[ok[-1]] - sg[ok[0]]


def test_variability_of_five_virtual_repeats(repeats):
    tests = [load_one([d], qa=False).test for d in repeats]
    v = variability(tests)
    hand = np.array([_hand_totals(t) for t in tests])
    # same grid, same trapezoidal rule: equal to float rounding (rtol 1e-9)
    np.testing.assert_allclose(v.values["fuel_mass_kg"], hand[:, 0], rtol=1e-9)
    st = v.stats["fuel_mass_kg"]
    assert st["mean"] == pytest.approx(hand[:, 0].mean(), rel=1e-9)
    assert st["std"] == pytest.approx(np.std(hand[:, 0], ddof=1), rel=1e-9)
    assert st["cv"] == pytest.approx(np.std(hand[:, 0], ddof=1) / hand[:, 0].mean(), rel=1e-9)
    assert st["spread"] == pytest.approx(np.ptp(hand[:, 0]), rel=1e-9)
    assert v.stats["soc_delta"]["std"] == pytest.approx(np.std(hand[:, 1], ddof=1), rel=1e-6, abs=1e-12)
    # only sensor noise differs: the repeats agree to well under 1 % in fuel
    assert 0.0 < st["cv"] < 0.01
    assert len(v.test_ids) == 5 and len(set(v.test_ids)) == 5


def test_end_to_end_virtual_dyno_validation_and_cli(tmp_path):
    truth = {"engine_on_power_w": 11000.0}
    d = tmp_path / "vt"
    synth.make_virtual_test("prius_2004", "japan1015", seed=3, faults="none", outdir=d,
                            controller_overrides=truth)
    lt = load_one([d])  # import + QA pipeline
    assert lt.qa is not None and "veh_spd_test" in lt.test
    nominal = validate_test(lt.test, "prius_2004", dt=0.5)
    true = validate_test(lt.test, "prius_2004", dt=0.5, overrides={"controller.engine_on_power_w": 11000.0})
    # through real sensors (noise, quantised OBD SOC, 10 Hz speed ripple) the true
    # parameters still bring the engine behaviour closer than the nominal ones
    assert true.comparison.on_agreement > nominal.comparison.on_agreement
    assert abs(true.comparison.fuel_error) < abs(nominal.comparison.fuel_error)

    out = tmp_path / "out"
    rc = main(["validate", str(d), "-o", str(out), "--dt", "0.5", "--soc-tol", "50"])
    assert rc == 0
    payload = json.loads((out / "validation.json").read_text())
    assert {t["title"].split(" (")[0] for t in payload["tables"]} >= {
        "Test vs simulation summary", "Component effort and flow", "Validation ladder"}
    assert payload["figures"] and payload["figures"][0]["figure"]["data"]
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["tests"][0]["totals_test"]["fuel_mass_kg"] > 0
    assert list(out.glob("overlays_*.parquet"))


def test_cli_calibrate_writes_outputs_and_errors(tmp_path, capsys):
    d = tmp_path / "vt"
    synth.make_virtual_test("prius_2004", "ece15", seed=1, faults="none", outdir=d)
    out = tmp_path / "cal"
    rc = main(["calibrate", str(d), "-o", str(out), "--params", "engine_on_power_w",
               "--maxiter", "2", "--popsize", "3", "--no-qa", "--json"])
    assert rc == 0
    doc = json.loads((out / "calibration.json").read_text())
    assert doc["parameters"] == ["controller.engine_on_power_w"]
    assert (out / "vehicle_calibrated.yaml").is_file()
    assert json.loads(capsys.readouterr().out)["best"]
    rc = main(["calibrate", str(d), "-o", str(tmp_path / "bad"), "--params", "nope_param", "--no-qa"])
    assert rc == 2 and not (tmp_path / "bad" / "calibration.json").exists()
    assert "unknown" in capsys.readouterr().err


def test_grouping_rule(tmp_path):
    a, b = tmp_path / "a.txt", tmp_path / "b.csv"
    a.write_text("x")
    b.write_text("x")
    d = tmp_path / "dir"
    d.mkdir()
    groups = group_args([d, a, b, tmp_path / "t.parquet"], ["x.txt,y.csv"])
    assert groups == [[d], [tmp_path / "t.parquet"], [a, b],
                      [tmp_path.__class__("x.txt"), tmp_path.__class__("y.csv")]]
