"""Loss-surface fit of an electric machine, machine scaling, and the system operating point."""

from __future__ import annotations

import numpy as np
import pytest

from vehval.constants import RPM_RAD_PER_S as RPM
from vehval.sim.audit import energy_audit
from vehval.sim.simulate import simulate
from vehval.vehicle.machine_fit import LossSurface, fit_loss_surface, loss_table, scaled_losses

TRUE = LossSurface(coef=(180.0, 0.0, 0.008, 4.4, 0.06, 8e-7))


def _points(rng):
    spd = rng.uniform(300, 6000, 300)
    trq = rng.uniform(10, 290, 300)
    return spd, trq, TRUE.loss(spd * RPM, trq)


def test_fit_recovers_a_known_surface():
    spd, trq, loss = _points(np.random.default_rng(3))
    fit = fit_loss_surface(spd, trq, loss)
    # exact data: the non-negative least squares must reproduce it (1e-6 relative)
    np.testing.assert_allclose(fit.loss(spd * RPM, trq), loss, rtol=1e-6)
    assert fit.rms_efficiency < 1e-6 and fit.n_points == 300


def test_fit_terms_never_negative_and_generating_mirrors_motoring():
    spd, trq, loss = _points(np.random.default_rng(4))
    noisy = loss * (1 + 0.05 * np.random.default_rng(5).standard_normal(loss.size))
    fit = fit_loss_surface(spd, trq, noisy)
    assert min(fit.coef) >= 0.0
    w = np.array([100.0, 300.0])
    assert np.allclose(fit.loss(w, [50.0, 120.0]), fit.loss(w, [-50.0, -120.0]))
    assert np.all(np.diff(fit.loss(200.0, np.linspace(0, 400, 9))) > 0)  # rises with torque


def test_scaled_machine_has_the_same_efficiency_at_corresponding_points():
    s_w, s_p = 10000 / 6500, 0.6
    w, t = 200.0, 150.0
    w1, t1 = w * s_w, t * s_p / s_w
    eff = t * w / (t * w + TRUE.loss(w, t))
    eff1 = t1 * w1 / (t1 * w1 + scaled_losses(TRUE, w1, t1, s_w, s_p))
    assert eff1 == pytest.approx(eff, rel=1e-12)


def test_loss_table_subtracts_spin_loss_and_stays_non_negative():
    tab = np.array(loss_table(TRUE.loss, [0, 3000, 6000], [-100, 0, 100],
                              spin_loss=lambda w: 1e4 * np.ones_like(w)))
    assert tab.shape == (3, 3) and np.all(tab >= 0) and tab[0, 1] == 0.0


@pytest.fixture(scope="module")
def hwfet_pair(prius):
    return {op: simulate(prius, "hwfet", dt=1.0, **{"controller.operating_point": op})
            for op in ("best_line", "system")}


def test_system_operating_point_cuts_recirculation(hwfet_pair):
    a = {op: energy_audit(r.summary)["indicators"] for op, r in hwfet_pair.items()}
    assert a["system"]["recirculation_share"] < 0.9 * a["best_line"]["recirculation_share"]
    for r in hwfet_pair.values():
        assert r.summary["trace_n_miss"] == 0
        assert abs(r.summary["energy_balance_rel"]) < 1e-9


def test_operating_point_option_is_validated(prius):
    from vehval.errors import ConfigError

    with pytest.raises(ConfigError, match="operating_point"):
        prius.with_overrides({"controller.operating_point": "fastest"})
