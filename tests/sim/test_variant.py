"""Vehicle variants: a trim changes weight, road load, tyres and battery; never the powertrain."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from vehval.errors import ConfigError
from vehval.vehicle import load_vehicle
from vehval.vehicle.scaling import scale_battery


def _write(tmp_path: Path, data: dict, name: str = "variant.yaml") -> Path:
    p = tmp_path / name
    p.write_text(yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
    return p


def _body(**values) -> dict:
    return {**values, "sources": {k: "EPA list, test X" for k in values}}


def test_variant_changes_only_what_it_names(tmp_path):
    p = _write(tmp_path, {"name": "light", "variant_of": "prius_2016",
                          "body": _body(mass_kg=1474.2, road_load_a_n=76.2)})
    base, var = load_vehicle("prius_2016"), load_vehicle(p)
    assert var.variant_of == "prius_2016" and var.name == "light"
    assert var.body.mass_kg == 1474.2 and var.body.road_load_a_n == 76.2
    assert var.body.sources["mass_kg"] == "EPA list, test X"
    assert var.body.road_load_c_n_per_mps2 == base.body.road_load_c_n_per_mps2
    for blk in ("engine", "mg1", "mg2", "battery", "controller", "planetary"):
        assert getattr(var, blk) == getattr(base, blk), blk
    assert var.driveline == base.driveline


def test_packaged_eco_variant_is_the_2016_powertrain():
    eco, base = load_vehicle("prius_2016_eco"), load_vehicle("prius_2016")
    assert eco.variant_of == "prius_2016"
    assert eco.engine == base.engine and eco.mg2 == base.mg2 and eco.controller == base.controller
    assert eco.driveline.final_drive_ratio == base.driveline.final_drive_ratio
    # 3250 lb equivalent test weight (EPA list), rounded to the gram
    assert eco.body.mass_kg == pytest.approx(3250 * 0.45359237, abs=1e-3)
    b = eco.battery
    assert (b.chemistry, b.n_cells, b.capacity_ah, b.nominal_voltage_v) == ("li_ion", 56, 3.6,
                                                                           207.2)
    # scale_battery at the NiMH pack's power rating: OCV x k_v, resistance x k_v^2
    k_v = 207.2 / 201.6
    assert max(b.discharge_power_limit_w) == max(base.battery.discharge_power_limit_w)
    np.testing.assert_allclose(b.ocv_v, np.asarray(base.battery.ocv_v) * k_v, rtol=1e-12)
    np.testing.assert_allclose(b.resistance_discharge_ohm,
                               np.asarray(base.battery.resistance_discharge_ohm) * k_v**2,
                               rtol=1e-12)


@pytest.mark.parametrize(("block", "key", "value", "named"), [
    ("driveline", "final_drive_ratio", 3.19, "driveline.final_drive_ratio from 2.8344 to 3.19"),
    ("engine", "displacement_l", 1.497, "engine.displacement_l from 1.798 to 1.497"),
    ("controller", "engine_on_power_w", 9000.0, "controller.engine_on_power_w"),
])
def test_variant_refuses_a_powertrain_change(tmp_path, block, key, value, named):
    p = _write(tmp_path, {"name": "other", "variant_of": "prius_2016",
                          block: {key: value, "sources": {key: "a sheet"}}})
    with pytest.raises(ConfigError) as err:
        load_vehicle(p)
    msg = str(err.value)
    assert named in msg and "powertrain" in msg and str(p) in msg


def test_variant_value_needs_its_source(tmp_path):
    p = _write(tmp_path, {"name": "x", "variant_of": "prius_2016",
                          "body": {"mass_kg": 1400.0}})
    with pytest.raises(ConfigError, match=r"body\.sources\.mass_kg.*give its source"):
        load_vehicle(p)


def test_variant_of_unknown_base_and_conventional_base(tmp_path):
    p = _write(tmp_path, {"name": "x", "variant_of": "no_such_car", "body": _body(mass_kg=1.4e3)})
    with pytest.raises(ConfigError, match="unknown vehicle 'no_such_car'"):
        load_vehicle(p)
    p = _write(tmp_path, {"name": "x", "variant_of": "cruze_diesel_2014",
                          "body": _body(mass_kg=1.4e3)})
    with pytest.raises(ConfigError, match="variants are defined for power-split"):
        load_vehicle(p)


def test_variant_of_a_file_beside_it_and_battery_block(tmp_path):
    base = load_vehicle("prius_2004")
    Path(tmp_path / "base.yaml").write_text(Path(base.file).read_text(), encoding="utf-8")
    pack = scale_battery(base.battery, n_cells=56, n_modules=2, capacity_ah=3.6,
                         nominal_voltage_v=207.2, chemistry="li_ion")
    p = _write(tmp_path, {"name": "x", "variant_of": "base.yaml",
                          "battery": pack.model_dump()})
    var = load_vehicle(p)
    assert var.battery.chemistry == "li_ion" and var.engine == base.engine
    # a variant of a variant keeps the chain
    q = _write(tmp_path, {"name": "y", "variant_of": "variant.yaml",
                          "body": _body(aux_power_w=250.0)}, "second.yaml")
    v2 = load_vehicle(q)
    assert v2.battery.chemistry == "li_ion" and v2.body.aux_power_w == 250.0


def test_tyre_change_is_a_variant(tmp_path):
    p = _write(tmp_path, {"name": "t", "variant_of": "prius_2016",
                          "driveline": {"wheel_radius_m": 0.31,
                                        "sources": {"wheel_radius_m": "P215/45R17"}}})
    assert load_vehicle(p).driveline.wheel_radius_m == 0.31


def test_rated_pack_keeps_the_voltage_sag_at_its_rating():
    """With a given power rating the resistance is scaled by k_v^2 / k_p: the rated power is
    drawn at the same fraction of the OCV as in the reference pack (at the same C-rate this
    is k_v / k_c)."""
    ref = load_vehicle("prius_2004").battery
    peak = max(ref.discharge_power_limit_w)
    for p_w in (peak, 27e3):
        li = scale_battery(ref, n_cells=56, n_modules=2, capacity_ah=3.6,
                           nominal_voltage_v=207.2, chemistry="li_ion", power_limit_w=p_w)
        k_v, k_p = 207.2 / 201.6, p_w / peak
        np.testing.assert_allclose(li.resistance_discharge_ohm,
                                   np.asarray(ref.resistance_discharge_ohm) * k_v**2 / k_p,
                                   rtol=1e-12)
        # current at the rated power as a share of the short-circuit current OCV / R
        for k in range(len(ref.soc)):
            if ref.ocv_v[k] > 0:
                share_ref = peak / ref.ocv_v[k] * ref.resistance_discharge_ohm[k] / ref.ocv_v[k]
                share_new = p_w / li.ocv_v[k] * li.resistance_discharge_ohm[k] / li.ocv_v[k]
                assert share_new == pytest.approx(share_ref, rel=1e-12)


@pytest.mark.parametrize("cycle", ["udds", "us06"])
def test_eco_variant_keeps_the_known_behaviour(cycle):
    """The Li-ion variant: electric launch, engine off at standstill, SOC window, no trace
    miss, Willis through the reduction gear and energy closure at every step."""
    from vehval.sim.simulate import simulate

    veh = load_vehicle("prius_2016_eco")
    r = simulate(veh, cycle, dt=0.2, charge_balance=True)
    s = r.summary

    def sig(base):
        return np.asarray(r.test[f"{base}_simu"].values, float)

    v, w_eng = sig("veh_spd"), sig("eng_spd_out")
    assert s["trace_n_miss"] == 0
    assert abs(s["energy_balance_rel"]) < 1e-9  # closure to round-off over the run
    soc = sig("ess_soc")
    assert veh.battery.soc_min <= soc.min() and soc.max() <= veh.battery.soc_max
    rg = veh.driveline.mg2_reduction_ratio
    willis = sig("mot_spd_out") / rg * 78 + sig("gen_spd_out") * 30 - w_eng * 108
    assert np.max(np.abs(willis)) < 1e-6  # every step, round-off [rad/s x teeth]
    # standstill well after the first launch: engine off (warm car, no cold start here)
    stopped = (v == 0) & (r.test["veh_spd_simu"].time > 30)
    assert np.all(w_eng[stopped] == 0)
    if cycle == "udds":  # the first launch is electric: engine still off at 3 m/s
        first = int(np.argmax(v > 3.0))
        assert w_eng[first] == 0
