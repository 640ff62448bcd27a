"""Fuel table, template keys of the results stage and their bad-input messages."""

from pathlib import Path

import pytest
import yaml

from vehval.errors import ConfigError
from vehval.fuels import fuel_properties, known_fuels
from vehval.io.template import load_template

BASE = {"template_version": 1, "files": [{"source": "dyno", "channels": {
    "Speed": {"name": "veh_spd_test", "unit": "mph"},
    "Fuel": {"name": "fuel_rate_test", "unit": "g/s"},
    "Phase": {"name": "test_phase_test"}}}]}


def _write(tmp_path: Path, **extra) -> Path:
    p = tmp_path / "t.yaml"
    p.write_text(yaml.safe_dump(dict(BASE, **extra)))
    return p


def test_every_fuel_value_has_a_source_and_a_plausible_figure():
    for name in known_fuels():
        f = fuel_properties(name)
        assert 700 < f.density_kg_per_m3 < 900
        assert 25e6 < f.lhv_j_per_kg < 45e6
        assert 0.5 < f.carbon_mass_fraction < 0.9
        assert all(len(f.sources[p]) > 10 for p in ("density_kg_per_m3", "lhv_j_per_kg",
                                                    "carbon_mass_fraction"))


def test_explicit_properties_override_the_table():
    f = fuel_properties({"name": "diesel", "density_kg_per_m3": 840.0})
    assert f.density_kg_per_m3 == 840.0 and f.sources["density_kg_per_m3"] == "template"
    assert f.uncertainty["density_kg_per_m3"] == 0.0
    assert f.lhv_j_per_kg == fuel_properties("diesel").lhv_j_per_kg


def test_unknown_fuel_lists_the_known_ones(tmp_path):
    with pytest.raises(ConfigError) as exc:
        load_template(_write(tmp_path, fuel="kerosene"))
    msg = str(exc.value)
    assert "unknown fuel 'kerosene'" in msg and "diesel" in msg and "gasoline_e10" in msg


def test_negative_accuracy_is_refused(tmp_path):
    with pytest.raises(ConfigError) as exc:
        load_template(_write(tmp_path, accuracy={"fuel_rate_test": {"reading_pct": -1}}))
    assert "accuracy.fuel_rate_test.reading_pct" in str(exc.value)
    assert "greater than or equal to 0" in str(exc.value)


def test_accuracy_on_an_unmapped_channel_is_refused(tmp_path):
    with pytest.raises(ConfigError) as exc:
        load_template(_write(tmp_path, accuracy={"ess_curr_test": {"reading_pct": 0.5}}))
    assert "accuracy.ess_curr_test: the template maps no channel" in str(exc.value)


def test_full_scale_pct_needs_a_full_scale(tmp_path):
    with pytest.raises(ConfigError, match="full_scale"):
        load_template(_write(tmp_path, accuracy={"fuel_rate_test": {"full_scale_pct": 0.1}}))


def test_phase_channel_must_be_mapped(tmp_path):
    with pytest.raises(ConfigError, match="phase_channel"):
        load_template(_write(tmp_path, phase_channel="eng_spd_out_test"))


def test_results_keys_load_and_round_trip(tmp_path):
    t = load_template(_write(tmp_path, fuel="diesel", phase_channel="test_phase_test",
                             accuracy={"fuel_rate_test": {"reading_pct": 1.0, "offset": 0.01,
                                                          "unit": "g/s"}}))
    assert t.fuel == "diesel" and t.accuracy["fuel_rate_test"].offset == 0.01
    again = tmp_path / "again.yaml"
    t.save(again)
    assert load_template(again).accuracy == t.accuracy


def test_template_init_writes_a_commented_fuel_placeholder(tmp_path, cli):
    raw = tmp_path / "run.csv"
    raw.write_text("Time[s],Dyno_Speed[mph],Fuel_Flow[g/s]\n0,0,0.1\n0.1,0.2,0.2\n0.2,0.4,0.3\n")
    out = tmp_path / "tpl.yaml"
    code, _stdout, err = cli("template", "init", raw, "-o", out)
    assert code == 0, err
    text = out.read_text()
    assert "# fuel: diesel" in text and "known:" in text
    assert load_template(out).fuel is None          # a comment, not a value
