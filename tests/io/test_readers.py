"""Raw readers: D3 text, generic CSV/TSV variants, repairs with notes, clear errors."""

from __future__ import annotations

import numpy as np
import pytest
from iohelpers import D3_HEADER, d3_rows, write_d3

from vehval.errors import InputFileError
from vehval.io.readers import detect_format, read_raw


def test_d3_basic(d3_file):
    r = read_raw(d3_file)
    assert r.fmt == "d3"
    assert r.time_name == "Time" and r.time_unit == "sec"
    assert r.names == ["Time", "Dyno_Speed", "Engine_Speed", "Cell_Temp", "Phase_#"]
    assert r.units == ["sec", "mph", "rpm", "F", None]
    assert r.data["Time"][0] == -1.0  # negative start kept
    # exact decimal text -> exact float parse
    np.testing.assert_allclose(r.data["Dyno_Speed"], [v[1] for v in d3_rows()], rtol=0)  # repr() written: exact round trip
    assert r.notes == []
    assert r.first_data_line == 2


def test_stray_bytes_before_time_header_repaired_with_note(tmp_path):
    p = write_d3(tmp_path / "x.txt", prefix=b"fp")
    r = read_raw(p)
    assert r.time_name == "Time" and r.fmt == "d3"
    assert any("stray" in n and "'fp'" in n for n in r.notes)


def test_control_byte_before_unrecognisable_header_is_an_error(tmp_path):
    p = write_d3(tmp_path / "x.txt", header=["Speed[mph]", "Other[rpm]", "A", "B", "C"],
                 prefix=b"\x07")
    with pytest.raises(InputFileError, match=r"x\.txt line 1: stray control byte"):
        read_raw(p)


def test_control_byte_before_time_header_repaired(tmp_path):
    p = write_d3(tmp_path / "x.txt", prefix=b"\x01\xff")
    r = read_raw(p)
    assert r.time_name == "Time" and any("stray" in n for n in r.notes)


@pytest.mark.parametrize("delim", [",", ";", "\t"])
def test_delimiter_sniffing(tmp_path, delim):
    p = tmp_path / "a.csv"
    p.write_text(f"time{delim}speed [km/h]{delim}I\n0{delim}1.5{delim}2\n1{delim}2.5{delim}3\n")
    r = read_raw(p)
    assert r.meta["delimiter"] == delim
    assert r.names == ["time", "speed", "I"] and r.units == [None, "km/h", None]
    np.testing.assert_array_equal(r.data["speed"], [1.5, 2.5])


def test_decimal_comma_semicolon(tmp_path):
    p = tmp_path / "a.csv"
    p.write_text("Zeit[s];Speed[km/h]\n0,0;12,5\n0,1;-13,25\n")
    r = read_raw(p)
    assert r.meta == {"delimiter": ";", "decimal": ","}
    np.testing.assert_array_equal(r.data["Speed"], [12.5, -13.25])
    assert r.time_name == "Zeit"


def test_utf8_bom(tmp_path):
    p = tmp_path / "a.csv"
    p.write_bytes(b"\xef\xbb\xbfTime[s],Temp[\xc2\xb0C]\n0,20.5\n1,21\n")
    r = read_raw(p)
    assert r.names == ["Time", "Temp"] and r.units == ["s", "°C"]
    assert r.time_name == "Time"


@pytest.mark.parametrize("enc", ["utf-16", "utf-16-le"])
def test_utf16_with_and_without_bom(tmp_path, enc):
    p = tmp_path / "a.txt"
    p.write_bytes("Time[s]\tSpeed[mph]\r\n0\t1.5\r\n0.1\t2.5\r\n".encode(enc))
    r = read_raw(p)
    assert r.names == ["Time", "Speed"]
    np.testing.assert_array_equal(r.data["Speed"], [1.5, 2.5])
    assert "decoded from UTF-16" in r.notes


def test_unit_row(tmp_path):
    p = tmp_path / "a.csv"
    p.write_text("time,speed\ns,km/h\n0,1\n1,2\n")
    r = read_raw(p)
    assert r.units == ["s", "km/h"] and r.first_data_line == 3
    assert any("unit row" in n for n in r.notes)


def test_truncated_last_line_dropped_with_note(tmp_path):
    p = tmp_path / "a.csv"
    p.write_text("a,b,c\n1,2,3\n4,5,6\n7,8")
    r = read_raw(p)
    np.testing.assert_array_equal(r.data["a"], [1, 4])
    assert any("line 4" in n and "truncated" in n for n in r.notes)


def test_nul_padding_stripped_with_note(tmp_path):
    p = tmp_path / "a.csv"
    p.write_bytes(b"a,b\r\n1,2\r\n3,4\r\n" + b"\0" * 300)
    r = read_raw(p)
    np.testing.assert_array_equal(r.data["b"], [2, 4])
    assert any("300 NUL" in n for n in r.notes)


def test_nul_inside_data_is_an_error_naming_the_line(tmp_path):
    p = tmp_path / "a.csv"
    p.write_bytes(b"a,b\n1,2\n3,\0\0\n5,6\n")
    with pytest.raises(InputFileError, match=r"a\.csv line 3: NUL byte"):
        read_raw(p)


def test_non_numeric_cell_names_line_and_channel(tmp_path):
    p = tmp_path / "a.csv"
    p.write_text("t,speed,rpm\n0,1,2\n1,2,3\n2,abc,4\n")
    with pytest.raises(InputFileError, match=r"a\.csv line 4: non-numeric value 'abc' in channel 'speed'"):
        read_raw(p)


def test_wrong_field_count_in_middle_names_line(tmp_path):
    p = tmp_path / "a.csv"
    p.write_text("t,speed,rpm\n0,1,2\n1,2\n2,3,4\n")
    with pytest.raises(InputFileError, match=r"a\.csv line 3: 2 fields, the header has 3"):
        read_raw(p)


def test_duplicate_channel_names(tmp_path):
    p = tmp_path / "a.txt"
    p.write_text("Time[s]\tSpeed[mph]\tSpeed[km/h]\n0\t1\t2\n")
    with pytest.raises(InputFileError, match=r"duplicate channel name 'Speed' in columns 2 and 3"):
        read_raw(p)


def test_missing_empty_and_header_only(tmp_path):
    with pytest.raises(InputFileError, match="file not found"):
        read_raw(tmp_path / "nope.txt")
    (tmp_path / "e.txt").write_bytes(b"")
    with pytest.raises(InputFileError, match="empty"):
        read_raw(tmp_path / "e.txt")
    (tmp_path / "w.txt").write_bytes(b"\r\n\n  \n")
    with pytest.raises(InputFileError, match="empty"):
        read_raw(tmp_path / "w.txt")
    (tmp_path / "h.txt").write_text("Time[s]\tA[V]\r\n")
    with pytest.raises(InputFileError, match="no data rows"):
        read_raw(tmp_path / "h.txt")


def test_empty_cells_are_nan(tmp_path):
    p = tmp_path / "a.csv"
    p.write_text("t,x\n0,1\n1,\n2,NaN\n3,4\n")
    r = read_raw(p)
    assert np.isnan(r.data["x"]).tolist() == [False, True, True, False]


def test_detect_format(tmp_path, d3_file):
    assert detect_format(d3_file) == "d3"
    p = tmp_path / "b.csv"
    p.write_text("RPM,SOC\n1,2\n")
    assert detect_format(p) == "csv"
    assert read_raw(p).time_name is None
    with pytest.raises(InputFileError, match="unknown format"):
        read_raw(p, fmt="xls")


def test_d3_header_constant():
    assert D3_HEADER[0].startswith("Time")


def test_utf32_unknown_encoding_cr_only_and_empty_last_cell(tmp_path):
    p = tmp_path / "u32.txt"
    p.write_bytes("Time[s]\tSpeed[mph]\r\n0\t1\r\n".encode("utf-32"))
    assert read_raw(p).data["Speed"].tolist() == [1.0]
    with pytest.raises(InputFileError, match="unknown text encoding 'no-such-codec'"):
        read_raw(p, encoding="no-such-codec")
    p = tmp_path / "cr.csv"
    p.write_bytes(b"t,x\r0,1\r1,2\r")
    assert read_raw(p).data["x"].tolist() == [1.0, 2.0]
    p = tmp_path / "e.txt"
    p.write_bytes(b"Time[s]\tSpeed[mph]\tEmpty[A]\r\n0\t12.5\t\r\n1\t12.5\t\r\n")
    r = read_raw(p)
    assert r.data["Speed"].tolist() == [12.5, 12.5] and np.isnan(r.data["Empty"]).all()
    assert r.notes == []


def test_corrupted_mdf_is_an_error_not_a_crash(tmp_path):
    """Flipped bytes in MDF blocks must give InputFileError (asammdf's C code would segfault
    on an out-of-record channel offset; the layout is checked first)."""
    from asammdf import MDF
    from asammdf import Signal as MSig

    t = np.arange(20) * 0.1
    mdf = MDF(version="4.10")
    mdf.append([MSig(samples=t, timestamps=t, name="A", unit="V")])
    good = tmp_path / "g.mf4"
    mdf.save(good, overwrite=True)
    mdf.close()
    data = good.read_bytes()
    rng = np.random.default_rng(3)
    outcomes = set()
    for k in range(30):
        raw = bytearray(data[: int(len(data) * (0.2 + 0.8 * k / 30))] if k % 2 else data)
        if not k % 2:
            for pos in rng.integers(0, len(raw), 3):
                raw[pos] = int(rng.integers(0, 256))
        p = tmp_path / "m.mf4"
        p.write_bytes(bytes(raw))
        try:
            read_raw(p)
            outcomes.add("ok")
        except InputFileError:
            outcomes.add("error")
    assert "error" in outcomes


def test_an_epa_test_car_list_is_named_not_read_as_a_time_series(tmp_path, capsys):
    """`vehval info 19tstcar.csv` said "non-numeric value 'aston martin' ... fix the cell"."""
    from helpers.epa_lists import row, write_list
    from vehval.cli import main

    path = write_list(tmp_path / "19tstcar.csv", [row()])
    with pytest.raises(InputFileError, match=r"19tstcar\.csv: is an EPA Test Car List .* "
                                             r"`vehval epa list`"):
        read_raw(path)
    assert main(["info", str(path)]) == 2
    assert "is an EPA Test Car List" in capsys.readouterr().err


def test_mixed_line_ends_are_read(tmp_path):
    p = tmp_path / "mixed.txt"
    p.write_bytes(b"Time[s]\tSpeed[mph]\r0\t1\r\n1\t2\n2\t3\r3\t4\r\n")
    r = read_raw(p)
    assert r.data["Speed"].tolist() == [1.0, 2.0, 3.0, 4.0]
    assert any("mixed line ends" in n for n in r.notes)
