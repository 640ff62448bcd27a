"""What pint says about units, kept on disk between runs (vehval.units): the same answers
as pint, pint not imported once they are known, and a damaged file is only ignored."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from vehval import units
from vehval.errors import UnitError

SRC = Path(__file__).resolve().parents[1] / "src"
PAIRS = [("mph", "m/s"), ("rpm", "rad/s"), ("degF", "degC"), ("°F", "degC"), ("kW", "W"),
         ("g/s", "kg/s"), ("%", "dimensionless"), ("lbf", "N"), ("ft-lb", "N*m"),
         ("inHg", "kPa"), ("kph", "m/s"), ("ms", "s"), ("Ah", "coulomb")]


@pytest.fixture
def facts_dir(tmp_path, monkeypatch):
    monkeypatch.setenv("VEHVAL_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(units, "_facts", None)
    yield tmp_path
    units._facts = None  # the next test reads its own file


def _pint_answers() -> dict:
    """Conversions and dimensions straight from the registry (nothing kept)."""
    out = {}
    for a, b in PAIRS:
        out[(a, b)] = units._conversion(a, b, None)
        ua = units.parse_unit(a)
        out[a] = (sorted((str(k), v) for k, v in dict(ua.dimensionality).items()),
                  ua.dimensionless)
    return out


def test_kept_answers_equal_pint_and_survive_a_new_process(facts_dir):
    want = _pint_answers()
    for _ in range(2):                      # the first pass asks pint, the second reads
        for a, b in PAIRS:
            assert units.conversion(a, b) == want[(a, b)]
            assert list(units.dimension(a)) == [tuple(x) for x in want[a][0]]
            assert units.is_dimensionless(a) is want[a][1]
    files = list(facts_dir.glob("units/*.json"))
    assert len(files) == 1 and files[0] == units.facts_path()
    assert units.dimension("mph") == units.dimension("km/h") != units.dimension("rpm")
    # a new interpreter answers from the file without importing pint
    code = ("import sys\nfrom vehval import units\n"
            f"print([units.conversion(a, b) for a, b in {PAIRS!r}], units.dimension('mph'))\n"
            "print('pint' in sys.modules)")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(SRC), *sys.path]),
               VEHVAL_CACHE_DIR=str(facts_dir))
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env,
                         timeout=120, check=True).stdout.splitlines()
    assert out[-1] == "False"
    assert out[0] == f"{[want[p] for p in PAIRS]} {units.dimension('mph')}"


def test_unknown_units_and_failed_conversions_still_ask_pint(facts_dir):
    units.conversion("kW", "W")
    for _ in range(2):
        with pytest.raises(UnitError, match="unknown unit 'furlongs per blink'"):
            units.dimension("furlongs per blink")
        with pytest.raises(UnitError, match="cannot convert 'mph'"):
            units.conversion("mph", "kg")
    kept = json.loads(units.facts_path().read_text())
    assert "furlongs per blink" not in kept["dimension"]
    assert not any("kg" in k for k in kept["conversion"])


def test_identity_writes_nothing(facts_dir):
    assert units.conversion("s", "second") == (1.0, 0.0)
    assert not list(facts_dir.iterdir())


@pytest.mark.parametrize("content", ["{not json", '{"conversion": {"[1]": ["x", 1]}, '
                                     '"dimension": {}}', "[]", '{"conversion": 3}'])
def test_a_damaged_file_is_ignored_and_replaced(facts_dir, content):
    path = units.facts_path()
    path.parent.mkdir(parents=True)
    path.write_text(content)
    assert units.conversion("mph", "m/s") == units._conversion("mph", "m/s", None)
    kept = json.loads(path.read_text())
    assert list(kept["conversion"].values()) == [[0.44704, 0.0]]


def test_an_unwritable_place_only_costs_the_speed(tmp_path, monkeypatch):
    blocker = tmp_path / "file"
    blocker.write_text("")
    monkeypatch.setenv("VEHVAL_CACHE_DIR", str(blocker / "below"))  # cannot be created
    monkeypatch.setattr(units, "_facts", None)
    try:
        assert units.conversion("rpm", "rad/s") == units._conversion("rpm", "rad/s", None)
        assert units.dimension("s") == (("[time]", 1),)
    finally:
        units._facts = None


def _version(monkeypatch, hexname: str) -> None:
    """Act as the version of the module whose file is ``hexname``.json (no answers loaded)."""
    monkeypatch.setattr(units, "_facts_name", lambda: f"{hexname}.json")
    monkeypatch.setattr(units, "_facts", None)


def test_a_new_version_removes_the_files_of_the_others_and_nothing_else(facts_dir, monkeypatch):
    _version(monkeypatch, "a" * 16)
    units.conversion("mph", "m/s")
    units.conversion("rpm", "rad/s")               # written again: nothing to remove
    folder = facts_dir / "units"
    old, keep = folder / f"{'a' * 16}.json", facts_dir / "keep.json"
    assert old.is_file()
    stale, live = folder / ".units-dead.tmp", folder / ".units-live.tmp"
    strangers = ["notes.txt", f"{'b' * 16}.json.bak", f"{'C' * 16}.json", "units.json"]
    for name in [".units-dead.tmp", ".units-live.tmp", f"{'0' * 16}.json", *strangers]:
        (folder / name).write_text("{}")
    os.utime(stale, (1_000_000, 1_000_000))        # its writer died long ago
    (folder / f"{'1' * 16}.json").mkdir()          # a cache name, but not a file
    keep.write_text("{}")
    (folder / f"{'2' * 16}.json").symlink_to(keep)  # a cache name, but a link
    _version(monkeypatch, "d" * 16)                # the module changed
    assert units.conversion("kW", "W") == (1000.0, 0.0)
    left = sorted(p.name for p in folder.iterdir())
    assert left == sorted([f"{'d' * 16}.json", live.name, f"{'1' * 16}.json",
                           f"{'2' * 16}.json", *strangers])
    assert keep.read_text() == "{}"
    assert json.loads(units.facts_path().read_text())["conversion"]


def test_removal_failures_and_a_vanished_file_are_ignored(facts_dir, monkeypatch):
    folder = facts_dir / "units"
    folder.mkdir()
    (folder / f"{'0' * 16}.json").write_text("{}")

    def refuse(path, *a, **k):
        raise PermissionError(13, "refused", str(path))

    _version(monkeypatch, "e" * 16)
    with monkeypatch.context() as m:
        m.setattr(units.os, "unlink", refuse)
        assert units.conversion("mph", "m/s") == units._conversion("mph", "m/s", None)
    own = units.facts_path()
    assert own.is_file() and (folder / f"{'0' * 16}.json").is_file()
    # another process removed the file between the listing and the removal
    entries = list(os.scandir(folder))
    (folder / f"{'0' * 16}.json").unlink()
    with monkeypatch.context() as m:
        m.setattr(units.os, "scandir", lambda _p: entries)
        assert units._remove_other_versions(own) == []
    assert sorted(p.name for p in folder.iterdir()) == [own.name]


def test_concurrent_first_writers_keep_one_file(facts_dir):
    """Two processes of the same version create the file at once, with an earlier version's
    file present: both answer, one file is left (theirs)."""
    folder = facts_dir / "units"
    folder.mkdir()
    (folder / f"{'0' * 16}.json").write_text("{}")
    code = ("from vehval import units\n"
            f"for a, b in {PAIRS!r}:\n    units.conversion(a, b)\n"
            "print(units.facts_path().name)")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(SRC), *sys.path]),
               VEHVAL_CACHE_DIR=str(facts_dir))
    procs = [subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True, env=env) for _ in range(2)]
    outs = [p.communicate(timeout=120) for p in procs]
    assert [p.returncode for p in procs] == [0, 0], [e[-2000:] for _o, e in outs]
    names = {o.strip() for o, _e in outs}
    assert len(names) == 1 and sorted(p.name for p in folder.iterdir()) == sorted(names)
    assert len(json.loads((folder / names.pop()).read_text())["conversion"]) >= len(PAIRS) - 2
