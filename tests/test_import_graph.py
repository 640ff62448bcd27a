"""The package's import graph: data flows one way (import -> QA -> results -> analysis ->
validate -> report), with no cycle, no undeclared import between two units of one floor and no
ImportError guard around the package's own modules.

The floors and the allowed same-floor imports are the one table of :mod:`vehval.layers`;
``docs/architecture.md`` is drawn from it by ``scripts/architecture.py`` and must be current.
"""

from __future__ import annotations

import ast
import functools
import importlib.util
from pathlib import Path

from vehval import layers

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src"
PKG = SRC / "vehval"


@functools.cache
def _graph() -> dict[str, frozenset[str]]:
    return {m: frozenset(d) for m, d in layers.graph(SRC).items()}


def graph() -> dict[str, set[str]]:
    """Module -> the vehval modules it imports (read once, a fresh copy each call)."""
    return {m: set(d) for m, d in _graph().items()}


def _is_module(name: str) -> bool:
    p = SRC / name.replace(".", "/")
    return p.with_suffix(".py").is_file() or (p / "__init__.py").is_file()


def test_the_layer_rule_holds():
    """No upward import, no undeclared same-floor import, no cycle, every unit placed."""
    bad = layers.violations(graph())
    assert not bad, "\n".join(bad)


def test_every_declared_same_layer_import_is_used_and_on_one_floor():
    assert not layers.unused_same_layer(graph()), "remove from vehval.layers.SAME_LAYER"
    assert all(layers.LAYERS[a] == layers.LAYERS[b] for a, b in layers.SAME_LAYER)
    assert set(layers.FLOOR_NAMES) == set(layers.LAYERS.values())


def test_the_checks_can_fail():
    """The real check, on small graphs that break the rule, reports each break."""
    table = {"low": 0, "mid": 1, "mid2": 1, "top": 2}
    allowed = frozenset({("mid", "mid2")})
    ok = {"vehval.top": {"vehval.mid.a"}, "vehval.mid.a": {"vehval.mid2", "vehval.mid.b"},
          "vehval.mid.b": {"vehval.low"}, "vehval.mid2": {"vehval.low"}, "vehval.low": set()}
    assert layers.violations(ok, table, allowed) == []

    upward = {**ok, "vehval.low": {"vehval.top"}}
    bad = layers.violations(upward, table, allowed)
    assert any("vehval.low (floor 0) imports vehval.top (floor 2): upward" in b for b in bad)

    undeclared = {**ok, "vehval.mid2": {"vehval.mid.b"}}
    assert layers.violations(undeclared, table, allowed) == [
        "vehval.mid2 imports vehval.mid.b, both on floor 1: declare ('mid2', 'mid') in "
        "vehval.layers.SAME_LAYER or move a unit"]

    cycle = {**ok, "vehval.mid.b": {"vehval.low", "vehval.mid.a"}}
    assert layers.violations(cycle, table, allowed) == [
        "import cycle: vehval.mid.a -> vehval.mid.b"]

    unplaced = {**ok, "vehval.new": {"vehval.low"}}
    assert layers.violations(unplaced, table, allowed) == [
        "new: not placed in vehval.layers.LAYERS (give it a floor)"]

    # and the package's own graph, with one real upward import added, fails too
    g = graph()
    g["vehval.equations.calc"] = g.get("vehval.equations.calc", set()) | {"vehval.qa.level2"}
    assert any("vehval.equations.calc (floor 3) imports vehval.qa.level2 (floor 4)" in b
               for b in layers.violations(g))


def test_architecture_doc_is_current():
    """docs/architecture.md is what scripts/architecture.py draws from the table today."""
    spec = importlib.util.spec_from_file_location("architecture", ROOT / "scripts" / "architecture.py")
    assert spec and spec.loader
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    doc = ROOT / "docs" / "architecture.md"
    assert doc.read_text(encoding="utf-8") == script.render(graph()), \
        "docs/architecture.md is stale: run python scripts/architecture.py --write (make generate)"


def test_no_import_error_guard_around_own_modules():
    found = []
    for path in sorted(PKG.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if not isinstance(node, ast.Try):
                continue
            catches = {getattr(h.type, "id", None) for h in node.handlers} | {
                getattr(e, "id", None) for h in node.handlers
                if isinstance(h.type, ast.Tuple) for e in h.type.elts}
            if not catches & {"ImportError", "ModuleNotFoundError"}:
                continue
            own = [n for stmt in node.body for n in ast.walk(stmt)
                   if (isinstance(n, ast.ImportFrom) and (n.module or "").startswith("vehval"))
                   or (isinstance(n, ast.Import) and any(a.name.startswith("vehval") for a in n.names))]
            if own:
                found.append(f"{path.relative_to(SRC)}:{node.lineno}")
    assert not found, found


#: the simulator's insides: only vehval.sim itself may import them (everything else goes
#: through the front door, vehval.sim.simulate, or the rule's API, vehval.sim.rule and
#: vehval.sim.supervisor)
SIM_INTERNALS = {"vehval.sim.kernel", "vehval.sim.packing", "vehval.sim.layout",
                 "vehval.sim.phases", "vehval.sim.plant", "vehval.sim.indices",
                 "vehval.sim.stack", "vehval.sim.conventional_kernel",
                 "vehval.sim.conventional"}


def test_simulator_internals_stay_inside_sim():
    bad = [f"{a} imports {b}" for a, deps in graph().items() for b in deps
           if b in SIM_INTERNALS and not a.startswith("vehval.sim.")]
    assert not bad, "\n".join(bad)
    assert all(_is_module(m) for m in SIM_INTERNALS)  # the rule names real modules
