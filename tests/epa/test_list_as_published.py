"""The lists as published: a UTF-8 byte-order mark, any line ending, every test number kept,
a row listed again named, analytically derived rows marked and not judged, a placeholder 0."""

from __future__ import annotations

import json

import pytest

from helpers.epa_lists import FULL_HEADER, row, write_list
from vehval.cli import main
from vehval.epa import read_lists, read_test_car_list
from vehval.epa.validation import validate_tests
from vehval.errors import ConfigError, InputFileError

AD_HEADER = [*FULL_HEADER, "Analytically Derived FE?", "ADFE Test Number"]


def _bom(path, rows, newline="\r\n", **kw):
    """A list written as recent years publish it: UTF-8 with a byte-order mark."""
    write_list(path, rows, newline=newline, encoding="utf-8", **kw)
    path.write_bytes(b"\xef\xbb\xbf" + path.read_bytes())
    return path


@pytest.mark.parametrize("newline", ["\r\n", "\r", "\n"])
def test_utf8_byte_order_mark_any_line_ending(tmp_path, newline, capsys):
    """A list starting with a UTF-8 byte-order mark was refused with "missing column(s)
    'Model Year'" (the mark read as part of the first column's name)."""
    path = _bom(tmp_path / "21tstcar.csv", [row(model="PRIUS Caf\u00e9"), row(number="T2")],
                newline=newline)
    tests = read_test_car_list(path)
    assert [t.test_number for t in tests] == ["T1", "T2"]
    assert tests[0].year == 2016 and tests[0].model == "PRIUS Caf\u00e9"  # not 'CafÃ©'
    assert main(["epa", "list", str(path)]) == 0
    assert capsys.readouterr().out.splitlines()[-1] == "2 vehicles, 2 tests"


def test_utf8_without_mark_and_latin1_both_read(tmp_path):
    utf8 = write_list(tmp_path / "a.csv", [row(model="M\u00e9gane")], encoding="utf-8")
    latin = write_list(tmp_path / "b.csv", [row(model="M\u00e9gane")], encoding="latin-1")
    assert read_test_car_list(utf8)[0].model == read_test_car_list(latin)[0].model == "M\u00e9gane"


def test_utf16_and_a_damaged_utf8_list_refused_with_one_line(tmp_path, capsys):
    path = tmp_path / "u16.csv"
    path.write_bytes("\ufeffModel Year,Make\r\n2016,TOYOTA\r\n".encode("utf-16-le"))
    with pytest.raises(InputFileError, match="UTF-16"):
        read_test_car_list(path)
    bad = _bom(tmp_path / "bad.csv", [row(), row(number="T2")])
    data = bad.read_bytes()
    bad.write_bytes(data.replace(b"T2", b"T\xe92"))  # a latin-1 byte after a UTF-8 mark
    assert main(["epa", "list", str(bad)]) == 2
    err = capsys.readouterr().err
    assert "line 3" in err and "0xE9" in err and "Traceback" not in err


def test_equal_rows_of_different_test_numbers_all_kept(tmp_path, capsys):
    """The 2019 Pacifica: HCRX10045415 repeats HCRX10045413's vehicle, procedure, figure and
    road load with its own test number; it was dropped (`epa tests` showed 5 of 6 rows)."""
    rows = [row(number=n, code=3, desc="HWFE", fe=40.0) for n in ("H13", "H15")]
    rows.append(row(number="F12", code=21, desc="Federal fuel 2-day exhaust", fe=24.3,
                    bags=(24.0, 23.05, 27.45, "")))
    path = write_list(tmp_path / "19tstcar.csv", rows)
    assert [t.test_number for t in read_lists([path])] == ["H13", "H15", "F12"]
    assert main(["epa", "tests", str(path), "--json"]) == 0
    assert {r["test_number"] for r in json.loads(capsys.readouterr().out)} == {"H13", "H15",
                                                                               "F12"}


def test_a_true_duplicate_is_named_not_silently_merged(tmp_path, capsys):
    """The same test number with the same values twice: one test, and `epa tests` says so
    (a line, and duplicate_rows / duplicate_note in --json)."""
    path = write_list(tmp_path / "16tstcar.csv", [row(number="T1"), row(number="T1"),
                                                  row(number="T2", fe=60.0)])
    tests = read_lists([path])
    assert [t.test_number for t in tests] == ["T1", "T2"]
    assert tests[0].duplicate_rows == ("16tstcar.csv:3",)
    assert "identical values" in tests[0].duplicate_note
    assert main(["epa", "tests", str(path)]) == 0
    out = capsys.readouterr().out
    assert "note: T1 (16tstcar.csv:2): listed 2 times (lines 2, 3) with identical values" in out
    assert main(["epa", "tests", str(path), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data[0]["duplicate_rows"] == ["16tstcar.csv:3"] and data[1]["duplicate_rows"] == []


def test_one_number_differing_only_in_a_column_not_read_is_one_test(tmp_path):
    """The lists give a diesel's test once per aftertreatment device: one test."""
    header = [*FULL_HEADER, "Aftertreatment Device Cd"]
    rows = [{**row(number="D1"), "Aftertreatment Device Cd": cd} for cd in ("SCR", "DPF", "OC")]
    tests = read_test_car_list(write_list(tmp_path / "x.csv", rows, header=header))
    assert len(tests) == 1 and len(tests[0].duplicate_rows) == 2
    assert "differing only in 'Aftertreatment Device Cd' (columns not read)" in tests[0].duplicate_note


def test_one_number_given_to_two_tests_keeps_both(tmp_path):
    """A number on rows of another vehicle: both rows kept, each naming the other."""
    path = write_list(tmp_path / "x.csv", [row(number="T1"), row(number="T1", vid="OTHER")])
    tests = read_test_car_list(path)
    assert [t.vehicle_id for t in tests] == ["16-ZV1H", "OTHER"]
    assert "also given to line(s) 3" in tests[0].duplicate_note
    assert "also given to line(s) 2" in tests[1].duplicate_note


def test_unnumbered_rows_match_numbered_rows_one_to_one(tmp_path):
    """A list without test numbers (2017) repeating two equal tests of a numbered list: each
    unnumbered row joins one numbered test; none is lost, none counted twice."""
    d = tmp_path / "lists"
    d.mkdir()
    write_list(d / "17tstcar.csv", [row(number="", year=2017), row(number="", year=2017)])
    write_list(d / "19tstcar.csv", [row(number="H13", year=2019), row(number="H15", year=2019)])
    tests = read_lists([d])
    assert [t.test_number for t in tests] == ["H13", "H15"]
    assert all(t.years == (2017, 2019) for t in tests)
    # a test listed once per aftertreatment device in the numbered list stands for as many
    # unnumbered rows of the other list
    header = [*FULL_HEADER, "Aftertreatment Device Cd"]
    write_list(d / "19tstcar.csv", [{**row(number="D1", year=2019), "Aftertreatment Device Cd": c}
                                    for c in ("SCR", "DPF")], header=header)
    tests = read_lists([d])
    assert [t.test_number for t in tests] == ["D1"] and tests[0].years == (2017, 2019)


def _ad_list(tmp_path):
    rows = [{**row(number="T1", code=3, desc="HWFE", fe=71.2),
             "Analytically Derived FE?": "No"},
            {**row(number="T9", code=3, desc="HWFE", fe=70.0, weight=3500),
             "Analytically Derived FE?": "Yes", "ADFE Test Number": "T1"}]
    return write_list(tmp_path / "16tstcar.csv", rows, header=AD_HEADER)


def test_analytically_derived_rows_marked(tmp_path, capsys):
    path = _ad_list(tmp_path)
    tests = read_test_car_list(path)
    assert [t.analytically_derived for t in tests] == [False, True]
    assert tests[1].adfe_test_number == "T1"
    assert read_test_car_list(write_list(tmp_path / "r.csv", [row()]))[0].analytically_derived is None
    assert main(["epa", "tests", str(path)]) == 0
    out = capsys.readouterr().out.splitlines()
    assert next(ln for ln in out if ln.startswith("T9 ")).endswith("  AD")
    assert not next(ln for ln in out if ln.startswith("T1 ")).endswith("AD")
    assert any(ln.startswith("AD: 1 test(s) the list marks as analytically derived") for ln in out)


def test_validate_does_not_judge_analytically_derived_rows(tmp_path, capsys):
    """`epa validate` judged a derived figure as if it were a test."""
    path = _ad_list(tmp_path)
    val = validate_tests("prius_2016", read_test_car_list(path), dt=1.0)
    by = {c.test: c for c in val.comparisons}
    assert by["T1"].judged and not by["T1"].analytically_derived
    assert not by["T9"].judged and by["T9"].analytically_derived
    assert "analytically derived from test T1" in by["T9"].note
    assert val.stats()["n_judged"] == 1
    assert main(["epa", "validate", str(path), "--vehicle", "prius_2016", "--tests",
                 "model=PRIUS", "--dt", "1"]) == 0
    out = capsys.readouterr().out
    assert next(ln for ln in out.splitlines() if ln.startswith("T9 ")).endswith("no (derived)")
    assert "1 test(s) (T9) the list marks as analytically derived" in out
    assert "1/1 judged figures" in out or "0/1 judged figures" in out


def test_axle_ratio_zero_named_as_listed(tmp_path, capsys):
    """An axle ratio of 0 was called "empty": it is stated as listed and named a placeholder."""
    from helpers.epa_lists import HEADER, camry_rows
    from vehval.epa.specs import specs_from_tests

    rows = camry_rows()
    for r in rows:
        r["Axle Ratio"] = "0"
    path = write_list(tmp_path / "19tstcar.csv", rows, header=HEADER)
    with pytest.raises(ConfigError) as err:
        specs_from_tests(read_test_car_list(path))
    msg = str(err.value)
    assert "axle ratio 0 as listed ('Axle Ratio'): a placeholder or impossible value" in msg
    assert "empty" not in msg
    assert main(["epa", "tests", str(path)]) == 0
    assert "! F1 (19tstcar.csv:2): axle ratio 0 as listed" in capsys.readouterr().out
    assert main(["epa", "tests", str(path), "--json"]) == 0
    assert "axle_ratio" in json.loads(capsys.readouterr().out)[0]["impossible_values"]
    for r in rows:
        r["Axle Ratio"] = ""
    path = write_list(tmp_path / "19tstcar.csv", rows, header=HEADER)
    with pytest.raises(ConfigError, match="'Axle Ratio' empty or absent"):
        specs_from_tests(read_test_car_list(path))
