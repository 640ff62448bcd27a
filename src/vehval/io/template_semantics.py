"""Import templates checked beyond their schema: every mapped name in the registry, every
unit known and of the signal's dimension, names unique, the architecture's and the results'
signals present (:func:`semantic_errors`, used by :mod:`vehval.io.template` on load).

``t`` is a :class:`vehval.io.template.Template` throughout (typed ``Any`` here: the template
module imports this one).
"""

from __future__ import annotations

from typing import Any

from vehval.errors import SignalError, UnitError
from vehval.nomenclature import registry
from vehval.units import conversion, dimension


def semantic_errors(t: Any) -> list[str]:
    """Checks beyond the schema: names in the registry, units known and convertible.

    Returns
    -------
    list of str
        One ``key.path: problem`` message per problem (empty when the template is sound).
    """
    reg = registry()
    errors: list[str] = []
    seen: dict[str, str] = {}
    time_dim = dimension("s")
    for fi, f in enumerate(t.files):
        try:
            if dimension(f.time.unit) != time_dim:
                errors.append(f"files[{fi}].time.unit: '{f.time.unit}' is not a time unit")
        except UnitError as exc:
            errors.append(f"files[{fi}].time.unit: {exc}")
        for raw, ch in f.channels.items():
            where = f"files[{fi}].channels.{raw}"
            if ch.delete:
                continue
            assert ch.name is not None  # a kept channel is named (checked by ChannelSpec)
            try:
                spec = reg.spec_of(ch.name)
            except SignalError as exc:
                errors.append(f"{where}.name: {exc}")
                continue
            if ch.name in seen:
                errors.append(f"{where}.name: '{ch.name}' is also given to {seen[ch.name]}: "
                              "give one of them a source qualifier (e.g. _obd_)")
            seen[ch.name] = where
            if ch.unit is None:
                continue
            try:
                conversion(ch.unit, spec.unit, fuel_density_kg_per_m3=1.0)
            except UnitError as exc:
                errors.append(f"{where}.unit: channel '{raw}': {exc}")
    for name in list(t.selection.keep) + list(t.selection.drop):
        try:
            reg.parse(name)
        except SignalError as exc:
            errors.append(f"selection: {exc}")
    errors.extend(_results_errors(t, seen))
    errors.extend(_architecture_errors(t, seen))
    from vehval.io.road_load import road_load_errors

    errors.extend(road_load_errors(t.constants))   # signs and magnitudes of a target road load
    return errors


def _architecture_errors(t: Any, mapped: dict[str, str]) -> list[str]:
    """A template of a stated architecture: no channel of a category the car lacks, no
    fuel on a battery-electric car, its required signals mapped."""
    from vehval.vehicle.definition import ARCHITECTURES, REQUIRED_SIGNALS, absent_categories

    arch = t.architecture
    if arch is None:
        return []
    if arch not in ARCHITECTURES:
        return [f"architecture: unknown architecture '{arch}' (known: "
                f"{', '.join(ARCHITECTURES)})"]
    reg = registry()
    errors = []
    absent = absent_categories(arch)
    for name, where in mapped.items():
        cat = reg.spec_of(name).category
        if cat in absent:
            errors.append(f"{where}.name: '{name}' is a{'n' if cat[0] in 'aeiou' else ''} "
                          f"{cat} signal, which a {arch} car does not have: remove the "
                          "channel or correct 'architecture'")
    if arch == "battery_electric" and t.fuel is not None:
        errors.append("fuel: a battery_electric car burns no fuel: remove 'fuel'")
    bases = {reg.parse(n).base for n in mapped}
    needs = REQUIRED_SIGNALS.get(arch, ())
    if needs and not any(set(alt) <= bases for alt in needs):
        errors.append(f"architecture {arch}: the template maps no battery signals; map "
                      + " or ".join(" and ".join(f"'{b}'" for b in alt) for alt in needs))
    return errors


def _results_errors(t: Any, mapped: dict[str, str]) -> list[str]:
    """Checks of the results keys: fuel known, accuracy and phase channel on mapped signals."""
    from vehval.errors import VehvalError
    from vehval.fuels import fuel_properties
    from vehval.fuels.table import density_problem

    errors: list[str] = [p for p in (
        density_problem("constants.fuel_density_kg_per_m3", t.constants.fuel_density_kg_per_m3),
        density_problem("fuel.density_kg_per_m3",
                        getattr(t.fuel, "density_kg_per_m3", None)))  # a FuelSpec's; a name has none
        if p]
    try:
        fuel_properties(t.fuel)
    except VehvalError as exc:
        errors.append(str(exc))
    names = ", ".join(sorted(mapped)) or "none"
    for name, acc in t.accuracy.items():
        if name not in mapped:
            errors.append(f"accuracy.{name}: the template maps no channel to '{name}' "
                          f"(mapped: {names}): use one of those names or remove the entry")
            continue
        if acc.unit is not None:
            try:
                conversion(acc.unit, registry().spec_of(name).unit)
            except (UnitError, SignalError) as exc:
                errors.append(f"accuracy.{name}.unit: {exc}")
    if t.phase_channel is not None and t.phase_channel not in mapped:
        errors.append(f"phase_channel: the template maps no channel to '{t.phase_channel}' "
                      f"(mapped: {names})")
    return errors
