"""Layouts of the compiled loops: generated indices unique and contiguous, every parameter
packed from its vehicle-file key and read back at its own position."""

from __future__ import annotations

import ast
import importlib.util
from pathlib import Path

import numpy as np
import pytest

from vehval.errors import ConfigError
from vehval.sim import indices, layout
from vehval.sim.conventional import CONV_COMPUTED, CONV_FROM_FILE, conv_param_vector
from vehval.sim.packing import COMPUTED, FROM_FILE, param_vector
from vehval.vehicle import load_vehicle

LAYOUTS = [("P", layout.PARAMS), ("S", layout.SIGNALS), ("Y", layout.SUMMARY),
           ("X", layout.STATE), ("CP", layout.CONV_PARAMS), ("CS", layout.CONV_SIGNALS),
           ("CY", layout.CONV_SUMMARY)]


@pytest.mark.parametrize("prefix,names", LAYOUTS, ids=[p for p, _ in LAYOUTS])
def test_indices_unique_and_contiguous(prefix, names):
    assert len(set(names)) == len(names)
    got = sorted(getattr(indices, f"{prefix}_{n.upper()}") for n in names)
    assert got == list(range(len(names)))
    assert getattr(indices, f"N_{prefix}") == len(names)


@pytest.mark.parametrize("table,computed,names", [
    (FROM_FILE, COMPUTED, layout.PARAMS), (CONV_FROM_FILE, CONV_COMPUTED, layout.CONV_PARAMS)])
def test_every_parameter_has_one_source(table, computed, names):
    assert set(table).isdisjoint(computed)
    assert set(table) | set(computed) == set(names)


def _read_back(veh, table, pack, names):
    """Scale each file key by 1.01: its own entry (and only it) moves by that factor."""
    base = pack(veh)
    checked = 0
    for name, (blk, key, factor) in table.items():
        old = getattr(getattr(veh, blk), key)
        if not old:
            continue
        try:
            var = veh.with_overrides({f"{blk}.{key}": old * 1.01})
        except ConfigError:
            continue  # a consistency rule forbids this end (e.g. a hysteresis)
        new = pack(var)
        k = names.index(name)
        assert new[k] == pytest.approx(old * 1.01 * factor, rel=1e-12), name
        moved = np.flatnonzero(new != base)
        # eq_factor depends on the engine's best efficiency (engine keys move it too)
        assert set(moved) - {k, names.index("eq_factor") if "eq_factor" in names else k} \
            == set(), (name, [names[j] for j in moved])
        checked += 1
    return checked


def test_power_split_parameters_read_back():
    veh = load_vehicle("prius_2004")
    n = _read_back(veh, FROM_FILE, lambda v: param_vector(v, 0.6), layout.PARAMS)
    assert n >= 0.8 * len(FROM_FILE)
    p = param_vector(veh, 0.55, cold_start=True)
    assert p[layout.PARAMS.index("soc_init")] == 0.55
    assert p[layout.PARAMS.index("cold_start")] == 1.0


def test_conventional_parameters_read_back():
    veh = load_vehicle("cruze_diesel_2014")
    n = _read_back(veh, CONV_FROM_FILE, conv_param_vector, layout.CONV_PARAMS)
    assert n >= 0.8 * len(CONV_FROM_FILE)
    k = layout.CONV_PARAMS.index("warm_frac")
    assert conv_param_vector(veh)[k] == 0.0
    assert conv_param_vector(veh, cold_start=True)[k] == veh.engine.warmup_fuel_fraction


def test_generated_indices_are_current_plain_constants():
    """indices.py is what scripts/sim_indices.py writes from the layout today, and holds only
    plain ``NAME = int`` assignments (no generated globals: a reader, grep and mypy see each)."""
    root = Path(__file__).resolve().parents[2]
    spec = importlib.util.spec_from_file_location("sim_indices", root / "scripts" / "sim_indices.py")
    assert spec and spec.loader
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    text = Path(indices.__file__).read_text(encoding="utf-8")
    assert text == script.render(), \
        "sim/indices.py is stale: run python scripts/sim_indices.py --write (make generate)"
    tree = ast.parse(text)
    body = tree.body[1:]                                   # after the docstring
    assert body and all(isinstance(s, ast.Assign) and isinstance(s.value, ast.Constant)
                        and type(s.value.value) is int for s in body)
    assert {s.targets[0].id for s in body} == {
        k for k in vars(indices) if not k.startswith("_")}
