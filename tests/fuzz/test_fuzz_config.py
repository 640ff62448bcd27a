"""Hostile template and vehicle YAML: a validated model or a VehvalError, nothing else, no hang."""

from __future__ import annotations

import copy
import math
from pathlib import Path

import pytest
import yaml
from hypothesis import given
from hypothesis import strategies as st

from vehval.errors import VehvalError

from .helpers import FUZZ, FUZZ_SLOW, outcome

VALID_TEMPLATE = {
    "template_version": 1,
    "description": "fuzz base",
    "constants": {"test_mass_kg": 1295, "fuel_density_kg_per_m3": 745},
    "files": [{"match": "*_d3.txt", "source": "dyno", "format": "d3",
               "time": {"column": "Time", "unit": "s"},
               "channels": {"Dyno_Speed": {"name": "veh_spd_test", "unit": "mph"},
                            "Engine_Speed": {"name": "eng_spd_out_test", "unit": "rpm",
                                             "scale": 1.0, "offset": 0.0},
                            "Bty_Curr": {"name": "ess_curr_test", "unit": "A",
                                         "invalid_values": [-327.68]},
                            "Test_Cell_RH": {"delete": True, "reason": "not used"}}}],
    "selection": {"keep": [], "drop": {}},
}

WEIRD = st.sampled_from([None, math.nan, math.inf, -math.inf, 1e308, -1.0, 0, "", "ü∞\u202e",
                         [], {}, [1, [2, [3]]], {"x": {"y": None}}, True, 10 ** 30, "1e400",
                         "x" * 5000])


def _paths(obj, prefix=()):
    """Every key path of a nested dict/list."""
    yield prefix
    if isinstance(obj, dict):
        for k, v in obj.items():
            yield from _paths(v, prefix + (k,))
    elif isinstance(obj, list):
        for i, v in enumerate(obj):
            yield from _paths(v, prefix + (i,))


def _mutate(base, ops):
    data = copy.deepcopy(base)
    paths = [p for p in _paths(data) if p]
    for idx, action, value in ops:
        if not paths:
            break
        path = paths[idx % len(paths)]
        parent = data
        try:
            for k in path[:-1]:
                parent = parent[k]
            if action == "set":
                parent[path[-1]] = value
            elif action == "delete":
                del parent[path[-1]]
            elif isinstance(parent, dict):
                parent["unknown_" + str(idx)] = value
        except (KeyError, IndexError, TypeError):
            continue
        paths = [p for p in _paths(data) if p]
    return data


OPS = st.lists(st.tuples(st.integers(0, 10 ** 6), st.sampled_from(["set", "delete", "add"]), WEIRD),
               min_size=1, max_size=4)

BILLION_LAUGHS = """\
a: &a ["lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol"]
b: &b [*a, *a, *a, *a, *a, *a, *a, *a, *a]
c: &c [*b, *b, *b, *b, *b, *b, *b, *b, *b]
d: &d [*c, *c, *c, *c, *c, *c, *c, *c, *c]
e: &e [*d, *d, *d, *d, *d, *d, *d, *d, *d]
f: &f [*e, *e, *e, *e, *e, *e, *e, *e, *e]
g: &g [*f, *f, *f, *f, *f, *f, *f, *f, *f]
h: &h [*g, *g, *g, *g, *g, *g, *g, *g, *g]
"""


def _template_ok(t):
    from vehval.io.template import Template

    assert isinstance(t, Template)
    assert t.files, "a loaded template has at least one files entry"


@FUZZ
@given(ops=OPS)
def test_template_mutations(tmp_path, ops):
    from vehval.io.template import load_template

    p = tmp_path / "t.yaml"
    p.write_text(yaml.safe_dump(_mutate(VALID_TEMPLATE, ops), allow_unicode=True), encoding="utf-8")
    res = outcome(load_template, p)
    if not isinstance(res, VehvalError):
        _template_ok(res)


@FUZZ
@given(data=st.one_of(st.binary(max_size=600), st.text(max_size=600).map(str.encode)),
       cut=st.floats(0, 1))
def test_template_random_and_truncated(tmp_path, data, cut):
    from vehval.io.template import load_template

    p = tmp_path / "t.yaml"
    for raw in (data, yaml.safe_dump(VALID_TEMPLATE).encode()[: int(cut * 900)]):
        p.write_bytes(raw)
        res = outcome(load_template, p)
        if not isinstance(res, VehvalError):
            _template_ok(res)


@pytest.mark.parametrize("where", ["top", "files", "channels", "description"])
def test_template_alias_bomb(tmp_path, where):
    """An exponential alias structure must be rejected quickly, not expanded."""
    from vehval.io.template import load_template

    tail = {"top": "files: *h\n", "files": "template_version: 1\nfiles: [*h]\n",
            "channels": "files: [{source: dyno, channels: {X: *h}}]\n",
            "description": "description: *h\nfiles: [{source: dyno}]\n"}[where]
    p = tmp_path / "bomb.yaml"
    p.write_text(BILLION_LAUGHS + tail, encoding="utf-8")
    res = outcome(load_template, p)
    assert isinstance(res, VehvalError)


# ---------------------------------------------------------------- vehicle files


def _vehicle_base():
    vehicle = pytest.importorskip("vehval.vehicle")
    path = Path(vehicle.__file__).resolve().parent.parent / "data" / "vehicles" / "prius_2004.yaml"
    if not path.is_file():
        pytest.skip("no packaged vehicle file")
    return vehicle.load_vehicle, yaml.safe_load(path.read_text(encoding="utf-8")), path


@FUZZ_SLOW
@given(ops=OPS)
def test_vehicle_mutations(tmp_path, ops):
    load_vehicle, base, _ = _vehicle_base()
    p = tmp_path / "v.yaml"
    p.write_text(yaml.safe_dump(_mutate(base, ops), allow_unicode=True), encoding="utf-8")
    res = outcome(load_vehicle, p)
    if not isinstance(res, VehvalError):
        limits = res.signal_limits() if hasattr(res, "signal_limits") else {}
        assert isinstance(limits, dict)


@FUZZ_SLOW
@given(data=st.binary(max_size=600), cut=st.floats(0, 1))
def test_vehicle_random_and_truncated(tmp_path, data, cut):
    load_vehicle, _, path = _vehicle_base()
    p = tmp_path / "v.yaml"
    good = path.read_bytes()
    for raw in (data, good[: int(cut * len(good))]):
        p.write_bytes(raw)
        outcome(load_vehicle, p)


@pytest.mark.parametrize("where", ["top", "engine"])
def test_vehicle_alias_bomb(tmp_path, where):
    load_vehicle, _, _ = _vehicle_base()
    tail = {"top": "name: *h\n", "engine": "name: x\nengine: {speed_rpm: *h}\n"}[where]
    p = tmp_path / "bomb.yaml"
    p.write_text(BILLION_LAUGHS + tail, encoding="utf-8")
    assert isinstance(outcome(load_vehicle, p), VehvalError)
