"""SAE J1634 figures: hand-computed case, MPGe unit round trip, virtual test end to end."""

from __future__ import annotations

import json
import math
from types import SimpleNamespace

import pytest
import yaml

from vehval.cycles import load_cycle
from vehval.errors import ConfigError
from vehval.fuels.quantities import (
    KWH_PER_GALLON_EQUIVALENT,
    kwh_per_100mi_from_mpge,
    mpge,
    mpge_from_kwh_per_100mi,
    wh_per_mile,
)
from vehval.io.template import load_template
from vehval.results.j1634 import j1634_results, j1634_scope
from vehval.vehicle import load_vehicle


def test_hand_computed_case():
    # 10 miles on 2.5 kWh DC with an 80 % charger: 3.125 kWh AC -> 312.5 Wh/mi AC,
    # 250 Wh/mi DC, MPGe = 10 / (3.125 / 33.705) = 107.856
    d = 10 * 1609.344
    out = j1634_scope(2.5 * 3.6e6, d, 0.8)
    assert out["ac_energy_kwh"] == pytest.approx(3.125)
    assert out["dc_wh_per_mile"] == pytest.approx(250.0)
    assert out["ac_wh_per_mile"] == pytest.approx(312.5)
    assert out["ac_kwh_per_100mi"] == pytest.approx(31.25)
    assert out["ac_kwh_per_100km"] == pytest.approx(3.125 / (d / 1e5))
    assert out["mpge"] == pytest.approx(107.856, abs=1e-3)
    # a measured wall energy replaces the charger efficiency
    meas = j1634_scope(2.5 * 3.6e6, d, 0.8, measured_ac_j=3.0 * 3.6e6)
    assert meas["mpge"] == pytest.approx(10 / (3.0 / 33.705))
    assert meas["ac_basis"] == "measured wall energy"


def test_mpge_round_trip():
    assert KWH_PER_GALLON_EQUIVALENT == 33.705
    for value in (60.0, 112.0, 180.4, 250.0):
        assert mpge_from_kwh_per_100mi(kwh_per_100mi_from_mpge(value)) == pytest.approx(value)
    # 33.705 kWh over 100 miles is 100 MPGe
    assert mpge(33.705 * 3.6e6, 100 * 1609.344) == pytest.approx(100.0)
    assert wh_per_mile(3.6e6, 1609.344) == pytest.approx(1000.0)
    assert math.isinf(mpge(0.0, 1000.0))


def test_results_scopes_skip_missing_energy():
    res = SimpleNamespace(values={"bag1": {"distance_m": 1000.0, "ess_energy_net_j": 3.6e5},
                                  "test": {"distance_m": 1000.0, "ess_energy_net_j": None}},
                          uncertainty={})
    out = j1634_results(res)
    assert list(out["scopes"]) == ["bag1"] and out["charger_efficiency_assumed"]


@pytest.mark.parametrize("cycle", ["udds", "hwfet"])
def test_virtual_bev_results_within_half_percent(bev_file, tmp_path, cycle):
    """Virtual BEV test through import, QA and results: J1634 within 0.5 % of the key."""
    from vehval.synth.bev import make_bev_test
    from vehval.workflow import TestRun

    truth = make_bev_test(load_vehicle(bev_file), load_cycle(cycle), 3, tmp_path / "virt")
    run = TestRun.load(truth["files"], truth["template"])
    res = run.results().results
    assert not [f for f in run.qa().result.findings if f.severity.name == "ERROR"]
    j = res.j1634["scopes"]
    key = truth["j1634"]
    for scope_key, scope in zip(sorted(k for k in key if k != "test"),
                                [p.name for p in res.phases]):
        assert j[scope]["mpge"] == pytest.approx(key[scope_key]["mpge"], rel=0.005)
        assert j[scope]["dc_wh_per_mile"] == pytest.approx(key[scope_key]["dc_wh_per_mile"],
                                                           rel=0.005)
    assert j["test"]["mpge"] == pytest.approx(key["test"]["mpge"], rel=0.005)
    assert json.loads(json.dumps(res.to_dict()))["j1634"]["standard"] == "SAE J1634"
    if cycle == "udds":  # the screen: J1634 figures, no fuel economy, composite or J1711
        import contextlib
        import io

        from vehval.cli.commands_results import echo_results

        out = io.StringIO()
        with contextlib.redirect_stdout(out):
            echo_results(res)
        text = out.getvalue()
        assert "MPGe" in text and "SAE J1634" in text
        assert "fuel economy" not in text and "ftp75_from_udds" not in text
        assert "SOC:" not in text


def _bev_template(tmp_path, extra_channel: str = "", fuel: str = "") -> str:
    text = ("template_version: 1\narchitecture: battery_electric\n" + fuel
            + "files:\n  - match: '*.txt'\n    source: dyno\n    format: d3\n"
            "    time: {column: Time, unit: s}\n    channels:\n"
            "      Dyno_Speed: {name: veh_spd_test, unit: mph}\n"
            "      Volt: {name: ess_volt_test, unit: V}\n"
            "      Amp: {name: ess_curr_test, unit: A}\n" + extra_channel)
    path = tmp_path / "template.yaml"
    path.write_text(text, encoding="utf-8")
    return str(path)


def test_bev_template_with_fuel_channel_refused(tmp_path):
    path = _bev_template(tmp_path, "      Fuel: {name: fuel_rate_test, unit: g/s}\n")
    with pytest.raises(ConfigError) as exc:
        load_template(path)
    msg = str(exc.value)
    assert "\n" not in msg
    assert "fuel_rate_test" in msg and "battery_electric" in msg


def test_bev_template_with_fuel_declared_refused(tmp_path):
    with pytest.raises(ConfigError, match="burns no fuel"):
        load_template(_bev_template(tmp_path, fuel="fuel: gasoline_e10\n"))


def test_bev_template_without_battery_refused(tmp_path):
    path = tmp_path / "t.yaml"
    path.write_text(yaml.safe_dump({
        "template_version": 1, "architecture": "battery_electric",
        "files": [{"match": "*.txt", "source": "dyno", "format": "d3",
                   "time": {"column": "Time", "unit": "s"},
                   "channels": {"Dyno_Speed": {"name": "veh_spd_test", "unit": "mph"}}}]}))
    with pytest.raises(ConfigError, match="no battery signals"):
        load_template(path)


def test_bev_template_accepted(tmp_path):
    assert load_template(_bev_template(tmp_path)).architecture == "battery_electric"
