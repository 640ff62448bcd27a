"""Row matching of the Test Car Lists for s_r and s_R, and `vehval epa repeatability`."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from helpers.data import EPA_LISTS as EPA
from helpers.epa_lists import row, write_list
from vehval.cli import main
from vehval.epa import read_test_car_list
from vehval.epa.precision import collect, dedupe, estimate, powertrain_family

FTP = dict(code=21, desc="Federal fuel 2-day exhaust (w/can load)")
REPO = Path(__file__).resolve().parents[2]


def _rows():
    """Four conventional cars, each: two MFR HWFETs, one EPA HWFET of the same setting, and
    one EPA HWFET under another configuration number; a 4-bag hybrid FTP."""
    out = []
    for i, fe in enumerate((30.0, 35.0, 40.0, 45.0)):
        vid = f"CAR{i}"
        out += [row(model="SEDAN", vid=vid, cfg="0", number=f"M{i}a", orig="MFR", fe=fe),
                row(model="SEDAN", vid=vid, cfg="0", number=f"M{i}b", orig="MFR",
                    fe=round(fe * 1.01, 1)),
                row(model="SEDAN", vid=vid, cfg="0", number=f"E{i}", orig="EPA",
                    fe=round(fe * 0.98, 1)),
                row(model="SEDAN", vid=vid, cfg="7", number=f"X{i}", orig="EPA",
                    fe=round(fe * 1.05, 1))]
    # the same test listed again under a second represented model: counted once
    out.append(row(model="SEDAN SPORT", vid="CAR0", cfg="0", number="M0a", orig="MFR", fe=30.0))
    out.append(row(model="PRIUS", vid="HYB", number="H1", fe=78.0,
                   bags=(50.7, 126.3, 62.7, 114.4), **FTP))
    return out


@pytest.fixture
def lab_list(tmp_path) -> Path:
    return write_list(tmp_path / "16tstcar.csv", _rows())


def test_duplicate_test_numbers_are_removed(lab_list):
    d = dedupe(read_test_car_list(lab_list))
    assert d.duplicates == 1 and d.conflicting == 0
    assert [t.test_number for t in d.kept].count("M0a") == 1


def test_groups_pairs_and_families(lab_list):
    tests = read_test_car_list(lab_list)
    s = collect(tests)
    assert len(s.repeats[("conventional", "hwfet")]) == 4          # MFR pairs only
    assert all(len(g) == 2 for g in s.repeats[("conventional", "hwfet")])
    strict = s.pairs[("conventional", "hwfet")]
    assert len(strict) == 4 and all(len(p.a) == 1 for p in strict)  # config 7 not matched
    vehicle = s.pairs_vehicle[("conventional", "hwfet")]
    assert all(len(p.a) == 2 for p in vehicle)                      # any configuration
    hyb = [t for t in tests if t.vehicle_id == "HYB"][0]
    assert powertrain_family(hyb, {"HYB"}) == "hybrid"
    cell = {(c.family, c.procedure): c for c in estimate(s)}[("conventional", "hwfet")]
    assert c_pct(cell.s_r) == pytest.approx(0.71, abs=0.1)           # 1 % apart: s = 0.71 %
    assert cell.s_R.offset < 0 and cell.s_R.dof == 4


def c_pct(p):
    return 100 * p.s


def test_cli_table_json_and_refusal(lab_list, capsys):
    assert main(["epa", "repeatability", str(lab_list)]) == 0
    out = capsys.readouterr().out
    assert "| conventional | hwfet |" in out and "1 duplicate test numbers" in out
    assert main(["epa", "repeatability", str(lab_list), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    cell = [c for c in data["lists"][0]["cells"] if c["procedure"] == "hwfet"][0]
    assert cell["s_r"]["dof"] == 4 and cell["s_R"]["dof"] == 4
    assert {"s_r", "s_R", "s_R_vehicle", "available", "notes"} <= set(cell)


def test_cli_names_the_count_when_refused(tmp_path, capsys):
    rows = [r for r in _rows() if r["Test Vehicle ID"] in ("CAR0", "CAR1")]
    f = write_list(tmp_path / "16tstcar.csv", rows)
    assert main(["epa", "repeatability", str(f)]) == 0
    out = capsys.readouterr().out
    assert "2 (< 3: refused)" in out
    assert main(["epa", "repeatability", str(f), "--confidence", "1.2"]) == 2


def test_packaged_defaults_have_provenance():
    from vehval.uncertainty.defaults import precision_default

    d = precision_default("ftp75", "conventional")
    assert 0.005 < d.s_r < 0.03 and d.n["s_r"] > 100
    assert "16tstcar.csv" in d.provenance and "19tstcar.csv" in d.provenance
    h = precision_default("ftp75", "hybrid")
    assert h.s_r is not None and "of all families" in h.provenance   # s_R pooled
    from vehval.errors import ConfigError
    with pytest.raises(ConfigError, match="known"):
        precision_default("wltc")


@pytest.mark.skipif(not EPA.is_dir(), reason="EPA Test Car List not found")
def test_docs_table_is_the_command_output(capsys):
    """docs/validation.md's table is `vehval epa repeatability` on the 2016 and 2019 lists."""
    assert main(["epa", "repeatability", str(EPA / "16tstcar.csv"),
                 str(EPA / "19tstcar.csv")]) == 0
    out = [ln for ln in capsys.readouterr().out.splitlines() if ln.startswith("| ")]
    doc = (REPO / "docs" / "validation.md").read_text(encoding="utf-8").splitlines()
    for line in out:
        assert line in doc, line
