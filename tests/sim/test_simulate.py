"""Physics invariants of the forward simulation over regulatory cycles."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from vehval.errors import ConfigError, VehvalError
from vehval.sim.batch import simulate_batch
from vehval.sim.control import ENG_OFF_MINTIME, ENG_ON_MINTIME
from vehval.sim.driver import MPH, trace_misses
from vehval.sim.simulate import simulate

RPM = math.pi / 30
CYCLES = ("udds", "hwfet", "us06", "japan1015")


def sig(res, base):
    return res.test[f"{base}_simu"].values


def test_signals_named_and_on_uniform_grid(runs):
    res = runs["udds"]
    for name in ("veh_spd", "veh_acc", "veh_frc_in", "veh_frc_loss", "whl_trq_out", "whl_spd",
                 "eng_spd_out", "eng_trq_out", "eng_pwr_out", "eng_spd_target", "eng_on",
                 "fuel_rate", "gen_spd_out", "gen_trq_out", "mot_spd_out", "mot_trq_out",
                 "ess_volt", "ess_curr", "ess_pwr", "ess_soc", "boost_volt_out", "brk_frc",
                 "drv_pwr_demand", "pg_trq_ring"):
        s = res.test[f"{name}_simu"]
        assert s.source == "simu"
        assert np.allclose(np.diff(s.time), 0.1, atol=1e-9)
    for key in ("fuel_mass_kg", "distance_m", "fuel_economy_mpg", "fuel_consumption_l_per_100km",
                "soc_initial", "soc_final", "fuel_economy_soc_corrected_mpg",
                "engine_on_fraction", "engine_starts", "trace_max_miss_mps"):
        assert key in res.summary


@pytest.mark.parametrize("cycle", CYCLES)
def test_willis_every_step(runs, cycle):
    # Willis: w_mot*Nr + w_gen*Ns = w_eng*(Nr+Ns); atol 1e-6 rad/s*teeth (round-off only)
    r = runs[cycle]
    res = sig(r, "mot_spd_out") * 78 + sig(r, "gen_spd_out") * 30 - sig(r, "eng_spd_out") * 108
    assert np.max(np.abs(res)) < 1e-6
    # the ring turns at the final-drive ratio times the wheel speed (rtol: round-off)
    assert np.allclose(sig(r, "mot_spd_out"), 4.113 * sig(r, "whl_spd"), rtol=1e-12, atol=1e-9)


@pytest.mark.parametrize("cycle", ("udds", "hwfet", "us06"))
def test_energy_balance_closes(runs, cycle):
    """fuel + battery chemical energy = losses + road load + brakes + kinetic energy change.

    Tolerance 0.5 % of the energy throughput (the acceptance limit); by construction (mid-step speeds)
    it closes to round-off, so a bookkeeping error of any size shows up.
    """
    s = runs[cycle].summary
    assert abs(s["energy_balance_rel"]) < 0.005
    assert abs(s["unmet_energy_j"]) < 1e-3 * s["fuel_energy_j"]  # battery never beyond its power
    # the road load integrates to the same energy from the recorded signals (rtol 2 %: the
    # recorded force is per step, integrated here with the trapezoid rule)
    r = runs[cycle]
    e_road = np.trapezoid(sig(r, "veh_frc_loss") * sig(r, "veh_spd"), r.test["veh_spd_simu"].time)
    assert e_road == pytest.approx(s["road_energy_j"], rel=0.02)


@pytest.mark.parametrize("cycle", CYCLES)
def test_limits_respected(runs, prius, cycle):
    r = runs[cycle]
    soc = sig(r, "ess_soc")
    assert prius.battery.soc_min <= soc.min() and soc.max() <= prius.battery.soc_max
    assert sig(r, "eng_spd_out").max() <= 5000 * RPM
    assert np.abs(sig(r, "gen_spd_out")).max() <= 10000 * RPM
    assert np.abs(sig(r, "mot_spd_out")).max() <= 6500 * RPM
    assert np.abs(sig(r, "mot_trq_out")).max() <= 400 + 1e-9
    assert np.abs(sig(r, "gen_trq_out")).max() <= 55 + 1e-9
    # battery power within its limits. They are enforced on the speeds predicted for the
    # middle of the step, so the allowance grows with the step: 1 % at 0.1 s, 5 % at 0.5 s.
    p = sig(r, "ess_pwr")
    tol = 1.01 if r.dt <= 0.1 else 1.05
    assert p.max() <= 21000 * tol and p.min() >= -21000 * tol


@pytest.mark.parametrize("cycle", CYCLES)
def test_trace_within_epa_tolerance(runs, cycle):
    r = runs[cycle]
    t = r.test["veh_spd_simu"].time
    m = trace_misses(t, np.interp(t, r.cycle.time_s, r.cycle.speed_mps), sig(r, "veh_spd"),
                     2 * MPH, 1.0)
    assert m["n_miss"] == 0, m
    assert r.summary["trace_max_miss_mps"] == pytest.approx(m["max_miss_mps"], abs=1e-9)


@pytest.mark.parametrize("cycle", CYCLES)
def test_minimum_on_off_times(runs, prius, cycle):
    r = runs[cycle]
    st = sig(r, "eng_ctrl_state")
    t = r.test["eng_ctrl_state_simu"].time
    on = (st >= 2).astype(int)
    edges = np.nonzero(np.diff(on))[0] + 1
    dt = r.dt
    for a, b in zip(edges[:-1], edges[1:]):
        dur = t[b] - t[a]
        if on[a]:
            assert dur >= prius.controller.min_on_time_s - dt / 2
        elif st[a] == ENG_OFF_MINTIME and not (st[b - 1] == ENG_OFF_MINTIME and on[b]
                                                and sig(r, "ess_soc")[b - 1] < 0.46):
            assert dur >= prius.controller.min_off_time_s - dt / 2
    # entering on goes through Eng_On_MinTime, leaving through Eng_Off_MinTime
    for a in edges:
        assert st[a] in (ENG_ON_MINTIME, ENG_OFF_MINTIME)


def test_engine_runs_and_stops(runs):
    s = runs["udds"].summary
    assert 0.1 < s["engine_on_fraction"] < 0.8 and s["engine_starts"] >= 5
    assert runs["hwfet"].summary["engine_on_fraction"] > 0.7
    # plausibility (dyno, unadjusted): wide bands, the physics not the calibration
    assert 45 < s["fuel_economy_mpg"] < 90
    assert 30 < runs["us06"].summary["fuel_economy_mpg"] < 60
    eng_on = sig(runs["udds"], "eng_on") > 0
    assert np.all(sig(runs["udds"], "fuel_rate")[~eng_on] == 0.0)  # no fuel when off


def test_charge_balance_and_step_size(prius):
    r1 = simulate(prius, "udds", dt=1.0, charge_balance=True)
    s = r1.summary
    assert abs(s["soc_final"] - s["soc_initial"]) <= 0.005
    # SOC-corrected economy equals the raw one once balanced (rtol 2 %)
    assert s["fuel_economy_soc_corrected_mpg"] == pytest.approx(s["fuel_economy_mpg"], rel=0.02)
    r01 = simulate(prius, "udds", dt=0.1, soc_initial=s["soc_initial"])
    # dt = 1 s and 0.1 s agree on fuel within 5 % (same physics, coarser control timing)
    assert s["fuel_mass_kg"] == pytest.approx(r01.summary["fuel_mass_kg"], rel=0.05)


def test_soc_correction_direction(prius):
    lo = simulate(prius, "udds", dt=1.0, soc_initial=0.50).summary  # ends higher: charged
    hi = simulate(prius, "udds", dt=1.0, soc_initial=0.70).summary  # ends lower: discharged
    assert lo["soc_final"] > 0.50 and hi["soc_final"] < 0.70
    assert lo["fuel_economy_soc_corrected_mpg"] > lo["fuel_economy_mpg"]
    assert hi["fuel_economy_soc_corrected_mpg"] < hi["fuel_economy_mpg"]


def test_batch_matches_single_runs(prius):
    variants = [{}, {"controller.soc_gain_w": 1e5}, {"controller.engine_on_power_w": 12e3},
                {"engine.idle_speed_rpm": 1100.0}]
    res = simulate_batch(prius, "hwfet", variants, dt=1.0, workers=2)
    for v, r in zip(variants, res):
        single = simulate(prius, "hwfet", dt=1.0, **v).summary
        assert r["fuel_mass_kg"] == pytest.approx(single["fuel_mass_kg"], rel=1e-12)
        assert r["variant"] == v
    arr = simulate_batch(prius, "hwfet", np.array([[1e5], [2e5]]), dt=1.0,
                         columns=["controller.soc_gain_w"])
    assert arr[0]["fuel_mass_kg"] == pytest.approx(res[1]["fuel_mass_kg"], rel=1e-12)
    with pytest.raises(ConfigError, match="columns"):
        simulate_batch(prius, "hwfet", np.ones((2, 1)), dt=1.0)


def test_bad_inputs(prius):
    with pytest.raises(VehvalError, match="known cycles"):
        simulate(prius, "no_such_cycle")
    with pytest.raises(ConfigError, match="dt"):
        simulate(prius, "udds", dt=0.0)
    with pytest.raises(ConfigError, match="soc_initial"):
        simulate(prius, "udds", soc_initial=0.99)
    with pytest.raises(ConfigError, match="no parameter"):
        simulate(prius, "udds", **{"body.mass": 1000})


def test_cli_simulate_json_and_output(tmp_path, capsys):
    from vehval.cli import main

    rc = main(["simulate", "--vehicle", "prius_2004", "--cycle", "japan1015", "--dt", "1",
               "--json", "-o", str(tmp_path / "out")])
    assert rc == 0
    data = json.loads(capsys.readouterr().out)
    assert data["cycle"] == "japan1015" and data["fuel_economy_mpg"] > 0
    assert (tmp_path / "out" / "summary.json").exists()
    assert any(p.name.startswith("signals.") for p in (tmp_path / "out").iterdir())
    rc = main(["simulate", "--cycle", "nope", "--dt", "1"])
    assert rc == 2 and "known cycles" in capsys.readouterr().err


def test_cli_simulate_metric_reads_litres_per_100km(capsys, monkeypatch):
    # --units metric leads with L/100 km on every fuel line, the SOC-corrected one too
    from vehval.cli import main
    from vehval.display import ENV_VAR

    monkeypatch.setenv(ENV_VAR, "us")  # --units sets it for the run: restored after the test

    rc = main(["--units", "metric", "simulate", "--vehicle", "prius_2004", "--cycle",
               "japan1015", "--dt", "1"])
    assert rc == 0
    lines = {ln.split("  ")[1].strip(): ln for ln in capsys.readouterr().out.splitlines()
             if ln.startswith("  ") and "  " in ln.strip()}
    for key in ("fuel economy", "SOC-corrected"):
        figure = lines[key].split(key)[1].strip()
        assert figure.split(" (")[0].endswith("L/100 km") and figure.endswith("mpg)"), lines[key]
    # the trace tolerance (±2 mph, the regulatory band) in the display unit of speed too
    assert lines["trace max miss"].endswith("(outside ±3.2 km/h / ±1 s)"), lines["trace max miss"]
    assert "mph" not in lines["trace max miss"]
