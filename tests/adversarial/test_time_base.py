"""Time bases: timestamps going backwards or repeating are reported in QA (a
``rate_irregular`` error), never repaired silently, and no note claims an option that was
not given."""

from __future__ import annotations

import json

from helpers.cli import TEMPLATE, run_cli, write_d3


def _swap_rows(path, i: int, dup: int) -> None:
    lines = path.read_text().splitlines()
    lines[i], lines[i + 1] = lines[i + 1], lines[i]
    lines[dup] = lines[dup - 1]
    path.write_text("\n".join(lines) + "\n")


def test_backwards_and_repeated_time_is_a_qa_error(tmp_path, capsys):
    f = tmp_path / "r_d3.txt"
    write_d3(f)
    _swap_rows(f, 100, 300)
    t = tmp_path / "T.yaml"
    t.write_text(TEMPLATE)
    rc, out, err = run_cli(["qa", f, "-t", t, "-o", tmp_path / "out", "--json"], capsys)
    assert rc == 0, err
    doc = json.loads(out)
    found = [x for x in doc["findings"] if x["kind"] == "rate_irregular"
             and x["severity"] == "error"]
    assert {x["signal"] for x in found} == {"veh_spd_test", "eng_spd_out_test"}
    msg = found[0]["message"]
    assert "1 decreasing step(s) sorted" in msg and "1 repeated timestamp(s) dropped" in msg
    assert "line 102" in msg
    assert "--repair-time" not in json.dumps(doc) + err


def test_import_refuses_it_and_the_option_is_named_only_when_given(tmp_path, capsys):
    f = tmp_path / "r_d3.txt"
    write_d3(f)
    _swap_rows(f, 100, 300)
    t = tmp_path / "T.yaml"
    t.write_text(TEMPLATE)
    rc, _, err = run_cli(["import", f, "-t", t, "-o", tmp_path / "x.parquet"], capsys)
    assert rc == 2 and "line 102: decreasing timestamp" in err
    rc, _, err = run_cli(["import", f, "-t", t, "-o", tmp_path / "x.parquet", "--repair-time"],
                         capsys)
    assert rc == 0 and "time base repaired on import" in err


def test_clean_time_base_has_no_rate_error(tmp_path, capsys):
    f = tmp_path / "c_d3.txt"
    write_d3(f)
    t = tmp_path / "T.yaml"
    t.write_text(TEMPLATE)
    rc, out, err = run_cli(["qa", f, "-t", t, "-o", tmp_path / "out", "--json"], capsys)
    assert rc == 0, err
    assert not [x for x in json.loads(out)["findings"] if x["kind"] == "rate_irregular"
                and x["severity"] == "error"]
