"""Parquet Test round trip (units, provenance, meta, multi-rate) and MDF4 / plain Parquet reads."""

from __future__ import annotations

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

import vehval.test as vt
from vehval.errors import InputFileError
from vehval.io.importer import import_test
from vehval.io.parquet import read_test, write_test
from vehval.io.readers import read_raw
from vehval.test import Signal, Test


def _multi_rate_test() -> Test:
    t10 = np.arange(0, 5, 0.1)
    t1 = np.arange(0, 5, 1.0) + 0.25
    meta = vt.TestMeta(test_id="x1", vehicle="prius_2004", files=["a.txt", "b.csv"], template="T.yaml",
                    constants={"test_mass_kg": 1295.0}, deleted=[{"name": "rh", "reason": "r"}],
                    notes=["n1"], offsets_s={"obd": 0.3}, fuel="ethanol_e85",
                    cycle_match={"name": "udds", "score": 0.9, "signal": "veh_spd_test",
                                 "method": "cycle", "rms_mps": 0.2, "offsets_s": [1.5],
                                 "windows_s": [[1.5, 1371.5]]})
    spd = Signal.standard("veh_spd_test", t10, np.linspace(0, 20, t10.size), source="dyno",
                          raw_name="Dyno_Speed", raw_unit="mph", file="a.txt", notes=["hello"])
    spd.values[3] = np.nan
    return Test([spd,
                 Signal.standard("eng_spd_out_test", t10, 300 + t10, source="dyno", raw_unit="rpm"),
                 Signal.standard("ess_soc_obd_test", t1, 0.6 + 0 * t1, source="obd", raw_name="eng2soc",
                                 raw_unit="%", file="b.csv"),
                 Signal.standard("eng_on_test", t1, [0, 1, 1, 0, 1], source="obd")], meta=meta)


def test_parquet_round_trip_units_provenance_meta(tmp_path):
    test = _multi_rate_test()
    p = write_test(test, tmp_path / "out" / "t.parquet")
    # layout: one time column per group, padded with nulls
    table = pq.read_table(p)
    assert "time__dyno" in table.column_names and "time__obd" in table.column_names
    assert table.column("time__obd").null_count == table.num_rows - 5
    back = read_test(p)
    assert back.names == test.names
    for s in test:
        b = back[s.name]
        assert (b.unit, b.source, b.raw_name, b.raw_unit, b.file, b.resample, b.notes) == \
               (s.unit, s.source, s.raw_name, s.raw_unit, s.file, s.resample, s.notes)
        np.testing.assert_array_equal(b.time, s.time)
        np.testing.assert_array_equal(b.values, s.values)  # NaN at the same place
    assert back["eng_on_test"].resample == "previous"
    assert back.meta.to_dict() == test.meta.to_dict()
    assert not list(tmp_path.glob("out/.*.tmp"))  # atomic write left no temporary


def test_the_template_fuel_and_the_cycle_match_survive_the_file(tmp_path):
    """A test's declared fuel (the template's ``fuel:``) is read back: without it a
    validated test's fuel fell to the vehicle's and its mpg moved 5.6 % (E85 against
    gasoline); a damaged cycle match is refused like any damaged metadata."""
    from vehval.fuels.resolve import resolve_fuel

    test = _multi_rate_test()
    back = read_test(write_test(test, tmp_path / "t.parquet"))
    assert back.meta.fuel == "ethanol_e85" and back.meta.cycle_match["offsets_s"] == [1.5]
    assert resolve_fuel(test=back).fuel.name == "ethanol_e85"
    test.meta.fuel = {"density_kg_per_m3": 900.0, "lhv_j_per_kg": 4.0e7}
    assert read_test(write_test(test, tmp_path / "d.parquet")).meta.fuel == test.meta.fuel
    test.meta.cycle_match["offsets_s"] = ["soon"]
    with pytest.raises(InputFileError, match="damaged vehval metadata.*cycle_match.offsets_s"):
        read_test(write_test(test, tmp_path / "bad.parquet"))


def test_read_test_rejects_plain_parquet(tmp_path):
    p = tmp_path / "plain.parquet"
    pq.write_table(pa.table({"Time[s]": [0.0, 0.1], "Speed[km/h]": [1.0, 2.0], "label": ["a", "b"]}), p)
    with pytest.raises(InputFileError, match="not a vehval Test file"):
        read_test(p)
    r = read_raw(p)
    assert r.fmt == "parquet" and r.time_name == "Time" and r.units == ["s", "km/h"]
    assert any("'label'" in n for n in r.notes)


def test_raw_read_of_test_parquet_keeps_per_channel_time(tmp_path):
    p = write_test(_multi_rate_test(), tmp_path / "t.parquet")
    r = read_raw(p)
    assert r.time_of("ess_soc_obd_test").size == 5 and r.time_of("veh_spd_test").size == 50
    assert r.unit_of("veh_spd_test") == "m/s"


@pytest.fixture
def mdf_file(tmp_path):
    from asammdf import MDF
    from asammdf import Signal as MSig

    t10 = np.arange(50) * 0.1
    t1 = np.arange(5) * 1.0
    mdf = MDF(version="4.10")
    mdf.append([MSig(samples=60.0 + 0 * t10, timestamps=t10, name="Dyno_Speed", unit="mph"),
                MSig(samples=3000.0 + 0 * t10, timestamps=t10, name="Engine_Speed", unit="rpm")])
    mdf.append([MSig(samples=55.0 + t1, timestamps=t1, name="SOC", unit="%")])
    p = tmp_path / "run.mf4"
    mdf.save(p, overwrite=True)
    mdf.close()
    return p


def test_mdf4_read_back_per_channel_rates(mdf_file):
    r = read_raw(mdf_file)
    assert r.fmt == "mdf4" and r.time_name is None
    assert r.names == ["Dyno_Speed", "Engine_Speed", "SOC"]
    assert r.units == ["mph", "rpm", "%"]
    np.testing.assert_allclose(r.time_of("Dyno_Speed"), np.arange(50) * 0.1, atol=1e-12)
    np.testing.assert_array_equal(r.time_of("SOC"), np.arange(5.0))
    np.testing.assert_array_equal(r.data["SOC"], 55.0 + np.arange(5.0))


def test_mdf4_import_and_parquet_round_trip(tmp_path, mdf_file):
    t = tmp_path / "m.yaml"
    t.write_text("files:\n  - source: can\n    channels:\n"
                 "      Dyno_Speed: {name: veh_spd_test}\n"
                 "      Engine_Speed: {name: eng_spd_out_test}\n"
                 "      SOC: {name: ess_soc_test}\n")
    test = import_test([mdf_file], t)
    assert test["veh_spd_test"].values[0] == pytest.approx(26.8224, rel=1e-12)
    assert test["ess_soc_test"].time.size == 5
    assert test["ess_soc_test"].values[0] == pytest.approx(0.55, rel=1e-12)
    assert len(test.time_bases()) == 2
    back = read_test(write_test(test, tmp_path / "m.parquet"))
    np.testing.assert_array_equal(back["ess_soc_test"].time, np.arange(5.0))
    assert back["eng_spd_out_test"].unit == "rad/s"


def test_bad_mdf_file(tmp_path):
    p = tmp_path / "bad.mf4"
    p.write_bytes(b"MDF     garbage" * 10)
    with pytest.raises(InputFileError, match=r"bad\.mf4: not a readable MDF file"):
        read_raw(p)


def test_plain_parquet_null_timestamps_are_missing_times(tmp_path):
    p = tmp_path / "ts.parquet"
    ts = pa.array([None, 1_000, 2_000, None, 4_000], type=pa.timestamp("ms", tz="Europe/Berlin"))
    pq.write_table(pa.table({"Timestamp": ts, "Speed[km/h]": pa.array([1, 2, None, 4, 5],
                                                                       pa.int64())}), p)
    r = read_raw(p)
    t = r.data["Timestamp"]
    assert np.isnan(t[[0, 3]]).all() and t[[1, 2, 4]].tolist() == [0.0, 1.0, 3.0]
    assert np.isnan(r.data["Speed"][2]) and any("(2 empty)" in n for n in r.notes)
