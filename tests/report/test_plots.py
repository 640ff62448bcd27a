"""Engineering plots: hand-computed Willans line and energies, map plots with a vehicle."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from vehval.report import plots
from vehval.test import Signal, Test
from vehval.test import TestMeta as Meta

from .helpers import LHV, make_test


def test_willans_recovers_the_line():
    w = plots.willans(make_test())
    # fuel = (2.7 P + 4000 W) / LHV exactly: the fit is exact to rounding
    assert w["slope"] == pytest.approx(2.7, rel=1e-9)
    assert w["intercept"] == pytest.approx(4000.0, rel=1e-6)
    assert w["r2"] == pytest.approx(1.0, abs=1e-12)
    fig = plots.willans_figure(make_test())
    assert len(fig.data) == 2


def test_energy_flows_hand_computed():
    t = np.arange(0.0, 100.01, 0.01)
    test = Test([Signal.standard("fuel_rate_test", t, np.full(t.size, 1e-3), source="d"),   # 42.6 kW
                 Signal.standard("eng_pwr_out_test", t, np.full(t.size, 15e3), source="d"),
                 Signal.standard("ess_pwr_test", t, np.where(t < 50, 2e3, -1e3), source="d"),
                 Signal.standard("whl_pwr_out_test", t, np.where(t < 50, 10e3, -4e3), source="d")],
                Meta(constants={"fuel_lhv_j_per_kg": LHV}))
    f = plots.energy_flows(test)
    # trapezoid over steps: the switch at t = 50 s costs half a sample (rtol 1e-3)
    assert f["fuel"] == pytest.approx(1e-3 * LHV * 100, rel=1e-9)
    assert f["engine"] == pytest.approx(15e3 * 100, rel=1e-9)
    assert f["battery_out"] == pytest.approx(2e3 * 50, rel=1e-3)
    assert f["battery_in"] == pytest.approx(1e3 * 50, rel=1e-3)
    assert f["wheel_out"] == pytest.approx(10e3 * 50, rel=1e-3)
    assert f["braking"] == pytest.approx(4e3 * 50, rel=1e-3)
    fig = plots.sankey_figure(f)
    link = fig.data[0].link
    # energy conservation at the powertrain node: in = out (losses are the balance)
    nodes = list(fig.data[0].node.label)
    pt = nodes.index("Powertrain")
    inflow = sum(v for s, d, v in zip(link.source, link.target, link.value) if d == pt)
    outflow = sum(v for s, d, v in zip(link.source, link.target, link.value) if s == pt)
    assert inflow == pytest.approx(outflow, rel=1e-12)


def test_skips_are_explicit():
    empty = Test([Signal.standard("veh_spd_test", [0, 1], [0, 1])])
    with pytest.raises(plots.PlotSkipped, match="fuel"):
        plots.willans(empty)
    with pytest.raises(plots.PlotSkipped):
        plots.sankey_figure(plots.energy_flows(empty))
    with pytest.raises(plots.PlotSkipped, match="fuel map"):
        plots.engine_map_figure(empty, None)


def test_histograms():
    test = make_test()
    fig = plots.regen_current_histogram(test)
    assert fig.data[0].x.size > 0
    fig = plots.engine_power_histogram(test)
    p = np.asarray(fig.data[0].x)
    assert p.min() >= 0 and p.max() == pytest.approx((250 * 80) / 1e3, rel=0.05)


def _fake_engine():
    spd = np.linspace(1000, 5000, 9)
    trq = np.linspace(0, 110, 12)
    pw = spd[:, None] * plots.RPM * trq[None, :]
    fuel = (2.7 * pw + 3000.0) / LHV * 1e3                       # [g/s]
    return SimpleNamespace(speed_rpm=list(spd), torque_nm=list(trq), fuel_rate_g_per_s=fuel.tolist(),
                           max_torque_nm=[100.0] * 9, fuel_lhv_j_per_kg=LHV, idle_speed_rpm=1000.0,
                           max_speed_rpm=5000.0, max_power_w=57e3)


def test_engine_map_with_duck_typed_vehicle():
    veh = SimpleNamespace(engine=_fake_engine())
    fig = plots.engine_map_figure(make_test(), veh)
    z = np.asarray(fig.data[0].z, float)
    # efficiency = P / (2.7 P + 3 kW) < 1/2.7 everywhere
    assert np.nanmax(z) < 100 / 2.7 and np.nanmax(z) > 30
    assert any("engine running" in (tr.name or "") for tr in fig.data)


def test_engine_map_with_the_real_vehicle():
    vm = pytest.importorskip("vehval.vehicle")
    try:
        veh = vm.load_vehicle("prius_2004")
    except Exception as exc:  # noqa: BLE001
        pytest.skip(f"prius_2004 vehicle not available yet: {exc}")
    fig = plots.engine_map_figure(make_test(), veh)
    assert any(tr.name == "best efficiency" for tr in fig.data)
    for which in ("mot", "gen"):
        plots.machine_map_figure(make_test(), veh, which)


def test_regen_current_from_power_and_voltage():
    """Without ess_curr the braking-current histogram uses ess_pwr / ess_volt (exact here)."""
    t = np.arange(0.0, 60.0, 0.1)
    v = np.where(t < 30, t, 60 - t)                           # accelerate, then brake at 1 m/s²
    test = Test([Signal.standard("veh_spd_test", t, v, source="d"),
                 Signal.standard("ess_pwr_calc", t, np.where(t < 30, 4e3, -8e3), source="calc"),
                 Signal.standard("ess_volt_test", t, np.full(t.size, 200.0), source="d")])
    fig = plots.regen_current_histogram(test)
    x = np.asarray(fig.data[0].x, float)
    assert x.size > 250 and np.all(x == -40.0)                  # -8 kW / 200 V, braking only
    with pytest.raises(plots.PlotSkipped, match="ess_curr"):
        plots.regen_current_histogram(Test([Signal.standard("veh_spd_test", t, v)]))


def test_engine_map_points_only_while_running():
    veh = SimpleNamespace(engine=_fake_engine())
    t = np.arange(0.0, 10.0, 0.1)
    w = np.where(t < 5, 20.0, 200.0)                          # cranking at 20 rad/s, then running
    test = Test([Signal.standard("eng_spd_out_test", t, w), Signal.standard("eng_trq_out_test", t, 50 + 0 * t)])
    pts = next(tr for tr in plots.engine_map_figure(test, veh).data if "running" in (tr.name or ""))
    assert np.allclose(np.asarray(pts.x), 200.0 / plots.RPM)


def test_audit_cross_check_says_why_it_exceeds_the_measured_road_load():
    """On the Cruze UDDS the audit listed road load 1.27 MJ and 'road load from the
    coast-down coefficients (cross-check)' 3.23 MJ with no word on the 2.5x gap: a chassis
    dyno applies only the set part of the target road load."""
    from vehval.report.energy_flow import audit_rows

    audit = {"fuel_j": 30.4e6, "engine_output_j": None, "traction_j": 4.46e6,
             "sinks": {"powertrain_loss_j": 25.9e6, "road_load_j": 1.27e6, "brakes_j": 3.19e6},
             "road_load_coefficients_j": 3.23e6}
    label = audit_rows(audit)[-1][0]
    assert label.startswith("road load from the target") and "tyre and driveline losses" in label


def test_tables_2_and_3_in_display_units(monkeypatch):
    """Table 3 on the Cruze read mean_abs_diff 162.5, test_range 8346, offset -138.5 in N and
    rel_diff 0.01947 (a fraction) whatever the unit system."""
    from vehval.report.sections import _pair_rows

    row = {"base": "veh_frc_in", "measured": "veh_frc_in_test", "n": 13870,
           "mean_abs_diff": 162.458, "test_range": 8345.77, "rel_diff": 0.019466, "r2": 0.97955,
           "slope": 0.98885, "offset": -138.543, "unit": "N"}
    monkeypatch.setenv("VEHVAL_UNITS", "us")
    (us,) = _pair_rows([row])
    assert us["unit"] == "lbf" and us["mean_abs_diff"] == pytest.approx(36.522, abs=1e-3)
    assert us["offset"] == pytest.approx(-31.146, abs=1e-3) and us["r2"] == row["r2"]
    assert us["rel_diff [%]"] == pytest.approx(1.9466) and "rel_diff" not in us
    monkeypatch.setenv("VEHVAL_UNITS", "metric")
    (si,) = _pair_rows([row])
    assert si["unit"] == "N" and si["mean_abs_diff"] == row["mean_abs_diff"]
    spd = _pair_rows([{"ref": "eng_spd_out_test", "mean_abs_diff": 10.472, "unit": "rad/s"}])
    assert spd[0]["unit"] == "rpm" and spd[0]["mean_abs_diff"] == pytest.approx(100.0, rel=1e-4)


def test_finding_numbers_in_display_units():
    """The QA1 table read 'value = -1e-06; limit_min = 0; fraction = 1.442e-04' (kg/s and a
    fraction) for a fuel rate the message itself gave as -0.001 g/s."""
    from vehval.report.sections import _finding_row

    row = {"signal": "fuel_rate_test", "kind": "negative",
           "numbers": {"value": -1e-06, "limit_min": 0.0, "fraction": 0.00014419,
                       "noise_sigma": 0.0, "runs": 1, "duration_s": 2.5}}
    text = _finding_row(row)["numbers"]
    assert text == ("value = -0.001 g/s; limit_min = 0 g/s; fraction = 0.01442 %; "
                    "noise_sigma = 0 g/s; runs = 1; duration_s = 2.5 s")
    assert _finding_row({"signal": "x", "numbers": None}) == {"signal": "x", "numbers": None}


def test_calculation_parameters_in_display_units(monkeypatch):
    """'Calculations: parameters' read fuel_lhv_j_per_kg 4.280e+07."""
    from vehval.report.sections import calculations_section

    monkeypatch.setenv("VEHVAL_UNITS", "us")
    sec = calculations_section({"calculations": {"set": "conventional", "parameters": {
        "fuel_lhv_j_per_kg": {"value": 42.8e6, "from": "template constant"},
        "wheel_radius_m": {"value": 0.305, "from": "template constant"},
        "test_mass_kg": {"value": 1727.3, "from": "template constant"}}}})
    t = next(t for t in sec.tables if t.title == "Calculations: parameters")
    values = {r[0]: r[1] for r in t.rows}
    assert values == {"fuel_lhv_j_per_kg": "42.8 MJ/kg", "wheel_radius_m": "0.305 m",
                      "test_mass_kg": "3808 lb"}
