"""Round trip: identify a conventional car from virtual tests that it generated itself.

The packaged cruze_diesel_2014 file drives UDDS and WLTC on the virtual dyno (slow fuel
bench: 1.5 s delay + 1 s lag; force delayed 0.2 s; white noise); identification from the
two files must give back the generating parameters within the tolerances stated below.
"""

import numpy as np
import pytest

from vehval.cycles import load_cycle
from vehval.identify import identify_conventional, load_traces
from vehval.identify.spec import load_spec
from vehval.sim.maps import interp2
from vehval.synth.conventional import make_conventional_test
from vehval.vehicle import load_vehicle

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def round_trip(tmp_path_factory):
    truth = load_vehicle("cruze_diesel_2014")
    files, tpl = [], None
    for cyc in ("udds", "wltc3b"):
        out = tmp_path_factory.mktemp(cyc)
        info = make_conventional_test(truth, load_cycle(cyc), seed=3, outdir=out)
        files += info["files"]
        tpl = info["template"]
    return truth, identify_conventional(load_traces(files, tpl), "round_trip",
                                        declared=declared_spec(truth))


def declared_spec(veh) -> dict:
    """The specification a user would declare for the virtual car (its own data sheet)."""
    e = veh.engine
    return load_spec(None, {"rated_power_kw": e.max_power_w / 1e3,
                            "max_speed_rpm": e.max_speed_rpm,
                            "peak_torque_nm": max(e.max_torque_nm),
                            "wheel_radius_m": veh.driveline.wheel_radius_m,
                            "gears": len(veh.gearbox.ratios), "test_mass_kg": veh.body.mass_kg})


def test_road_load_and_inertia(round_trip):
    truth, idf = round_trip
    got = idf.vehicle.body
    # A within 5 N, B within 3 %, C within 0.01 N/(m/s)^2 (small: weakly observable on
    # cycles below 130 km/h), mass within 0.5 %
    assert got.road_load_a_n == pytest.approx(truth.body.road_load_a_n, abs=5.0)
    assert got.road_load_b_n_per_mps == pytest.approx(truth.body.road_load_b_n_per_mps, rel=0.03)
    assert got.road_load_c_n_per_mps2 == pytest.approx(truth.body.road_load_c_n_per_mps2, abs=0.01)
    assert got.mass_kg == pytest.approx(truth.body.mass_kg, rel=0.005)
    # the true values lie inside the stated 95 % intervals widened x3 (serial correlation)
    rl = idf.road_load
    assert abs(rl.values["mass_kg"] - truth.body.mass_kg) < 3 * rl.ci95["mass_kg"] + 1.0


def test_gearbox_and_converter(round_trip):
    truth, idf = round_trip
    got, want = np.array(idf.vehicle.gearbox.ratios), truth.overall_ratios()
    assert got.size == want.size
    # gears the converter locks in: 1 %; first gear (never locked) is an upper bound: +10 %
    np.testing.assert_allclose(got[1:], want[1:], rtol=0.01)
    assert want[0] * 0.98 < got[0] < want[0] * 1.10
    np.testing.assert_allclose(idf.vehicle.converter.lockup_speed_mps[1:],
                               truth.converter.lockup_speed_mps[1:], atol=1.0)
    assert idf.vehicle.converter.capacity_nm_s2_per_rad2 == pytest.approx(
        truth.converter.capacity_nm_s2_per_rad2, rel=0.05)


def test_fuel_model(round_trip):
    truth, idf = round_trip
    c_t, c_i = truth.engine_control, idf.vehicle.engine_control
    assert c_i.idle_fuel_rate_g_per_s == pytest.approx(c_t.idle_fuel_rate_g_per_s, rel=0.03)
    # overrun 12 %: the generating map (an older identification) breaks the efficiency bound
    # of the identified surface above 3000 rpm (marginal fuel 20-120 g/kWh at low torque,
    # 2.7 g/s at zero torque at 4400 rpm); the bounded surface cannot follow it there and
    # the overrun rate, smeared with fired fuel by the meter, takes part of the difference
    assert c_i.overrun_fuel_rate_g_per_s == pytest.approx(c_t.overrun_fuel_rate_g_per_s, rel=0.12)
    fm = idf.fuel_map
    assert fm.delay_s == pytest.approx(1.5, abs=0.25)   # the bench delay is found
    # fuel map where the cycles run (1000-2000 rpm, 60-160 N·m): 7 % (the generating map
    # has a P² curvature term that the identified Willans lines, linear in power, leave out)
    m_t, m_i = truth.engine.arrays(), idf.vehicle.engine.arrays()
    for rpm in (1000.0, 1500.0, 2000.0):
        for nm in (60.0, 100.0, 160.0):
            w = rpm * np.pi / 30
            a = interp2(m_t["spd"], m_t["trq"], m_t["fuel"], w, nm)
            b = interp2(m_i["spd"], m_i["trq"], m_i["fuel"], w, nm)
            assert b == pytest.approx(a, rel=0.07), (rpm, nm)


def test_driveline_drag(round_trip):
    # the virtual template states target = set + drag / share: the drag comes back within
    # the road-load fit's uncertainty (A within 5 N, B within 3 %, both x share)
    truth, idf = round_trip
    g_t, g_i = truth.gearbox, idf.vehicle.gearbox
    assert g_t.drag_force_n > 50.0
    assert g_i.drag_force_n == pytest.approx(g_t.drag_force_n, abs=3.0)
    assert g_i.drag_force_n_per_mps == pytest.approx(g_t.drag_force_n_per_mps, abs=0.2)
