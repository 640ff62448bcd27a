"""One strict loader for every YAML and JSON document the user gives vehval.

Rules (each breach is a :class:`~vehval.errors.ConfigError` naming the file and line):

- a key defined twice in one mapping is an error naming both lines (YAML's "last one wins"
  silently imported km/h where the first definition said mph);
- ``.inf``/``.nan`` are refused: every number of a template, vehicle or calculation file must
  be finite (a ``scale: .inf`` or a mass of 1e308 x 10 gives no meaningful result);
- nesting deeper than :data:`MAX_DEPTH` and documents larger than :data:`MAX_BYTES` are
  refused before they are built (no recursion error, no minutes of parsing);
- anchors (``&name``) and aliases (``*name``) are refused: an alias repeats a node without
  its bytes, so 475 kB of YAML could build a 3.8 GB map (no vehval document needs them).

This module is the only place that parses YAML: templates, vehicles, calculation and fault
files, the package data tables and command-line values all go through :func:`load_yaml`.
"""

from __future__ import annotations

import json
import math
import re
import stat
from pathlib import Path

import yaml

from vehval.errors import ConfigError

#: Deepest nesting of mappings/sequences accepted (real files use fewer than 10).
MAX_DEPTH = 64
#: Largest YAML/JSON document accepted [bytes] (vehicle files with maps are ~100 kB).
MAX_BYTES = 5_000_000


#: libyaml's parser when PyYAML was built with it (several times faster), else PyYAML's own.
_BaseLoader = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


class _StrictLoader(_BaseLoader):  # type: ignore[valid-type,misc]
    """SafeLoader that refuses duplicate keys and non-finite numbers."""


def _construct_mapping(loader: _StrictLoader, node: yaml.MappingNode, deep: bool = False):
    loader.flatten_mapping(node)
    seen: dict = {}
    for key_node, _ in node.value:
        key = loader.construct_object(key_node, deep=deep)
        try:
            hash(key)
        except TypeError:
            raise ConfigError(f"{loader.where} line {key_node.start_mark.line + 1}: a mapping key "
                              "must be a plain value") from None
        if key in seen:
            raise ConfigError(f"{loader.where} line {key_node.start_mark.line + 1}: key '{key}' "
                              f"is defined twice (first on line {seen[key] + 1}): keep one")
        seen[key] = key_node.start_mark.line
    return yaml.SafeLoader.construct_mapping(loader, node, deep=deep)


def _construct_float(loader: _StrictLoader, node: yaml.ScalarNode) -> float:
    value = yaml.SafeLoader.construct_yaml_float(loader, node)
    if not math.isfinite(value):
        shown = node.value if len(node.value) <= 40 else node.value[:37] + "..."
        raise ConfigError(f"{loader.where} line {node.start_mark.line + 1}: '{shown}' is not "
                          "a finite number: give a finite value")
    return value


_StrictLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _construct_mapping)
_StrictLoader.add_constructor("tag:yaml.org,2002:float", _construct_float)
#: Numbers with an exponent and no exponent sign (``42.8e6``, ``1e-3`` has one): YAML 1.2
#: reads them as floats, PyYAML's 1.1 rules as strings; a user writing 42.8e6 means a number.
_StrictLoader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(?:[0-9][0-9_]*(?:\.[0-9_]*)?|\.[0-9_]+)[eE][-+]?[0-9]+$"),
    list("-+0123456789."))


#: Largest JSON document accepted [bytes] (validation.json with overlays of many tests).
MAX_JSON_BYTES = 500_000_000


def _check_size(text: str, where: str, limit: int = MAX_BYTES) -> None:
    if len(text) > limit:
        raise ConfigError(f"{where}: {len(text) / 1e6:.0f} MB is too large for a configuration "
                          f"document (limit {limit / 1e6:.0f} MB)")


def _check_events(text: str, where: str) -> None:
    """Refuse deep nesting, anchors and aliases from the event stream (nothing is built)."""
    depth = 0
    try:
        for event in yaml.parse(text, Loader=_BaseLoader):
            if isinstance(event, yaml.AliasEvent) or getattr(event, "anchor", None) is not None:
                kind = "alias '*" if isinstance(event, yaml.AliasEvent) else "anchor '&"
                raise ConfigError(f"{where} line {event.start_mark.line + 1}: YAML {kind}"
                                  f"{event.anchor}' is not accepted (a vehval document repeats "
                                  "no node by reference): write the values out")
            if isinstance(event, (yaml.MappingStartEvent, yaml.SequenceStartEvent)):
                depth += 1
                if depth > MAX_DEPTH:
                    raise ConfigError(f"{where} line {event.start_mark.line + 1}: nesting deeper "
                                      f"than {MAX_DEPTH} levels: not a vehval document")
            elif isinstance(event, (yaml.MappingEndEvent, yaml.SequenceEndEvent)):
                depth -= 1
    except yaml.YAMLError:
        return      # the loader reports the syntax error with its line


def load_yaml(text: str, where: str = "document"):
    """Parse YAML ``text`` strictly (see module doc); ``where`` names it in errors."""
    _check_size(text, where)
    _check_events(text, where)
    loader = None
    try:
        loader = _StrictLoader(text)
        loader.where = where
        return loader.get_single_data()
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        line = f" line {mark.line + 1}" if mark is not None else ""
        if isinstance(exc, yaml.reader.ReaderError):  # a control character: its line, one line
            line = f" line {text.count(chr(10), 0, exc.position) + 1}"
        detail = str(getattr(exc, "problem", None) or exc).splitlines()[0]
        raise ConfigError(f"{where}{line}: YAML syntax error (not valid YAML): {detail}") from None
    except RecursionError:
        raise ConfigError(f"{where}: nesting too deep: not a vehval document") from None
    finally:
        if loader is not None:
            loader.dispose()


def _read_text(path: Path, kind: str) -> str:
    """The UTF-8 text of the configuration file ``path`` (a ``kind`` file: YAML, JSON), read
    to at most :data:`MAX_BYTES`; a directory, device, pipe, unreadable or non-UTF-8 file is
    a ConfigError."""
    try:
        if path.is_dir():
            raise IsADirectoryError
        if not stat.S_ISREG(path.stat().st_mode):  # a device or a pipe (/dev/zero never ends)
            raise ConfigError(f"{path}: not a regular file, a {kind} file is expected")
        with path.open("rb") as fh:  # bounded read: the size on disk may lie (procfs, growing)
            raw = fh.read(MAX_BYTES + 1)
        if len(raw) > MAX_BYTES:
            raise ConfigError(f"{path}: too large for a configuration file (limit "
                              f"{MAX_BYTES / 1e6:.0f} MB)")
        return raw.decode("utf-8")
    except IsADirectoryError:
        raise ConfigError(f"{path}: is a directory, a {kind} file is expected") from None
    except UnicodeDecodeError as exc:
        raise ConfigError(f"{path}: not UTF-8 text (byte {exc.start}): save it as UTF-8") from None
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read ({exc.strerror})") from None


def read_yaml(path: str | Path):
    """Read and parse a YAML file strictly; unreadable or non-UTF-8 files are a ConfigError."""
    path = Path(path)
    return load_yaml(_read_text(path, "YAML"), str(path))


def load_json(text: str, where: str = "document", *, finite: bool = False):
    """Parse JSON ``text``; syntax errors, deep nesting and (with ``finite``) NaN/Infinity
    are a :class:`ConfigError` naming ``where``."""
    _check_size(text, where, MAX_JSON_BYTES)

    def _constant(name: str):
        if finite:
            raise ConfigError(f"{where}: '{name}' is not a finite number")
        return float(name.replace("Infinity", "inf"))

    try:
        return json.loads(text, parse_constant=_constant)
    except json.JSONDecodeError as exc:
        raise ConfigError(f"{where} line {exc.lineno}: not valid JSON ({exc.msg})") from None
    except RecursionError:
        raise ConfigError(f"{where}: JSON nesting too deep: not a vehval document") from None


_JSON_STRING = re.compile(r'"(?:[^"\\]|\\.)*"')


def _check_json_depth(text: str, where: str) -> None:
    """Refuse JSON nested deeper than :data:`MAX_DEPTH` before it is parsed (brackets inside
    strings do not count)."""
    depth = 0
    for m in re.finditer(r"[\[\]{}]", _JSON_STRING.sub("", text)):
        depth += 1 if m.group() in "[{" else -1
        if depth > MAX_DEPTH:
            raise ConfigError(f"{where}: JSON nesting deeper than {MAX_DEPTH} levels: not a "
                              "vehval document")


def read_json(path: str | Path, *, finite: bool = False):
    """Read and parse a JSON configuration file (start values, settings): at most
    :data:`MAX_BYTES`, nesting at most :data:`MAX_DEPTH`, with ``finite`` no NaN/Infinity;
    every breach a ConfigError naming the file."""
    path = Path(path)
    text = _read_text(path, "JSON")
    _check_json_depth(text, str(path))
    return load_json(text, str(path), finite=finite)
