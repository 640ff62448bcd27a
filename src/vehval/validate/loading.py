"""Turn command-line arguments into validated tests (import + QA), one Test per group.

Grouping rule (also in docs/validation.md):

* a directory is one test: its ``validated.parquet`` (output of ``vehval qa``) when present,
  else the raw files matching the template's ``files[].match`` globs;
* a ``.parquet`` file is one already validated test;
* all other loose files given together form one test (its acquisition files);
* ``--test A,B`` (repeatable) is one test made of the comma-separated files or directory.

Raw tests are imported with the template (``-t``, else the directory's ``template.yaml``)
and run through the QA pipeline; its validated test (aligned, calculated, selected) is used.
"""

from __future__ import annotations

import fnmatch
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Sequence

from vehval.errors import ConfigError, InputFileError
from vehval.test import Test

RAW_EXT = {".txt", ".csv", ".tsv", ".dat", ".mf4", ".mdf", ".parquet"}
NOT_DATA = {"clean.parquet", "validated.parquet", "template.yaml", "truth.json", "readme.txt"}


@dataclass
class LoadedTest:
    """A test ready for validation, with what produced it."""

    test: Test
    qa: Any = None
    template: Any = None
    origin: str = ""


def _template_for(path: Path | None, template: Any) -> Any:
    from vehval.io.template import load_template

    if template is not None:
        return load_template(template) if isinstance(template, (str, Path)) else template
    if path is not None and path.is_dir() and (path / "template.yaml").is_file():
        return load_template(path / "template.yaml")
    raise ConfigError(f"no template for {path}: give -t TEMPLATE.yaml (or put template.yaml in "
                      "the test directory)")


def _dir_files(d: Path, template: Any) -> list[Path]:
    files = sorted(p for p in d.iterdir() if p.is_file())
    globs = [f.match for f in template.files if f.match]
    if globs and len(globs) == len(template.files):
        out = [p for p in files if any(fnmatch.fnmatch(p.name, g) for g in globs)]
    else:
        out = [p for p in files if p.suffix.lower() in RAW_EXT and p.name.lower() not in NOT_DATA]
    if not out:
        raise InputFileError(f"{d}: no data file matches the template "
                             f"({', '.join(globs) or 'any data file'})")
    return out


def load_one(paths: Sequence[Path], template: Any = None, vehicle: Any = None, *,
             qa: bool = True) -> LoadedTest:
    """Load one test from a directory, a Parquet test or a group of raw files."""
    from vehval.io.importer import import_test
    from vehval.io.parquet import read_test

    paths = [Path(p) for p in paths]
    for p in paths:
        if not p.exists():
            raise InputFileError(f"{p}: not found")
    if len(paths) == 1 and paths[0].is_dir() and (paths[0] / "validated.parquet").is_file():
        return LoadedTest(read_test(paths[0] / "validated.parquet"), origin=str(paths[0]))
    if len(paths) == 1 and paths[0].is_file() and paths[0].suffix.lower() == ".parquet":
        return LoadedTest(read_test(paths[0]), origin=str(paths[0]))
    if len(paths) == 1 and paths[0].is_dir():
        tpl = _template_for(paths[0], template)
        files = _dir_files(paths[0], tpl)
        test_id = paths[0].name
    else:
        if any(p.is_dir() for p in paths):
            raise InputFileError("a test group mixes directories and files: give one directory "
                                 "or the files of one test")
        tpl = _template_for(None, template) if template is not None else _template_for(paths[0].parent, None)
        files = paths
        test_id = None
    test = import_test(files, tpl, repair_time=True, test_id=test_id)
    if not qa:
        return LoadedTest(test, template=tpl, origin=", ".join(map(str, files)))
    from vehval.qa.pipeline import run_qa

    res = run_qa(test, vehicle, tpl)
    return LoadedTest(res.validated, qa=res, template=tpl, origin=", ".join(map(str, files)))


def group_args(files: Sequence[Path], groups: Sequence[str]) -> list[list[Path]]:
    """Apply the grouping rule of the module docstring to positional paths and ``--test`` groups."""
    out: list[list[Path]] = []
    loose: list[Path] = []
    for f in files:
        f = Path(f)
        if f.is_dir() or f.suffix.lower() == ".parquet":
            out.append([f])
        else:
            loose.append(f)
    if loose:
        out.append(loose)
    for g in groups:
        items = [Path(x.strip()) for x in str(g).split(",") if x.strip()]
        if items:
            out.append(items)
    return out


def load_tests(files: Sequence[Path], groups: Sequence[str] = (), template: Any = None,
               vehicle: Any = None, *, qa: bool = True) -> list[LoadedTest]:
    """Load every test named on the command line (see the module docstring)."""
    out = [load_one(g, template, vehicle, qa=qa) for g in group_args(files, groups)]
    seen: dict[str, int] = {}
    for lt in out:  # test ids must be unique: they key the results
        tid = lt.test.meta.test_id or "test"
        if tid in seen:
            seen[tid] += 1
            lt.test.meta.test_id = f"{tid}_{seen[tid]}"
        else:
            seen[tid] = 1
            lt.test.meta.test_id = tid
    return out
