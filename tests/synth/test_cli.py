"""`vehval synth` command line: success and clear errors (exit 2, one line, nothing written)."""

from __future__ import annotations

import json

import pytest

from vehval.cli import main

pytestmark = pytest.mark.xdist_group("synth")


def test_synth_cli_writes_a_virtual_test(tmp_path, capsys):
    out = tmp_path / "vt"
    rc = main(["synth", "--cycle", "steady:30kph:20s", "--seed", "8", "--faults", "none",
               "-o", str(out), "--json"])
    assert rc == 0
    info = json.loads(capsys.readouterr().out)
    assert info["faults"] == 0 and info["offsets_s"] == {"dyno": 0.0, "obd": 0.0}
    assert all((out / p.split("/")[-1]).is_file() for p in info["files"])
    truth = json.loads((out / "truth.json").read_text())
    assert truth["seed"] == 8 and truth["cycle"].startswith("steady")
    # a second run into the same directory replaces the virtual test (no stale files)
    rc = main(["synth", "--cycle", "steady:40kph:20s", "--faults", "none", "-o", str(out)])
    assert rc == 0
    assert len(list(out.glob("*_d3.txt"))) == 1 and len(list(out.glob("*_obd.csv"))) == 1


@pytest.mark.parametrize("args, fragment", [
    (["--cycle", "no_such_cycle"], "unknown drive cycle 'no_such_cycle'"),
    (["--vehicle", "no_such_vehicle"], "no_such_vehicle"),
    (["--faults", "{missing}"], "does not exist"),
    (["--faults", "{bad}"], "unknown channel 'Nope'"),
    (["--control", "no_such_param=1"], "no_such_param"),
    (["--control", "novalue"], "KEY=VALUE"),
])
def test_synth_cli_errors(tmp_path, capsys, args, fragment):
    bad = tmp_path / "bad.yaml"
    bad.write_text("- {kind: zero, channel: Nope}\n")
    args = [a.format(missing=tmp_path / "none.yaml", bad=bad) for a in args]
    out = tmp_path / "vt"
    rc = main(["synth", *args, "-o", str(out)])
    err = capsys.readouterr().err
    assert rc == 2
    assert err.startswith("vehval: error:") and fragment in err and "Traceback" not in err
    assert not out.exists()


def test_synth_cli_refuses_foreign_non_empty_dir(tmp_path, capsys):
    (tmp_path / "notes.txt").write_text("mine")
    rc = main(["synth", "--cycle", "steady:30kph:10s", "-o", str(tmp_path)])
    assert rc == 2 and "not empty" in capsys.readouterr().err


def test_synth_cli_screen_states_the_offsets_in_seconds_not_as_a_dict(tmp_path, capsys):
    # the screen printed the truth's dict: "offsets {'dyno': 0.0, 'obd': -2.7}"
    rc = main(["synth", "--cycle", "steady:30kph:20s", "--faults", "none",
               "-o", str(tmp_path / "vt")])
    assert rc == 0
    line = next(x for x in capsys.readouterr().out.splitlines() if "offsets" in x)
    assert line.endswith("offsets dyno 0 s, obd 0 s"), line
    assert "{" not in line and "'" not in line
