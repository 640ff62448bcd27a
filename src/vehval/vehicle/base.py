"""Common base for component parameter blocks: unknown keys rejected, every value sourced."""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np
from pydantic import BaseModel, ConfigDict, ValidationError, model_validator
from vehval.constants import RPM_RAD_PER_S as RPM
from vehval.errors import ConfigError


class Block(BaseModel):
    """A parameter block. ``sources`` maps every parameter name to its source (text)."""

    model_config = ConfigDict(extra="forbid", frozen=False, validate_assignment=False,
                              allow_inf_nan=False)

    sources: dict[str, str]

    @model_validator(mode="after")
    def _every_parameter_has_a_source(self):
        fields = type(self).model_fields
        params = set(fields) - {"sources"}
        # a parameter left at its structural default (e.g. no reduction gear) needs no source
        needed = {k for k in params
                  if fields[k].is_required() or getattr(self, k) != fields[k].default}
        missing = sorted(needed - set(self.sources))
        if missing:
            raise ValueError(f"parameters without a source: {', '.join(missing)} "
                             "(add them under 'sources:' with where the value comes from)")
        unknown = sorted(set(self.sources) - params)
        if unknown:
            raise ValueError(f"'sources' names unknown parameters: {', '.join(unknown)}")
        empty = sorted(k for k, v in self.sources.items() if not str(v).strip())
        if empty:
            raise ValueError(f"empty source for: {', '.join(empty)}")
        return self


def bp_check(values: Sequence[float], key: str) -> list[float]:
    """Raise ValueError naming ``key`` unless ``values`` are strictly increasing breakpoints."""
    arr = np.asarray(values, dtype=float)
    if arr.ndim != 1 or arr.size < 2 or not np.all(np.isfinite(arr)):
        raise ValueError(f"'{key}' must be a list of at least 2 finite numbers")
    d = np.diff(arr)
    if np.any(d <= 0):
        i = int(np.nonzero(d <= 0)[0][0])
        raise ValueError(f"'{key}' breakpoints must be strictly increasing (entry {i + 1} = "
                         f"{arr[i + 1]:g} follows {arr[i]:g})")
    return list(values)


def table_check(values, rows: int, cols: int | None, key: str) -> None:
    """Raise ValueError naming ``key`` unless ``values`` has shape (rows,) or (rows, cols)."""
    arr = np.asarray(values, dtype=float)
    shape = (rows,) if cols is None else (rows, cols)
    if arr.shape != shape:
        raise ValueError(f"'{key}' has shape {arr.shape}, expected {shape} to match its breakpoints")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"'{key}' must contain finite numbers only")


def apply_overrides(veh, overrides: dict[str, Any] | None, blocks: tuple[str, ...]):
    """Validated copy of ``veh`` with parameters replaced by dotted path ``<block>.<name>``."""
    if not overrides:
        return veh
    per_block: dict[str, dict[str, Any]] = {}
    for raw_key, value in overrides.items():
        key = raw_key.replace("__", ".")
        parts = key.split(".")
        if len(parts) != 2 or parts[0] not in blocks:
            raise ConfigError(f"override '{raw_key}': use <block>.<parameter> with block one "
                              f"of {', '.join(blocks)}")
        blk, name = parts
        fields = type(getattr(veh, blk)).model_fields
        if name == "sources" or name not in fields:
            raise ConfigError(f"override '{raw_key}': '{blk}' has no parameter '{name}' "
                              f"(known: {', '.join(k for k in fields if k != 'sources')})")
        per_block.setdefault(blk, {})[name] = value
    update = {}
    where = f"{veh.file or veh.name} with overrides"
    for blk, changes in per_block.items():
        old = getattr(veh, blk)
        data = {**old.model_dump(), **changes}
        data["sources"] = {**{k: "override given by the caller" for k in changes},
                           **old.sources}
        try:
            update[blk] = type(old).model_validate(data)
        except ValidationError as exc:
            msgs = "; ".join(f"key '{blk}.{'.'.join(str(x) for x in e['loc']) or '?'}': "
                             f"{e['msg'].removeprefix('Value error, ')}"
                             for e in exc.errors()[:5])
            raise ConfigError(f"{where}: invalid override: {msgs}") from None
    new = veh.model_copy(update=update)
    new._file = veh._file
    return new
