"""`vehval predict`: the normalised error of every test and phase, and the set verdict
(virtual tests of the packaged Cruze; a set from a car burning 8 % more is called biased;
the packaged Cruze records no prediction interval, so U_model = 0 here)."""

from __future__ import annotations

import json
import math

import pytest

from vehval.cli import main
from vehval.cycles import load_cycle
from vehval.synth.conventional import make_conventional_test
from vehval.uncertainty.defaults import precision_default
from vehval.vehicle import load_vehicle

pytestmark = pytest.mark.slow

CYCLES = (("udds", "ftp75"), ("hwfet", "hwfet"), ("us06", "us06"))


def _tests(tmp_path_factory, veh, tag: str) -> tuple[list[str], str]:
    files, tpl = [], ""
    for k, (cyc, _) in enumerate(CYCLES):
        info = make_conventional_test(veh, load_cycle(cyc), seed=30 + k,
                                      outdir=tmp_path_factory.mktemp(f"{tag}{cyc}"))
        files.append(str(info["files"][0]))
        tpl = str(info["template"])
    return files, tpl


@pytest.fixture(scope="module")
def sets(tmp_path_factory):
    truth = load_vehicle("cruze_diesel_2014")
    fuel = [[x * 1.08 for x in r] for r in truth.engine.fuel_rate_g_per_s]
    thirsty = truth.with_overrides({"engine.fuel_rate_g_per_s": fuel})
    return {"fair": _tests(tmp_path_factory, truth, "f"),
            "biased": _tests(tmp_path_factory, thirsty, "b")}


def _predict(capsys, files, tpl, *extra):
    rc = main(["predict", "cruze_diesel_2014", *files, "-t", tpl, *extra])
    cap = capsys.readouterr()
    assert rc in (0, None), cap.err
    return cap.out


def test_en_per_test_and_phase_by_hand(sets, capsys):
    files, tpl = sets["fair"]
    rows = json.loads(_predict(capsys, files, tpl, "--json"))
    assert len(rows) == 3
    for r, (_, proc) in zip(rows, CYCLES):
        s_r = precision_default(proc, "conventional").s_r
        for row, meas, pred in [(r, r["fuel_measured_g"], r["fuel_predicted_g"])] + [
                (p, p["measured_g"], p["predicted_g"]) for p in r["phases"]]:
            u_model = (row["pi95_rel"] or 0.0) * pred
            u_meas = math.hypot(row.get("results_fuel_U_g") or 0.0, 2 * s_r * meas)
            assert row["s_r"] == pytest.approx(s_r)
            assert row["u_model_g"] == pytest.approx(u_model)
            assert row["u_meas_g"] == pytest.approx(u_meas)
            assert row["en"] == pytest.approx((pred - meas) / math.hypot(u_model, u_meas))
            assert row["consistent"] == (abs(row["en"]) <= 1)
    sv = rows[0]["set_verdict"]
    assert sv["n"] == 3 and sv["verdict"] == "consistent with the data"
    assert sv["mean_error_pct"] == pytest.approx(
        100 * sum(r["error_rel"] for r in rows) / 3, abs=1e-6)
    assert all(r["set_verdict"] == sv for r in rows)


def test_biased_model_called_biased(sets, capsys):
    files, tpl = sets["biased"]
    out = _predict(capsys, files, tpl)
    line = next(x for x in out.splitlines() if x.startswith("set verdict"))
    assert ": biased by -" in line, out
    mean = float(line.split("mean error ")[1].split(" %")[0])
    assert -9.0 < mean < -5.0   # the model's map burns 1 / 1.08 of the car's
    assert " En " in out
