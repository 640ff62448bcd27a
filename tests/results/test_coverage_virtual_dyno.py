"""Coverage of the k = 2 interval on virtual dyno runs (the forward simulation of the 2004
Prius on the UDDS) with known sensor accuracies: 100 seeded runs."""

import numpy as np
import pytest

from vehval.io.template import AccuracySpec
from vehval.results import compute_results
from vehval.test import Signal, Test
from vehval.test import TestMeta as Meta

FUEL = {"density_kg_per_m3": 743.0, "lhv_j_per_kg": 42.9e6, "carbon_mass_fraction": 0.866}
#: Declared accuracies; the seeded runs draw their systematic errors within these limits.
ACC = {"veh_spd_test": AccuracySpec(reading_pct=0.2, offset=0.02),
       "fuel_rate_test": AccuracySpec(reading_pct=1.0, offset=0.003, unit="g/s"),
       "ess_volt_test": AccuracySpec(reading_pct=0.2),
       "ess_curr_test": AccuracySpec(reading_pct=0.5, offset=0.05)}


def _limits():
    return {"veh_spd_test": (0.002, 0.02), "fuel_rate_test": (0.01, 3e-6),
            "ess_volt_test": (0.002, 0.0), "ess_curr_test": (0.005, 0.05)}


def _measured(truth: dict, t: np.ndarray, seed: int) -> Test:
    rng = np.random.default_rng(seed)
    test = Test(meta=Meta(test_id=f"v{seed}", cycle="udds"))
    for name, (gain, off) in _limits().items():
        x = truth[name]
        g, o = rng.uniform(-1, 1) * gain, rng.uniform(-1, 1) * off
        noise = rng.normal(0, 0.002 * (np.std(x) or 1.0), t.size)
        test.add(Signal.standard(name, t, x * (1 + g) + o + noise))
    return test


@pytest.mark.slow
def test_coverage_on_virtual_dyno_runs():
    from vehval.sim.simulate import simulate

    sim = simulate("prius_2004", "udds", dt=0.1).test
    t = sim["veh_spd_simu"].time
    truth = {f"{b}_test": sim[f"{b}_simu"].values for b in ("veh_spd", "fuel_rate", "ess_volt",
                                                              "ess_curr")}
    clean = Test(meta=Meta(test_id="truth", cycle="udds"))
    for name, x in truth.items():
        clean.add(Signal.standard(name, t, x))
    ref = compute_results(clean, fuel=FUEL, accuracy=ACC)
    keys = [("test", "fuel_economy_mpg"), ("test", "ess_energy_net_j")]
    hits = {k: 0 for k in keys}
    widths = []
    for seed in range(100):
        res = compute_results(_measured(truth, t, seed), fuel=FUEL, accuracy=ACC)
        for k in keys:
            hits[k] += abs(res.value(*k) - ref.value(*k)) <= res.expanded(*k)
        widths.append(res.expanded("test", "fuel_economy_mpg") / res.value("test", "fuel_economy_mpg"))
    print(f"\nvirtual dyno: fuel economy {ref.value('test', 'fuel_economy_mpg'):.2f} mpg, "
          f"coverage {hits[keys[0]]}/100 (battery net energy {hits[keys[1]]}/100), "
          f"mean U {100 * np.mean(widths):.2f} %")
    assert 88 <= hits[keys[0]] <= 100 and 85 <= hits[keys[1]] <= 100
    assert 0.008 < np.mean(widths) < 0.03
