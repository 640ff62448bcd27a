"""The 2000 Insight (parallel hybrid) log: its import template, and the hybrid template rule."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from helpers.data import REAL
from vehval.errors import ConfigError
from vehval.io.importer import import_test
from vehval.io.template import load_template

TEMPLATE = Path(__file__).parent / "templates" / "insight_2000_10hz.yaml"
LOG = REAL / "advisor_insight_hwfet_10hz" / "Hwy2x_Insight_test_data_69soc_hot.txt"


def _write(tmp_path, data) -> Path:
    p = tmp_path / "t.yaml"
    p.write_text(yaml.safe_dump(data))
    return p


def test_hybrid_template_without_battery_signal_is_refused_in_one_line(tmp_path):
    data = yaml.safe_load(TEMPLATE.read_text())
    chans = data["files"][0]["channels"]
    chans["batt_amps"] = {"delete": True, "reason": "not used"}  # the voltage alone is not enough
    with pytest.raises(ConfigError) as exc:
        load_template(_write(tmp_path, data))
    msg = str(exc.value)
    assert "\n" not in msg and "battery signal" in msg and "ess_curr" in msg
    assert "parallel_hybrid" in msg


def test_conventional_template_needs_no_battery_signal(tmp_path):
    data = yaml.safe_load(TEMPLATE.read_text())
    chans = data["files"][0]["channels"]
    for k in ("batt_amps", "batt_volts", "derived_em_trq_nm"):
        del chans[k]
    data["vehicle"] = "cruze_diesel_2014"
    data["architecture"] = "conventional"
    assert load_template(_write(tmp_path, data)).vehicle == "cruze_diesel_2014"


@pytest.mark.realdata
def test_the_insight_log_imports_in_si():
    if not LOG.exists():
        pytest.skip(f"Insight log not found at {LOG}")
    t = import_test(LOG, TEMPLATE)
    names = {s.name for s in t}
    assert {"veh_spd_test", "ess_curr_test", "ess_volt_test", "eng_spd_out_test"} <= names
    rpm = t["eng_spd_out_test"].values * 30 / np.pi
    assert 2900 < np.nanmax(rpm) < 2950             # the log's 2928 rpm peak
    assert t.meta.cycle == "hwfet_x2"
