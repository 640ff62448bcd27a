"""The package's layers: the one table of which top-level unit may import which.

Data flows one way (import -> align -> QA -> calc -> results -> analysis -> validate ->
report). Each top-level module or package (a *unit*) sits on a floor of :data:`LAYERS`; a
module may import units of lower floors freely, a unit of its own floor only along an edge
declared in :data:`SAME_LAYER`, and never a higher floor. The import graph has no cycle.

:func:`graph` reads every ``import`` / ``from ... import`` of ``vehval`` in the sources with
``ast`` (imports inside functions included: a deferred import is still a dependency) without
importing anything; :func:`violations` checks a graph against the table. The import-graph test
runs the check on the package, and ``scripts/architecture.py`` draws the table as
``docs/architecture.md``. Standard library only.
"""

from __future__ import annotations

import ast
from collections.abc import Iterable, Mapping
from pathlib import Path

#: Directory that holds the ``vehval`` package.
SRC = Path(__file__).resolve().parents[1]

#: Floor of each top-level unit (0 = foundation). A new unit must be placed here (the
#: import-graph test fails until it is).
LAYERS: dict[str, int] = {
    "vehval": 0, "errors": 0, "constants": 0, "units": 0, "nomenclature": 0, "safe_yaml": 0,
    "jsonsafe": 0, "conditions": 0, "protocols": 0, "numba_cache": 0, "progress": 0,
    "fuels": 0, "display": 0, "uncertainty": 0, "layers": 0, "integrals": 0, "figures": 0,
    "test": 1, "cycles": 1, "cycles_match": 1, "cycles_text": 1, "vehicle": 1,
    "io": 2, "align": 2,
    "equations": 3, "sim": 3, "calibration": 3,
    "qa": 4,
    "results": 5, "synth": 5,
    "analysis": 6,
    "validate": 7, "epa": 7,
    "report": 8, "catalog": 8, "catalog_schema": 8,
    "workflow": 9, "batch": 9, "identify": 9, "architectures": 9,
    "cli": 10, "serve": 10, "__main__": 10,
}

#: Name of each floor, bottom up.
FLOOR_NAMES: dict[int, str] = {
    0: "foundation: errors, units, constants, fuels, display",
    1: "the test model, drive cycles, vehicle files",
    2: "reading files, aligning time bases",
    3: "equations, the simulator, calibration tables",
    4: "quality assurance",
    5: "results; the virtual dyno",
    6: "analysis",
    7: "validation; EPA test car lists",
    8: "reports, the catalog",
    9: "workflows: one test, a batch, identification, the stages of each architecture",
    10: "the command line and the workbench",
}

#: Imports allowed between two different units of the same floor, ``(importer, imported)``.
#: Any other same-floor import fails the check: declare it here, or move a unit a floor down.
SAME_LAYER: frozenset[tuple[str, str]] = frozenset({
    # floor 0: every foundation module may raise vehval's errors
    ("conditions", "errors"), ("display", "errors"), ("fuels", "errors"),
    ("nomenclature", "errors"), ("safe_yaml", "errors"), ("uncertainty", "errors"),
    ("units", "errors"),
    # floor 0: tables read with the safe YAML loader
    ("fuels", "safe_yaml"), ("nomenclature", "safe_yaml"), ("uncertainty", "safe_yaml"),
    # floor 0: sensor accuracies per signal class, in the signals' SI units
    ("uncertainty", "nomenclature"), ("uncertainty", "units"),
    # floor 0: fuel properties at reference conditions; display formats fuels and names
    ("fuels", "conditions"), ("fuels", "constants"), ("display", "constants"),
    ("display", "fuels"), ("display", "nomenclature"),
    # floor 1: cycle matching reads the cycle table and words its account in one place
    ("cycles_match", "cycles"), ("cycles_match", "cycles_text"),
    # floor 8: the catalog opens its file through the schema module (DDL, check, migration)
    ("catalog", "catalog_schema"),
    # floor 9: a batch and an identification run the one-test workflow
    ("batch", "workflow"), ("identify", "workflow"),
    # floor 9: the workflow chooses each stage by architecture in the stage registry, whose
    # conventional entries are identification's
    ("workflow", "architectures"), ("architectures", "identify"),
    # floor 10: ``python -m vehval`` is the command line; ``vehval serve`` starts the workbench
    ("__main__", "cli"), ("cli", "serve"),
})


def unit(module: str) -> str:
    """Top-level unit of a dotted module name (``vehval.qa.level2`` -> ``qa``)."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 and parts[0] == "vehval" else parts[0]


def _module_name(path: Path, src: Path) -> str:
    parts = path.relative_to(src).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _is_module(name: str, src: Path) -> bool:
    p = src / name.replace(".", "/")
    return p.with_suffix(".py").is_file() or (p / "__init__.py").is_file()


def graph(src: Path = SRC) -> dict[str, set[str]]:
    """Module -> the ``vehval`` modules it imports, for every module under ``src/vehval``."""
    out: dict[str, set[str]] = {}
    for path in sorted((src / "vehval").rglob("*.py")):
        mod = _module_name(path, src)
        deps = out.setdefault(mod, set())
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom) and node.module and node.level == 0 \
                    and node.module.split(".")[0] == "vehval":
                for alias in node.names:
                    sub = f"{node.module}.{alias.name}"
                    deps.add(sub if _is_module(sub, src) else node.module)
            elif isinstance(node, ast.Import):
                deps.update(a.name for a in node.names if a.name.split(".")[0] == "vehval")
        deps.discard(mod)
    return out


def unit_graph(g: Mapping[str, Iterable[str]]) -> dict[str, set[str]]:
    """Unit -> the other units it imports (the module graph folded onto units)."""
    out: dict[str, set[str]] = {}
    for a, deps in g.items():
        out.setdefault(unit(a), set()).update(unit(b) for b in deps if unit(b) != unit(a))
    return out


def cycles(g: Mapping[str, Iterable[str]]) -> list[list[str]]:
    """Import cycles of ``g`` (strongly connected components of two or more modules)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:          # Tarjan's strongly connected components
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(g.get(v, ())):
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
                found.append(sorted(comp))

    for v in sorted(g):
        if v not in index:
            visit(v)
    return found


def violations(g: Mapping[str, Iterable[str]], layers: Mapping[str, int] = LAYERS,
               same_layer: frozenset[tuple[str, str]] = SAME_LAYER) -> list[str]:
    """Every break of the layer rule in ``g``, one line each (empty when the graph is clean):
    a unit missing from ``layers``, an upward import, an undeclared same-floor import between
    two units, an import cycle."""
    bad: list[str] = []
    missing = sorted({unit(m) for a, deps in g.items() for m in (a, *deps)} - set(layers))
    bad += [f"{u}: not placed in vehval.layers.LAYERS (give it a floor)" for u in missing]
    for a, deps in sorted(g.items()):
        ua = unit(a)
        for b in sorted(deps):
            ub = unit(b)
            if ua in missing or ub in missing or ua == ub:
                continue
            if layers[ub] > layers[ua]:
                bad.append(f"{a} (floor {layers[ua]}) imports {b} (floor {layers[ub]}): upward")
            elif layers[ub] == layers[ua] and (ua, ub) not in same_layer:
                bad.append(f"{a} imports {b}, both on floor {layers[ua]}: declare "
                           f"({ua!r}, {ub!r}) in vehval.layers.SAME_LAYER or move a unit")
    bad += [f"import cycle: {' -> '.join(c)}" for c in cycles(g)]
    return bad


def unused_same_layer(g: Mapping[str, Iterable[str]],
                      same_layer: frozenset[tuple[str, str]] = SAME_LAYER) -> list[tuple[str, str]]:
    """Declared same-floor edges that no import uses any more (to be removed from the table)."""
    used = {(a, b) for a, deps in unit_graph(g).items() for b in deps}
    return sorted(same_layer - used)
