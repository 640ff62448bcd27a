"""scripts/epa_survey.py: the cross-car survey of the spec-built conventional car.

The what-if wrappers are checked on a built map; the survey itself on the real EPA lists
(skips cleanly when the shared data directory is absent), against the figures of the
docs/validation.md table.
"""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path

import numpy as np
import pytest

from helpers.data import REAL
from vehval.constants import RPM_RAD_PER_S as RPM
from vehval.epa import engine_model as em

REPO = Path(__file__).resolve().parents[2]
_spec = importlib.util.spec_from_file_location("vehval_epa_survey",
                                               REPO / "scripts" / "epa_survey.py")
survey_mod = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(survey_mod)
EPA = REAL / "epa_test_car_list"


def _map(fuel=None):
    spd, trq = np.array([1000.0, 2000.0]), np.array([0.0, 100.0, 200.0])
    tmax = np.array([200.0, 200.0])
    f = fuel or em.fuel_rate_g_per_s
    return f(spd, trq, tmax, 2.0, 0.4, 1.0, 43e6), spd


def test_part_load_pumping_what_if(monkeypatch):
    """The pumping what-if adds k / eta x V_d N / 2 at zero load and nothing at full load."""
    monkeypatch.setattr(em, "fuel_rate_g_per_s", em.fuel_rate_g_per_s)
    base, spd = _map()
    survey_mod.with_part_load_pumping(0.5)
    pumped, _ = _map()
    extra0 = 0.5e5 / 0.4 * 2e-3 * spd * RPM / (4 * math.pi) / 43e6 * 1e3  # [g/s]
    assert pumped[:, 0] - base[:, 0] == pytest.approx(extra0, rel=1e-9)
    assert pumped[:, 2] == pytest.approx(base[:, 2])  # full load: no throttling
    assert np.all(pumped[:, 1] > base[:, 1])


def test_high_load_from_bmep_what_if(monkeypatch):
    """From an absolute BMEP equal to the share's BMEP the map is unchanged; lower, more."""
    monkeypatch.setattr(em, "fuel_rate_g_per_s", em.fuel_rate_g_per_s)
    base, _ = _map()
    share_bar = em.HIGH_LOAD_FROM * float(em.mep_pa(200.0, 2.0)) / 1e5
    survey_mod.with_high_load_from_bmep(share_bar)
    same, _ = _map()
    assert same == pytest.approx(base)


@pytest.mark.realdata
@pytest.mark.skipif(not EPA.is_dir(), reason="EPA Test Car List not found")
def test_survey_first_cars_match_the_docs_table():
    """The first three cars of the survey (2016 F150 3.5 L 6AT, 2019 F150 5.0 L 10AT, 2019
    BMW 540i 8AT), uncalibrated: the errors of the docs/validation.md table, and
    diagnostics that hold by construction."""
    rows = survey_mod.survey([str(EPA / "16tstcar.csv"), str(EPA / "19tstcar.csv")], 3, 0.5,
                             2, survey_mod.CARS[:3])
    assert [r["car"] for r in rows] == ["Ford F150 4X2 2016", "Ford F150 Super Cab 4X4 2019",
                                        "BMW 540i 2019"]
    documented = [(-2.6, -14.9, -12.6), (3.8, -6.8, -10.2), (2.4, -7.1, -9.2)]
    for r, (ftp, hwfet, ratio) in zip(rows, documented):
        assert 100 * r["ftp75"] == pytest.approx(ftp, abs=0.06)
        assert 100 * r["hwfet"] == pytest.approx(hwfet, abs=0.06)
        assert 100 * r["ratio"] == pytest.approx(ratio, abs=0.06)
        assert 1.0 <= r["gear"] <= r["gears"] and 0.0 <= r["top_share"] <= 1.0
        assert 0.0 < r["friction_share"] < 1.0 and 0.0 <= r["low_load_fuel_share"] <= 1.0
        assert 0.0 < r["ftp_idle_share"] < 0.2  # the FTP-75 stands 18 % of its time
        # the model's engine is never slower than top gear's N/V at the same speed
        assert r["eng_rpm"] > r["nv_rpm"] * 0.98
    assert [r["half"] for r in rows] == ["A", "B", "A"]
