"""Read the JSON results the report is built from (``findings.json``, ``control.json``...)."""

from __future__ import annotations

from pathlib import Path

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
