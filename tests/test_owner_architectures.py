"""One owner for the choice by vehicle architecture, and a thin command line.

* the stage registry (:mod:`vehval.architectures`) covers every architecture the simulator
  runs (:data:`vehval.sim.simulate.ARCHITECTURES`): a new powertrain gets its stages there;
* no module of the command line, and not the workflow, tests an architecture by name: a
  string ``"power_split"`` / ``"conventional"`` compared, tested with ``in`` or used as a
  key (a subscript or a dict key) fails with the file and line (the registry owns them);
* every module under ``vehval/cli`` is at most 250 lines: the command line parses and
  prints, the stages build their documents.

The scans read the sources with ``ast`` (no import).
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PKG = Path(__file__).resolve().parents[1] / "src" / "vehval"
NAMES = ("power_split", "conventional")
MAX_CLI_LINES = 250


def _scanned() -> list[Path]:
    return (sorted((PKG / "cli").glob("*.py")) + sorted((PKG / "workflow").glob("*.py"))
            + sorted((PKG / "serve").glob("*.py")))


def architecture_tests(source: str, names: tuple[str, ...] = NAMES) -> list[int]:
    """Lines where a string of ``names`` is compared, tested with ``in``, or used as a key."""
    def named(node: ast.AST | None) -> bool:
        return isinstance(node, ast.Constant) and node.value in names

    def holds(node: ast.AST) -> bool:      # the name itself, or a tuple/list/set of names
        if isinstance(node, (ast.Tuple, ast.List, ast.Set)):
            return any(named(e) for e in node.elts)
        return named(node)

    bad = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Compare) and any(holds(x) for x in (node.left, *node.comparators)):
            bad.append(node.lineno)
        elif isinstance(node, ast.Subscript) and named(node.slice):
            bad.append(node.lineno)
        elif isinstance(node, ast.Dict) and any(named(k) for k in node.keys):
            bad.append(node.lineno)
        elif isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) \
                and node.func.attr in ("get", "pop", "setdefault") and node.args \
                and named(node.args[0]):
            bad.append(node.lineno)
    return sorted(bad)


@pytest.mark.parametrize("bad", [
    'if veh.architecture == "conventional":\n    pass\n',
    'x = arch != "power_split"\n',
    'ok = name in ("conventional", "x")\n',
    'f = TABLE["power_split"]\n',
    'T = {"conventional": 1}\n',
    'f = TABLE.get("conventional")\n',
])
def test_the_scan_finds_an_architecture_test(bad):
    assert architecture_tests(bad) == [1 + bad.count("\n", 0, bad.index(next(
        n for n in NAMES if n in bad)))]


def test_the_scan_passes_text_and_defaults():
    ok = ('def f(a="conventional"):\n    raise E(f"{a}: for \'conventional\' cars only")\n'
          'g(family="conventional")\n')
    assert architecture_tests(ok) == []


def test_no_architecture_test_in_the_command_line_or_the_workflow():
    found = [f"{p.relative_to(PKG.parent)}:{line}"
             for p in _scanned() for line in architecture_tests(p.read_text(encoding="utf-8"))]
    assert not found, ("an architecture chosen by name outside the stage registry "
                       f"(vehval.architectures): {', '.join(found)}")


def test_every_cli_module_is_thin():
    long = {p.name: n for p in sorted((PKG / "cli").glob("*.py"))
            if (n := len(p.read_text(encoding="utf-8").splitlines())) > MAX_CLI_LINES}
    assert not long, (f"cli modules over {MAX_CLI_LINES} lines: {long}; move the domain "
                      "helpers and the documents into their packages")


def test_the_registry_covers_every_simulated_architecture():
    from vehval.architectures import REGISTRY
    from vehval.sim.simulate import ARCHITECTURES

    missing = sorted(set(ARCHITECTURES) - set(REGISTRY))
    assert not missing, f"architectures without stages in vehval.architectures: {missing}"
    for name, entry in REGISTRY.items():
        assert entry.name == name
        assert entry.family and entry.label and entry.hint
        # every simulated car has a virtual test and a validation; calibration where written
        assert callable(entry.synth)
        assert callable(entry.validate), name
        assert entry.calibrate is None or callable(entry.calibrate), name


def test_a_stage_an_architecture_lacks_is_refused_naming_who_has_it():
    from vehval.architectures import REGISTRY, having, require
    from vehval.errors import ConfigError

    for stage in ("analyze", "identify", "predict", "validate", "calibrate"):
        for name, entry in REGISTRY.items():
            if getattr(entry, stage) is None:
                with pytest.raises(ConfigError) as exc:
                    require(name, stage)
                assert f"not available for '{name}'" in str(exc.value)
                assert all(repr(h) in str(exc.value) for h in having(stage))
            else:
                assert require(name, stage) is getattr(entry, stage)


def test_an_unknown_architecture_is_named():
    from vehval.architectures import stages
    from vehval.errors import ConfigError

    with pytest.raises(ConfigError, match="'steam'"):
        stages("steam")
