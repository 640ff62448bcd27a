"""Vehicle file: every parameter sourced, clear errors for bad files."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
import yaml

from vehval.errors import ConfigError
from vehval.sim import indices, layout
from vehval.vehicle import BLOCKS, list_vehicles, load_vehicle

SHIPPED = Path(load_vehicle("prius_2004").file)


def test_every_parameter_has_a_source(prius):
    raw = yaml.safe_load(SHIPPED.read_text())
    for blk in BLOCKS:
        params = set(raw[blk]) - {"sources", "uncertainty"}
        assert params, blk
        assert set(raw[blk]["sources"]) == params, f"{blk}: unsourced or stray sources"
        assert all(str(v).strip() for v in raw[blk]["sources"].values())
    # a parameter left at its structural default (e.g. no cold-start model) needs no source
    def at_default(name):
        blk, key = name.split(".", 1)
        f = type(getattr(prius, blk)).model_fields[key]
        return not f.is_required() and getattr(getattr(prius, blk), key) == f.default

    assert set(prius.sources()) >= {k for k in prius.parameters() if not at_default(k)}


def test_table1_values(prius):
    assert prius.body.mass_kg == 1295
    assert (prius.body.road_load_a_n, prius.body.road_load_b_n_per_mps,
            prius.body.road_load_c_n_per_mps2) == (88.6, 0.14, 0.36)
    assert (prius.planetary.sun_teeth, prius.planetary.ring_teeth) == (30, 78)
    assert prius.driveline.final_drive_ratio == 4.113
    assert prius.driveline.wheel_radius_m == 0.305
    assert prius.battery.capacity_ah == 6.5 and prius.battery.n_cells == 168
    assert prius.battery.nominal_voltage_v == 201.6
    assert prius.engine.max_power_w == 57000 and prius.engine.max_speed_rpm == 5000
    assert prius.mg2.max_torque_nm == 400 and prius.mg2.max_power_w == 50000
    assert prius.mg1.max_speed_rpm == 10000
    assert "prius_2004" in list_vehicles()


def test_signal_limits(prius):
    lim = prius.signal_limits()
    assert lim["eng_spd_out"][1] == pytest.approx(5000 * math.pi / 30)
    assert lim["gen_spd_out"] == pytest.approx((-10000 * math.pi / 30, 10000 * math.pi / 30))
    assert lim["mot_trq_out"][1] == 400
    assert lim["ess_soc"] == (prius.battery.soc_min, prius.battery.soc_max)


def _write(tmp_path, mutate) -> Path:
    data = yaml.safe_load(SHIPPED.read_text())
    mutate(data)
    p = tmp_path / "bad_vehicle.yaml"
    p.write_text(yaml.safe_dump(data))
    return p


def _rename(d, blk, old, new):
    d[blk][new] = d[blk].pop(old)


@pytest.mark.parametrize("mutate, key", [
    (lambda d: _rename(d, "body", "mass_kg", "mas_kg"), "body.mas_kg"),
    (lambda d: d["engine"].pop("inertia_kg_m2"), "engine.inertia_kg_m2"),
    (lambda d: d["body"].__setitem__("mass_kg", -1295.0), "body.mass_kg"),
    (lambda d: d["mg2"]["speed_rpm"].reverse(), "speed_rpm"),
    (lambda d: d["battery"]["soc"].__setitem__(3, 0.1), "soc"),
    (lambda d: d["controller"]["sources"].pop("soc_target"), "soc_target"),
    (lambda d: d.pop("driver"), "driver"),
])
def test_bad_vehicle_files_name_key_and_file(tmp_path, mutate, key):
    p = _write(tmp_path, mutate)
    with pytest.raises(ConfigError) as exc:
        load_vehicle(p)
    msg = str(exc.value)
    assert key in msg and str(p) in msg


def test_unknown_vehicle_and_bad_override(prius):
    with pytest.raises(ConfigError, match="known vehicles"):
        load_vehicle("prius_2099")
    with pytest.raises(ConfigError, match="no parameter"):
        prius.with_overrides({"controller.soc_tagret": 0.5})
    with pytest.raises(ConfigError, match="mass_kg"):
        prius.with_overrides({"body.mass_kg": -1})
    v = prius.with_overrides({"controller__soc_target": 0.55})
    assert v.controller.soc_target == 0.55 and prius.controller.soc_target == 0.6


def test_index_constants_mirror_layout():
    for pre, names in (("P_", layout.PARAMS), ("S_", layout.SIGNALS), ("Y_", layout.SUMMARY)):
        for i, n in enumerate(names):
            assert getattr(indices, pre + n.upper()) == i
    assert indices.N_P == len(layout.PARAMS) and indices.N_S == len(layout.SIGNALS)
    assert indices.N_Y == len(layout.SUMMARY)
