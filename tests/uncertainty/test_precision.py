"""Repeatability, reproducibility, En and the set verdict on synthetic results of known truth
(numpy only: each figure below is a draw of what a lab measures, with the scatter injected)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vehval.errors import VehvalError
from vehval.uncertainty import (
    InsufficientDataError,
    LabPair,
    measurement_uncertainty,
    normalised_error,
    repeatability,
    reproducibility,
    set_verdict,
)

TRUTH = 50.0  # a fuel economy [mpg]


def _groups(rng, s, n_groups=8, k=3):
    """Repeated results of n_groups cars (each its own true figure), k tests each, with a
    relative test-to-test scatter s."""
    truths = TRUTH * rng.uniform(0.6, 1.6, n_groups)
    return [list(t * (1 + s * rng.standard_normal(k))) for t in truths]


@pytest.mark.parametrize("s", [0.005, 0.01, 0.03])
def test_s_r_lies_within_its_90_pct_interval_for_85_of_100_seeds(s):
    hits = 0
    for seed in range(100):
        p = repeatability(_groups(np.random.default_rng(seed), s), confidence=0.90)
        assert p.groups + p.excluded == 8
        hits += p.contains(s)
    assert hits >= 85, hits


def test_s_r_interval_is_not_trivially_wide():
    """The check above can fail: a 3 % scatter is outside the 90 % interval of 1 % data."""
    p = repeatability(_groups(np.random.default_rng(1), 0.01), confidence=0.90)
    assert not p.contains(0.03) and p.ci_high < 0.02


def test_fewer_than_three_pairs_is_refused_with_the_count():
    with pytest.raises(InsufficientDataError, match=r"2 pair\(s\).*2 group\(s\).*at least 3"):
        repeatability([[50.0, 50.5], [40.0, 40.2], [30.0]])
    with pytest.raises(InsufficientDataError, match=r"2 setting\(s\).*at least 3"):
        reproducibility([LabPair((50.0,), (51.0,)), LabPair((40.0,), (40.5,))])


def test_outlier_group_is_screened_and_counted():
    rng = np.random.default_rng(5)
    groups = _groups(rng, 0.01, n_groups=30, k=2) + [[25.0, 40.1]]   # a highway figure filed
    kept = repeatability(groups)
    every = repeatability(groups, outlier_level=None)
    assert kept.excluded == 1 and kept.dof == 30
    assert kept.s < 0.015 < every.s


def test_s_R_from_lab_pairs_covers_the_truth():
    s_r, s_L = 0.01, 0.02
    s_R = math.hypot(s_r, s_L)
    hits = 0
    for seed in range(100):
        rng = np.random.default_rng(seed)
        pairs = []
        for _ in range(20):
            t = TRUTH * rng.uniform(0.6, 1.6)
            a = t * (1 + s_L * rng.standard_normal()) * (1 + s_r * rng.standard_normal())
            b = t * (1 + s_L * rng.standard_normal()) * (1 + s_r * rng.standard_normal())
            pairs.append(LabPair((a,), (b,)))
        p = reproducibility(pairs, s_r=s_r, confidence=0.90)
        assert p.s >= s_r                      # s_L^2 clamped at 0
        hits += p.contains(s_R)
    assert hits >= 85, hits


def test_unbiased_model_is_consistent_in_95_pct_of_comparisons():
    """600 comparisons: model with its own U, measurement with a meter U and a repeatability
    estimated from separate repeats."""
    rng = np.random.default_rng(42)
    inside = n = 0
    for level in (0.005, 0.01, 0.03):
        s_r = repeatability(_groups(rng, level, n_groups=40, k=2)).s
        for _ in range(200):
            truth = TRUTH * rng.uniform(0.6, 1.6)
            u_model, u_meter = 0.01, 0.005       # standard uncertainties [-]
            model = truth * (1 + u_model * rng.standard_normal())
            measured = truth * (1 + u_meter * rng.standard_normal()) * (
                1 + level * rng.standard_normal())
            u_meas = measurement_uncertainty(measured, u_result=2 * u_meter * measured, s_r=s_r)
            c = normalised_error(model, measured, 2 * u_model * truth, u_meas)
            inside += c.consistent
            n += 1
    assert n >= 300
    assert 0.92 <= inside / n <= 0.98, inside / n


def _set(rng, bias, scatter=0.01, n=10, u_model=0.005):
    truth = TRUTH * rng.uniform(0.8, 1.2)
    out = []
    for _ in range(n):
        measured = truth * (1 + bias) * (1 + scatter * rng.standard_normal())
        out.append(normalised_error(truth, measured, 2 * u_model * truth,
                                    measurement_uncertainty(measured, s_r=scatter)))
    return out


def test_fuel_meter_bias_of_3_pct_is_called_biased():
    biased = consistent = 0
    for seed in range(100):
        v = set_verdict(_set(np.random.default_rng(seed), 0.03), s_r=0.01)
        biased += v.biased and v.verdict.startswith("biased by -")
        consistent += v.verdict == "consistent with the data"
    assert biased >= 90 and consistent <= 5, (biased, consistent)


def test_no_bias_is_rarely_called_biased():
    called = sum(set_verdict(_set(np.random.default_rng(seed), 0.0), s_r=0.01).biased
                 for seed in range(100))
    assert called <= 10, called


def test_between_lab_part_widens_the_bias_limit():
    """A -3 % mean against another lab with s_R = 3.5 % is not beyond reproducibility."""
    comps = _set(np.random.default_rng(3), 0.03, scatter=0.01)
    same = set_verdict(comps, s_r=0.01)
    other = set_verdict(comps, s_r=0.01, s_R=0.035, different_source=True)
    assert same.biased and not other.biased
    assert other.bias_limit > abs(other.mean_error) > same.bias_limit
    # the same mean against s_r alone: beyond one lab's repeatability, within s_R
    assert other.beyond_s_r and same.beyond_s_r
    assert other.bias_limit_s_r == pytest.approx(2 * 0.01 / math.sqrt(len(comps)))
    assert other.to_dict()["bias_limit_s_r_pct"] == pytest.approx(100 * other.bias_limit_s_r)
    fair = set_verdict(_set(np.random.default_rng(3), 0.0, scatter=0.01), s_r=0.01)
    assert not fair.beyond_s_r


def test_published_figure_by_hand():
    """En against a published figure: U_meas = the stated U and 2 s_R_vehicle combined."""
    from vehval.uncertainty import judge_published
    from vehval.uncertainty.defaults import precision_default

    d = precision_default("hwfet", "hybrid")
    cmp, basis = judge_published(63.0, 65.4, u_model=1.2, cycle="hwfet", family="hybrid",
                                 u_stated=0.8)
    u_meas = math.hypot(0.8, 2 * d.s_R_vehicle * 65.4)
    assert basis["which"] == "s_R_vehicle" and basis["s_R"] == d.s_R_vehicle
    assert cmp.u_meas == pytest.approx(u_meas)
    assert cmp.en == pytest.approx((63.0 - 65.4) / math.hypot(1.2, u_meas))
    nedc, b2 = judge_published(70.0, 69.0, u_model=3.0, cycle="nedc", family="hybrid")
    assert b2["procedure"] == "ftp75" and "nedc" in b2["note"]


def test_understated_uncertainty_is_called():
    rng = np.random.default_rng(7)
    comps = []
    for _ in range(20):   # unbiased on average, but 3 % scatter claimed as 0.2 %
        measured = TRUTH * (1 + 0.03 * rng.standard_normal())
        comps.append(normalised_error(TRUTH, measured, 0.001 * TRUTH, 0.001 * TRUTH))
    v = set_verdict(comps, s_r=0.001)
    assert v.understated and v.coverage_ci[1] < 0.95
    assert v.verdict in ("uncertainty understated",) or v.verdict.startswith("biased")


def test_uninformative_flag():
    assert normalised_error(50.0, 50.0, 4.0, 4.0).uninformative          # 5.7 / 50 > 10 %
    assert not normalised_error(50.0, 50.0, 2.0, 2.0).uninformative      # 2.8 / 50
    v = set_verdict([normalised_error(50.0, 49.0 + i, 6.0, 6.0) for i in range(3)], s_r=0.01)
    assert v.n_uninformative == 3 and "uninformative" in v.notes[0]


def test_bad_input_is_refused():
    with pytest.raises(InsufficientDataError, match="2 comparison"):
        set_verdict(_set(np.random.default_rng(0), 0.0, n=2), s_r=0.01)
    with pytest.raises(VehvalError, match="s_R"):
        measurement_uncertainty(50.0, s_r=0.01, different_source=True)
    with pytest.raises(VehvalError, match="non-zero"):
        normalised_error(50.0, 0.0, 1.0, 1.0)
    with pytest.raises(VehvalError, match=">= 0"):
        normalised_error(50.0, 50.0, -1.0, 1.0)
    with pytest.raises(VehvalError, match="confidence"):
        repeatability([[1, 2]] * 4, confidence=1.5)


def test_different_source_uses_s_R_not_both():
    u = measurement_uncertainty(50.0, u_result=1.0, s_r=0.01, s_R=0.03, different_source=True)
    assert u == pytest.approx(math.hypot(1.0, 2 * 0.03 * 50.0))
