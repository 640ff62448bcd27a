"""Templates: strict schema with key-path errors, semantic checks, save/load, propose, check."""

from __future__ import annotations

import pytest
from iohelpers import D3_TEMPLATE, write_d3

from vehval.errors import ConfigError
from vehval.io.propose import UNMATCHED_REASON, check_template, match_channel, propose_template
from vehval.io.template import ChannelSpec, FileSpec, Template, load_template


def _write(tmp_path, text, name="T.yaml"):
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    return p


def test_load_valid(d3_template):
    t = load_template(d3_template)
    assert t.files[0].channels["Dyno_Speed"].name == "veh_spd_test"
    assert t.constants_dict() == {"test_mass_kg": 1295.0, "fuel_density_kg_per_m3": 745.0}
    assert t.path == d3_template


def test_misspelled_key_names_path_and_suggests(tmp_path):
    p = _write(tmp_path, D3_TEMPLATE.replace("{name: eng_spd_out_test, unit: rpm}",
                                             "{name: eng_spd_out_test, unti: rpm}"))
    with pytest.raises(ConfigError) as exc:
        load_template(p)
    assert ("T.yaml: files[0].channels.Engine_Speed.unti: unknown key (did you mean 'unit'?)"
            in str(exc.value))


def test_misspelled_top_level_and_constant(tmp_path):
    p = _write(tmp_path, D3_TEMPLATE.replace("description:", "descripton:")
               .replace("test_mass_kg", "test_mas_kg"))
    msg = str(pytest.raises(ConfigError, load_template, p).value)
    assert "descripton: unknown key (did you mean 'description'?)" in msg
    assert "constants.test_mas_kg: unknown key (did you mean 'test_mass_kg'?)" in msg


def test_unknown_unit_names_channel(tmp_path):
    p = _write(tmp_path, D3_TEMPLATE.replace("unit: mph", "unit: mphx"))
    with pytest.raises(ConfigError, match=r"files\[0\]\.channels\.Dyno_Speed\.unit: channel "
                                          r"'Dyno_Speed': unknown unit 'mphx'"):
        load_template(p)


def test_incompatible_unit_and_unknown_name(tmp_path):
    p = _write(tmp_path, D3_TEMPLATE.replace("unit: mph", "unit: rpm")
               .replace("amb_temp_test", "amb_tmp_test"))
    msg = str(pytest.raises(ConfigError, load_template, p).value)
    assert "Dyno_Speed.unit: channel 'Dyno_Speed': cannot convert 'rpm'" in msg
    assert "Cell_Temp.name: signal name 'amb_tmp_test'" in msg


def test_duplicate_standard_name(tmp_path):
    p = _write(tmp_path, D3_TEMPLATE.replace("eng_spd_out_test", "veh_spd_test"))
    with pytest.raises(ConfigError, match="'veh_spd_test' is also given to"):
        load_template(p)


def test_missing_name_without_delete_and_yaml_error(tmp_path):
    p = _write(tmp_path, D3_TEMPLATE.replace("{delete: true, reason: not needed}", "{unit: V}"))
    with pytest.raises(ConfigError, match=r"channels\.Phase_#: give the standard 'name'"):
        load_template(p)
    p = _write(tmp_path, "files: [\n  - {source: dyno", name="bad.yaml")
    with pytest.raises(ConfigError, match=r"bad\.yaml line \d+: YAML syntax error"):
        load_template(p)
    with pytest.raises(ConfigError, match="template file not found"):
        load_template(tmp_path / "none.yaml")
    p = _write(tmp_path, "- a\n- b\n", name="list.yaml")
    with pytest.raises(ConfigError, match="must be a YAML mapping"):
        load_template(p)


def test_bad_source_tag_and_time_both(tmp_path):
    p = _write(tmp_path, D3_TEMPLATE.replace("source: dyno", "source: Dyno_1")
               .replace("{column: Time, unit: s}", "{column: Time, rate_hz: 10}"))
    msg = str(pytest.raises(ConfigError, load_template, p).value)
    assert "files[0].source" in msg and "files[0].time: give either 'column' or 'rate_hz'" in msg


def test_save_load_round_trip(tmp_path, d3_template):
    t = load_template(d3_template)
    out = t.save(tmp_path / "sub" / "copy.yaml")
    text = out.read_text()
    assert "#" not in text.replace("Phase_#", "")  # no comments
    assert "Dyno_Speed: {name: veh_spd_test, unit: mph}" in text
    t2 = load_template(out)
    assert t2.model_dump() == t.model_dump()


def test_match_channel_alias_and_fuzzy():
    assert match_channel("Engine Speed", "rpm") == "eng_spd_out"      # alias
    assert match_channel("Eng_Spd", "rpm") == "eng_spd_out"           # tokens
    assert match_channel("Motor Temp", "degC") == "mot_temp"          # tokens + unit
    assert match_channel("MG2 Torque", "N*m") == "mot_trq_out"
    assert match_channel("Speed", "rpm") != "veh_spd"                 # unit rules out m/s
    assert match_channel("Wobble frobnicator", "V") is None


def test_match_channel_unit_in_the_name():
    # an ADVISOR-era test file: no unit row, the unit is the last word of the name
    assert match_channel("speed_mph", None) == "veh_spd"
    assert match_channel("batt_volts", None) == "ess_volt"
    assert match_channel("batt_amps", None) == "ess_curr"
    assert match_channel("eng_rpm", None) == "eng_spd_out"
    # the unit word decides the dimension: a speed in rpm is not the vehicle speed
    assert match_channel("speed_kph", None) == "veh_spd"
    assert match_channel("wobble_mph", None) is None


def test_propose_unique_names_sources_and_unmatched(tmp_path):
    dyno = write_d3(tmp_path / "a_d3.txt",
                    header=["Time[s]", "Dyno_Speed[mph]", "Engine Speed[rpm]", "Frob[V]", "Phase_#"])
    obd = tmp_path / "b.csv"
    obd.write_text("eng2rpm,eng2vsp,eng2soc\n800,10,55\n810,11,55\n")
    t, unmatched = propose_template([dyno, obd])
    d, o = t.files
    assert (d.source, d.format, o.source, o.format) == ("dyno", "d3", "obd", "csv")
    assert d.time.column == "Time" and o.time.rate_hz == 1.0
    assert d.channels["Engine Speed"].name == "eng_spd_out_test"
    assert o.channels["eng2rpm"].name == "eng_spd_out_obd_test"       # second engine speed
    assert o.channels["eng2vsp"].name == "veh_spd_obd_test"
    assert d.channels["Frob"].delete and d.channels["Frob"].reason == UNMATCHED_REASON
    assert unmatched == ["a_d3.txt: Frob"]
    assert d.match == "a_d3.txt" and o.match == "b.csv"
    assert any("eng2rpm" in x and "no unit" in x for x in t.todo)
    assert any("eng2soc" in x and "'%'" in x for x in t.todo)
    # the proposal saves and loads
    p = t.save(tmp_path / "T.yaml")
    assert load_template(p).files[1].source == "obd"


def test_check_template_report(tmp_path, d3_template):
    f = write_d3(tmp_path / "x.txt", header=["Time[s]", "Dyno_Speed[km/h]", "Extra[V]",
                                             "Cell_Temp[F]", "Phase_#"])
    rep = check_template(d3_template, [f])
    assert rep.ok
    text = rep.format()
    assert "template channel 'Engine_Speed' is not in the file" in text
    assert "channels not in the template (ignored at import): Extra" in text
    assert "template unit 'mph' differs from the header unit 'km/h'" in text
    # unit problem -> error
    t = Template(files=[FileSpec(source="obd", time={"rate_hz": 1.0},
                                 channels={"Extra": ChannelSpec(name="eng_spd_out_test")})])
    rep = check_template(t, [f])
    assert not rep.ok and "cannot convert 'V'" in rep.errors[0]


def test_check_template_says_each_problem_once(tmp_path):
    """Reported: `template check` repeated each error once per file (126 lines on 42 files)."""
    files = [write_d3(tmp_path / f"x{i}.txt", header=["Time[s]", "Extra[V]"],
                      rows=[[0.0, 1.0], [1.0, 2.0], [2.0, 3.0]]) for i in range(5)]
    t = Template(files=[FileSpec(source="obd", match="x*.txt", time={"rate_hz": 1.0},
                                 channels={"Extra": ChannelSpec(name="eng_spd_out_test")})])
    rep = check_template(t, files)
    assert len(rep.errors) == 5                       # per file in the report object
    lines = [ln for ln in rep.format().splitlines() if ln.startswith("error:")]
    assert len(lines) == 1, lines
    assert lines[0].startswith("error: x0.txt, x1.txt, x2.txt and 2 more file(s): channel 'Extra'")
    assert rep.format().splitlines()[-1].startswith("1 error(s)")


def test_template_init_never_maps_distinct_columns_to_one_quantity(tmp_path):
    """Reported on an OBD log: three DTC counters became one signal, B+ and a second voltage
    one, ap1/ap2 one; QA then compared them as sources ("gain differs by +198310 %")."""
    from vehval.io.propose import propose_template
    from vehval.nomenclature import registry

    cols = ["RPM", "B+", "B2+", "bt1", "bt2", "eng2ap1", "eng2ap2", "eng2dtcw", "eng2dtcd",
            "eng2dtct", "eng2bp"]
    f = tmp_path / "log.csv"
    f.write_text(",".join(cols) + "\n" + "\n".join(",".join(str(i + k) for k in range(len(cols)))
                                                    for i in range(5)) + "\n")
    t, _ = propose_template([f])
    ch = t.files[0].channels
    kept = {k: c.name for k, c in ch.items() if not c.delete}
    reg = registry()
    parsed = {k: reg.parse(n) for k, n in kept.items()}
    sources_by_base: dict[str, list] = {}
    for k, p in parsed.items():
        sources_by_base.setdefault(p.base, []).append(p.source)
    for base, srcs in sources_by_base.items():
        if len(srcs) > 1:   # only numbered instances share a quantity within one file
            assert all(s and s[-1].isdigit() for s in srcs), (base, srcs)
    assert kept["bt1"].endswith("_bt1_test") and kept["bt2"].endswith("_bt2_test")
    assert kept["eng2ap1"].endswith("_ap1_test") and kept["eng2ap2"].endswith("_ap2_test")
    assert ch["eng2dtcd"].delete and "already mapped from 'eng2dtcw'" in ch["eng2dtcd"].reason
    assert ch["B2+"].delete and ch["eng2bp"].delete


def test_check_template_names_the_channel_a_typo_meant(tmp_path, d3_template):
    """A misspelled channel key ('Engine_Sped') was two unrelated warnings; the first now
    names the file's channel it probably meant."""
    f = write_d3(tmp_path / "x.txt", header=["Time[s]", "Dyno_Speed[mph]", "Engine_Speed[rpm]",
                                             "Cell_Temp[F]", "Phase_#"])
    t = load_template(d3_template)
    t.files[0].channels["Engine_Sped"] = t.files[0].channels.pop("Engine_Speed")
    rep = check_template(t, [f])
    assert ("template channel 'Engine_Sped' is not in the file (did you mean 'Engine_Speed'?"
            in rep.format())
