"""Read the JSON results the report is built from (``findings.json``, ``control.json``...)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from vehval.errors import ConfigError, InputFileError
from vehval.io.paths import check_input_file
from vehval.safe_yaml import load_json as load_json_text

#: Result files the report reads from an output directory, by kind.
RESULT_FILES = {"findings": "findings.json", "control": "control.json", "validation": "validation.json"}


def load_json(path: str | Path) -> dict:
    """A JSON result file as a dict; :class:`InputFileError` naming the file and line."""
    path = Path(path)
    check_input_file(path, "JSON result file", data=False)
    try:
        doc = load_json_text(path.read_text(encoding="utf-8"), str(path))
    except (OSError, UnicodeDecodeError) as exc:
        raise InputFileError(f"{path}: cannot be read ({exc})") from None
    except ConfigError as exc:
        raise InputFileError(f"{exc}: re-run the command that wrote it") from None
    if not isinstance(doc, dict):
        raise InputFileError(f"{path}: expected a JSON object, found {type(doc).__name__}")
    return doc


def results_beside(origin: str | Path | None, kinds: tuple[str, ...] = ("findings", "control")) -> dict:
    """Results stored next to a validated test: ``{kind: dict}`` for each file present.

    Parameters
    ----------
    origin : str or Path or None
        The output directory of ``vehval qa`` or a Parquet test file in it; anything else
        (e.g. a list of raw files) finds nothing.
    kinds : tuple of str
        Keys of :data:`RESULT_FILES` to look for.
    """
    if not origin:
        return {}
    p = Path(origin)
    folder = p if p.is_dir() else (p.parent if p.is_file() and p.suffix.lower() == ".parquet" else None)
    if folder is None:
        return {}
    return {k: load_json(folder / RESULT_FILES[k]) for k in kinds if (folder / RESULT_FILES[k]).is_file()}


#: the version key each kind of result document carries (a validation.json has none)
VERSION_KEYS = {"findings": "findings_version", "results": "results_version",
                "control": "control_version"}
_WRITER = {"findings": "vehval qa", "results": "vehval results", "control": "vehval analyze",
           "validation": "vehval validate"}


def checked_document(doc: dict, kind: str, path: str | Path) -> dict:
    """``doc`` read from ``path`` as the report's ``kind`` document; :class:`InputFileError`
    when it carries another kind's version key (a results.json given as ``--validation``)."""
    for other, key in VERSION_KEYS.items():
        if other != kind and key in doc:
            raise InputFileError(f"{path}: is a {other} document ('{key}'), not a {kind} "
                                 f"document: give the {kind}.json of `{_WRITER[kind]}`")
    return doc


def _test_id(item: Any) -> str:
    """The test id of a Test or of a result document ('' when it names none)."""
    meta = getattr(item, "meta", None)
    if meta is not None:
        return str(getattr(meta, "test_id", "") or "")
    test = item.get("test") if isinstance(item, dict) else None
    if isinstance(test, dict):
        return str(test.get("id") or test.get("test_id") or "")
    return ""


def refuse_other_test(test: Any, test_path: str | Path,
                      others: list[tuple[Any, str | Path | None]]) -> None:
    """Refuse a file of another test than ``test`` (read from ``test_path``): each of
    ``others`` (a Test or a result document, and its path) that names a test id other than
    the test's (files naming none are taken as they are)."""
    want = _test_id(test)
    for item, path in others:
        got = _test_id(item) if item is not None else ""
        if want and got and got != want:
            raise InputFileError(f"{path}: is of test '{got}', the report's test {test_path} is "
                                 f"'{want}': give the files of one test")
