"""Loader bombs: YAML aliases, Parquet decompression, EPA lists, units and template numbers
are refused with one clear line before anything large is built."""

from __future__ import annotations

import json
import re
import resource

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from helpers.cli import TEMPLATE, run_cli
from vehval.epa.reader import MAX_LIST_BYTES, read_test_car_list
from vehval.errors import ConfigError, InputFileError, UnitError
from vehval.io import budget
from vehval.io.parquet import read_parquet_raw, read_test, write_test
from vehval.io.template import load_template
from vehval.safe_yaml import load_yaml, read_yaml
from vehval.test import Signal, Test, TestMeta
from vehval.units import conversion


def test_yaml_alias_bomb_refused_before_it_is_built(tmp_path):
    """Was: a 475 kB vehicle file with a row aliased 10^5 times reached 3.8 GB."""
    row = "[" + ", ".join(["1.0"] * 200) + "]"
    text = "engine:\n  fuel_rate_g_per_s:\n  - &r " + row + "\n" + "  - *r\n" * 100_000
    p = tmp_path / "v.yaml"
    p.write_text(text)
    with pytest.raises(ConfigError, match=r"line 3: YAML anchor '&r' is not accepted"):
        read_yaml(p)


@pytest.mark.parametrize("text", ["a: &x 1\nb: 2\n", "a: 1\nb: *x\n", "base: &b {k: 1}\nc:\n  <<: *b\n"])
def test_any_anchor_or_alias_is_refused(text):
    with pytest.raises(ConfigError, match="YAML (anchor|alias)"):
        load_yaml(text, "doc.yaml")


def test_vehicle_cli_alias_bomb_one_line(tmp_path, capsys):
    p = tmp_path / "bomb.yaml"
    p.write_text("architecture: x\nname: &n a\nother: *n\n")
    rc, _, err = run_cli(["vehicle", "show", p], capsys)
    assert rc == 2 and err.count("\n") == 1 and "anchor" in err


def test_every_yaml_reader_goes_through_safe_yaml():
    """No module parses YAML on its own (the one loader is vehval.safe_yaml)."""
    from pathlib import Path

    import vehval
    root = Path(vehval.__file__).parent
    offenders = [str(p.relative_to(root)) for p in root.rglob("*.py")
                 if p.name != "safe_yaml.py"
                 and any(k in p.read_text(encoding="utf-8")
                         for k in ("yaml.safe_load", "yaml.load(", "yaml.full_load", "yaml.parse("))]
    assert offenders == []


def _zeros_parquet(path, rows: int, cols: int = 8, chunk: int = 2_000_000) -> None:
    names = [f"C{i}[V]" for i in range(cols)]
    z = np.zeros(chunk)
    with pq.ParquetWriter(path, pa.schema([(n, pa.float64()) for n in names]),
                          compression="zstd") as w:
        for _ in range(rows // chunk):
            w.write_table(pa.table({n: z for n in names}), row_group_size=chunk)


def test_parquet_decompression_bomb_refused_from_the_footer(tmp_path, monkeypatch):
    """A few MB on disk declaring far more once decoded: refused, naming both sizes."""
    f = tmp_path / "bomb.parquet"
    _zeros_parquet(f, 4_000_000)           # 256 MB decoded, ~0.4 MB on disk
    monkeypatch.setattr(budget, "MAX_DECODED_BYTES", 100_000_000)
    with pytest.raises(InputFileError) as exc:
        read_parquet_raw(f)
    msg = str(exc.value)
    assert "bomb.parquet" in msg and "declares 260 MB" in msg and "budget of 100 MB" in msg
    assert "split the file" in msg


def test_parquet_row_count_and_zero_rows_refused(tmp_path, monkeypatch):
    from vehval.io import parquet
    f = tmp_path / "rows.parquet"
    _zeros_parquet(f, 2_000_000, cols=1)
    monkeypatch.setattr(parquet, "MAX_ROWS", 1_000_000)
    with pytest.raises(InputFileError, match="declares 2,000,000 rows"):
        read_parquet_raw(f)
    z = tmp_path / "zero.parquet"
    pq.write_table(pa.table({"Time[s]": pa.array([], pa.float64()),
                             "Speed[mph]": pa.array([], pa.float64())}), z)
    with pytest.raises(InputFileError, match="no rows"):
        read_parquet_raw(z)


def _small_test_file(tmp_path, **meta_changes):
    t = np.arange(50) * 0.1
    test = Test([Signal("veh_spd_test", t, np.ones(50), "m/s", "dyno")],
                TestMeta(test_id="T", files=["a.txt"]))
    p = write_test(test, tmp_path / "t.parquet")
    if meta_changes:
        table = pq.read_table(p)
        info = json.loads(table.schema.metadata[b"vehval"])
        info["meta"].update(meta_changes)
        pq.write_table(table.replace_schema_metadata({b"vehval": json.dumps(info).encode()}), p)
    return p


@pytest.mark.parametrize("change", [{"files": 5}, {"notes": [1, 2]}, {"constants": {"m": "x"}},
                                    {"synthetic": "yes"}])
def test_parquet_metadata_of_the_wrong_type_is_damaged(tmp_path, change):
    p = _small_test_file(tmp_path, **change)
    with pytest.raises(InputFileError, match=f"meta.{next(iter(change))}"):
        read_test(p)


def test_parquet_metadata_nested_deep_is_one_line(tmp_path, capsys):
    p = _small_test_file(tmp_path)
    table = pq.read_table(p)
    text = table.schema.metadata[b"vehval"].decode().replace(
        '"notes": [', '"notes": [' + "[" * 100_000 + "]" * 100_000 + ",", 1)
    pq.write_table(table.replace_schema_metadata({b"vehval": text.encode()}), p)
    with pytest.raises(InputFileError, match="nesting too deep"):
        read_test(p)
    for args in (["info", p], ["info", p, "--json"]):
        rc, _, err = run_cli(args, capsys)
        assert rc == 2 and err.count("\n") == 1, err


def test_budget_follows_the_address_space_limit(monkeypatch):
    monkeypatch.setattr(resource, "getrlimit", lambda _k: (1 << 30, 1 << 30))
    monkeypatch.setattr(budget, "_vm_size", lambda: 600_000_000)
    size, why = budget.decode_budget()
    assert size == int((2**30 - 600_000_000) * 0.5) and "address-space limit" in why
    with pytest.raises(InputFileError, match=r"needs about 703 MB of memory, 474 MB is left"):
        budget.check_memory(703e6, "QA of 'T'", advice="more memory")


EPA_HEADER = ("Model Year,Represented Test Veh Make,Represented Test Veh Model,Test Vehicle ID,"
              "Equivalent Test Weight (lbs.),Axle Ratio,N/V Ratio,Test Procedure Cd,"
              "Test Procedure Description,Test Fuel Type Cd,RND_ADJ_FE,FE_UNIT,FE Bag 1,"
              "FE Bag 2,FE Bag 3,FE Bag 4,Target Coef A (lbf),Target Coef B (lbf/mph),"
              "Target Coef C (lbf/mph**2),Set Coef A (lbf),Set Coef B (lbf/mph),"
              "Set Coef C (lbf/mph**2)")
EPA_ROW = "2019,TOYOTA,PRIUS,V1,3000,3.2,30,21,FTP,61,50.1,MPG,48,52,50,,20,0.2,0.02,5,0.1,0.02"


def test_epa_list_reads_and_streams(tmp_path):
    p = tmp_path / "19tstcar.csv"
    p.write_bytes((EPA_HEADER + "\r" + EPA_ROW + "\r" + EPA_ROW.replace("V1", "V2") + "\r")
                  .encode("latin-1"))
    tests = read_test_car_list(p)
    assert [t.vehicle_id for t in tests] == ["V1", "V2"] and tests[1].source.endswith(":3")


@pytest.mark.parametrize("bad,match", [
    ('"unclosed,' + EPA_ROW, "line 3"),
    ("x" * 140_000 + "," + EPA_ROW, "longer than 131,072 characters"),
    ('2019,"TOYOTA\nMORE",' + EPA_ROW[5:], "not closed on its line"),
    (EPA_ROW.replace("TOYOTA", "TOY\x00OTA"), "line 3: a NUL byte"),
    (EPA_ROW + "," + ",".join(["1"] * 1000), "line 3: 1022 fields, the header has 22"),
])
def test_epa_list_bad_quoting_is_a_clear_error(tmp_path, capsys, bad, match):
    p = tmp_path / "19tstcar.csv"
    p.write_text(EPA_HEADER + "\n" + EPA_ROW + "\n" + bad + "\n" + EPA_ROW + "\n",
                 encoding="latin-1")
    with pytest.raises(InputFileError, match=match):
        read_test_car_list(p)
    rc, _, err = run_cli(["epa", "list", p], capsys)
    assert rc == 2 and err.count("\n") == 1


def test_epa_list_over_budget_refused_before_reading(tmp_path):
    p = tmp_path / "all.csv"
    with p.open("wb") as fh:
        fh.write(EPA_HEADER.encode() + b"\n")
        fh.truncate(MAX_LIST_BYTES + 1)     # sparse: nothing large is written
    with pytest.raises(InputFileError, match=r"64 MB budget"):
        read_test_car_list(p)


@pytest.mark.parametrize("unit", ["Ym/ys*(Ym/ym)**20", "degC*(Ym/ym)**10", "ym/Ys*(ym/Ym)**20"])
def test_pathological_units_are_unit_errors(unit):
    with pytest.raises(UnitError, match="cannot convert"):
        conversion(unit, "degC" if unit.startswith("degC") else "m/s")


@pytest.mark.parametrize("edit,match", [
    ("Dyno_Speed: {name: veh_spd_test, unit: mph}",
     "Dyno_Speed: {name: veh_spd_test, unit: mph, scale: yes}"),
    ("time: {column: Time, unit: s}", "time: {rate_hz: 1.0e-300}"),
    ("time: {column: Time, unit: s}", "time: {rate_hz: 1.0e+300}"),
    ("Dyno_Speed: {name: veh_spd_test, unit: mph}",
     "Dyno_Speed: {name: veh_spd_test, unit: 'Ym/ys*(Ym/ym)**20'}"),
    ("Dyno_Speed: {name: veh_spd_test, unit: mph}",
     "Dyno_Speed: {name: veh_spd_test, unit: mph, offset: '3'}"),
])
def test_template_numbers_and_units_refused(tmp_path, edit, match):
    p = tmp_path / "T.yaml"
    p.write_text(TEMPLATE.replace(edit, match))
    with pytest.raises(ConfigError) as exc:
        load_template(p)
    msg = str(exc.value)
    key = {"scale": "scale: must be a number", "rate_hz": "rate_hz:", "Ym": "Dyno_Speed.unit",
           "offset": "offset: must be a number"}
    assert any(v in msg for k, v in key.items() if k in match), msg


@pytest.mark.parametrize("extra, match", [
    ("scale: 1.0e+308", "scale 1e+308 is outside"), ("scale: 0", "scale 0 is outside"),
    ("scale: 1.0e-12", "scale 1e-12 is outside"), ("offset: -1.0e+308", "offset -1e+308 is beyond"),
])
def test_template_scale_and_offset_bounded(tmp_path, extra, match):
    """A factor of 1e308 turns every sample into inf; 0 erases the channel: both refused."""
    p = tmp_path / "T.yaml"
    p.write_text(TEMPLATE.replace("Dyno_Speed: {name: veh_spd_test, unit: mph}",
                                  f"Dyno_Speed: {{name: veh_spd_test, unit: mph, {extra}}}"))
    with pytest.raises(ConfigError, match=re.escape(match)):
        load_template(p)


def test_template_plain_scales_still_load(tmp_path):
    p = tmp_path / "T.yaml"
    p.write_text(TEMPLATE.replace("Dyno_Speed: {name: veh_spd_test, unit: mph}",
                                  "Dyno_Speed: {name: veh_spd_test, unit: mph, scale: -2.5e-3, "
                                  "offset: 273.15}"))
    spec = load_template(p)
    assert spec is not None


def test_text_file_over_budget_refused_before_reading(tmp_path, monkeypatch):
    from vehval.io.delimited import read_delimited
    p = tmp_path / "big_d3.txt"
    with p.open("wb") as fh:
        fh.write(b"Time[s]\tV[mph]\n0\t1\n")
        fh.truncate(300_000_000)           # sparse
    from vehval.io import delimited
    monkeypatch.setattr(delimited, "MAX_TEXT_BYTES", 100_000_000)
    with pytest.raises(InputFileError, match=r"big_d3.txt: the text data file is 300 MB, more "
                                             r"than the budget of 100 MB"):
        read_delimited(p, fmt="d3")


def test_mdf_declared_size_over_budget_refused(tmp_path, monkeypatch):
    from asammdf import MDF
    from asammdf import Signal as MSig

    from vehval.io.mdf import read_mdf
    t = np.arange(0, 2000, 0.01)
    mdf = MDF(version="4.10")
    mdf.append([MSig(samples=0 * t, timestamps=t, name="Zero", unit="V")])
    p = tmp_path / "z.mf4"
    mdf.save(p, overwrite=True, compression=2)
    mdf.close()
    monkeypatch.setattr(budget, "MAX_DECODED_BYTES", 1_000_000)
    with pytest.raises(InputFileError, match=r"z.mf4: the MDF4 file declares \d+ MB of data"):
        read_mdf(p)
