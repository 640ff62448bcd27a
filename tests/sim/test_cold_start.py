"""Cold-start model of the power-split and conventional kernels: warm-up fuel by hand,
engine-on hold, energy closure; a hot run is unchanged."""

from __future__ import annotations

import numpy as np
import pytest

from vehval.cycles import load_cycle
from vehval.sim.layout import SIGNALS
from vehval.sim.simulate import run_once, summarise, time_grid
from vehval.vehicle import load_vehicle

DT = 0.5
FUEL = SIGNALS.index("fuel_rate")
ON = SIGNALS.index("eng_on")


@pytest.fixture(scope="module")
def udds():
    return time_grid(load_cycle("udds"), DT)


def test_warmup_fuel_by_hand(udds):
    """Without a hold the warm-up fuel does not feed back on the dynamics: every step's fuel
    is the hot run's x (1 + f exp(-(i + 1/2) dt / tau)), the rest identical."""
    t, vt = udds
    veh = load_vehicle("prius_2004").with_overrides({
        "engine.warmup_fuel_fraction": 0.5, "engine.warmup_time_constant_s": 100.0})
    hot, ys_hot = run_once(veh, t, vt, DT, 0.6)
    cold, ys_cold = run_once(veh, t, vt, DT, 0.6, cold_start=True)
    factor = 1.0 + 0.5 * np.exp(-(np.arange(t.size - 1) + 0.5) * DT / 100.0)
    # row i + 1 holds step i's values
    np.testing.assert_allclose(cold[1:, FUEL], hot[1:, FUEL] * factor, rtol=1e-12)
    others = [k for k in range(len(SIGNALS)) if k != FUEL]
    np.testing.assert_array_equal(cold[:, others], hot[:, others])
    assert ys_cold[0] > ys_hot[0] * 1.02  # fuel mass: the extra is visible on a UDDS
    s = summarise(veh, ys_cold, 0.6)
    assert abs(s["energy_balance_rel"]) < 1e-9  # the extra fuel is booked as engine loss


def test_hold_keeps_the_engine_on(udds):
    t, vt = udds
    veh = load_vehicle("prius_2004").with_overrides({"controller.cold_start_engine_on_s": 60})
    hot, _ = run_once(veh, t, vt, DT, 0.6)
    cold, ys = run_once(veh, t, vt, DT, 0.6, cold_start=True)
    held = (t > 2.0) & (t < 60.0)  # after the start-up transition
    assert np.all(cold[held, ON] > 0.5) and not np.all(hot[held, ON] > 0.5)
    assert abs(summarise(veh, ys, 0.6)["energy_balance_rel"]) < 1e-9


def test_hold_power_floor_loads_the_engine_and_charges(udds):
    """With a power floor the held engine runs loaded (the floor, here above the 2004
    engine's 11 kW minimum) from the first firing to the end of the hold, the surplus
    charging the battery; after the hold the controller is back; energy still closes."""
    t, vt = udds
    base = load_vehicle("prius_2004").with_overrides({"controller.cold_start_engine_on_s": 60})
    veh = base.with_overrides({"controller.cold_start_engine_power_w": 14000.0})
    idle, _ = run_once(base, t, vt, DT, 0.6, cold_start=True)
    loaded, ys = run_once(veh, t, vt, DT, 0.6, cold_start=True)
    pwr, soc = SIGNALS.index("eng_pwr_out"), SIGNALS.index("ess_soc")
    settled = (t > 5.0) & (t < 60.0)  # after the start-up transition
    held_pwr = loaded[settled, pwr]
    assert np.percentile(held_pwr, 5) > 0.99 * 14000.0  # the floor, bar short dips where
    assert held_pwr.min() > 0.85 * 14000.0  # a machine or battery limit binds
    assert np.median(idle[settled, pwr]) < 14000.0  # without the floor: less (idle at rest)
    end = np.searchsorted(t, 60.0)
    assert loaded[end, soc] > idle[end, soc] + 0.02  # the surplus went to the battery
    assert abs(summarise(veh, ys, 0.6)["energy_balance_rel"]) < 1e-9
    hot_a, _ = run_once(base, t, vt, DT, 0.6)
    hot_b, _ = run_once(veh, t, vt, DT, 0.6)
    np.testing.assert_array_equal(hot_a, hot_b)  # a hot run has no hold, hence no floor


def test_hold_power_floor_below_the_engine_minimum_is_refused():
    from vehval.errors import ConfigError

    with pytest.raises(ConfigError, match="cold_start_engine_power_w.*below.*engine_min_power_w"):
        load_vehicle("prius_2004").with_overrides({"controller.cold_start_engine_power_w": 5000})


def test_hot_run_ignores_the_model(udds):
    t, vt = udds
    base = load_vehicle("prius_2004")
    veh = base.with_overrides({"engine.warmup_fuel_fraction": 0.5,
                               "controller.cold_start_engine_on_s": 60})
    a, _ = run_once(base, t, vt, DT, 0.6, cold_start=True)  # no model: cold == hot
    b, _ = run_once(veh, t, vt, DT, 0.6)
    np.testing.assert_array_equal(a, b)


def test_simulate_cli_cold_start(capsys):
    """`vehval simulate --cold-start` on the 2016 Prius (which models the cold start)."""
    import json

    from vehval.cli import main

    res = {}
    for flag in ([], ["--cold-start"]):
        assert main(["simulate", "--vehicle", "prius_2016", "--cycle", "udds", "--dt", "0.5",
                     "--charge-balance", "--json", *flag]) == 0
        s = json.loads(capsys.readouterr().out)
        res[bool(flag)] = s
    assert res[True]["cold_start"] is True and res[False]["cold_start"] is False
    assert res[True]["fuel_mass_kg"] > 1.03 * res[False]["fuel_mass_kg"]
    assert abs(res[True]["energy_balance_rel"]) < 1e-9


def test_conventional_warmup_fuel_by_hand():
    """The conventional loop: every step's fuel (idle and overrun included) is the hot run's
    x (1 + f exp(-(i + 1/2) dt / tau)), every other signal identical, energy still closed;
    without ``cold_start`` the warm-up does not apply."""
    from vehval.sim.conventional_kernel import CONV_SIGNALS
    from vehval.sim.simulate import simulate

    fuel = CONV_SIGNALS.index("fuel_rate")
    base = load_vehicle("cruze_diesel_2014")
    veh = base.with_overrides({"engine.warmup_fuel_fraction": 0.4,
                               "engine.warmup_time_constant_s": 250.0})
    hot = simulate(veh, "udds", dt=DT)
    cold = simulate(veh, "udds", dt=DT, cold_start=True)
    h = np.column_stack([hot.test[f"{b}_simu"].values for b in CONV_SIGNALS])
    c = np.column_stack([cold.test[f"{b}_simu"].values for b in CONV_SIGNALS])
    factor = 1.0 + 0.4 * np.exp(-(np.arange(h.shape[0] - 1) + 0.5) * DT / 250.0)
    np.testing.assert_allclose(c[1:, fuel], h[1:, fuel] * factor, rtol=1e-12)
    others = [k for k in range(len(CONV_SIGNALS)) if k != fuel]
    np.testing.assert_array_equal(c[:, others], h[:, others])
    assert cold.summary["cold_start"] and not hot.summary["cold_start"]
    assert abs(cold.summary["energy_balance_rel"]) < 1e-9
    assert cold.summary["fuel_mass_kg"] > 1.05 * hot.summary["fuel_mass_kg"]
    plain = simulate(base, "udds", dt=DT, cold_start=True)  # no warm-up model: cold == hot
    assert plain.summary["fuel_mass_kg"] == hot.summary["fuel_mass_kg"]


def test_cold_start_on_a_car_without_a_cold_model_says_so(capsys):
    """`simulate --cold-start` on a car with no warm-up model ran as a hot start, silently."""
    from vehval.cli import main

    assert main(["simulate", "--vehicle", "prius_2004", "--cycle", "ece15", "--dt", "1",
                 "--cold-start"]) == 0
    assert "prius_2004 has no cold-start model" in capsys.readouterr().err
    assert main(["simulate", "--vehicle", "prius_2004", "--cycle", "ece15", "--dt", "1",
                 "--cold-start", "--set", "engine.warmup_fuel_fraction=0.2"]) == 0
    assert "no cold-start model" not in capsys.readouterr().err
