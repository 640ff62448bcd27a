"""The calibration engine: searches, hold-out evaluation, one provenance and one writer."""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
import pytest

from vehval.calibration import (
    Provenance,
    before_after,
    de_polish,
    grid_refine,
    holdout_worse,
    powell,
    vehicle_with_values,
    write_vehicle_yaml,
)
from vehval.calibration.provenance import bounds_text, grid_text
from vehval.vehicle import load_vehicle

SRC = Path(__file__).resolve().parents[2] / "src" / "vehval"


def test_grid_refine_scores_each_setting_once_and_refines_towards_the_minimum():
    calls: list[tuple[float, ...]] = []

    def evaluate(settings):
        calls.extend(settings)
        return [((s[0] - 2.3) ** 2 + (s[1] - 1.0) ** 2, 0.0) for s in settings]

    found = grid_refine({"a": [1.0, 2.0, 3.0], "b": [0.0, 1.0]}, evaluate, refine_rounds=3)
    assert len(calls) == len(set(calls)) == len(found.evaluations)
    assert [v for v, _ in found.evaluations[:6]] == [(1.0, 0.0), (1.0, 1.0), (2.0, 0.0),
                                                     (2.0, 1.0), (3.0, 0.0), (3.0, 1.0)]
    # grid best (2, 1); steps on a 0.5, 0.25, 0.125: 2.5, then 2.25, then 2.25 stays
    assert found.best == (2.25, 1.0)
    assert found.score == min(sc for _, sc in found.evaluations)
    one = grid_refine({"a": [1.0, 2.0, 3.0]}, lambda ss: [abs(s[0] - 2.2) for s in ss], 0)
    assert one.best == (2.0,) and len(one.evaluations) == 3 and one.method == "grid"


def test_powell_finds_a_minimum_within_the_bounds():
    found = powell(lambda x: float((x[0] - 0.7) ** 2), np.array([0.9]), [(0.5, 1.0)], 60)
    assert found.x[0] == pytest.approx(0.7, abs=1e-3) and found.value < found.start_value
    assert found.n_evaluations >= 2 and found.method == "bounded Powell"
    edge = powell(lambda x: float(-x[0]), np.array([0.9]), [(0.5, 1.0)], 60)
    assert 0.9 < edge.x[0] <= 1.0 and edge.value == pytest.approx(-edge.x[0])


def test_de_polish_reaches_the_minimum_through_the_objectives_best():
    best = [np.inf, None]

    def f(x):
        j = float(np.sum((np.asarray(x) - np.array([0.3, -0.2])) ** 2))
        if j < best[0]:
            best[:] = [j, np.array(x, float)]
        return j

    method = de_polish(lambda xs: np.array([f(xs[:, k]) for k in range(xs.shape[1])]), f,
                       lambda: (best[0], best[1]), np.array([-1.0, -1.0]), np.array([1.0, 1.0]),
                       np.array([0.9, 0.9]), popsize=6, maxiter=30, seed=0, label="test objective")
    assert method.startswith("differential evolution (test objective, popsize 6, ")
    assert method.endswith("+ Nelder-Mead polish")
    assert np.allclose(best[1], [0.3, -0.2], atol=1e-2)


def test_before_after_in_order_and_the_guard():
    seen = []
    rows = before_after(lambda t, v: seen.append((t, v["p"])) or v["p"] * t,
                        [("tuned", [1, 2]), ("held out", [3])], {"p": 1.0}, {"p": 2.0})
    assert [(r[0], r[1], r[2], r[3]) for r in rows] == [("tuned", 1, 1.0, 2.0),
                                                        ("tuned", 2, 2.0, 4.0),
                                                        ("held out", 3, 3.0, 6.0)]
    assert seen == [(1, 1.0), (1, 2.0), (2, 1.0), (2, 2.0), (3, 1.0), (3, 2.0)]
    b = {"h": {"fuel_pct": 1.0, "soc_pct": 1.0}}
    a = {"h": {"fuel_pct": 2.0, "soc_pct": 1.0}}
    assert "h: fuel 1.00 -> 2.00 %" in holdout_worse(b, a, ["h"])
    assert holdout_worse(a, b, ["h"]) == "" and holdout_worse(b, a, []) == ""


def _prov(**kw) -> Provenance:
    base = dict(by="vehval calibrate", tests=["A", "B"], objective="objective",
                start_value=0.5, best_value=0.01, method="bounded Powell",
                start={"gearbox.efficiency": 0.93},
                ranges={"gearbox.efficiency": bounds_text(0.5, 1.0)}, dt=0.1,
                holdout=["C"], date="2026-01-02")
    base.update(kw)
    return Provenance(**base)


def test_one_provenance_format():
    assert _prov().text("gearbox.efficiency") == (
        "calibrated by vehval calibrate on tests A, B on 2026-01-02: objective 0.5 -> 0.01 "
        "(bounded Powell; start 0.93, bounds [0.5, 1]; dt 0.1 s; held out C)")
    epa = _prov(by="vehval epa calibrate", objective="RMS error of the judged figures",
                start_value=0.026, best_value=0.0101, percent=True, holdout=[],
                ranges={"gearbox.efficiency": grid_text([0.9, 0.95])}, details=["x y"])
    assert epa.text("gearbox.efficiency") == (
        "calibrated by vehval epa calibrate on tests A, B on 2026-01-02: RMS error of the "
        "judged figures 2.6 % -> 1.0 % (bounded Powell; start 0.93, grid 0.9, 0.95; "
        "dt 0.1 s; x y)")


@pytest.mark.parametrize("name,param", [("prius_2004", "controller.engine_on_power_w"),
                                        ("cruze_diesel_2014", "gearbox.efficiency")])
def test_one_writer_for_every_architecture(tmp_path, name, param):
    veh = load_vehicle(name)
    value = veh.parameters()[param] * 0.97
    cal = vehicle_with_values(veh, {param: value}, _prov(start={param: 1.0},
                                                         ranges={param: "bounds [0, 2]"}).text)
    path = write_vehicle_yaml(cal, tmp_path / "v.yaml", "vehval calibrate")
    back = load_vehicle(path)
    assert type(back) is type(veh) and back.parameters()[param] == value
    blk, key = param.split(".")
    assert getattr(back, blk).sources[key].startswith("calibrated by vehval calibrate on tests A, B")
    others = {k: v for k, v in back.parameters().items() if k != param}
    assert others == {k: v for k, v in veh.parameters().items() if k != param}
    assert path.read_text(encoding="utf-8").startswith("# Calibrated by vehval calibrate;")


@pytest.mark.parametrize("module", ["validate/calibration.py", "identify/calibrate.py",
                                    "epa/calibrate.py"])
def test_calibrators_have_no_search_or_writer_of_their_own(module):
    """The searches and the vehicle writer are the engine's: no calibrator imports an
    optimiser or writes YAML itself."""
    tree = ast.parse((SRC / module).read_text(encoding="utf-8"))
    imported = {a.name for n in ast.walk(tree) if isinstance(n, (ast.Import, ast.ImportFrom))
                for a in n.names}
    mods = {n.module for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)}
    assert not imported & {"minimize", "differential_evolution", "yaml", "itertools"}
    assert "scipy.optimize" not in mods and "vehval.calibration" in mods
