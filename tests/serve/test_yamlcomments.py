"""Comments of a template survive the workbench's rewrite."""

from __future__ import annotations

from vehval.serve.yamlcomments import carry_comments

OLD = """# fuel: declare the test fuel
# or 'fuel: {density_kg_per_m3: ...}'
# fuel: diesel
template_version: 1
description: proposed
files:
- source: dyno
  # the facility file
  channels:
    Speed: {name: veh_spd_test, unit: mph}  # checked on the roll
    Fuel: {name: fuel_rate_test, unit: mg/s}
- source: obd
  channels:
    Speed: {name: veh_spd_obd_test, unit: km/h}
# end note
"""


def test_comments_kept_in_place():
    new = OLD.replace("unit: mg/s", "unit: g/s")
    new = "\n".join(line.split("  #")[0] for line in new.splitlines() if not line.lstrip().startswith("#"))
    out = carry_comments(OLD, new + "\n")
    assert out == OLD.replace("unit: mg/s", "unit: g/s")


def test_changed_line_keeps_its_end_of_line_comment_and_new_keys_go_in():
    new = ("template_version: 1\ndescription: proposed\nfuel: gasoline_e0\nfiles:\n- source: dyno\n"
           "  channels:\n    Speed: {name: veh_spd_test, unit: km/h}\n"
           "    Fuel: {name: fuel_rate_test, unit: mg/s}\n- source: obd\n  channels:\n"
           "    Speed: {name: veh_spd_obd_test, unit: km/h}\n")
    out = carry_comments(OLD, new).splitlines()
    # the `# fuel:` placeholders of template init go once the key is set (never stale)
    assert out[0] == "template_version: 1" and not any(ln.startswith("# fuel") for ln in out)
    assert "fuel: gasoline_e0" in out
    assert "    Speed: {name: veh_spd_test, unit: km/h}  # checked on the roll" in out
    assert out.index("  # the facility file") == out.index("  channels:") - 0 - 1
    assert out[-1] == "# end note"
    # the second file's Speed line (same key) has no comment: it gets none
    assert "    Speed: {name: veh_spd_obd_test, unit: km/h}" in out


def test_placeholder_kept_while_the_key_is_unset():
    new = "\n".join(ln.split("  #")[0] for ln in OLD.splitlines() if not ln.lstrip().startswith("#"))
    assert carry_comments(OLD, new + "\n").splitlines()[:3] == OLD.splitlines()[:3]


def test_number_literals_kept():
    old = ("constants:\n  test_mass_kg: 1727   # test weight\n  fuel_lhv_j_per_kg: 42.8e6\n"
           "  road_load_a_n: 100.69\n")
    new = ("constants:\n  test_mass_kg: 1727.0\n  fuel_lhv_j_per_kg: 42800000.0\n"
           "  road_load_a_n: 101.5\n")
    out = carry_comments(old, new).splitlines()
    assert out == ["constants:", "  test_mass_kg: 1727   # test weight",
                   "  fuel_lhv_j_per_kg: 42.8e6", "  road_load_a_n: 101.5"]
