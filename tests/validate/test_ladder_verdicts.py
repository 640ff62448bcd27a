"""`vehval validate`: the ladder's verdict by the normalised error of the fuel mass, the fixed
tolerances kept as the secondary check, and the set verdict (virtual dyno tests)."""

from __future__ import annotations

import json
import math

import pytest

from vehval.cli import main
from vehval.synth import make_virtual_test
from vehval.uncertainty.defaults import cycle_precision
from vehval.vehicle import load_vehicle

pytestmark = pytest.mark.slow

CYCLES = (("udds", 3), ("hwfet", 4), ("udds", 5))


def _set(tmp_path, tag: str, overrides: dict | None = None) -> list[str]:
    out = []
    for cyc, seed in CYCLES:
        vt = make_virtual_test(cycle=cyc, seed=seed, faults="none",
                               outdir=tmp_path / f"{tag}_{cyc}_{seed}",
                               vehicle_overrides=overrides)
        out.append(str(vt.files[0].parent))
    return out


def _validate(tmp_path, dirs: list[str], tag: str, *extra: str) -> dict:
    out = tmp_path / f"out_{tag}"
    assert main(["validate", *dirs, "--vehicle", "prius_2004", "-o", str(out), "--dt", "1",
                 "--smooth-hz", "1", *extra]) == 0
    return json.loads((out / "metrics.json").read_text(encoding="utf-8"))


def test_en_by_hand_and_unbiased_set_consistent(tmp_path, capsys):
    m = _validate(tmp_path, _set(tmp_path, "fair"), "fair")
    lad = m["ladder"]
    u_cyc = m["model_uncertainty"]["u_rel_by_cycle"]
    assert u_cyc["udds"] > 0 and u_cyc["hwfet"] > 0   # the vehicle's ranges, linearised
    tests = {t["test_id"]: t for t in m["tests"]}
    for e in lad["entries"]:
        meas, model = e["errors"]["fuel_test_kg"], e["errors"]["fuel_sim_kg"]
        u_rel = tests[e["test_id"]]["uncertainty_rel"]["fuel_mass_kg"]
        s_r = cycle_precision(e["cycle"], "hybrid")[0].s_r
        u_meas = math.hypot(2 * u_rel * meas, 2 * s_r * meas)
        u_model = u_cyc[e["cycle"]] * model
        assert e["u_meas_kg"] == pytest.approx(u_meas)
        assert e["u_model_kg"] == pytest.approx(u_model)
        assert e["en"] == pytest.approx((model - meas) / math.hypot(u_model, u_meas))
        assert e["verdict"] == ("consistent" if abs(e["en"]) <= 1 else "inconsistent")
        assert isinstance(e["passed"], bool)   # the tolerance check stays
    sv = lad["set_verdict"]
    assert sv["n"] == 3 and sv["verdict"] == "consistent with the data"
    out = capsys.readouterr().out
    assert "set verdict (n = 3): consistent with the data" in out
    assert "tolerance (secondary check): held-out:" in out


def test_biased_model_called_biased(tmp_path, capsys):
    """The tested car burns 10 % more than the model's engine map: every test's En is far
    beyond 1 and the set is biased by about -9 %."""
    fuel = load_vehicle("prius_2004").engine.fuel_rate_g_per_s
    thirsty = {"engine.fuel_rate_g_per_s": [[1.1 * x for x in r] for r in fuel]}
    m = _validate(tmp_path, _set(tmp_path, "bias", thirsty), "bias", "--model-uncertainty",
                  "none")
    lad = m["ladder"]
    assert all(e["verdict"] == "inconsistent" and e["en"] < -1 for e in lad["entries"])
    sv = lad["set_verdict"]
    assert sv["biased"] and sv["verdict"].startswith("biased by -")
    assert -12 < sv["mean_error_pct"] < -6
