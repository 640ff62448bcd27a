"""Real public data: every file of the three datasets imports; SI values match hand conversion
of values read straight from the raw text (independent of the reader).

Skips cleanly when the shared data directory is absent (env VEHVAL_SHARED_DATA, the shared
``data`` directory, or ``<repo>/../shared/data``; its ``real/`` folder holds the files).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from helpers.data import CRUZE, REAL
from vehval.io.importer import import_test
from vehval.io.propose import check_template, propose_template
from vehval.io.template import load_template

pytestmark = pytest.mark.realdata

REPO = Path(__file__).resolve().parents[2]
CAMRY = REAL / "d3_2018_toyota_camry_1hz_subset"
PRIUS = REAL / "obd_2014_toyota_prius_c"
TEMPLATES = Path(__file__).parent / "templates"

if not REAL.is_dir():
    pytest.skip(f"real data not found at {REAL}", allow_module_level=True)

MPH = 0.44704                   # m/s per mph (exact)
RPM = 2 * math.pi / 60          # rad/s per rpm
TOL = dict(rel=1e-12, abs=1e-15)  # both sides are float64 products of the same decimal text


def _rows(path: Path, delim: str) -> tuple[list[str], list[list[str]]]:
    """Header tokens and the first 200 data rows, split by hand (no vehval code)."""
    lines = path.read_bytes().rstrip(b"\0").decode("utf-8").splitlines()
    header = lines[0].split(delim)
    rows = [ln.split(delim) for ln in lines[1:201]]
    return header, [r for r in rows if len(r) == len(header)]  # a truncated last row is dropped


def _files(d: Path, pattern: str) -> list[Path]:
    return sorted(d.glob(pattern))


def test_cruze_all_files():
    files = _files(CRUZE, "*Test Data.txt")
    assert len(files) == 10
    t, unmatched = propose_template([files[0]])
    assert unmatched == []
    # hand edit: 61410007 has no fuel measurement -> keep the channel but note it; cell RH gone
    ch = t.files[0].channels
    assert ch["Dyno_Speed"].name == "veh_spd_test" and ch["Engine_Speed"].name == "eng_spd_out_test"
    ch["Test_Cell_RH"] = ch["Test_Cell_RH"].model_copy(update={"delete": True, "reason": "not used",
                                                                "name": None, "unit": None})
    for f in files:
        test = import_test([f], t)
        assert len(test) == 8
        v = test["veh_spd_test"]
        assert v.time[0] == pytest.approx(-10.0) and np.all(np.diff(v.time) > 0)
        assert np.nanmax(v.values) < 70.0  # below 157 mph: plausible m/s
        assert test.meta.deleted[0]["name"] == "Test_Cell_RH"
        header, rows = _rows(f, "\t")
        i = max(range(len(rows)), key=lambda k: float(rows[k][6]))  # largest engine speed
        assert test["eng_spd_out_test"].values[i] == pytest.approx(float(rows[i][6]) * RPM, **TOL)
        assert v.values[i] == pytest.approx(float(rows[i][1]) * MPH, **TOL)
        assert test["fuel_rate_test"].values[i] == pytest.approx(float(rows[i][7]) * 1e-3, **TOL)
        assert test["amb_temp_test"].values[i] == pytest.approx(float(rows[i][3]), **TOL)
    first = import_test([files[0]], t)
    assert any("'fp'" in n for n in first.meta.notes)  # 61410004 stray bytes repaired


def test_camry_all_files():
    files = _files(CAMRY, "*Test Data.txt")
    assert len(files) == 4
    t, unmatched = propose_template([files[0]])
    assert unmatched == [] and any("fuel_density" in x for x in t.todo)
    t.constants.fuel_density_kg_per_m3 = 745.0  # hand edit: gasoline density [kg/m^3]
    for f in files:
        test = import_test([f], t)
        assert set(test.names) == {"veh_spd_test", "fuel_rate_test"}
        header, rows = _rows(f, ",")
        assert header == ["Time[s]", "Eng_FuelFlow_Direct_DI[ccps]", "Dyno_Spd[mph]"]
        i = max(range(len(rows)), key=lambda k: float(rows[k][1]))
        # ccps -> m^3/s (1e-6) -> kg/s (x 745 kg/m^3)
        assert test["fuel_rate_test"].values[i] == pytest.approx(float(rows[i][1]) * 1e-6 * 745.0, **TOL)
        assert test["veh_spd_test"].values[i] == pytest.approx(float(rows[i][2]) * MPH, **TOL)
        assert test["veh_spd_test"].time[i] == pytest.approx(float(rows[i][0]), **TOL)


def test_prius_c_all_files():
    files = _files(PRIUS, "output*.csv")
    assert len(files) == 7
    tmpl = load_template(TEMPLATES / "prius_c_obd.yaml")
    assert check_template(tmpl, files).ok
    for f in files:
        prop, _ = propose_template([f])
        assert prop.files[0].source == "obd" and prop.files[0].time.rate_hz == 1.0
        test = import_test([f], tmpl)
        header, rows = _rows(f, ",")
        col = {h: k for k, h in enumerate(header)}
        i = max(range(len(rows)), key=lambda k: float(rows[k][col["eng2vsp"]]))
        assert test["veh_spd_obd_test"].values[i] == pytest.approx(
            float(rows[i][col["eng2vsp"]]) / 3.6, **TOL)
        assert test["ess_soc_obd_test"].values[i] == pytest.approx(
            float(rows[i][col["eng2soc"]]) / 100.0, **TOL)
        assert test["eng_spd_out_obd_test"].values[i] == pytest.approx(
            float(rows[i][col["eng2rpm"]]) * RPM, **TOL)
        np.testing.assert_array_equal(test["ess_curr_test"].time[:3], [0.0, 1.0, 2.0])
        raw_curr = [float(r[col["Bty_Curr"]]) for r in rows]
        for k, c in enumerate(raw_curr):
            if c == -327.68:
                assert np.isnan(test["ess_curr_test"].values[k])
            else:
                assert test["ess_curr_test"].values[k] == pytest.approx(c, **TOL)
    # the sentinel occurs in output1 (line 108): NaN, recorded in the signal notes
    test = import_test([PRIUS / "output1.csv"], tmpl)
    assert np.isnan(test["ess_curr_test"].values[106])
    assert any("-327.68" in n for n in test["ess_curr_test"].notes)
    # output0: truncated last line dropped; output4: NUL padding stripped (both noted)
    assert any("truncated" in n for n in import_test([PRIUS / "output0.csv"], tmpl).meta.notes)
    assert any("NUL" in n for n in import_test([PRIUS / "output4.csv"], tmpl).meta.notes)
