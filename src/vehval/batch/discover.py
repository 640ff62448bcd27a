"""Test discovery and input hashing for batch runs.

Discovery rule (documented in ``docs/catalog.md``):

* ``DIR`` given: every immediate subdirectory of ``DIR`` (hidden ones excepted) is one test,
  made of the files in it whose names match one of the template's ``files[].match`` globs
  (all non-hidden files when the template has a single entry without ``match``).
  When the template has exactly one ``files`` entry, each matching file directly inside
  ``DIR`` is also a test of its own.
* A glob given (``"data/*/"``, ``"runs/*.txt"``): each matched directory is a test as above;
  each matched file is a test of that single file.
* Never taken: hidden entries, the batch's own output folder (when it lies inside the
  input folder; the output folder is never the input folder itself), the output of an
  earlier batch (:func:`earlier_output`: a folder holding ``catalog.duckdb``, and the
  entries a batch writes beside that catalog; said in ``notes``, not an error),
  symlinks leading out of the input folder, symlink loops, broken symlinks,
  FIFOs, sockets and devices (reading a FIFO blocks) and unreadable folders; a template without ``match`` takes only data files (by extension and
  content: no PDF, image, README or SOURCE.txt). Every entry skipped for a reason other than
  being hidden or the batch's own output is reported (``skipped``), never silently dropped.
* The test id is the directory name, or the file name without its extension; ids are made
  unique (``name-2``...) in sorted path order, and contain only ``[A-Za-z0-9._-]``.
"""

from __future__ import annotations

import glob
import hashlib
import json
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from vehval.catalog_schema import CATALOG_FILE
from vehval.errors import InputFileError
from vehval.io.folder import data_files, is_data_file, template_patterns
from vehval.io.paths import inside, sanitize_id, special_kind

_GLOB_CHARS = set("*?[")

#: The entries a batch writes into its output folder (OUTDIR): never tests. The catalog
#: marks a folder as a batch's output (:func:`earlier_output`).
CATALOG_NAME = CATALOG_FILE
INDEX_NAME = "index.html"
#: Directory of OUTDIR holding the one plotly.js copy the test reports share.
ASSETS_DIR = "assets"
#: Directory of OUTDIR holding one folder per test.
TESTS_DIR = "tests"
#: File beside the catalog holding the set verdicts of the latest run.
SET_VERDICT_NAME = "set_verdict.json"
OUTPUT_NAMES = (TESTS_DIR, ASSETS_DIR, CATALOG_NAME, f"{CATALOG_NAME}.wal", INDEX_NAME,
                SET_VERDICT_NAME)


#: What ``vehval qa`` (and the workbench's QA of a test) writes: a folder holding both is
#: an output, not a test.
QA_OUTPUTS = ("findings.json", "validated.parquet")


def _qa_output(p: Path) -> bool:
    return p.is_dir() and all((p / name).is_file() for name in QA_OUTPUTS)


def earlier_output(p: Path) -> str | None:
    """Why ``p`` is (part of) an earlier output, or None: a folder holding a batch's
    catalog, one of the entries a batch writes (:data:`OUTPUT_NAMES`) beside it (an earlier
    run whose output folder was the input folder), a ``vehval qa`` output folder
    (:data:`QA_OUTPUTS`), or a folder of such folders (the workbench's ``qa/`` beside a
    folder of one-file tests)."""
    try:
        if p.is_dir() and (p / CATALOG_NAME).is_file():
            return f"an earlier batch's output folder: it holds {CATALOG_NAME}"
        if p.name in OUTPUT_NAMES and (p.parent / CATALOG_NAME).is_file():
            return f"an earlier batch's output: {CATALOG_NAME} beside it"
        if _qa_output(p):
            return f"the output of `vehval qa` or the workbench: it holds {', '.join(QA_OUTPUTS)}"
        if p.is_dir():
            kids = [k for k in p.iterdir() if _visible(k)]
            if kids and all(_qa_output(k) for k in kids):
                return "a folder of `vehval qa` / workbench outputs (one per test)"
    except OSError:
        return None
    return None


@dataclass
class TestSpec:
    """One test of a batch: an id and the files that make it up."""

    __test__ = False  # not a pytest class

    test_id: str
    files: list[Path]
    file_hashes: dict[str, str] = field(default_factory=dict)
    input_hash: str = ""




def _visible(p: Path) -> bool:
    return not p.name.startswith(".")


#: (path, reason) of the entries a discovery skipped and reports.
Skipped = list[tuple[Path, str]]


def _why_not(p: Path, root: Path, exclude: list[Path]) -> str | None:
    """None when ``p`` may be taken; else why not ('' when silently: hidden, own output)."""
    if not _visible(p):
        return ""
    if p.is_symlink():
        try:
            p.resolve(strict=True)
        except RuntimeError:
            return "a symlink loop"
        except OSError as exc:
            return f"a broken symlink ({exc.strerror or exc})"
        if not inside(p, root):
            return f"a symlink leading out of {root}: not followed"
    if any(inside(p, e) for e in exclude):
        return ""
    kind = special_kind(p)
    if kind:
        return f"{kind}, not a regular file: not read"
    return None


def _allowed(p: Path, root: Path, exclude: list[Path], skipped: Skipped | None = None,
             notes: Skipped | None = None) -> bool:
    """Visible, not an excluded output folder, no symlink leading out of ``root``, no symlink
    loop, not an earlier batch's output; a refusal with a reason is appended to ``skipped``,
    an earlier batch's output to ``notes``."""
    why = _why_not(p, root, exclude)
    if why and skipped is not None:
        skipped.append((p, why))
    if why is None and (old := earlier_output(p)):
        if notes is not None:
            notes.append((p, old))
        return False
    return why is None


def _matching_files(directory: Path, template: Any, root: Path | None = None,
                    exclude: Sequence[Path] = (), skipped: Skipped | None = None,
                    notes: Skipped | None = None) -> list[Path]:
    root = root or directory
    files = sorted(p for p in directory.iterdir()
                   if _allowed(p, root, list(exclude), skipped, notes) and p.is_file())
    return data_files(files, template)


def folder_inputs(directory: Path, template: Any, root: Path,
                  exclude: Sequence[str | Path] = ()) -> list[Path]:
    """The files of ``directory`` that would make it a test (the template's patterns)."""
    return _matching_files(directory, template, root, [Path(e) for e in exclude])


def _test_folder(p: Path, template: Any, root: Path, excl: list[Path],
                 skipped: Skipped | None) -> list[Path] | None:
    """The matching files of test folder ``p``; None (reported) when it cannot be read."""
    try:
        return _matching_files(p, template, root, excl, skipped)
    except OSError as exc:
        if skipped is not None:
            skipped.append((p, f"cannot be read ({exc.strerror or exc})"))
        return None


def discover_tests(target: str | Path, template: Any,  # noqa: C901, PLR0912 - one branch per accepted layout of a batch directory
                   exclude: Sequence[str | Path] = (),
                   skipped: Skipped | None = None,
                   notes: Skipped | None = None) -> list[TestSpec]:
    """Find the tests of a batch (see the module docstring for the rule).

    Parameters
    ----------
    target : str or Path
        A directory or a glob pattern.
    template : Template
        The import template (its ``files[].match`` patterns select the files).
    exclude : paths
        Folders never taken as tests (the batch's own output folder when it lies inside
        the input folder).
    skipped : list, optional
        Receives ``(path, reason)`` of every entry skipped for a reason worth telling: a
        symlink loop or a broken symlink, a symlink leading out, a FIFO, socket or device,
        an unreadable folder.
    notes : list, optional
        Receives ``(path, reason)`` of every earlier batch's output left out
        (:func:`earlier_output`): not a test, and not an error.

    Returns
    -------
    list of TestSpec
        Sorted by path; a directory without any matching file still becomes a test (its
        import then fails with a clear error rather than vanishing from the batch).
    """
    patterns = template_patterns(template)
    single = len(patterns) == 1
    excl = [Path(e) for e in exclude]
    target_s = str(target)
    found: list[tuple[str, list[Path]]] = []
    if any(c in target_s for c in _GLOB_CHARS) and not Path(target_s).exists():
        paths = sorted(Path(p) for p in glob.glob(target_s))
        if not paths:
            raise InputFileError(f"no file or directory matches '{target_s}'")
        for p in paths:
            if not _allowed(p, p.parent, excl, skipped, notes):
                continue
            if p.is_dir():
                files = _test_folder(p, template, p, excl, skipped)
                if files is not None:
                    found.append((p.name, files))
            elif p.is_file() and (not single or any(patterns) or is_data_file(p)):
                found.append((p.stem, [p]))
    else:
        root = Path(target_s)
        if not root.is_dir():
            raise InputFileError(f"batch input '{root}' is not a directory (give a directory or a "
                                 "quoted glob such as 'data/*/')")
        for p in sorted(root.iterdir()):
            if not _allowed(p, root, excl, skipped, notes):
                continue
            if p.is_dir():
                files = _test_folder(p, template, root, excl, skipped)
                if files is not None:
                    found.append((p.name, files))
        if single:
            for f in _matching_files(root, template, root, excl):   # noted above
                found.append((f.stem, [f]))
    if not found:
        rule = ("a subdirectory per test or one file per test" if single
                else "one subdirectory per test")
        raise InputFileError(f"no tests found in '{target_s}': expected {rule} "
                             f"(template file patterns: {', '.join(p or '*' for p in patterns) or 'none'})")
    return _with_ids(found)


def _with_ids(found: Sequence[tuple[str, list[Path]]]) -> list[TestSpec]:
    """Tests from ``(name, files)`` in order: ids sanitised and made unique (``name-2``)."""
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


def file_tests(files: Sequence[Path], template: Any) -> list[TestSpec]:
    """The tests of one folder whose every data file is a test of its own (the batch rule for
    the files directly inside ``DIR``): ``[]`` unless the template has exactly one ``files``
    entry and more than one of ``files`` (sorted by name) is data for it.

    Parameters
    ----------
    files : paths
        The regular files of the folder (already screened: no links out, no FIFOs).
    template : Template
        The import template (its one ``files`` entry and ``match`` glob).
    """
    if len(template_patterns(template)) != 1:
        return []
    data = data_files(sorted(files, key=lambda p: p.name), template)
    return _with_ids([(f.stem, [f]) for f in data]) if len(data) > 1 else []


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
