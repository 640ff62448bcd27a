"""Configuration files: duplicate keys, non-finite numbers, implausible vehicles, deep nesting,
expression limits and include cycles are clear errors (never a silent or internal one)."""

from __future__ import annotations

import re

import numpy as np
import pytest
import yaml

from vehval.equations.calc import load_calculations
from vehval.equations.expr import parse_expression
from vehval.errors import ConfigError, VehvalError
from vehval.io.template import load_template
from vehval.safe_yaml import load_json, load_yaml
from vehval.vehicle import load_vehicle

TEMPLATE = """\
template_version: 1
files:
  - source: dyno
    time: {column: Time, unit: s}
    channels:
      Dyno_Speed: {name: veh_spd_test, unit: mph}
      Dyno_Speed: {name: veh_spd_test, unit: km/h}
"""


def test_duplicate_key_names_both_lines(tmp_path):
    p = tmp_path / "T.yaml"
    p.write_text(TEMPLATE)
    with pytest.raises(ConfigError, match=r"line 7: key 'Dyno_Speed' is defined twice \(first on line 6\)"):
        load_template(p)


def test_non_finite_scale_refused(tmp_path):
    p = tmp_path / "T.yaml"
    p.write_text(TEMPLATE.replace("      Dyno_Speed: {name: veh_spd_test, unit: km/h}\n", "")
                 .replace("unit: mph}", "unit: mph, scale: .inf}"))
    with pytest.raises(ConfigError, match=r"line 6: '\.inf' is not a finite number"):
        load_template(p)


@pytest.mark.parametrize("key,value", [("mass_kg", "1.0e+308"), ("mass_kg", "-5"),
                                       ("final_drive_ratio", "1e9"), ("max_power_w", "1e300")])
def test_implausible_vehicle_parameter_names_the_key(tmp_path, key, value):
    src = open(load_vehicle("prius_2004")._file, encoding="utf-8").read()
    new, n = re.subn(rf"^(  {key}): .*$", rf"\1: {value}", src, count=1, flags=re.M)
    assert n == 1
    p = tmp_path / "v.yaml"
    p.write_text(new)
    with pytest.raises(ConfigError, match=rf"\.{key}'"):
        load_vehicle(p)


@pytest.mark.parametrize("doc", ["[" * 20000 + "]" * 20000, "a:\n" + "".join(
    " " * i + f"k{i}:\n" for i in range(1, 200))])
def test_deep_yaml_is_a_clear_error(doc):
    with pytest.raises(ConfigError, match="nesting"):
        load_yaml(doc, "deep.yaml")


def test_deep_json_is_a_clear_error():
    with pytest.raises(ConfigError, match="nesting too deep"):
        load_json("[" * 20000 + "]" * 20000, "deep.json")


def test_non_finite_json_refused_when_required():
    with pytest.raises(ConfigError, match="not a finite number"):
        load_json('{"a": NaN}', "x.json", finite=True)


@pytest.mark.parametrize("expr,match", [
    ("smooth(x)", "takes 2 argument"),
    ("abs(x, x)", "takes 1 argument"),
    ("10**10**10", "exponent"),
    ("x ** 1000", "exponent"),
    ("-" * 500 + "x", "deep"),
    ("abs(" * 200 + "x" + ")" * 200, "deep|nesting"),
    ("smooth(x, 1e15)", "window"),
    ("smooth(x, 5e4)", "window"),
    ("smooth(x, -1)", "window"),
])
def test_expression_limits(expr, match):
    with pytest.raises(ConfigError, match=match):
        e = parse_expression(expr, "calc")
        t = np.arange(0.0, 100.0, 0.1)
        e.evaluate({"x": np.sin(t)}, t)


def test_expression_within_limits_still_works():
    t = np.arange(0.0, 100.0, 0.1)
    out = parse_expression("smooth(x, 2) + x ** 2 + clip(x, -1, 1)").evaluate({"x": np.sin(t)}, t)
    assert np.isfinite(out).all()


def test_calculation_include_cycle(tmp_path):
    a, b = tmp_path / "a.yaml", tmp_path / "b.yaml"
    a.write_text(yaml.safe_dump({"name": "a", "include": [str(b)], "relations": []}))
    b.write_text(yaml.safe_dump({"name": "b", "include": [str(a)], "relations": []}))
    with pytest.raises(ConfigError, match="cycle"):
        load_calculations(a)
    a.write_text(yaml.safe_dump({"name": "a", "include": [str(a)], "relations": []}))
    with pytest.raises(VehvalError, match="cycle"):
        load_calculations(a)
