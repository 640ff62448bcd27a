"""Parameter uncertainty in the vehicle file and the sensitivity of fuel economy to it."""

from __future__ import annotations

import json

import pytest
import yaml

from vehval.errors import ConfigError
from vehval.sim.sensitivity import sensitivity, uncertain_parameters
from vehval.vehicle import BLOCKS, load_vehicle
from vehval.vehicle.base import is_unsourced
from vehval.vehicle.definition import _vehicles_dir


def test_every_unsourced_parameter_has_an_uncertainty(prius):
    keys = {u.key for u in uncertain_parameters(prius)}
    for blk in BLOCKS:
        for name, src in getattr(prius, blk).sources.items():
            if is_unsourced(src):
                assert f"{blk}.{name}" in keys, f"{blk}.{name}"
    assert "body.aux_power_w" in keys and "battery.resistance_discharge_ohm" in keys


def test_one_at_a_time_and_monte_carlo(prius):
    res = sensitivity(prius, ["ece15"], ["body.aux_power_w", "planetary.ring_inertia_kg_m2"],
                      dt=1.0, monte_carlo=8, seed=1)
    rows = {r["key"]: r for r in res["parameters"]}
    aux = rows["body.aux_power_w"]["cycles"]["ece15"]
    # more accessory load, more fuel: the low end (200 W) gains, the high end (400 W) loses
    assert aux["low_pct"] > 0 > aux["high_pct"]
    assert res["parameters"][0]["key"] == "body.aux_power_w"  # ranked by swing
    mc = res["monte_carlo"]["ece15"]
    assert mc["n"] == 8 and mc["p5"] <= mc["p50"] <= mc["p95"]


def test_curve_scale_runs(prius):
    res = sensitivity(prius, ["ece15"], ["battery.resistance_discharge_ohm"], dt=1.0)
    r = res["parameters"][0]
    assert (r["low"], r["high"]) == (0.75, 1.33)
    assert r["cycles"]["ece15"]["low_pct"] >= r["cycles"]["ece15"]["high_pct"]


def _write(tmp_path, blk, name, spec):
    data = yaml.safe_load((_vehicles_dir() / "prius_2004.yaml").read_text())
    data[blk]["uncertainty"][name] = spec
    p = tmp_path / "v.yaml"
    p.write_text(yaml.safe_dump(data))
    return p


@pytest.mark.parametrize("blk,name,spec,msg", [
    ("body", "aux_power_w", {"range": [400.0, 500.0]}, "excludes the nominal value 300"),
    ("engine", "fire_speed_rpm", {"rel_sd": -0.1}, "negative standard deviation"),
    ("body", "mass_kgg", {"rel_sd": 0.1}, "unknown parameter 'mass_kgg'"),
])
def test_bad_uncertainty_is_one_clear_line(tmp_path, capsys, blk, name, spec, msg):
    from vehval.cli import main

    p = _write(tmp_path, blk, name, spec)
    with pytest.raises(ConfigError, match=msg):
        load_vehicle(p)
    rc = main(["sensitivity", "--vehicle", str(p), "--cycles", "ece15"])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and len(err.splitlines()) == 1 and str(p) in err and blk in err


def test_missing_uncertainty_for_an_unsourced_parameter(tmp_path):
    data = yaml.safe_load((_vehicles_dir() / "prius_2004.yaml").read_text())
    del data["body"]["uncertainty"]["aux_power_w"]
    p = tmp_path / "v.yaml"
    p.write_text(yaml.safe_dump(data))
    with pytest.raises(ConfigError, match="without an uncertainty: aux_power_w"):
        load_vehicle(p)


def test_cli_unknown_param_and_outputs(tmp_path, capsys):
    from vehval.cli import main

    rc = main(["sensitivity", "--cycles", "ece15", "--params", "body.nope"])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and "body.nope" in err and "prius_2004" in err and len(err.splitlines()) == 1
    rc = main(["sensitivity", "--cycles", "ece15", "--params", "body.aux_power_w", "--json",
               "-o", str(tmp_path / "s")])
    assert rc == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["parameters"][0]["key"] == "body.aux_power_w"
    assert (tmp_path / "s" / "sensitivity.json").exists()
    html = (tmp_path / "s" / "sensitivity.html").read_text()
    assert "Plotly.newPlot" in html and "body.aux_power_w" in html
