"""Units and nomenclature: hand-computed conversions and name parsing."""

import numpy as np
import pytest

from vehval.errors import SignalError, UnitError
from vehval.nomenclature import registry
from vehval.units import conversion, from_si, split_header, to_si


@pytest.mark.parametrize(
    "value, raw, si, expected",
    [
        (60.0, "mph", "m/s", 26.8224),             # 60 * 1609.344 / 3600
        (3000.0, "rpm", "rad/s", 314.159265),      # 3000 * 2 pi / 60
        (212.0, "F", "degC", 100.0),
        (32.0, "°F", "degC", 0.0),
        (100.0, "kph", "m/s", 27.7777778),
        (1.0, "lbf", "N", 4.4482216),
        (2.5, "g/s", "kg/s", 0.0025),
        (50.0, "%", "dimensionless", 0.5),
        (1.5, "kW", "W", 1500.0),
        (100.0, "ft-lb", "N*m", 135.581795),
    ],
)
def test_hand_conversions(value, raw, si, expected):
    # rtol 1e-7: exact definitions, only float rounding remains
    assert to_si(np.array([value]), raw, si)[0] == pytest.approx(expected, rel=1e-7, abs=1e-9)


def test_volumetric_fuel_needs_density_and_converts():
    with pytest.raises(UnitError, match="density"):
        conversion("ccps", "kg/s")
    # 1 cc/s of 745 kg/m^3 gasoline = 0.745 g/s
    assert to_si(np.array([1.0]), "ccps", "kg/s", fuel_density_kg_per_m3=745.0)[0] == pytest.approx(7.45e-4)


def test_round_trip_affine_units():
    x = np.array([-40.0, 0.0, 98.6])
    back = from_si(to_si(x, "degF", "degC"), "degC", "degF")
    np.testing.assert_allclose(back, x, rtol=0, atol=1e-9)


def test_unknown_and_incompatible_units():
    with pytest.raises(UnitError, match="unknown unit 'furlongz'"):
        conversion("furlongz", "m/s")
    with pytest.raises(UnitError, match="cannot convert 'rpm'"):
        conversion("rpm", "N")


def test_split_header():
    assert split_header("Dyno_Speed[mph]") == ("Dyno_Speed", "mph")
    assert split_header("Speed (kph)") == ("Speed", "kph")
    assert split_header("RPM") == ("RPM", None)


def test_parse_names():
    reg = registry()
    n = reg.parse("eng_spd_out_obd_test")
    assert (n.base, n.source, n.origin) == ("eng_spd_out", "obd", "test")
    assert reg.parse("mot_trq_out_calc").source is None
    assert reg.parse("eng_spd_target_obd_test").base == "eng_spd_target"
    assert reg.parse("eng_spd_out_obd_test").full == "eng_spd_out_obd_test"
    with pytest.raises(SignalError, match="must end with"):
        reg.parse("eng_spd_out")
    with pytest.raises(SignalError, match="not in the registry"):
        reg.parse("foo_bar_test")


def test_registry_covers_prius_equations():
    reg = registry()
    for base in ["mot_trq_out", "whl_trq_out", "pg_trq_ring", "eng_trq_out", "mot_spd_out",
                 "gen_spd_out", "eng_spd_out", "veh_frc_out", "veh_frc_in", "veh_frc_loss",
                 "veh_spd", "veh_acc", "fuel_rate", "ess_soc", "ess_curr", "ess_volt"]:
        spec = reg[base]
        assert spec.range[0] < spec.range[1]
    assert reg.match_alias("Engine_Speed") == "eng_spd_out"
    assert reg.match_alias("Dyno Speed") == "veh_spd"
