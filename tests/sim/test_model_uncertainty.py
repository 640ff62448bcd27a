"""Model uncertainty of a predicted figure: the linearisation by hand, the Monte Carlo's
floor on draws and its stated sampling error."""

from __future__ import annotations

import math

import pytest

from vehval.errors import ConfigError
from vehval.sim.model_uncertainty import MIN_DRAWS, figure_uncertainty
from vehval.sim.simulate import simulate
from vehval.vehicle import load_vehicle

KEY = "boost.efficiency"


@pytest.fixture(scope="module")
def veh():
    return load_vehicle("prius_2016")


def test_linear_by_hand(veh):
    """One parameter with a range: U = 2 |f(high) - f(low)| / 2 / sqrt(3) (uniform)."""
    fu = figure_uncertainty(veh, "hwfet", params=[KEY])
    spec = veh.boost.uncertainty["efficiency"]
    assert "range" in spec
    base = simulate(veh, "hwfet", dt=1.0, charge_balance=True).summary
    soc0 = base["soc_initial"]
    lo, hi = (simulate(veh.with_overrides({KEY: x}), "hwfet", dt=1.0, soc_initial=soc0)
              .summary["fuel_economy_soc_corrected_mpg"] for x in spec["range"])
    u = 2 * abs(hi - lo) / 2 / math.sqrt(3)
    assert fu.method == "linear" and fu.n_linearised == 1
    assert fu.u_mpg == pytest.approx(u, rel=1e-6)
    assert fu.u_rel == pytest.approx(u / base["fuel_economy_soc_corrected_mpg"], rel=1e-6)
    assert fu.contributors[0]["key"] == KEY and fu.contributors[0]["share"] == 1.0


def test_monte_carlo_refuses_few_draws_and_states_its_sampling_error(veh):
    with pytest.raises(ConfigError, match=f"99 draws is refused: at least {MIN_DRAWS}"):
        figure_uncertainty(veh, "hwfet", method="monte_carlo", draws=99)
    mc = figure_uncertainty(veh, "hwfet", method="monte_carlo", draws=120, params=[KEY])
    assert mc.n_draws == 120
    assert mc.sampling_error_rel == pytest.approx(1 / math.sqrt(2 * 119))
    lin = figure_uncertainty(veh, "hwfet", params=[KEY])
    # a uniform draw over the range: the same U as the linearisation within the sampling
    # error (3 sigma) and the curvature over the range
    assert mc.u_mpg == pytest.approx(lin.u_mpg, rel=3 * mc.sampling_error_rel + 0.05)


def test_no_ranges_no_model_uncertainty():
    fu = figure_uncertainty("cruze_diesel_2014", "hwfet")
    assert fu.method == "none" and fu.u_mpg == 0.0 and "no parameter" in fu.notes[0]


def test_unknown_method_refused(veh):
    with pytest.raises(ConfigError, match="unknown method"):
        figure_uncertainty(veh, "hwfet", method="guess")
