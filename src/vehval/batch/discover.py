"""Test discovery and input hashing for batch runs.

Discovery rule (documented in ``docs/catalog.md``):

* ``DIR`` given: every immediate subdirectory of ``DIR`` (hidden ones excepted) is one test,
  made of the files in it whose names match one of the template's ``files[].match`` globs
  (all non-hidden files when the template has a single entry without ``match``).
  When the template has exactly one ``files`` entry, each matching file directly inside
  ``DIR`` is also a test of its own.
* A glob given (``"data/*/"``, ``"runs/*.txt"``): each matched directory is a test as above;
  each matched file is a test of that single file.
* The test id is the directory name, or the file name without its extension; ids are made
  unique (``name-2``...) in sorted path order, and contain only ``[A-Za-z0-9._-]``.
"""

from __future__ import annotations

import fnmatch
import glob
import hashlib
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from vehval.errors import InputFileError
from vehval.io.paths import sanitize_id

_GLOB_CHARS = set("*?[")


@dataclass
class TestSpec:
    """One test of a batch: an id and the files that make it up."""

    __test__ = False  # not a pytest class

    test_id: str
    files: list[Path]
    file_hashes: dict[str, str] = field(default_factory=dict)
    input_hash: str = ""


def template_patterns(template: Any) -> list[str | None]:
    """The ``match`` glob of every ``files`` entry of a template (None when absent)."""
    entries = getattr(template, "files", None) or []
    return [getattr(e, "match", None) for e in entries]


def _visible(p: Path) -> bool:
    return not p.name.startswith(".")


def _matching_files(directory: Path, patterns: list[str | None]) -> list[Path]:
    files = sorted(p for p in directory.iterdir() if p.is_file() and _visible(p))
    pats = [p for p in patterns if p]
    if not pats:  # single entry without match: every file
        return files
    return [f for f in files if any(fnmatch.fnmatch(f.name, pat) for pat in pats)]


def discover_tests(target: str | Path, template: Any) -> list[TestSpec]:
    """Find the tests of a batch (see the module docstring for the rule).

    Parameters
    ----------
    target : str or Path
        A directory or a glob pattern.
    template : Template
        The import template (its ``files[].match`` patterns select the files).

    Returns
    -------
    list of TestSpec
        Sorted by path; a directory without any matching file still becomes a test (its
        import then fails with a clear error rather than vanishing from the batch).
    """
    patterns = template_patterns(template)
    single = len(patterns) == 1
    target_s = str(target)
    found: list[tuple[str, list[Path]]] = []
    if any(c in target_s for c in _GLOB_CHARS) and not Path(target_s).exists():
        paths = sorted(Path(p) for p in glob.glob(target_s))
        if not paths:
            raise InputFileError(f"no file or directory matches '{target_s}'")
        for p in paths:
            if not _visible(p):
                continue
            if p.is_dir():
                found.append((p.name, _matching_files(p, patterns)))
            elif p.is_file():
                found.append((p.stem, [p]))
    else:
        root = Path(target_s)
        if not root.is_dir():
            raise InputFileError(f"batch input '{root}' is not a directory (give a directory or a "
                                 "quoted glob such as 'data/*/')")
        for p in sorted(root.iterdir()):
            if not _visible(p):
                continue
            if p.is_dir():
                found.append((p.name, _matching_files(p, patterns)))
        if single:
            for f in _matching_files(root, patterns):
                found.append((f.stem, [f]))
    if not found:
        rule = ("a subdirectory per test or one file per test" if single
                else "one subdirectory per test")
        raise InputFileError(f"no tests found in '{target_s}': expected {rule} "
                             f"(template file patterns: {', '.join(p or '*' for p in patterns) or 'none'})")
    specs: list[TestSpec] = []
    seen: set[str] = set()
    for name, files in found:
        base = sanitize_id(name)
        tid, i = base, 2
        while tid in seen:
            tid, i = f"{base}-{i}", i + 1
        seen.add(tid)
        specs.append(TestSpec(tid, [f.resolve() for f in files]))
    return specs


def file_sha256(path: Path, chunk: int = 1 << 20) -> str:
    """SHA-256 of a file's bytes (hex)."""
    h = hashlib.sha256()
    try:
        with open(path, "rb") as fh:
            while block := fh.read(chunk):
                h.update(block)
    except OSError as exc:
        raise InputFileError(f"cannot read {path}: {exc.strerror or exc}") from None
    return h.hexdigest()


def settings_hash(settings: dict) -> str:
    """SHA-256 of the canonical JSON of the batch settings that affect a test's result."""
    return hashlib.sha256(json.dumps(settings, sort_keys=True, default=str).encode()).hexdigest()


def hash_spec(spec: TestSpec, settings_digest: str) -> TestSpec:
    """Fill ``file_hashes`` and ``input_hash`` (files' bytes + their names + settings)."""
    spec.file_hashes = {f.name: file_sha256(f) for f in spec.files}
    h = hashlib.sha256(settings_digest.encode())
    for name in sorted(spec.file_hashes):
        h.update(f"\0{name}\0{spec.file_hashes[name]}".encode())
    spec.input_hash = h.hexdigest()
    return spec
