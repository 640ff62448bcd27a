"""Common base for component parameter blocks: unknown keys rejected, every value sourced."""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np
from pydantic import BaseModel, ConfigDict, PrivateAttr, ValidationError, model_validator

from vehval.errors import ConfigError

#: a source starting with one of these words marks a value without a public source
UNSOURCED_PREFIXES = ("engineering",)


def is_unsourced(source: str) -> bool:
    """True when ``source`` declares an engineering estimate/choice rather than a reference."""
    return str(source).strip().lower().startswith(UNSOURCED_PREFIXES)


def uncertainty_bounds(nominal: Any, spec: dict[str, Any]) -> tuple[Any, Any]:
    """Low and high ends of a parameter's uncertainty (``range``, ``rel_sd`` or ``scale``).

    ``rel_sd`` gives nominal x (1 -+ 2 sd) (about a 95 % interval); ``scale`` multiplies
    every entry of a curve or map by its two factors.
    """
    if "range" in spec:
        return spec["range"][0], spec["range"][1]
    if "rel_sd" in spec:
        sd = float(spec["rel_sd"])
        return nominal * (1 - 2 * sd), nominal * (1 + 2 * sd)
    lo, hi = spec["scale"]
    arr = np.asarray(nominal, float)
    return (arr * lo).tolist(), (arr * hi).tolist()


def _check_uncertainty(block: "Block", key: str, spec: Any) -> None:
    where = f"uncertainty of '{key}'"
    if not isinstance(spec, dict) or len(spec) != 1 or \
            next(iter(spec)) not in ("range", "rel_sd", "scale"):
        raise ValueError(f"{where}: give exactly one of range: [low, high], rel_sd: x "
                         "(relative standard deviation) or scale: [low, high] (curves/maps)")
    kind, val = next(iter(spec.items()))
    nominal = getattr(block, key)
    scalar = isinstance(nominal, (int, float)) and not isinstance(nominal, bool)
    if kind == "rel_sd":
        if isinstance(val, bool) or not isinstance(val, (int, float)) or not np.isfinite(val):
            raise ValueError(f"{where}: rel_sd must be a number")
        if val < 0:
            raise ValueError(f"{where}: negative standard deviation rel_sd = {val:g}")
        if not scalar:
            raise ValueError(f"{where}: rel_sd applies to a number; use scale for a curve")
        return
    if (not isinstance(val, (list, tuple)) or len(val) != 2
            or not all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in val)):
        raise ValueError(f"{where}: {kind} must be [low, high]")
    lo, hi = float(val[0]), float(val[1])
    if lo > hi:
        raise ValueError(f"{where}: {kind} [{lo:g}, {hi:g}] has low above high")
    if kind == "range":
        if not scalar:
            raise ValueError(f"{where}: range applies to a number; use scale for a curve")
        if not lo <= float(nominal) <= hi:
            raise ValueError(f"{where}: range [{lo:g}, {hi:g}] excludes the nominal value "
                             f"{float(nominal):g}")
    elif scalar or not lo <= 1.0 <= hi or lo <= 0:
        raise ValueError(f"{where}: scale [{lo:g}, {hi:g}] must be positive factors around 1 "
                         "for a curve or map (use range or rel_sd for a number)")


class Block(BaseModel):
    """A parameter block. ``sources`` maps every parameter name to its source (text).

    ``uncertainty`` (optional) maps parameter names to ``{range: [low, high]}``,
    ``{rel_sd: x}`` or, for curves and maps, ``{scale: [low, high]}``. A block that declares
    it must give one for every parameter whose source is an engineering estimate or choice.
    """

    model_config = ConfigDict(extra="forbid", frozen=False, validate_assignment=False,
                              allow_inf_nan=False)

    sources: dict[str, str]
    uncertainty: dict[str, Any] | None = None

    @model_validator(mode="after")
    def _every_parameter_has_a_source(self):
        fields = type(self).model_fields
        params = set(fields) - {"sources", "uncertainty"}
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
        if self.uncertainty is not None:
            for key, spec in self.uncertainty.items():
                if key not in params:
                    raise ValueError(f"'uncertainty' names unknown parameter '{key}'")
                _check_uncertainty(self, key, spec)
            bare = sorted(k for k, v in self.sources.items()
                          if is_unsourced(v) and k not in self.uncertainty)
            if bare:
                raise ValueError(f"unsourced parameters without an uncertainty: "
                                 f"{', '.join(bare)} (add them under 'uncertainty:')")
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


def check_speed_axis(speed_rpm: Sequence[float], max_speed_rpm: float) -> None:
    """Raise ValueError unless a map's speed breakpoints [rpm] reach at least half the
    machine's ``max_speed_rpm``: an axis ending far below it was given in rad/s (rpm / 9.55),
    and the map would be clamped at its edge over most of the speed range."""
    top = float(np.max(np.abs(np.asarray(speed_rpm, float))))
    if top < 0.5 * max_speed_rpm:
        raise ValueError(f"'speed_rpm' breakpoints end at {top:g}, far below 'max_speed_rpm' = "
                         f"{max_speed_rpm:g}: the map's speeds are in rpm (rad/s x 9.549); "
                         "give the map up to the maximum speed")


def table_check(values, rows: int, cols: int | None, key: str) -> None:
    """Raise ValueError naming ``key`` unless ``values`` has shape (rows,) or (rows, cols)."""
    shape = (rows,) if cols is None else (rows, cols)
    try:
        arr = np.asarray(values, dtype=float)
    except ValueError:  # ragged rows: numpy cannot make a table of them
        lens = sorted({len(r) for r in values if isinstance(r, list)})
        raise ValueError(f"'{key}' rows have different lengths ({', '.join(map(str, lens))}): "
                         f"expected {rows} rows of {cols} values to match its breakpoints") from None
    if arr.shape != shape:
        raise ValueError(f"'{key}' has shape {arr.shape}, expected {shape} to match its breakpoints")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"'{key}' must contain finite numbers only")


def check_soc_target(soc_target: float, battery: Any) -> None:
    """Raise ValueError unless the controller's ``soc_target`` (the SOC a run starts from by
    default and the one charge sustaining aims at) lies in the battery's SOC window."""
    if not battery.soc_min <= soc_target <= battery.soc_max:
        raise ValueError(f"'controller.soc_target' = {soc_target:g} is outside the battery "
                         f"window [soc_min, soc_max] = [{battery.soc_min:g}, "
                         f"{battery.soc_max:g}]: give a target inside it")


def block_with(block: Any, changes: dict[str, Any]) -> Any:
    """Validated copy of a parameter block with ``changes`` applied.

    An overridden value is the caller's: its file source is replaced and its file uncertainty
    dropped. Raises pydantic's ``ValidationError`` when the block rejects the new values.
    """
    data = {**block.model_dump(), **changes}
    data["sources"] = {**block.sources, **{k: "override given by the caller" for k in changes}}
    if getattr(block, "uncertainty", None) is not None:
        data["uncertainty"] = {k: v for k, v in block.uncertainty.items() if k not in changes}
    return type(block).model_validate(data)


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
        try:
            update[blk] = block_with(getattr(veh, blk), changes)
        except ValidationError as exc:
            raise ConfigError(f"{where}: invalid override: "
                              f"{validation_text(exc, (blk,), 5)}") from None
    fields = {k: update.get(k, getattr(veh, k)) for k in type(veh).model_fields}
    try:  # the vehicle's own cross-block checks (the blocks are kept as validated)
        new = type(veh).model_validate(fields)
    except ValidationError as exc:
        raise ConfigError(f"{where}: invalid override: {validation_text(exc)}") from None
    new._file = veh._file
    return new


def _given(err: Any) -> str:
    """' (got VALUE)' for a pydantic error on one value (empty for a missing key, an
    unknown key or a check of several values)."""
    if err["type"] in ("missing", "extra_forbidden", "value_error", "assertion_error"):
        return ""
    value = err.get("input")
    if isinstance(value, (dict, BaseModel)):
        return " (got a mapping)"
    text = repr(value)
    return f" (got {text if len(text) <= 60 else text[:57] + '...'})"


def validation_text(exc: ValidationError, prefix: tuple[str, ...] = (), limit: int = 8) -> str:
    """One line from a pydantic ``ValidationError``: per error the dotted key (under
    ``prefix``), what is wrong and the value given (a check of several keys names them in
    its message)."""
    parts = []
    for err in exc.errors()[:limit]:
        key = ".".join(str(x) for x in (*prefix, *err["loc"]))
        msg = err["msg"].removeprefix("Value error, ")
        if err["type"] == "extra_forbidden":
            msg = "unknown key (misspelled?)"
        elif err["type"] == "missing":
            msg = "missing key"
        parts.append((f"key '{key}': " if key else "") + msg + _given(err))
    return "; ".join(parts)


class BlockVehicle(BaseModel):
    """A vehicle made of parameter blocks (``_blocks()``): the file it came from, its flat
    parameters and their sources, and validated copies with parameters overridden."""

    model_config = ConfigDict(extra="forbid")

    _file: str = PrivateAttr(default="")

    def _blocks(self) -> tuple[str, ...]:  # the vehicle's block names, in file order
        raise NotImplementedError

    @property
    def file(self) -> str:
        """File the vehicle was loaded from ('' when built in code)."""
        return self._file

    def parameters(self) -> dict:
        """Flat dict of every scalar parameter by dotted path (e.g. ``body.mass_kg``)."""
        out = {}
        for blk in self._blocks():
            for key, val in getattr(self, blk).model_dump(exclude={"sources"}).items():
                if isinstance(val, (int, float)) and not isinstance(val, bool):
                    out[f"{blk}.{key}"] = val
        return out

    def sources(self) -> dict[str, str]:
        """Source of every parameter by dotted path."""
        return {f"{blk}.{k}": v for blk in self._blocks()
                for k, v in getattr(self, blk).sources.items()}

    def with_overrides(self, overrides: dict | None) -> Any:
        """A validated copy with parameters replaced by dotted path (``body.mass_kg``)."""
        return apply_overrides(self, overrides, self._blocks())
