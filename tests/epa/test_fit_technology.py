"""scripts/fit_technology.py: the closed-form levels and the choice of the grid point."""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path

import numpy as np
import pytest

from vehval.epa import technology as tech

REPO = Path(__file__).resolve().parents[2]
_spec = importlib.util.spec_from_file_location("vehval_fit_technology",
                                               REPO / "scripts" / "fit_technology.py")
fit = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(fit)
EFF0 = {"automatic": 0.95, "cvt": 0.90, "automated_manual": 0.96, "manual": 0.97}


def _records(eta, gamma, eff, noise=0.0, seed=0, n=400):
    """Rows whose model (at the reference efficiency and EFF0) errs as a car whose true
    efficiency is eta_t x (kW/L / 60)^-gamma_t and gearbox eff_f would make it err."""
    rng = np.random.default_rng(seed)
    out = []
    for k in range(n):
        t = ("spark_na", "spark_turbo")[(k // 4) % 2]  # every family with each engine
        f = tuple(EFF0)[k % 4]
        kwl = float(rng.uniform(45, 70) if t == "spark_na" else rng.uniform(80, 130))
        truth = eta[t] * (kwl * 1e3 / tech.REFERENCE_SPECIFIC_POWER_W_PER_L) ** -gamma[t] * eff[f]
        model = fit.INDICATED_EFFICIENCY * EFF0[f]
        err = model / truth * math.exp(noise * rng.standard_normal()) - 1.0
        out.append({"car": f"c{k}", "tech": t, "family": f, "kw_per_l": kwl, "error": err,
                    "procedure": ("ftp75", "hwfet")[k % 2]})
    return out


def test_fit_levels_recover_known_efficiencies():
    eta = {"spark_na": 0.42, "spark_turbo": 0.45}
    gamma = {"spark_na": 0.2, "spark_turbo": 0.3}
    eff = {"automatic": 0.96, "cvt": 0.93, "automated_manual": 0.95, "manual": 0.97}
    lev = fit.fit_levels(_records(eta, gamma, eff), EFF0)
    # the level of the families and the engines is shared: compare products
    for t in eta:
        for f in eff:
            assert lev["eta"][t] * lev["eff"][f] == pytest.approx(eta[t] * eff[f], rel=1e-3)
        assert lev["gamma"][t] == pytest.approx(gamma[t], abs=1e-3)
    assert max(abs(lev["adjusted"](r)) for r in _records(eta, gamma, eff)) < 1e-3


def test_choose_takes_the_grid_point_of_least_scatter():
    eta = {"spark_na": 0.42, "spark_turbo": 0.45}
    gamma = {"spark_na": 0.0, "spark_turbo": 0.0}
    good = _records(eta, gamma, EFF0, noise=0.01, seed=1)
    bad = _records(eta, gamma, EFF0, noise=0.08, seed=2)
    res = fit.choose({(1.0, 1.0, 0.0): bad, (0.5, 2.5, 0.8): good}, EFF0)
    assert res["combo"] == {"spark_na": (0.5, 2.5, 0.8), "spark_turbo": (0.5, 2.5, 0.8)}
    j = fit.judge(good)
    assert j["n_cars"] == len(good) and j["ftp75"]["n"] + j["hwfet"]["n"] == len(good)


def test_diesel_fit_keeps_the_families_and_writes_only_the_diesel(tmp_path):
    """The diesel's fit sets its efficiency alone (the few diesel cars do not refit the
    gearbox families), and the written file keeps every gasoline value as it was."""
    recs = []
    for k in range(60):
        f = tuple(EFF0)[k % 4]
        err = fit.INDICATED_EFFICIENCY / 0.47 - 1.0  # a diesel whose efficiency is 0.47
        recs.append({"car": f"d{k}", "tech": "diesel", "family": f, "kw_per_l": 50.0 + k % 10,
                     "error": err, "procedure": "ftp75"})
    lev = fit.fit_levels(recs, EFF0, shared=False)
    assert lev["eta"]["diesel"] == pytest.approx(0.47, rel=1e-6)
    assert lev["eff"] == {} and lev["gamma"]["diesel"] == 0.0
    base = tech.load_coefficients()
    res = fit.choose({(1.3, 1.5, 0.0): recs}, EFF0, shared=False)
    text = fit.yaml_text("16tstcar.csv", res, {}, base, 60, 1, fuel="diesel")
    p = tmp_path / "c.yaml"
    p.write_text(text, encoding="utf-8")
    new = tech.load_coefficients(p)
    assert new.engine_value("diesel", "indicated_efficiency").value == pytest.approx(0.47,
                                                                                     rel=1e-3)
    assert new.engine_value("diesel", "idle_factor").value == 1.5
    for t in ("spark_na", "spark_turbo"):
        for k, c in base.engine[t].items():
            assert new.engine_value(t, k).value == pytest.approx(c.value, rel=1e-3)
    for f, v in base.transmission.items():
        assert new.transmission_value(f, "efficiency").value == pytest.approx(
            v["efficiency"].value, rel=1e-3)
    assert "diesel" in new.header.get("fit_diesel", "")
