"""The virtual files look like real ones, and the same seed gives the same bytes."""

from __future__ import annotations

import json

import numpy as np
import pytest

from vehval.io.propose import propose_template
from vehval.io.readers import read_raw
from vehval.io.template import load_template

pytestmark = pytest.mark.xdist_group("synth")


def test_d3_file_layout(virtual_none):
    data = virtual_none.d3.read_bytes()
    lines = data.split(b"\r\n")
    assert lines[-1] == b"" and b"\n" not in data.replace(b"\r\n", b"")  # CRLF only
    header = lines[0].decode().split("\t")
    assert header[0] == "Time[sec]" and "Dyno_Speed[mph]" in header and "Phase_#" in header
    first = lines[1].decode().split("\t")
    assert first[0] == "-10.000" and all(len(c.split(".")[1]) == 3 for c in first)


def test_template_is_valid_and_says_virtual(virtual_none):
    t = load_template(virtual_none.out.template_path)
    assert "VIRTUAL TEST" in t.description and t.vehicle == "prius_2004"
    assert t.constants.test_mass_kg == virtual_none.truth["constants"]["test_mass_kg"]
    assert {f.source for f in t.files} == {"dyno", "obd"}
    readme = (virtual_none.dir / "README.txt").read_text()
    assert readme.startswith("VIRTUAL TEST")


@pytest.mark.realdata
def test_d3_reader_and_template_init_treat_virtual_like_real(virtual_none, cruze_data):
    real_dir = cruze_data
    if not any(real_dir.glob("*Test Data.txt")):
        pytest.skip(f"no D3 test file in {real_dir}")
    real_file = sorted(real_dir.glob("*Test Data.txt"))[0]
    for name in ("61410012 Test Data.txt", "61410013 Test Data.txt"):
        if (real_dir / name).is_file():  # a file without the corrupted 'fp' header
            real_file = real_dir / name
            break
    real, virt = read_raw(real_file), read_raw(virtual_none.d3)
    assert virt.fmt == real.fmt == "d3"
    assert virt.meta.get("delimiter") == real.meta.get("delimiter") == "\t"
    assert virt.time_name == real.time_name == "Time"
    assert virt.units[0] == real.units[0] == "sec"
    for raw in (real, virt):
        t = raw.data[raw.time_name]
        assert t[0] == -10.0 and np.all(np.diff(t) > 0)
        assert abs(np.median(np.diff(t)) - 0.1) < 1e-6
    # channels both files share are parsed the same way (name and unit)
    shared = set(real.names) & set(virt.names)
    assert {"Time", "Dyno_Speed", "Dyno_Tractive_Effort", "Engine_Speed", "Phase_#"} <= shared
    for n in shared - {"Test_Cell_Temp", "Engine_Coolant_Temp"}:  # °F here, °C in the real file
        assert virt.units[virt.names.index(n)] == real.units[real.names.index(n)], n
    # template init proposes the same thing for the shared channels
    t_real, _ = propose_template([real_file])
    t_virt, _ = propose_template([virtual_none.d3])
    fr, fv = t_real.files[0], t_virt.files[0]
    assert fr.format == fv.format and fr.time.column == fv.time.column == "Time"
    assert fr.source == fv.source
    for n in ("Dyno_Speed", "Dyno_Tractive_Effort", "Engine_Speed", "Phase_#"):
        assert fr.channels[n].name == fv.channels[n].name, n


def test_same_seed_same_bytes(virtual_default, virtual_default_again):
    a, b = virtual_default, virtual_default_again
    names = sorted(p.name for p in a.dir.iterdir())
    assert names == sorted(p.name for p in b.dir.iterdir())
    assert {"template.yaml", "truth.json", "clean.parquet", "README.txt"} <= set(names)
    for n in names:
        assert (a.dir / n).read_bytes() == (b.dir / n).read_bytes(), n
    truth = json.loads((a.dir / "truth.json").read_text())
    assert str(a.dir) not in json.dumps(truth)  # no machine-specific paths in the truth
