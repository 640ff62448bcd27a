"""Virtual-dyno tests through import: the template's `cycle`/`synthetic` keys reach the Test,
identification from the imported speed agrees with the generating cycle, and
`template init` proposes the OBD source, target names and units for the virtual files.

One short virtual test per cycle kind (ECE-15, 195 s, default faults; a 90 s steady run
without faults) keeps this module at a few seconds.
"""

from __future__ import annotations

import pytest

from vehval.cycles import steady_cycle
from vehval.cycles_match import identify_cycle
from vehval.io.importer import import_test, set_cycle
from vehval.io.propose import propose_template
from vehval.io.template import load_template
from vehval.synth import make_virtual_test
from vehval.validate.ladder import rung_of

pytestmark = pytest.mark.xdist_group("io_virtual")


@pytest.fixture(scope="module")
def ece15(tmp_path_factory):
    return make_virtual_test(cycle="ece15", seed=3, faults="default",
                             outdir=tmp_path_factory.mktemp("vt") / "ece15")


@pytest.fixture(scope="module")
def steady(tmp_path_factory):
    return make_virtual_test(cycle=steady_cycle(50 / 3.6, 90.0), seed=5, faults="none",
                             outdir=tmp_path_factory.mktemp("vt") / "steady")


def test_virtual_template_declares_cycle_and_synthetic(ece15):
    t = load_template(ece15.template_path)
    assert t.cycle == "ece15" and t.synthetic is True
    test = import_test(ece15.files, t)
    assert test.meta.cycle == "ece15" and test.meta.synthetic is True
    assert "cycle from the template: ece15" in test.meta.notes


def test_identification_agrees_with_generating_cycle(ece15, steady):
    test = import_test(ece15.files, ece15.template_path)
    # every measured speed (dyno 10 Hz, OBD ~1 Hz with a clock offset) gives the cycle
    for sig in test.by_base("veh_spd", "test"):
        name, score, d = identify_cycle(sig.time, sig.values)
        assert name == "ece15", (sig.name, d)
        assert d["rms_mps"] < 0.5 and score > 0.5
    test.meta.cycle = ""
    set_cycle(test, None)
    assert test.meta.cycle == "ece15"
    assert any(n.startswith("cycle identified as ece15 (rms") and n.endswith("veh_spd_test")
               for n in test.meta.notes)
    st = import_test(steady.files, steady.template_path)
    assert st.meta.cycle == "steady_50kph_90s" and st.meta.synthetic
    st.meta.cycle = ""
    set_cycle(st, None)
    assert st.meta.cycle == "steady_50kph"
    assert rung_of(st.meta.cycle) == rung_of("steady_50kph_90s") == "steady"


def test_propose_on_virtual_files(ece15):
    d3, obd = ece15.files
    t, unmatched = propose_template([obd])
    assert t.files[0].source == "obd"  # OBD-like CSV, not the file stem
    ch = t.files[0].channels
    assert ch["TARGET_ENGINE_RPM"].name == "eng_spd_target_test"
    assert ch["ENGINE_RPM"].name == "eng_spd_out_test" and ch["ENGINE_RPM"].unit == "rpm"
    todo = "\n".join(t.todo)
    for name in ("MG2_TORQUE", "VEHICLE_SPEED", "HV_BATT_VOLTAGE"):  # no unit anywhere
        assert f"channel '{name}'" in todo and "set 'unit'" in todo
    assert "'rpm' taken from the channel name" in todo
    t2, unmatched = propose_template([d3, obd])
    assert unmatched == []
    assert t2.files[0].channels["Dyno_Load_Cell"].name == "dyno_frc_test"
    assert t2.files[1].source == "obd"
    assert t2.files[1].channels["ENGINE_RPM"].name == "eng_spd_out_obd_test"
