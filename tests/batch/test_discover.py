"""Test discovery rule and input hashing."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from vehval.batch.discover import discover_tests, hash_spec, settings_hash
from vehval.errors import InputFileError


def _tmpl(*matches):
    return SimpleNamespace(files=[SimpleNamespace(match=m) for m in matches])


def _touch(p, text="x"):
    p.parent.mkdir(parents=True, exist_ok=True)
    p.write_text(text)
    return p


def test_subdirectories_are_tests_with_matching_files(tmp_path):
    _touch(tmp_path / "a" / "run_d3.txt")
    _touch(tmp_path / "a" / "run_obd.csv")
    _touch(tmp_path / "a" / "notes.doc")          # matches no pattern: not part of the test
    _touch(tmp_path / "b" / "run_d3.txt")
    _touch(tmp_path / ".hidden" / "run_d3.txt")    # hidden directories are ignored
    _touch(tmp_path / "loose_d3.txt")              # multi-entry template: loose files ignored
    specs = discover_tests(tmp_path, _tmpl("*_d3.txt", "*_obd.csv"))
    assert [s.test_id for s in specs] == ["a", "b"]
    assert [f.name for f in specs[0].files] == ["run_d3.txt", "run_obd.csv"]
    assert [f.name for f in specs[1].files] == ["run_d3.txt"]


def test_single_entry_template_makes_each_file_a_test(tmp_path):
    _touch(tmp_path / "t1.txt")
    _touch(tmp_path / "t 2 (copy).txt")
    _touch(tmp_path / "sub" / "x.txt")
    specs = discover_tests(tmp_path, _tmpl("*.txt"))
    assert sorted(s.test_id for s in specs) == ["sub", "t1", "t_2_copy"]


def test_single_entry_without_match_takes_every_visible_file(tmp_path):
    _touch(tmp_path / "x.csv")
    _touch(tmp_path / ".x.csv.swp")
    assert [s.test_id for s in discover_tests(tmp_path, _tmpl(None))] == ["x"]


def test_glob_and_unique_ids(tmp_path):
    _touch(tmp_path / "p1" / "run.txt")
    _touch(tmp_path / "p2" / "run.txt")
    specs = discover_tests(str(tmp_path / "p*" / "*.txt"), _tmpl("*.txt"))
    assert [s.test_id for s in specs] == ["run", "run-2"]
    specs = discover_tests(str(tmp_path / "p*"), _tmpl("*.txt"))
    assert [s.test_id for s in specs] == ["p1", "p2"]


def test_nothing_found_is_a_clear_error(tmp_path):
    with pytest.raises(InputFileError, match="no tests found"):
        discover_tests(tmp_path, _tmpl("*.txt"))
    with pytest.raises(InputFileError, match="not a directory"):
        discover_tests(tmp_path / "absent", _tmpl("*.txt"))
    with pytest.raises(InputFileError, match="no file or directory matches"):
        discover_tests(str(tmp_path / "z*"), _tmpl("*.txt"))


def test_input_hash_follows_bytes_names_and_settings(tmp_path):
    f = _touch(tmp_path / "a" / "r.txt", "1")
    t = _tmpl("*.txt")
    h0 = hash_spec(discover_tests(tmp_path, t)[0], settings_hash({"steps": ["qa"]})).input_hash
    assert h0 == hash_spec(discover_tests(tmp_path, t)[0], settings_hash({"steps": ["qa"]})).input_hash
    assert h0 != hash_spec(discover_tests(tmp_path, t)[0], settings_hash({"steps": []})).input_hash
    f.write_text("2")
    assert h0 != hash_spec(discover_tests(tmp_path, t)[0], settings_hash({"steps": ["qa"]})).input_hash
