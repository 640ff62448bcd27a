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
