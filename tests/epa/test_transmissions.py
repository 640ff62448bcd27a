"""Every transmission of the lists built from specs: CVT, automated manual, manual; refusals."""

from __future__ import annotations

import numpy as np
import pytest

from helpers.epa_lists import HEADER, camry_rows, write_list
from vehval.constants import MPH_M_PER_S, RPM_RAD_PER_S
from vehval.epa import read_test_car_list
from vehval.epa import technology as tech
from vehval.epa import transmissions as tr
from vehval.epa.procedures import plan_for
from vehval.epa.specs import specs_from_tests, vehicle_from_specs
from vehval.epa.validation import predict_test
from vehval.errors import ConfigError


def _specs(tmp_path, code, gears, **cells):
    rows = camry_rows()
    for r in rows:
        r.update({"Tested Transmission Type Code": code, "# of Gears": str(gears), **cells})
    return specs_from_tests(read_test_car_list(write_list(tmp_path / f"{code}.csv", rows,
                                                          header=HEADER)))


def _nv(veh) -> float:
    """Engine rpm per mph in the top gear (lowest CVT ratio) of a built vehicle."""
    top = veh.overall_ratios()[-1]
    return top / veh.driveline.wheel_radius_m * MPH_M_PER_S / RPM_RAD_PER_S


@pytest.mark.parametrize("code,gears,family", [("A", 8, "automatic"), ("SA", 6, "automatic"),
                                               ("CVT", 1, "cvt"), ("SCV", 7, "cvt"),
                                               ("AM", 7, "automated_manual"),
                                               ("AMS", 6, "automated_manual"),
                                               ("M", 6, "manual")])
def test_every_listed_code_has_a_family(code, gears, family):
    assert tr.family_of(code, gears) == family


def test_unknown_or_non_conventional_codes_refused_in_one_line():
    with pytest.raises(ConfigError, match=r"row X1: unknown transmission type code 'ZZ'"):
        tr.family_of("ZZ", 6, "row X1")
    with pytest.raises(ConfigError, match="'OT' \\(other\\)"):
        tr.family_of("OT", 1, "row X1")
    with pytest.raises(ConfigError, match="1 gear: the automatic model has 3-10 gears"):
        tr.family_of("A", 1, "row X1")


def test_list_row_with_unknown_code_names_the_row(tmp_path):
    with pytest.raises(ConfigError) as err:
        _specs(tmp_path, "XYZ", 6)
    text = str(err.value)
    assert "EPA list row F1" in text and "'XYZ'" in text and "\n" not in text


@pytest.mark.parametrize("cells,what", [({"N/V Ratio": "0"}, "N/V"),
                                        ({"Rated Horsepower": "1"}, "rated power")])
def test_impossible_values_refused_naming_the_row(tmp_path, cells, what):
    with pytest.raises(ConfigError, match=f"EPA list row F1.*{what}"):
        _specs(tmp_path, "M", 6, **cells)


@pytest.mark.parametrize("code,gears", [("CVT", 1), ("AM", 7), ("M", 6)])
def test_each_family_keeps_n_v_and_runs_the_tests(tmp_path, code, gears):
    s = _specs(tmp_path, code, gears)
    veh = vehicle_from_specs(s)
    assert _nv(veh) == pytest.approx(24.7, rel=1e-9)
    assert all(src.strip() for src in veh.sources().values())
    for t in read_test_car_list(write_list(tmp_path / "r.csv", camry_rows(), header=HEADER)):
        proc, _ = plan_for(t)
        pred = predict_test(veh, t, proc, 0.5)
        assert pred.trace_n_miss < 20
        assert 0.6 < pred.overall_mpg / t.fe < 1.5  # a car of this size, not a broken one
        assert abs(pred.energy_balance_rel) < 0.01


def test_cvt_ratio_range_and_operating_line(tmp_path):
    veh = vehicle_from_specs(_specs(tmp_path, "CVT", 1))
    r = np.asarray(veh.gearbox.ratios)
    assert len(r) == tr.CVT_STEPS and r[0] / r[-1] == pytest.approx(tr.CVT_SPREAD)
    # at no load the ratio steps up once the next ratio turns the engine at the line speed
    up0 = np.asarray(veh.gearbox.upshift_speed_mps)
    w_next = up0 * veh.overall_ratios()[1:] / veh.driveline.wheel_radius_m / RPM_RAD_PER_S
    assert np.allclose(w_next, tr.CVT_LINE_RPM)
    # the generic belt efficiency is below the automatic's (the fitted one: docs/validation.md)
    generic = vehicle_from_specs(_specs(tmp_path, "CVT", 1), technology=False)
    assert generic.gearbox.efficiency == tr.EFFICIENCY["cvt"] < tr.EFFICIENCY["automatic"]


def test_clutch_launch_without_converter(tmp_path):
    """Automated manuals and manuals launch on a clutch: slipping only below idle in the
    gear, at CLUTCH_LAUNCH_RPM at peak torque (a converter's stall is 2500 rpm)."""
    auto = vehicle_from_specs(_specs(tmp_path, "A", 6))
    for code in ("AM", "M"):
        veh = vehicle_from_specs(_specs(tmp_path, code, 6))
        assert veh.converter.lockup_speed_mps == [0.0] * 6
        assert veh.converter.capacity_nm_s2_per_rad2 == pytest.approx(
            auto.converter.capacity_nm_s2_per_rad2 * (tr.STALL_SPEED_RPM / tr.CLUTCH_LAUNCH_RPM) ** 2)


@pytest.mark.parametrize("scale", [1.0, 1.2])
def test_manual_shift_speeds_of_the_cfr_or_earlier(tmp_path, scale):
    """The CFR's speeds (x the family's upshift scale of the technology coefficients), or
    earlier when the engine reaches MANUAL_SHIFT_FROM_RPM (x the scale) first."""
    import dataclasses

    from vehval.epa import technology as tech

    base = tech.load_coefficients()
    trs = {f: dict(v) for f, v in base.transmission.items()}
    trs["manual"]["upshift_scale"] = tech.Coefficient(scale, (scale, scale), "test")
    coef = dataclasses.replace(base, transmission=trs)
    veh = vehicle_from_specs(_specs(tmp_path, "M", 6), coefficients=coef)
    up = np.asarray(veh.gearbox.upshift_speed_mps) / MPH_M_PER_S
    ov = veh.overall_ratios()
    rpm_before = up * MPH_M_PER_S * ov[:-1] / veh.driveline.wheel_radius_m / RPM_RAD_PER_S
    for i, cfr in enumerate(tr.MANUAL_SHIFT_MPH):
        assert (up[i] <= scale * cfr + 1e-9
                or rpm_before[i] <= scale * tr.MANUAL_SHIFT_FROM_RPM + 1e-6)
    assert np.all(np.diff(up) > 0)
    rpm_after = up * MPH_M_PER_S * ov[1:] / veh.driveline.wheel_radius_m / RPM_RAD_PER_S
    assert np.all(rpm_after >= tr.MANUAL_MIN_RPM - 1e-6)  # never lugging


def test_automatic_without_technology_is_the_generic_model(tmp_path):
    """technology=False gives the first specs model's values (the calibration's start)."""
    s = _specs(tmp_path, "A", 8)
    veh = vehicle_from_specs(s, technology=False)
    assert veh.gearbox.efficiency == 0.95 and veh.gearbox.shift_time_s == 0.6
    assert "technology" not in veh.sources()["engine.fuel_rate_g_per_s"]
    tv = vehicle_from_specs(s)
    coef = tech.load_coefficients()
    eff = coef.transmission_value("automatic", "efficiency")
    assert tv.gearbox.efficiency == pytest.approx(eff.value)
    assert coef.where in tv.sources()["gearbox.efficiency"]
