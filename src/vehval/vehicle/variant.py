"""Vehicle variants: one powertrain file, trims that change only what the trim changes.

A variant file names its base (``variant_of: prius_2016``) and gives only the parameters the
trim changes, each with its source::

    name: prius_2016_eco
    variant_of: prius_2016
    body: {mass_kg: 1474.2, road_load_a_n: 76.2, sources: {mass_kg: "...", ...}}
    battery: {...}          # a complete block: another pack

A variant may change the test weight, the road load and the accessory load (``body``), the
tyres (``driveline.wheel_radius_m``, ``driveline.wheel_inertia_kg_m2``) and the battery (a
complete ``battery`` block, e.g. from :func:`vehval.vehicle.scaling.scale_battery`).
Anything else belongs to the powertrain: a variant that changes it (a displacement, an axle
ratio, a map) is refused with the parameter and both values named; another powertrain needs
its own vehicle file. The base's controller, machines and engine are used unchanged: a
variant is never refitted.
"""

from __future__ import annotations

import copy
from typing import Any, Callable

from vehval.errors import ConfigError

#: per block, the keys a variant may change (None: the whole block is replaced)
VARIANT_KEYS: dict[str, frozenset[str] | None] = {
    "body": frozenset({"mass_kg", "road_load_a_n", "road_load_b_n_per_mps",
                       "road_load_c_n_per_mps2", "aux_power_w"}),
    "driveline": frozenset({"wheel_radius_m", "wheel_inertia_kg_m2"}),
    "battery": None,
}

#: top-level keys of a variant file besides the blocks
_TOP = ("name", "description", "variant_of", "architecture")


def _fmt(v: Any) -> str:
    return f"{v:g}" if isinstance(v, (int, float)) and not isinstance(v, bool) else repr(v)


def merge_variant(data: dict[str, Any], base: dict[str, Any], where: str,
                  base_name: str) -> dict[str, Any]:
    """The complete vehicle mapping of a variant: ``base`` with the variant's changes.

    Parameters
    ----------
    data : dict
        The variant file's mapping (``variant_of`` and the changed blocks).
    base : dict
        The base vehicle's complete mapping (as read from its file).
    where : str
        The variant file (for messages).
    base_name : str
        How messages name the base vehicle.

    Returns
    -------
    dict
        A complete vehicle mapping (to be validated like any vehicle file), with
        ``variant_of`` kept.

    Raises
    ------
    ConfigError
        A change outside the variant keys (the parameter, the base's and the variant's values
        named), a changed value without its source, or a block that is not a mapping.
    """
    base_arch = base.get("architecture", "power_split")
    if base_arch != "power_split":
        raise ConfigError(f"{where}: key 'variant_of': {base_name} is a {base_arch!r} vehicle; "
                          "variants are defined for power-split vehicles")
    if data.get("architecture", base_arch) != base_arch:
        raise ConfigError(f"{where}: key 'architecture': a variant of {base_name} keeps its "
                          f"architecture {base_arch!r}")
    out = copy.deepcopy(base)
    out["variant_of"] = data["variant_of"]
    for key in ("name", "description"):
        if key in data:
            out[key] = data[key]
    for blk, changes in data.items():
        if blk in _TOP:
            continue
        if blk not in base:
            raise ConfigError(f"{where}: key '{blk}': not a block of {base_name} "
                              f"(blocks: {', '.join(k for k in base if isinstance(base[k], dict))})")
        if not isinstance(changes, dict):
            raise ConfigError(f"{where}: key '{blk}': a block must be a mapping")
        allowed = VARIANT_KEYS.get(blk, frozenset())
        if allowed is None:
            out[blk] = copy.deepcopy(changes)  # a complete block (validated as one)
        else:
            _merge_block(out[blk], base[blk], blk, changes, allowed, where, base_name)
    return out


def _merge_block(out: dict[str, Any], base: dict[str, Any], blk: str, changes: dict[str, Any],
                 allowed: frozenset[str], where: str, base_name: str) -> None:
    """Apply one block's changes (allowed keys only, each with its source) to ``out``."""
    srcs = changes.get("sources") or {}
    if not isinstance(srcs, dict):
        raise ConfigError(f"{where}: key '{blk}.sources': must be a mapping")
    for key, value in changes.items():
        if key in ("sources", "uncertainty") or (key not in allowed and value == base.get(key)):
            continue  # an unchanged value (e.g. a complete block written back) is no change
        if key not in allowed:
            old = base.get(key)
            what = (f"changes {blk}.{key} from {_fmt(old)} to {_fmt(value)}"
                    if old is not None else f"sets {blk}.{key} = {_fmt(value)}")
            raise ConfigError(
                f"{where}: variant of {base_name} {what}: that is a powertrain part, not a "
                f"trim; a variant changes only weight, road load, tyres and battery "
                f"({_allowed_text()}); another powertrain needs its own vehicle file")
        if not str(srcs.get(key, "")).strip():
            raise ConfigError(f"{where}: key '{blk}.sources.{key}': the variant changes "
                              f"{blk}.{key}: give its source")
        out[key] = value
        out.setdefault("sources", {})[key] = srcs[key]
    extra = sorted(k for k in set(srcs) - set(changes) if k not in base)
    if extra:
        raise ConfigError(f"{where}: key '{blk}.sources': names parameters the variant "
                          f"does not change: {', '.join(extra)}")
    unc = changes.get("uncertainty")
    if unc is not None:
        if not isinstance(unc, dict):
            raise ConfigError(f"{where}: key '{blk}.uncertainty': must be a mapping of "
                              f"parameter names, got {_fmt(unc)}")
        out["uncertainty"] = {**(out.get("uncertainty") or {}), **unc}


def _allowed_text() -> str:
    parts = []
    for blk, keys in VARIANT_KEYS.items():
        parts.append(f"{blk}.*" if keys is None else ", ".join(f"{blk}.{k}" for k in sorted(keys)))
    return "; ".join(parts)


def resolve_variant(data: dict[str, Any], where: str,
                    read_base: Callable[[str], tuple[dict[str, Any], str]],
                    depth: int = 0) -> dict[str, Any]:
    """Follow ``variant_of`` (a variant of a variant too) to a complete vehicle mapping.

    ``read_base(name)`` returns the base's mapping and where it was read from.
    """
    if data.get("variant_of") is None:
        return data
    if depth > 4:
        raise ConfigError(f"{where}: key 'variant_of': more than 4 levels of variants (a loop?)")
    name = data["variant_of"]
    if not isinstance(name, str) or not name.strip():
        raise ConfigError(f"{where}: key 'variant_of': give the base vehicle's name or path")
    base, base_where = read_base(name)
    if not isinstance(base, dict):
        raise ConfigError(f"{base_where}: a vehicle file must be a mapping of blocks")
    base = resolve_variant(base, base_where, read_base, depth + 1)
    return merge_variant(data, base, where, name)
