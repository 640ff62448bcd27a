"""One JSON policy for every document vehval writes: NaN/inf -> null, numpy -> Python.

JSON has no NaN or infinity, and numpy scalars and arrays are not JSON types. Every
writer goes through :func:`clean` (a JSON-ready copy) or :func:`dumps` (the text), so the
outputs agree on how a missing number looks (``null``).
"""

from __future__ import annotations

import enum
import json
import math
from pathlib import Path
from typing import Any

import numpy as np


def clean(value: Any) -> Any:
    """A JSON-ready copy of ``value``.

    Rules: objects with ``to_dict()`` become that dict; dicts keep their order with string
    keys; lists, tuples and sets become lists; numpy scalars and arrays become Python
    numbers and lists; non-finite floats become None; enums become their value; paths and
    any other object become ``str``.
    """
    if isinstance(value, dict):
        return {str(k): clean(v) for k, v in value.items()}
    if isinstance(value, (list, tuple, set, frozenset)):
        return [clean(v) for v in value]
    if isinstance(value, bool) or value is None or isinstance(value, str):
        return value
    if isinstance(value, (float, np.floating)):
        f = float(value)
        return f if math.isfinite(f) else None
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, np.bool_):
        return bool(value)
    if isinstance(value, np.ndarray):
        return clean(value.tolist())
    if isinstance(value, enum.Enum):
        return clean(value.value)
    if isinstance(value, Path):
        return str(value)
    to_dict = getattr(value, "to_dict", None)
    if callable(to_dict):
        return clean(to_dict())
    return str(value)


def finite_or_none(value: Any) -> Any:
    """A number as JSON allows it (NaN/inf -> None, numpy -> Python); other values unchanged."""
    if isinstance(value, (float, np.floating)):
        f = float(value)
        return f if math.isfinite(f) else None
    if isinstance(value, np.integer):
        return int(value)
    return value


def dumps(value: Any, *, indent: int | None = 1, sort_keys: bool = False) -> str:
    """The JSON text of ``value`` (cleaned, strict JSON), ending with a newline."""
    return json.dumps(clean(value), indent=indent, sort_keys=sort_keys, allow_nan=False) + "\n"
