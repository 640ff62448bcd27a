"""What `vehval identify` prints on the Cruze's cold starts (skipped without the real files):
the fitted road-load C is negative, the vehicle file holds 0; both tests start cold."""

from pathlib import Path

import pytest

from helpers.data import CRUZE
from helpers.data import CRUZE_TEMPLATE as TEMPLATE
from vehval.cli import main

SPEC = Path(__file__).resolve().parent / "cruze_spec.yaml"

pytestmark = [pytest.mark.realdata,
              pytest.mark.skipif(not CRUZE.is_dir(), reason="real data not available")]


def test_cold_starts_clamped_c_and_cold_warning(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("VEHVAL_UNITS", "us")   # `--units` sets it: restored after the test
    rc = main(["--units", "metric", "identify", str(CRUZE / "61410012 Test Data.txt"),
               str(CRUZE / "61410028 Test Data.txt"), "-t", str(TEMPLATE), "--spec", str(SPEC),
               "-o", str(tmp_path / "v.yaml")])
    cap = capsys.readouterr()
    assert rc == 0, cap.err
    line = next(x for x in cap.out.splitlines() if x.startswith("road load"))
    # C fitted at -0.0164 ± 0.0351 N/(m/s)²: the vehicle file holds the bound, 0, and says so
    assert ", C -0.0164 ± 0.0351 N/(m/s)² (the vehicle file holds 0 N/(m/s)²: a physical" in line
    warn = [x for x in cap.err.splitlines() if x.startswith("vehval: warning:")]
    assert len(warn) == 1 and "61410012 Test Data (coolant 24 °C" in warn[0]
    assert "61410028 Test Data (coolant -4 °C" in warn[0]
