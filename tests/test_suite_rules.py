"""Rules of the test suite, read from the test modules with ``ast``.

* Markers the Makefile relies on: a test function that starts Playwright, or that takes a
  fixture of its module that does, carries ``@pytest.mark.browser`` (or its module a
  ``pytestmark`` with it). ``slow`` is by measure (``--durations``), not by scan; unknown
  marker names are refused by ``--strict-markers`` (pyproject's ``addopts``).
* No test imports a test module or a conftest (``tests.x``, ``test_x``, ``conftest``): what
  tests share lives in ``tests/helpers`` or a ``helpers`` module of their folder, so that the
  suite collects from any directory.
"""

from __future__ import annotations

import ast
from pathlib import Path

TESTS = Path(__file__).resolve().parent
DRIVES = ("sync_playwright", "async_playwright")


def _drives_chromium(node: ast.AST) -> bool:
    return any(isinstance(n, (ast.Attribute, ast.Name))
               and (getattr(n, "attr", None) in DRIVES or getattr(n, "id", None) in DRIVES)
               for n in ast.walk(node))


def _marks(decorators: list[ast.expr]) -> set[str]:
    """Marker names among ``pytest.mark.X`` / ``pytest.mark.X(...)`` expressions."""
    out = set()
    for d in decorators:
        for n in ast.walk(d):
            if isinstance(n, ast.Attribute) and isinstance(n.value, ast.Attribute) \
                    and n.value.attr == "mark":
                out.add(n.attr)
    return out


def unmarked_browser_tests(tree: ast.Module) -> list[str]:
    """Test functions of one module that drive Chromium without the ``browser`` marker."""
    module_marks: set[str] = set()
    for node in tree.body:
        if isinstance(node, ast.Assign) and any(getattr(t, "id", None) == "pytestmark"
                                                for t in node.targets):
            module_marks |= _marks([node.value])
    funcs = [n for n in ast.walk(tree) if isinstance(n, ast.FunctionDef)]
    drivers = {f.name for f in funcs if _drives_chromium(f)}
    bad = []
    for f in funcs:
        if not f.name.startswith("test"):
            continue
        uses = f.name in drivers or any(a.arg in drivers for a in f.args.args)
        if uses and "browser" not in module_marks | _marks(f.decorator_list):
            bad.append(f"{f.name}:{f.lineno}")
    return bad


def test_every_chromium_test_is_marked_browser():
    bad = []
    for path in sorted(TESTS.rglob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        bad += [f"{path.relative_to(TESTS)}::{b}" for b in unmarked_browser_tests(tree)]
    assert not bad, "mark these @pytest.mark.browser:\n" + "\n".join(bad)


def test_the_scan_can_fail():
    src = '''
import pytest

@pytest.fixture
def page():
    with sync_api.sync_playwright() as p:
        yield p

def test_uses_fixture(page):
    pass

@pytest.mark.browser
def test_marked(page):
    pass

def test_direct():
    sync_playwright()

def test_plain():
    pass
'''
    assert unmarked_browser_tests(ast.parse(src)) == ["test_uses_fixture:9", "test_direct:16"]
    marked = "pytestmark = [pytest.mark.browser]\n" + src
    assert unmarked_browser_tests(ast.parse(marked)) == []


def _is_test_module(module: str, absolute: bool) -> bool:
    parts = module.split(".")
    return (absolute and parts[0] == "tests") or any(
        p == "conftest" or p.startswith("test_") for p in parts)


def forbidden_imports(tree: ast.Module) -> list[str]:
    """Imports of a test module, a conftest or the ``tests`` package, as ``line: module``."""
    bad = []
    for n in ast.walk(tree):
        if isinstance(n, ast.ImportFrom):
            # ``from . import test_x`` names the module in the import list
            mods = [n.module] if n.module else [a.name for a in n.names]
            bad += [f"{n.lineno}: {m}" for m in mods if _is_test_module(m, n.level == 0)]
        elif isinstance(n, ast.Import):
            bad += [f"{n.lineno}: {a.name}" for a in n.names if _is_test_module(a.name, True)]
    return bad


def test_no_test_imports_another_test_module_or_a_conftest():
    bad = []
    for path in sorted(TESTS.rglob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        bad += [f"{path.relative_to(TESTS)}:{b}" for b in forbidden_imports(tree)]
    assert not bad, "move what is shared into tests/helpers:\n" + "\n".join(bad)


def test_the_import_scan_can_fail():
    src = """
from tests.epa.conftest import row
from .conftest import make_test
from .test_browser import ARGS
import test_golden
from helpers.data import REAL
from .helpers import make_test
from vehval.batch.metrics import test_metrics
from . import test_other
"""
    assert forbidden_imports(ast.parse(src)) == [
        "2: tests.epa.conftest", "3: conftest", "4: test_browser", "5: test_golden",
        "9: test_other"]
