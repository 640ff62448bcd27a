"""Which files of a test folder are its raw data: one rule for the workflow, the batch
discovery and the workbench.

* When every ``files`` entry of the template has a ``match`` glob, the data are the files
  whose names match one of the globs (the template says what it reads).
* Otherwise (an entry without ``match`` reads any data file) a file is data when its
  extension is a data format's (:data:`DATA_EXTENSIONS`), its name is not one of the files
  the package writes into a test folder (:data:`OWN_OUTPUTS`) nor a document shipped beside
  data (README, SOURCE, LICENSE, NOTES...), and its first bytes are not a document's (PDF,
  PNG, ZIP...: :func:`vehval.io.paths.non_data_kind`).
"""

from __future__ import annotations

import fnmatch
import re
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from vehval.io.paths import non_data_kind

__all__ = ["DATA_EXTENSIONS", "OWN_OUTPUTS", "data_files", "is_data_file", "match_globs",
           "template_patterns"]

#: Extensions of raw data files (delimited text, MDF, Parquet).
DATA_EXTENSIONS = frozenset({".txt", ".csv", ".tsv", ".tab", ".dat", ".asc", ".mf4", ".mdf",
                             ".mf3", ".parquet", ".pq"})
#: Files the package writes into a test folder (lower case): never raw data.
OWN_OUTPUTS = frozenset({"clean.parquet", "validated.parquet", "template.yaml",
                         "template_final.yaml", "truth.json", "findings.json", "results.json"})
#: Names of documentation files shipped beside data.
_DOC_NAMES = re.compile(r"^(readme|source|license|licence|notes?|changelog|copying|authors)"
                        r"([._-].*)?$", re.I)


def template_patterns(template: Any) -> list[str | None]:
    """The ``match`` glob of every ``files`` entry of a template (None when absent)."""
    entries = getattr(template, "files", None) or []
    return [getattr(e, "match", None) for e in entries]


def match_globs(template: Any) -> list[str]:
    """The template's globs when every ``files`` entry has one, else [] (data by kind)."""
    pats = template_patterns(template)
    return [p for p in pats if p] if pats and all(pats) else []


def is_data_file(path: Path) -> bool:
    """Whether ``path`` is a raw data file by its kind (the rule of the module docstring)."""
    name = path.name
    return (path.suffix.lower() in DATA_EXTENSIONS and name.lower() not in OWN_OUTPUTS
            and not _DOC_NAMES.match(name) and non_data_kind(path) is None)


def data_files(files: Iterable[Path], template: Any = None) -> list[Path]:
    """The raw data among ``files`` of one test folder, in their order: the template's
    ``match`` globs when every entry has one, else every data file by kind."""
    globs = match_globs(template)
    if globs:
        return [p for p in files if any(fnmatch.fnmatch(p.name, g) for g in globs)]
    return [p for p in files if is_data_file(p)]
