"""CLI: `vehval template init|check`, `vehval import`, `vehval info`.

Every bad input gives a non-zero exit, one `vehval: error:` line naming the file/line/channel,
no traceback and no output file left behind.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from iohelpers import D3_TEMPLATE, assert_clean_failure, d3_rows, write_d3

from vehval.io.parquet import read_test


def test_init_check_import_info(tmp_path, cli, d3_file):
    t = tmp_path / "T.yaml"
    code, out, err = cli("template", "init", d3_file, "-o", t)
    assert code == 0, err
    assert "wrote" in out and t.exists()
    code, out, err = cli("template", "init", d3_file, "-o", t)
    assert_clean_failure(code, out, err, "already exists")
    code, out, err = cli("template", "check", t, d3_file)
    assert code == 0 and "0 error(s)" in out
    o = tmp_path / "o.parquet"
    code, out, err = cli("import", d3_file, "-t", t, "-o", o)
    assert code == 0, err
    test = read_test(o)
    assert test["veh_spd_test"].values[-1] == pytest.approx(26.8224, rel=1e-12)
    code, out, err = cli("info", o, "--json")
    info = json.loads(out)
    ch = {c["name"]: c for c in info["channels"]}
    assert ch["veh_spd_test"]["samples"] == 50 and ch["veh_spd_test"]["rate_hz"] == pytest.approx(10)
    assert ch["veh_spd_test"]["duration_s"] == pytest.approx(4.9)
    code, out, err = cli("info", d3_file)
    assert code == 0 and "Dyno_Speed" in out and "mph" in out


def test_check_fails_on_unit_error(tmp_path, cli, d3_file):
    t = tmp_path / "T.yaml"
    t.write_text("files:\n  - source: obd\n    channels:\n      Phase_#: {name: eng_spd_out_test}\n")
    code, out, err = cli("template", "check", t, d3_file)
    assert code == 1 and "no unit in the file or the template" in out and "Traceback" not in err


def _no_output(tmp_path):
    return not list(tmp_path.glob("*.parquet")) and not list(tmp_path.glob(".*.tmp"))


CASES = {
    "missing file": (lambda p: p / "nope.txt", None, ["nope.txt", "file not found"]),
    "empty file": (lambda p: (p / "e.txt").write_bytes(b"") and None or p / "e.txt", None,
                   ["e.txt", "empty"]),
    "non-numeric": (lambda p: write_d3(p / "n.txt", rows=[[0.0, 1.0, 2.0, 3.0, 0.0], [0.1, "x1", 2.0, 3.0, 0.0]]),
                    None, ["n.txt line 3", "'x1'", "Dyno_Speed"]),
    "duplicate names": (lambda p: write_d3(p / "d.txt", header=["Time[s]", "Dyno_Speed[mph]", "Dyno_Speed[km/h]",
                                                                "Cell_Temp[F]", "Phase_#"]),
                        None, ["d.txt", "duplicate channel name 'Dyno_Speed'"]),
    "no time column": (lambda p: write_d3(p / "nt.txt", header=["Tim[s]", "Dyno_Speed[mph]", "Engine_Speed[rpm]",
                                                                 "Cell_Temp[F]", "Phase_#"]),
                       lambda t: t.replace("format: auto\n    time: {column: Time, unit: s}", "format: d3"),
                       ["nt.txt", "no time column", "rate_hz"]),
    "unknown unit": (lambda p: write_d3(p / "u.txt"), lambda t: t.replace("unit: rpm", "unit: rpmm"),
                     ["T.yaml", "Engine_Speed", "unknown unit 'rpmm'"]),
    "misspelled key": (lambda p: write_d3(p / "k.txt"), lambda t: t.replace("unit: rpm", "unti: rpm"),
                       ["T.yaml: files[0].channels.Engine_Speed.unti: unknown key (did you mean 'unit'?)"]),
    "nul bytes": (lambda p: (p / "z.txt").write_bytes(b"Time[s]\tDyno_Speed[mph]\r\n0\t1\r\n0.1\t\0\r\n0.2\t3\r\n")
                  and None or p / "z.txt", None, ["z.txt line 3", "NUL byte"]),
    "stray control byte": (lambda p: write_d3(p / "s.txt", header=["Speed[mph]", "Engine_Speed[rpm]", "A", "B", "C"],
                                              prefix=b"\x07"), None, ["s.txt line 1", "stray control byte"]),
}


@pytest.mark.parametrize("case", list(CASES))
def test_bad_inputs_via_cli(tmp_path, cli, case):
    make, edit, needles = CASES[case]
    f = make(tmp_path)
    t = tmp_path / "T.yaml"
    t.write_text(edit(D3_TEMPLATE) if edit else D3_TEMPLATE)
    out_file = tmp_path / "out.parquet"
    code, out, err = cli("import", f, "-t", t, "-o", out_file)
    assert_clean_failure(code, out, err, *needles)
    assert not out_file.exists() and _no_output(tmp_path)


@pytest.mark.parametrize("kind,t2", [("decreasing", -1.0), ("repeated", -0.9)])
def test_bad_timestamps_via_cli(tmp_path, cli, d3_template, kind, t2):
    rows = d3_rows(10)
    rows[2][0] = t2
    f = write_d3(tmp_path / "x.txt", rows=rows)
    o = tmp_path / "o.parquet"
    code, out, err = cli("import", f, "-t", d3_template, "-o", o)
    assert_clean_failure(code, out, err, "x.txt line 4", kind, "--repair-time")
    assert not o.exists()
    code, out, err = cli("import", f, "-t", d3_template, "-o", o, "--repair-time")
    assert code == 0 and o.exists() and "repaired" in out
    assert np.all(np.diff(read_test(o)["veh_spd_test"].time) > 0)


def test_truncated_last_line_and_stray_prefix_repaired_via_cli(tmp_path, cli, d3_template):
    f = write_d3(tmp_path / "x.txt", prefix=b"fp")
    f.write_bytes(f.read_bytes() + b"9.9\t1.0")
    o = tmp_path / "o.parquet"
    code, out, err = cli("import", f, "-t", d3_template, "-o", o)
    assert code == 0, err
    assert "stray byte(s) 'fp'" in out and "truncated last line" in out
    assert read_test(o)["veh_spd_test"].time.size == 50


def test_existing_output_kept_on_failure(tmp_path, cli, d3_template):
    o = tmp_path / "o.parquet"
    o.write_bytes(b"previous")
    bad = tmp_path / "bad.txt"
    bad.write_bytes(b"")
    code, out, err = cli("import", bad, "-t", d3_template, "-o", o)
    assert code != 0 and o.read_bytes() == b"previous"


def test_info_of_an_imported_test_shows_the_display_units(tmp_path, cli, d3_file, monkeypatch):
    """A test Parquet stores SI units; `info` names the unit each channel is read in under
    the chosen display system, next to the stored one (a raw file lists its own units)."""
    monkeypatch.setenv("VEHVAL_UNITS", "us")     # `--units` sets it: restored after the test
    t, o = tmp_path / "T.yaml", tmp_path / "o.parquet"
    assert cli("template", "init", d3_file, "-o", t)[0] == 0
    assert cli("import", d3_file, "-t", t, "-o", o)[0] == 0
    rows = {}
    for system in ("us", "metric"):
        code, out, err = cli("--units", system, "info", o)
        assert code == 0, err
        assert "unit (SI)" in out and "shown as" in out
        rows[system] = next(line.split() for line in out.splitlines()
                            if line.split()[:1] == ["veh_spd_test"])
    assert rows["us"][1:4] == ["mph", "m/s", "mph"]          # declared, stored, shown
    assert rows["metric"][1:4] == ["mph", "m/s", "km/h"]
    code, out, err = cli("info", o, "--json")
    assert {c["unit"] for c in json.loads(out)["channels"]} >= {"m/s"}   # JSON stays SI


def test_info_of_a_test_shows_the_declared_percent_and_kpa(tmp_path, cli, monkeypatch):
    """Channels declared in % and kPa: `info` of the imported test names the declared unit
    next to the stored SI one ('dimensionless', 'Pa', which alone read as a wrong import) and
    the unit they are shown in; --json adds the raw name and unit."""
    monkeypatch.setenv("VEHVAL_UNITS", "metric")
    (tmp_path / "run.csv").write_text("Time,SOC,MAP,Speed\n" + "".join(
        f"{i * 0.1:.1f},{55 + i % 7},{40 + i % 5},{i % 30}\n" for i in range(200)))
    (tmp_path / "t.yaml").write_text(
        "template_version: 1\nfiles:\n  - source: obd\n    format: csv\n"
        "    time: {column: Time, unit: s}\n    channels:\n"
        "      SOC: {name: ess_soc_test, unit: '%'}\n"
        "      MAP: {name: eng_pres_intake_test, unit: kPa}\n"
        "      Speed: {name: veh_spd_test, unit: km/h}\n")
    o = tmp_path / "o.parquet"
    assert cli("import", tmp_path / "run.csv", "-t", tmp_path / "t.yaml", "-o", o)[0] == 0
    code, out, err = cli("info", o)
    assert code == 0, err
    header = next(line for line in out.splitlines() if line.split()[:1] == ["channel"])
    assert header.split()[1:5] == ["declared", "unit", "(SI)", "shown"]
    rows = {line.split()[0]: line.split()[1:4] for line in out.splitlines()
            if line.strip().startswith(("ess_", "eng_", "veh_"))}
    assert rows["ess_soc_test"] == ["%", "dimensionless", "%"]
    assert rows["eng_pres_intake_test"] == ["kPa", "Pa", "kPa"]
    assert rows["veh_spd_test"] == ["km/h", "m/s", "km/h"]
    chans = {c["name"]: c for c in json.loads(cli("info", o, "--json")[1])["channels"]}
    assert chans["ess_soc_test"]["unit"] == "dimensionless"          # the JSON stays SI
    assert (chans["ess_soc_test"]["raw_unit"], chans["ess_soc_test"]["raw_name"]) == ("%", "SOC")
    assert chans["eng_pres_intake_test"]["raw_unit"] == "kPa"
