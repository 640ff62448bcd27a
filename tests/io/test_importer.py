"""import_test: SI conversion by hand, sentinels, deletions, time checks and repair."""

from __future__ import annotations

import numpy as np
import pytest
from iohelpers import D3_TEMPLATE, d3_rows, write_d3

from vehval.errors import ConfigError, InputFileError, SignalError, UnitError
from vehval.io.importer import import_test
from vehval.io.template import load_template


def _tmpl(tmp_path, text, name="T.yaml"):
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    return p


def test_hand_conversions(d3_file, d3_template):
    test = import_test([d3_file], d3_template)
    v = test["veh_spd_test"]
    # 60 mph = 60 * 1609.344 m / 3600 s = 26.8224 m/s exactly
    assert v.values[-1] == pytest.approx(26.8224, rel=1e-12)
    assert v.unit == "m/s" and v.raw_unit == "mph" and v.raw_name == "Dyno_Speed"
    assert v.source == "dyno" and v.file == str(d3_file)
    # 3000 rpm = 3000 * 2 pi / 60 = 314.159... rad/s
    assert test["eng_spd_out_test"].values[0] == pytest.approx(100 * np.pi, rel=1e-12)
    # 77 °F = (77 - 32) * 5/9 = 25 °C (affine conversion)
    assert test["amb_temp_test"].values[0] == pytest.approx(25.0, abs=1e-12)
    np.testing.assert_allclose(v.time, [r[0] for r in d3_rows()], rtol=0, atol=1e-12)
    assert v.time[0] == -1.0
    m = test.meta
    assert m.test_id == "run_d3" and m.constants["test_mass_kg"] == 1295.0
    assert m.deleted == [{"name": "Phase_#", "file": "run_d3.txt", "source": "dyno",
                          "reason": "not needed"}]
    assert "Phase_#" not in [s.raw_name for s in test]


def test_scale_offset_invalid_values_and_selection_drop(tmp_path, d3_file):
    text = D3_TEMPLATE.replace("{name: eng_spd_out_test, unit: rpm}",
                               "{name: eng_spd_out_test, unit: rpm, scale: 2.0, offset: 1.0}")
    text = text.replace("{name: veh_spd_test, unit: mph}",
                        "{name: veh_spd_test, unit: mph, invalid_values: [60.0]}")
    text += "selection:\n  drop: {amb_temp_test: sensor broken}\n"
    test = import_test([d3_file], _tmpl(tmp_path, text))
    # si = to_si(raw) * scale + offset
    assert test["eng_spd_out_test"].values[0] == pytest.approx(100 * np.pi * 2 + 1, rel=1e-12)
    v = test["veh_spd_test"]
    assert np.isnan(v.values[-1]) and np.isfinite(v.values[:-1]).all()
    assert "1 sample(s) equal to invalid value(s) [60.0] replaced by NaN" in v.notes
    assert "amb_temp_test" not in test
    assert {"name": "amb_temp_test", "reason": "sensor broken", "by": "selection.drop"} in test.meta.deleted


def test_missing_and_extra_channels_reported(tmp_path, d3_template):
    f = write_d3(tmp_path / "x.txt", header=["Time[s]", "Dyno_Speed[mph]", "Extra[V]",
                                             "Cell_Temp[F]", "Phase_#"])
    test = import_test([f], d3_template)
    notes = "\n".join(test.meta.notes)
    assert "warning: x.txt: template channel(s) not in the file: Engine_Speed" in notes
    assert "warning: x.txt: channel(s) in the file but not in the template (not imported): Extra" in notes


def test_no_time_column_without_rate_is_an_error(tmp_path):
    f = tmp_path / "x.txt"
    f.write_text("Dyno_Speed[mph]\tEngine_Speed[rpm]\r\n1\t2\r\n3\t4\r\n")
    tmpl = _tmpl(tmp_path, D3_TEMPLATE.replace("format: auto\n    time: {column: Time, unit: s}", "format: d3"))
    with pytest.raises(InputFileError, match=r"x\.txt: no time column found .* set "
                                             r"files\[0\]\.time\.column or files\[0\]\.time\.rate_hz"):
        import_test([f], tmpl)
    tmpl = _tmpl(tmp_path, D3_TEMPLATE.replace("time: {column: Time, unit: s}",
                                               "time: {rate_hz: 2.0, start_s: 5}"), "T2.yaml")
    test = import_test([f], tmpl)
    np.testing.assert_array_equal(test["veh_spd_test"].time, [5.0, 5.5])


def test_named_time_column_absent(tmp_path, d3_file):
    tmpl = _tmpl(tmp_path, D3_TEMPLATE.replace("column: Time", "column: Zeit"))
    with pytest.raises(InputFileError, match=r"time column 'Zeit' \(files\[0\]\.time\.column\) is not in"):
        import_test([d3_file], tmpl)


@pytest.mark.parametrize("kind,t2", [("decreasing", -1.0), ("repeated", -0.9)])
def test_bad_timestamps_error_then_repair(tmp_path, d3_template, kind, t2):
    rows = d3_rows(10)
    rows[2][0] = t2          # line 4 of the file (header is line 1)
    f = write_d3(tmp_path / "x.txt", rows=rows)
    with pytest.raises(InputFileError, match=rf"x\.txt line 4: {kind} timestamp .*--repair-time"):
        import_test([f], d3_template)
    test = import_test([f], d3_template, repair_time=True)
    t = test["veh_spd_test"].time
    assert np.all(np.diff(t) > 0)
    assert t.size == 9  # one duplicate time dropped either way (-1.0 or -0.9 appears twice)
    assert any("time base repaired on import" in n and "--repair-time" not in n
               for n in test.meta.notes)
    assert any("time base repaired on import" in n for n in test["veh_spd_test"].notes)
    # values follow their timestamps: the first sample at each time is kept
    v = test["veh_spd_test"].values
    assert v[0] == 0.0


def test_unit_from_header_and_missing_unit(tmp_path, d3_file):
    text = D3_TEMPLATE.replace("{name: veh_spd_test, unit: mph}", "{name: veh_spd_test}")
    test = import_test([d3_file], _tmpl(tmp_path, text))
    assert test["veh_spd_test"].raw_unit == "mph"
    f = tmp_path / "o.csv"
    f.write_text("rpm,soc\n3000,50\n")
    text = ("files:\n  - source: obd\n    time: {rate_hz: 1}\n    channels:\n"
            "      rpm: {name: eng_spd_out_test}\n      soc: {name: ess_soc_test, unit: '%'}\n")
    with pytest.raises(ConfigError, match=r"channel 'rpm' -> eng_spd_out_test: no unit .* "
                                          r"set files\[0\]\.channels\.rpm\.unit"):
        import_test([f], _tmpl(tmp_path, text, "o.yaml"))
    test = import_test([f], _tmpl(tmp_path, text.replace("{name: eng_spd_out_test}",
                                                         "{name: eng_spd_out_test, unit: rpm}"), "o2.yaml"))
    assert test["ess_soc_test"].values[0] == pytest.approx(0.5)  # % -> fraction


def test_volumetric_fuel_needs_density(tmp_path):
    f = tmp_path / "c.txt"
    f.write_text("Time[s],Eng_FuelFlow_Direct_DI[ccps]\n0,1.0\n1,2.0\n")
    text = ("constants: {fuel_density_kg_per_m3: 745}\nfiles:\n  - source: dyno\n    channels:\n"
            "      Eng_FuelFlow_Direct_DI: {name: fuel_rate_test, unit: ccps}\n")
    test = import_test([f], _tmpl(tmp_path, text))
    # 1 cm^3/s * 1e-6 m^3/cm^3 * 745 kg/m^3 = 7.45e-4 kg/s
    np.testing.assert_allclose(test["fuel_rate_test"].values, [7.45e-4, 1.49e-3], rtol=1e-12)
    with pytest.raises(UnitError, match="fuel_rate_test: .*fuel_density_kg_per_m3"):
        import_test([f], _tmpl(tmp_path, text.replace("constants: {fuel_density_kg_per_m3: 745}\n", ""),
                               "n.yaml"))


def test_volumetric_fuel_takes_the_density_of_the_declared_fuel(tmp_path):
    """The template's ``fuel: diesel`` is the one fuel of import and ``template check``."""
    from vehval.fuels import table_fuel
    from vehval.io.propose import check_template

    f = tmp_path / "c.txt"
    f.write_text("Time[s],Eng_FuelFlow_Direct_DI[ccps]\n0,1.0\n1,2.0\n")
    text = ("fuel: diesel\nfiles:\n  - source: dyno\n    channels:\n"
            "      Eng_FuelFlow_Direct_DI: {name: fuel_rate_test, unit: ccps}\n")
    rho = table_fuel("diesel").density_kg_per_m3
    test = import_test([f], _tmpl(tmp_path, text))
    np.testing.assert_allclose(test["fuel_rate_test"].values, [1e-6 * rho, 2e-6 * rho], rtol=1e-12)
    assert test.meta.fuel == "diesel"
    assert check_template(_tmpl(tmp_path, text, "c.yaml"), [f]).ok
    bare = check_template(_tmpl(tmp_path, text.replace("fuel: diesel\n", ""), "b.yaml"), [f])
    assert not bare.ok and any("needs the fuel density" in e for e in bare.errors)


def test_two_files_two_sources_and_matching(tmp_path):
    d = write_d3(tmp_path / "t1_d3.txt")
    o = tmp_path / "t1_obd.csv"
    o.write_text("eng2rpm,eng2vsp\n3000,96.56064\n3000,0\n")
    text = ("files:\n"
            "  - {match: '*_d3.txt', source: dyno, channels: {Dyno_Speed: {name: veh_spd_test, unit: mph}}}\n"
            "  - match: '*_obd.csv'\n    source: obd\n    time: {rate_hz: 1.0}\n    channels:\n"
            "      eng2rpm: {name: eng_spd_out_obd_test, unit: rpm}\n"
            "      eng2vsp: {name: veh_spd_obd_test, unit: km/h}\n")
    t = _tmpl(tmp_path, text)
    test = import_test([o, d], t)
    assert test["veh_spd_obd_test"].source == "obd"
    # 96.56064 km/h = 26.8224 m/s (60 mph)
    assert test["veh_spd_obd_test"].values[0] == pytest.approx(26.8224, rel=1e-12)
    assert sorted(test.time_bases()) == ["dyno", "obd"]
    with pytest.raises(ConfigError, match="no files\\[\\] entry of T.yaml matches"):
        import_test([tmp_path / "T.yaml"], t)
    d2 = write_d3(tmp_path / "t2_d3.txt")
    with pytest.raises(ConfigError, match="both match files\\[0\\]"):
        import_test([d, d2], t)


def test_template_instance_and_duplicate_signal(tmp_path, d3_file, d3_template):
    t = load_template(d3_template)
    t.files.append(t.files[0].model_copy(deep=True))
    t.files[0].match = "*.txt"
    t.files[1].match = "*.dat"
    f2 = write_d3(tmp_path / "x.dat")
    with pytest.raises((SignalError, ConfigError), match="veh_spd_test"):
        import_test([d3_file, f2], t)


def test_missing_file(tmp_path, d3_template):
    with pytest.raises(InputFileError, match="file not found"):
        import_test([tmp_path / "nope.txt"], d3_template)


def test_file_with_none_of_the_template_channels_is_an_error(tmp_path):
    """A template that matches no channel of a file is a wrong template, not a warning."""
    from vehval.errors import InputFileError
    from vehval.io.importer import import_test

    f = tmp_path / "other.txt"
    f.write_bytes(b"Time[s]\tFoo[V]\tBar[A]\r\n0\t1\t2\r\n0.1\t1\t2\r\n")
    tpl = tmp_path / "t.yaml"
    tpl.write_text("template_version: 1\nfiles:\n  - source: dyno\n    time: {column: Time, unit: s}\n"
                   "    channels:\n      Dyno_Speed: {name: veh_spd_test, unit: mph}\n")
    with pytest.raises(InputFileError, match="none of the 1 channels.*wrong template"):
        import_test([f], tpl)
    # `template check` says the same, as an error (it passed with two warnings)
    from vehval.io.propose import check_template

    rep = check_template(tpl, [f])
    assert not rep.ok and any("none of the 1 channels" in e for e in rep.errors)


def test_template_unit_note_only_when_the_units_differ(tmp_path):
    """'degC' in the template for a header '[C]' (and 'percent' for '[%]') is the same unit:
    no 'used instead of header unit' note; 'degF' for '[C]' is one."""
    f = tmp_path / "r.txt"
    f.write_text("Time[s]\tTest_Cell_Temp[C]\tTest_Cell_RH[%]\n0\t23\t40\n1\t23\t41\n")
    text = ("files:\n  - source: dyno\n    channels:\n"
            "      Test_Cell_Temp: {name: amb_temp_test, unit: degC}\n"
            "      Test_Cell_RH: {name: amb_rh_test, unit: percent}\n")
    test = import_test([f], _tmpl(tmp_path, text))
    assert not [n for n in test.meta.notes if "used instead of header unit" in n]
    assert test["amb_temp_test"].notes == [] and test["amb_rh_test"].notes == []
    test = import_test([f], _tmpl(tmp_path, text.replace("unit: degC", "unit: degF"), "f.yaml"))
    assert test["amb_temp_test"].notes == ["template unit 'degF' used instead of header unit 'C'"]


def test_time_restarting_midway_is_refused_even_with_repair(tmp_path, d3_template):
    # two runs in one file: sorting would drop the second run as repeated times
    rows = d3_rows(200) + d3_rows(200)
    f = write_d3(tmp_path / "x.txt", rows=rows)
    with pytest.raises(InputFileError, match=r"x\.txt line 202: the time column 'Time' restarts"
                                             r" .*more than one run.*split the file"):
        import_test([f], d3_template, repair_time=True)
    # one stray time (high or low) in the middle is still a glitch --repair-time sorts in
    for bad in (1e4, -1.0):
        rows = d3_rows(200)
        rows[100][0] = bad
        test = import_test([write_d3(tmp_path / "y.txt", rows=rows)], d3_template,
                           repair_time=True)
        assert test["veh_spd_test"].time.size >= 198


def test_files_days_apart_are_refused(tmp_path):
    d = write_d3(tmp_path / "t1_d3.txt")
    o = tmp_path / "t1_obd.csv"
    # the logger's clock in epoch seconds beside the dyno's seconds from the start
    o.write_text("t,eng2rpm\n1700000000,3000\n1700000001,3000\n")
    text = ("files:\n"
            "  - {match: '*_d3.txt', source: dyno, channels: {Dyno_Speed: {name: veh_spd_test, unit: mph}}}\n"
            "  - match: '*_obd.csv'\n    source: obd\n    time: {column: t}\n    channels:\n"
            "      eng2rpm: {name: eng_spd_out_obd_test, unit: rpm}\n")
    t = _tmpl(tmp_path, text)
    with pytest.raises(InputFileError, match=r"t1_obd\.csv: its time runs 1700000000\.\.1700000001"
                                             r" s, .*not on one clock"):
        import_test([d, o], t)
    o.write_text("t,eng2rpm\n3600,3000\n3601,3000\n")     # an hour apart: for QA to align
    assert "eng_spd_out_obd_test" in import_test([d, o], t)
