"""The package's import graph: data flows one way (import -> QA -> results -> analysis ->
validate -> report), with no cycle and no ImportError guard around the package's own modules.

Every ``import`` / ``from ... import`` of ``vehval`` in the source is read with ``ast``
(imports inside functions included: a deferred import is still a dependency).
"""

from __future__ import annotations

import ast
from pathlib import Path

SRC = Path(__file__).resolve().parents[1] / "src"
PKG = SRC / "vehval"

#: Layer of each top-level module or package: a module may import only its own layer or
#: lower ones. A new package must be placed here (the test fails until it is).
LAYERS: dict[str, int] = {
    "vehval": 0, "errors": 0, "constants": 0, "units": 0, "nomenclature": 0, "safe_yaml": 0,
    "jsonsafe": 0, "conditions": 0, "protocols": 0, "numba_cache": 0, "__main__": 10,
    "fuels": 0, "display": 0, "uncertainty": 0,
    "test": 1, "cycles": 1, "cycles_match": 1, "vehicle": 1,
    "io": 2, "align": 2,
    "equations": 3, "sim": 3, "calibration": 3,
    "qa": 4,
    "results": 5, "synth": 5,
    "analysis": 6,
    "validate": 7, "epa": 7,
    "report": 8, "catalog": 8,
    "workflow": 9, "batch": 9, "identify": 9,
    "cli": 10, "serve": 10,
    "progress": 0,
}


def _module_name(path: Path) -> str:
    parts = path.relative_to(SRC).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _is_module(name: str) -> bool:
    p = SRC / name.replace(".", "/")
    return p.with_suffix(".py").is_file() or (p / "__init__.py").is_file()


def graph() -> dict[str, set[str]]:
    """Module -> the vehval modules it imports."""
    out: dict[str, set[str]] = {}
    for path in sorted(PKG.rglob("*.py")):
        mod = _module_name(path)
        deps = out.setdefault(mod, set())
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom) and node.module and node.level == 0 \
                    and node.module.split(".")[0] == "vehval":
                for alias in node.names:
                    sub = f"{node.module}.{alias.name}"
                    deps.add(sub if _is_module(sub) else node.module)
            elif isinstance(node, ast.Import):
                deps.update(a.name for a in node.names if a.name.split(".")[0] == "vehval")
        deps.discard(mod)
    return out


def _layer(mod: str) -> int:
    top = mod.split(".")[1] if "." in mod else mod
    assert top in LAYERS, f"{top}: place the new module in LAYERS of {__file__}"
    return LAYERS[top]


def test_no_module_imports_upward():
    bad = [f"{a} ({_layer(a)}) imports {b} ({_layer(b)})"
           for a, deps in graph().items() for b in deps if _layer(b) > _layer(a)]
    assert not bad, "\n".join(bad)


def test_no_import_cycle():
    g = graph()
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    cycles: list[list[str]] = []

    def visit(v: str) -> None:          # Tarjan's strongly connected components
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in g.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                cycles.append(sorted(comp))

    for v in sorted(g):
        if v not in index:
            visit(v)
    assert not cycles, cycles


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


def test_the_checks_can_fail(tmp_path):
    """The layer rule sees an upward import (equations -> qa, as before)."""
    assert _layer("vehval.qa.level2") > _layer("vehval.equations.calc")


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
