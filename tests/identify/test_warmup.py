"""Warm-up fuel identification from a cold and a hot start (synthetic traces with a known
warm-up), the cold-start policy, refusals, and its use by identify and predict."""

import dataclasses

import numpy as np
import pytest

from vehval.identify import IdentificationError
from vehval.identify.traces import Trace
from vehval.identify.warmup import (
    COLD_COOLANT_C,
    cold_start_state,
    fit_warmup,
    hot_partner,
)

F, TAU = 0.3, 400.0


def _hot(cycle="udds", coolant=88.0) -> Trace:
    """A hot-start trace: the packaged Cruze's simulated UDDS (speed, fuel), two phases."""
    from vehval.sim.simulate import simulate

    res = simulate("cruze_diesel_2014", "udds", dt=0.1)
    t = res.test["veh_spd_simu"].time
    v = res.test["veh_spd_simu"].values
    fuel = res.test["fuel_rate_simu"].values
    return Trace(test_id="hot", cycle=cycle, t=t, v=v, a=np.gradient(v, t),
                 force=np.zeros_like(t), w_eng=res.test["eng_spd_out_simu"].values, fuel=fuel,
                 phase=np.where(t < 505.0, 1.0, 2.0), coolant_start_c=coolant, file="hot.txt")


def _cold(hot: Trace, f=F, tau=TAU, coolant=22.0) -> Trace:
    return dataclasses.replace(hot, test_id="cold", file="cold.txt", coolant_start_c=coolant,
                               fuel=hot.fuel * (1.0 + f * np.exp(-hot.t / tau)))


@pytest.fixture(scope="module")
def hot():
    return _hot()


def test_recovers_a_known_warmup(hot):
    fit = fit_warmup(_cold(hot), hot)
    assert fit.fraction == pytest.approx(F, rel=0.03)
    assert fit.time_constant_s == pytest.approx(TAU, rel=0.05)
    assert fit.r2 > 0.999 and not fit.note
    # per-phase evidence: measured excess (cold - hot) and fitted excess agree
    for p in fit.phases:
        assert p["fitted_excess_g"] == pytest.approx(p["cold_g"] - p["hot_g"], rel=0.03)
    total = sum(p["cold_g"] - p["hot_g"] for p in fit.phases)
    assert fit.excess_g == pytest.approx(total, rel=1e-6)
    assert "cold-start test cold against the hot-start test hot" in fit.provenance()


def test_cold_start_policy():
    assert cold_start_state(dataclasses.replace(_stub(), coolant_start_c=24.0))[0] is True
    assert cold_start_state(dataclasses.replace(_stub(), coolant_start_c=91.0))[0] is False
    state, why = cold_start_state(_stub())
    assert state is None and "no engine coolant" in why
    edge = dataclasses.replace(_stub(), coolant_start_c=COLD_COOLANT_C)
    assert cold_start_state(edge)[0] is False


def _stub() -> Trace:
    t = np.arange(0.0, 10.0, 0.1)
    z = np.zeros_like(t)
    return Trace(test_id="s", cycle="udds", t=t, v=z, a=z, force=z, w_eng=z, fuel=z, phase=z)


def test_refusals_name_the_file_and_what_to_do(hot):
    with pytest.raises(IdentificationError, match="cold.txt: cycle udds, its hot reference "
                                                  "hot.txt is a hwfet"):
        fit_warmup(_cold(hot), dataclasses.replace(hot, cycle="hwfet"))
    with pytest.raises(IdentificationError, match="cold.txt: coolant 85 °C.*not a cold start"):
        fit_warmup(_cold(hot, coolant=85.0), hot)
    with pytest.raises(IdentificationError, match="hot.txt: coolant 20 °C.*not a hot start"):
        fit_warmup(_cold(hot), dataclasses.replace(hot, coolant_start_c=20.0))
    with pytest.raises(IdentificationError, match="burns no more fuel"):
        fit_warmup(_cold(hot, f=0.0), hot)
    with pytest.raises(IdentificationError, match="no hot-start identification test on its "
                                                  "cycle.*hwfet"):
        hot_partner(_cold(hot), [dataclasses.replace(hot, cycle="hwfet")])
    assert hot_partner(_cold(hot), [dataclasses.replace(hot, cycle="hwfet"), hot]) is hot


def test_identified_warmup_is_written_and_used_by_predict(hot):
    """identify_conventional with a cold trace writes the warm-up with its provenance; the
    model then predicts the cold test with it (and the hot one without)."""
    from vehval.identify import identify_conventional
    from vehval.identify.predict import predict_trace
    from vehval.sim.simulate import simulate

    # identification needs the dyno force: the simulated wheel force of the same run
    res = simulate("cruze_diesel_2014", "udds", dt=0.1)
    hw = dataclasses.replace(hot, force=res.test["veh_frc_in_simu"].values,
                             constants={"fuel_density_kg_per_m3": 851.0,
                                        "fuel_lhv_j_per_kg": 42.8e6})
    idf = identify_conventional([hw], "virtual", cold_trace=_cold(hw))
    eng = idf.vehicle.engine
    assert eng.warmup_fuel_fraction == pytest.approx(F, rel=0.03)
    assert eng.warmup_time_constant_s == pytest.approx(TAU, rel=0.05)
    assert "cold-start test cold" in eng.sources["warmup_fuel_fraction"]
    assert idf.summary()["warmup"]["cold_test"] == "cold"
    # the coolant range the identification covered takes in its cold-start test
    assert idf.summary()["conditions"]["coolant_start_c"] == [22.0, 88.0]
    cold_pred = predict_trace(idf.vehicle, _cold(hw))
    hot_pred = predict_trace(idf.vehicle, hw)
    assert cold_pred["cold_start"] and cold_pred["starts_cold"]
    assert not hot_pred["cold_start"] and hot_pred["starts_cold"] is False
    assert cold_pred["outside_identification"] == hot_pred["outside_identification"] == {}
    # the model's warm-up excess on the cold test is the identified one
    excess = cold_pred["fuel_predicted_g"] / hot_pred["fuel_predicted_g"] - 1.0
    measured = _cold(hw).fuel.sum() / hw.fuel.sum() - 1.0
    assert excess == pytest.approx(measured, rel=0.05)
