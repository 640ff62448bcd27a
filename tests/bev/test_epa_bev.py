"""Battery-electric rows of the EPA Test Car Lists: vehicle from a row, units, judging."""

from __future__ import annotations

import dataclasses
import math
import subprocess
import sys
from pathlib import Path

import pytest

from vehval.epa.bev import (
    bev_from_row,
    is_bev_row,
    judge_row,
    listed_figure,
    reduction_of_row,
    validate_bev,
    wheel_radius_from_nv,
)
from vehval.epa.reader import EpaTest
from vehval.errors import ConfigError
from vehval.vehicle import load_vehicle

ROOT = Path(__file__).resolve().parents[2]


def _row(**kw) -> EpaTest:
    """A 2016 Leaf S UDDS row as the list gives it (SI)."""
    base = dict(year=2016, make="NISSAN", model="NISSAN LEAF S", vehicle_id="KMC272",
                config="0", test_number="x", originator="MFR", procedure_code=81,
                procedure="Charge Depleting UDDS", fuel_code="62", mass_kg=1644.2,
                axle_ratio=8.19, n_v_ratio=114.7, target_a_n=133.3, target_b_n_per_mps=0.7095,
                target_c_n_per_mps2=0.4910, set_a_n=47.0, set_b_n_per_mps=-0.47,
                set_c_n_per_mps2=0.4696, fe=180.4, fe_unit="MPG",
                bags=(math.nan,) * 4, co2_g_per_km=math.nan, displacement_l=99.999,
                rated_power_w=107 * 745.7, source="16tstcar.csv:3281", fuel="Electricity",
                manufacturer="nissan")
    fields = {f.name for f in dataclasses.fields(EpaTest)}
    base = {k: v for k, v in base.items() if k in fields}
    base.update(kw)
    return EpaTest(**base)


def test_row_detection_and_units():
    assert is_bev_row(_row())
    assert not is_bev_row(_row(displacement_l=1.5))       # a plug-in hybrid's engine
    assert not is_bev_row(_row(procedure_code=3))         # not charge-depleting
    assert listed_figure(_row()) == (180.4, "MPGe")
    assert listed_figure(_row(fe=22.6)) == (22.6, "kWh/100mi")  # a Tesla-style row


def test_wheel_radius_and_reduction_from_the_row():
    assert wheel_radius_from_nv(8.19, 114.7) == pytest.approx(0.305, abs=1e-3)
    # a final-drive-only axle ratio (3.61): N/V sets the ratio at the generic radius
    ratio, r, how = reduction_of_row(_row(axle_ratio=3.61, n_v_ratio=135.2))
    assert r == 0.31 and ratio == pytest.approx(135.2 * 2 * math.pi * 0.31 / 26.8224)
    assert "N/V" in how[0]
    with pytest.raises(ConfigError, match="no single-reduction"):
        reduction_of_row(_row(axle_ratio=1.07, n_v_ratio=6.4))


def test_vehicle_from_row_is_sourced_and_simulates():
    veh = bev_from_row(_row())
    src = veh.sources()
    assert "16tstcar.csv:3281" in src["body.mass_kg"]
    assert src["motor.loss_w"].startswith("ORNL") and "fitted" in src["motor.loss_w"]
    j = judge_row(veh, _row(), 0.29)
    assert j.unit == "MPGe" and j.cycle == "udds"
    assert 0.7 < j.model / j.listed < 1.3
    assert abs(j.en) < 1.0 and j.u_meas > 0


def test_negative_road_load_row_refused_in_one_line():
    with pytest.raises(ConfigError) as exc:
        bev_from_row(_row(target_b_n_per_mps=-0.5))
    assert "road_load_b" in str(exc.value) and "\n" not in str(exc.value)


def test_validate_bev_skips_other_rows(tmp_path, monkeypatch):
    doc = validate_bev("bev/nissan_leaf_2016", [_row(), _row(displacement_l=2.0)], dt=1.0)
    assert doc["stats"]["n"] == 1 and len(doc["skipped"]) == 1
    assert doc["rows"][0]["unit"] == "MPGe"
    # the screen in the reader's units: kWh/100 km of an MPGe figure, by hand
    from vehval.epa.bev import validation_text

    j = doc["rows"][0]
    kwh_100km = 33.705 / j["listed"] * 100 / 1.609344
    monkeypatch.setenv("VEHVAL_UNITS", "metric")
    assert f"{kwh_100km:8.1f} " in validation_text(doc) and "kWh/100 km" in validation_text(doc)
    monkeypatch.setenv("VEHVAL_UNITS", "us")
    assert f"{j['listed']:8.1f} " in validation_text(doc) and "kWh/100 km" not in \
        validation_text(doc)
    # -o writes the report, the JSON and the CSV
    import json

    from vehval.report.epa import write_bev_report

    names = write_bev_report(doc, tmp_path / "out")
    assert sorted(names) == ["epa_validation.csv", "epa_validation.json", "report.html"]
    assert json.loads((tmp_path / "out" / "epa_validation.json").read_text())["stats"]["n"] == 1
    assert "battery-electric" in (tmp_path / "out" / "report.html").read_text()


def test_shipped_bev_vehicles_current_and_sourced():
    r = subprocess.run([sys.executable, str(ROOT / "scripts" / "make_bev_vehicles.py"),
                        "--check"], capture_output=True, text=True)
    assert r.returncode == 0, r.stdout + r.stderr
    for name in ("nissan_leaf_2016", "nissan_leaf_2019", "bmw_i3_2016", "chevrolet_bolt_2019",
                 "chevrolet_spark_ev_2016", "fiat_500e_2016"):
        veh = load_vehicle(f"bev/{name}")
        assert veh.architecture == "battery_electric"
        assert all(str(s).strip() for s in veh.sources().values())
