"""One rule for which files of a test folder are raw data: ``vehval/io/folder.py``.

The workflow (a test directory), the batch discovery and the workbench take a folder's data
through :func:`vehval.io.folder.data_files`. Anywhere else the scan fails on a second
definition: a set of data-file extensions written again (three or more of the data formats),
a set of the package's own output names to leave out (``{"clean.parquet", "readme.txt"}``) or of
the documents shipped beside data (a ``readme|source|...`` pattern).
"""

from __future__ import annotations

import ast
from pathlib import Path
from types import SimpleNamespace

from vehval.io.folder import data_files, is_data_file

PKG = Path(__file__).resolve().parents[1] / "src" / "vehval"
OWNER = Path("io") / "folder.py"
#: The data formats (a reader's own dispatch table names each format once, by reader).
FORMATS = {".txt", ".csv", ".tsv", ".tab", ".dat", ".asc", ".mf4", ".mdf", ".mf3", ".parquet",
           ".pq"}
OUTPUT_NAMES = {"clean.parquet", "validated.parquet", "findings.json", "results.json",
                "truth.json", "readme.txt"}
#: Modules whose extension tables say how to read a format, not which files are data.
READERS = {Path("io") / "readers.py", Path("io") / "importer.py", Path("cycles.py")}


def _strings(node: ast.AST) -> list[str]:
    elts = node.elts if isinstance(node, (ast.Set, ast.List, ast.Tuple)) else []
    return [e.value.lower() for e in elts
            if isinstance(e, ast.Constant) and isinstance(e.value, str)]


def scan(root: Path = PKG) -> list[str]:
    """Every second definition of the data-file rule under ``root``, as ``file:line: why``."""
    out = []
    for path in sorted(root.rglob("*.py")):
        rel = path.relative_to(root)
        if rel == OWNER:
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            s = _strings(node)
            line = getattr(node, "lineno", 0)
            if len(FORMATS.intersection(s)) >= 3 and rel not in READERS:
                out.append(f"{rel}:{line}: a set of data-file extensions (use vehval.io.folder)")
            if isinstance(node, ast.Set) and len(OUTPUT_NAMES.intersection(s)) >= 2:
                out.append(f"{rel}:{line}: names of files that are not data (use "
                           "vehval.io.folder)")
            if isinstance(node, ast.Constant) and isinstance(node.value, str) \
                    and "readme|" in node.value.lower():
                out.append(f"{rel}:{line}: document names beside data (use vehval.io.folder)")
    return out


def test_one_rule_for_the_data_files_of_a_folder():
    found = scan()
    assert not found, "\n".join(found)


def test_the_scan_sees_each_kind_of_breach(tmp_path):
    pkg = tmp_path / "vehval"
    (pkg / "io").mkdir(parents=True)
    (pkg / "io" / "folder.py").write_text("EXT = {'.txt', '.csv', '.dat'}\n")
    (pkg / "bad.py").write_text(
        "RAW_EXT = {'.txt', '.csv', '.tsv', '.dat'}\n"
        "NOT_DATA = {'clean.parquet', 'readme.txt'}\n"
        "import re\nDOC = re.compile(r'^(readme|source)')\n")
    text = "\n".join(scan(pkg))
    for why in ("data-file extensions", "not data", "document names"):
        assert why in text, (why, text)
    assert "folder.py" not in text


def test_the_rule(tmp_path):
    """By kind without globs (no document, output or PDF in disguise); by globs when every
    entry has one; an entry without a glob reads any data file."""
    for name, body in (("run.csv", b"t,v\n"), ("run.MF4", b"MDF     "), ("README.txt", b"x"),
                       ("SOURCE.txt", b"x"), ("clean.parquet", b"PAR1"), ("note.pdf", b"%PDF"),
                       ("scan.txt", b"%PDF-1.7"), ("bag.dat", b"1 2\n")):
        (tmp_path / name).write_bytes(body)
    files = sorted(tmp_path.iterdir())
    assert [p.name for p in data_files(files)] == ["bag.dat", "run.MF4", "run.csv"]
    both = SimpleNamespace(files=[SimpleNamespace(match="*.csv"), SimpleNamespace(match="b*")])
    assert [p.name for p in data_files(files, both)] == ["bag.dat", "run.csv"]
    part = SimpleNamespace(files=[SimpleNamespace(match="*.csv"), SimpleNamespace(match=None)])
    assert data_files(files, part) == data_files(files)
    assert not is_data_file(tmp_path / "scan.txt")
