"""A Monte Carlo of too few draws is refused naming the count (``--monte-carlo 2`` printed
U 0.26 mpg where the first-order U is 0.66), and the method stated is the one that gave U
(``--monte-carlo 1`` labelled the first-order U as Monte Carlo)."""

from __future__ import annotations

import numpy as np
import pytest

from vehval.errors import ConfigError
from vehval.results import compute_results
from vehval.results.uncertainty import MIN_DRAWS, Parameter, propagate

from .helpers import make_test, true_signals


def _linear(theta):
    n = len(next(iter(theta.values()))) if theta else 1
    g = theta.get("gain", np.zeros(n))
    return {"x": 10.0 * (1.0 + g)}


@pytest.mark.parametrize("draws", [1, 2, MIN_DRAWS - 1])
def test_too_few_draws_are_refused_naming_the_count(draws):
    with pytest.raises(ConfigError, match=rf"^{draws} Monte Carlo draws: at least 100"):
        propagate(_linear, [Parameter("gain", 0.01, "reading")], method="monte_carlo",
                  draws=draws)


def test_the_entry_states_the_method_that_gave_it():
    _, unc = propagate(_linear, [Parameter("gain", 0.01, "reading")], method="monte_carlo",
                       draws=MIN_DRAWS, seed=1)
    assert unc["x"]["method"] == "monte_carlo" and unc["x"]["draws"] == MIN_DRAWS
    _, unc = propagate(_linear, [], method="monte_carlo", draws=1000)
    assert unc["x"]["method"] == "first_order"        # nothing to draw: first order


def test_results_state_first_order_when_nothing_was_drawn():
    from vehval.io.template import AccuracySpec

    t, s = true_signals("udds")
    exact = {n: AccuracySpec() for n in ("veh_spd_test", "fuel_rate_test")}  # no error
    res = compute_results(make_test(t, s), fuel={"density_kg_per_m3": 850.0,
                                                 "lhv_j_per_kg": 42.8e6},
                          accuracy=exact, method="monte_carlo", draws=500)
    assert not res.parameters
    assert res.method == "first_order" and res.draws is None
    assert any("Monte Carlo asked for, but no parameter" in n for n in res.notes)


@pytest.mark.parametrize("n", ["1", "2", "99"])
def test_cli_refuses_fewer_than_100_draws(n, tmp_path, cli):
    code, out, err = cli("results", tmp_path / "x.txt", "-t", tmp_path / "t.yaml",
                         "-o", tmp_path / "o", "--monte-carlo", n)
    assert code == 2 and err.startswith(f"vehval: error: --monte-carlo {n}: must be 0 or "
                                        "within [100, 10000000] draws"), err
    assert "1/sqrt(2(n-1))" in err and err.count("\n") == 1


def test_cli_states_the_sampling_error_of_its_draws():
    from types import SimpleNamespace

    from vehval.cli.commands_results import _method_text

    assert _method_text(SimpleNamespace(method="first_order", draws=None)) == "first order"
    assert _method_text(SimpleNamespace(method="monte_carlo", draws=100)) == \
        "monte carlo (100 draws: U itself uncertain by about 7.1 %)"
