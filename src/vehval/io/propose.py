"""Propose a template from raw files (``vehval template init``) and check one against files
(``vehval template check``)."""

from __future__ import annotations

import difflib
import fnmatch
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import cast

from vehval.errors import UnitError, VehvalError
from vehval.fuels import resolve_fuel
from vehval.io.raw import RawTable
from vehval.io.readers import read_raw
from vehval.io.template import ChannelSpec, FileFormat, FileSpec, Template, TimeSpec, as_template
from vehval.nomenclature import registry
from vehval.units import conversion, dimension, parse_unit

__all__ = ["propose_template", "check_template", "CheckReport", "match_channel", "source_tag",
           "entry_for_file", "find_channel", "unit_known", "unit_from_name"]

UNMATCHED_REASON = "no standard name matched; edit"

#: Abbreviations -> one canonical token, so that ``Eng_Spd`` and ``Engine Speed`` compare equal.
_CANON = {
    "spd": "speed", "trq": "torque", "tq": "torque", "temp": "temperature", "tmp": "temperature",
    "volt": "voltage", "v": "voltage", "curr": "current", "i": "current", "pwr": "power",
    "frc": "force", "eng": "engine", "veh": "vehicle", "vehicle": "vehicle", "mot": "motor",
    "mg2": "motor", "gen": "generator", "mg1": "generator", "bty": "battery", "batt": "battery",
    "bat": "battery", "ess": "battery", "acc": "acceleration", "accel": "acceleration",
    "pos": "position", "pres": "pressure", "press": "pressure", "whl": "wheel", "brk": "brake",
    "amb": "ambient", "rh": "humidity", "te": "effort", "fuelflow": "fuel flow",
    "flow": "flow", "soc": "soc", "lim": "limit", "chg": "charge", "dis": "discharge",
    "rpm": "speed", "tgt": "target", "trgt": "target", "cmd": "target", "setpoint": "target",
    "volts": "voltage", "amps": "current", "amp": "current",
}
_PORTS = {"in", "out"}
_OBD_HINT = re.compile(r"^(eng2|obd|pid|mode01)|^(rpm|vss|maf|map|iat|ect|stft|ltft)$", re.I)
#: Raw-name tokens typical of OBD/CAN logger channels (``ENGINE_RPM``, ``PID_0D``, ``MAF``).
_OBD_TOKENS = {"obd", "obd2", "obdii", "pid", "elm", "elm327", "vss", "maf", "iat", "ect",
               "stft", "ltft", "rpm"}
#: Units written in channel names: token -> unit (``ENGINE_RPM`` -> rpm).
_NAME_UNITS = {"rpm": "rpm", "kph": "km/h", "kmh": "km/h", "mph": "mph", "pct": "%",
               "percent": "%", "degc": "degC", "degf": "degF", "kpa": "kPa", "nm": "N*m",
               "kw": "kW", "gps": "g/s", "volts": "V", "amps": "A"}
#: Name units that say nothing about the quantity (``rpm`` does: a shaft speed).
_UNIT_ONLY_TOKENS = frozenset(_NAME_UNITS) - {"rpm", "volts", "amps"}


def _tokens(text: str) -> list[str]:
    text = re.sub(r"([a-z])([A-Z])", r"\1 \2", text)
    out: list[str] = []
    for tok in re.split(r"[^A-Za-z0-9]+", text.lower()):
        if not tok:
            continue
        out.extend(_CANON.get(tok, tok).split())
    return out


def _score(a: list[str], b: list[str]) -> float:
    """Dice similarity of two token lists, near-identical tokens counting as equal."""
    if not a or not b:
        return 0.0
    rest = list(b)
    hits = 0
    for tok in a:
        if tok in rest:
            hits += 1
            rest.remove(tok)
            continue
        close = difflib.get_close_matches(tok, rest, n=1, cutoff=0.85)
        if close:
            hits += 1
            rest.remove(close[0])
    return 2.0 * hits / (len(a) + len(b))


@lru_cache(maxsize=1)
def _candidates() -> list[tuple[str, str, list[list[str]]]]:
    """(base, SI unit, token lists of the base name and its aliases) for every registry entry."""
    out = []
    for b, spec in registry().specs.items():
        if b == "time":
            continue
        cands = [[t for t in _tokens(b.replace("_", " ")) if t not in _PORTS]]
        cands += [_tokens(a) for a in spec.aliases]
        out.append((b, spec.unit, cands))
    return out


@lru_cache(maxsize=4096)
def _unit_fits(raw_unit: str | None, si_unit: str) -> bool:
    if raw_unit is None:
        return True
    try:
        conversion(raw_unit, si_unit, fuel_density_kg_per_m3=1.0)
        return True
    except UnitError:
        return False


def match_channel(raw_name: str, raw_unit: str | None, *, cutoff: float = 0.7) -> str | None:
    """Base name for a raw channel: registry alias first, then fuzzy tokens + unit dimension.

    Parameters
    ----------
    raw_name : str
        Channel name without unit, e.g. ``Engine Speed``.
    raw_unit : str or None
        Header unit; a candidate whose SI unit cannot be reached from it is rejected.
    cutoff : float
        Minimum token similarity (0..1) for a fuzzy match.
    """
    reg = registry()
    toks = _tokens(raw_name)
    base = reg.match_alias(raw_name)
    if base is not None and base != "time" and _unit_fits(raw_unit, reg[base].unit):
        return _targeted(base, toks, raw_unit)
    best, best_score = None, 0.0
    for b, unit, cands in _candidates():
        if not _unit_fits(raw_unit, unit):
            continue
        s = max(_score(toks, c) for c in cands)
        if s > best_score:
            best, best_score = b, s
    if best is not None and best_score >= cutoff:  # a best when the score is above 0
        return _targeted(best, toks, raw_unit)
    if raw_unit is None:
        # a unit written in the name (``speed_mph``): match the rest, in that unit's dimension
        rest, name_unit = _strip_name_unit(raw_name)
        if rest and name_unit is not None:
            return match_channel(rest, name_unit, cutoff=cutoff)
    return None


def _strip_name_unit(raw_name: str) -> tuple[str, str | None]:
    """``speed_mph`` -> (``speed``, ``mph``): the name without its unit token, and the unit."""
    toks = [t for t in re.split(r"[^a-z0-9]+", re.sub(r"([a-z])([A-Z])", r"\1 \2", raw_name).lower()) if t]
    units = [t for t in toks if t in _UNIT_ONLY_TOKENS]
    if len(units) != 1:
        return raw_name, None
    return " ".join(t for t in toks if t != units[0]), _NAME_UNITS[units[0]]


def _targeted(base: str, toks: list[str], raw_unit: str | None) -> str:
    """``<component>_<quantity>_target`` for a raw name saying "target" (``TARGET_ENGINE_RPM``
    -> ``eng_spd_target``) when the registry has that base name and the unit fits."""
    if "target" not in toks or base.endswith("_target"):
        return base
    parts = base.split("_")
    cand = "_".join(parts[:2]) + "_target"
    reg = registry()
    if cand in reg.specs and _unit_fits(raw_unit, reg[cand].unit):
        return cand
    return base


def unit_known(unit: str | None) -> bool:
    """Whether a header unit is understood (``None``, no unit, counts as known)."""
    if unit is None:
        return True
    try:
        dimension(unit)
        return True
    except UnitError:
        return False


def unit_from_name(raw_name: str, si_unit: str) -> str | None:
    """A unit written in a channel name (``ENGINE_RPM`` -> ``rpm``) that converts to
    ``si_unit``, or ``None``."""
    for tok in re.split(r"[^a-z0-9]+", re.sub(r"([a-z])([A-Z])", r"\1 \2", raw_name).lower()):
        unit = _NAME_UNITS.get(tok)
        if unit is not None and _unit_fits(unit, si_unit):
            return unit
    return None


def _obd_like(name: str) -> bool:
    if _OBD_HINT.search(name):
        return True
    toks = re.split(r"[^a-z0-9]+", re.sub(r"([a-z])([A-Z])", r"\1 \2", name).lower())
    return any(t in _OBD_TOKENS for t in toks)


def source_tag(raw: RawTable) -> str:
    """Default source tag of a file.

    A registry source named in the file name (``run1_obd.csv`` -> ``obd``, ``run1_daq.csv``
    -> ``daq``); else ``dyno`` for D3 files; ``obd`` for an OBD-like CSV (at least two
    channels named like OBD/CAN logger channels, e.g. ``ENGINE_RPM``, ``eng2vsp``, ``MAF``,
    and at most half of the channels with a unit in the header); else the file stem.
    """
    known = [x for x in registry().sources if x != "target"]
    for tok in re.split(r"[^a-z0-9]+", raw.path.stem.lower()):
        if tok in known:
            return tok
    if raw.fmt == "d3":
        return "dyno"
    if raw.fmt == "csv":
        chans = [(n, u) for n, u in zip(raw.names, raw.units) if n != raw.time_name]
        hits = sum(1 for n, _ in chans if _obd_like(n))
        with_unit = sum(1 for _, u in chans if u)
        if hits >= 2 and with_unit <= len(chans) / 2:
            return "obd"
    stem = re.sub(r"[^a-z0-9]", "", raw.path.stem.lower())
    if not stem or not stem[0].isalpha():
        stem = "f" + stem
    return stem[:16]


def _instance(raw_name: str) -> str | None:
    """``eng2ap1`` -> ``ap1``, ``bt3`` -> ``bt3``: the numbered instance at the end of a
    channel name (letters then digits), or None."""
    m = re.search(r"([a-z]+\d+)$", re.sub(r"[^a-z0-9]", "", raw_name.lower()))
    return m.group(1) if m else None


def _instance_name(base: str, inst: str, source: str, used: set[str]) -> str:
    """``<base>_<inst>_test``, or with the file's source in front when another file took it."""
    for qual in (inst, re.sub(r"[^a-z0-9]", "", f"{source}{inst}")):
        if f"{base}_{qual}_test" not in used:
            return f"{base}_{qual}_test"
    return _unique_name(base, source, inst, used)


def _unique_name(base: str, source: str, raw_name: str, used: set[str]) -> str:
    qual = re.sub(r"[^a-z0-9]", "", raw_name.lower())
    cands = [f"{base}_test"]
    # a source named in the raw name (``Eng_Speed_OBD``) beats the file's tag
    known = set(registry().sources)
    cands += [f"{base}_{tok}_test" for tok in re.split(r"[^a-z0-9]+", raw_name.lower())
              if tok in known and not base.endswith(f"_{tok}")]
    cands.append(f"{base}_{source}_test")
    if qual and qual[0].isalpha() and len(qual) <= 8:
        cands.append(f"{base}_{qual}_test")
    cands += [f"{base}_{source}{k}_test" for k in range(2, 100)]
    for c in cands:
        if c not in used:
            return c
    raise VehvalError(f"cannot find a unique name for channel '{raw_name}'")  # pragma: no cover


def propose_template(files: Sequence[str | Path]) -> tuple[Template, list[str]]:
    """Propose a template for raw files.

    Each channel is matched to a registry base name (alias, then fuzzy tokens and unit
    dimension); names are made unique with the file's source tag; unmatched channels are
    written with ``delete: true, reason: "no standard name matched; edit"``.

    Returns
    -------
    template : Template
        The proposal; ``template.todo`` lists what must still be filled in by hand (units of
        channels whose file gives none, time of files without a time column...).
    unmatched : list of str
        ``file: channel`` for every channel no standard name matched.
    """
    reg = registry()
    entries: list[FileSpec] = []
    unmatched: list[str] = []
    todo: list[str] = []
    used: set[str] = set()
    sources: set[str] = set()
    paths = [Path(f) for f in files]
    for path in paths:
        raw = read_raw(path)
        src = source_tag(raw)
        k = 2
        while src in sources:
            src = f"{source_tag(raw)}{k}"
            k += 1
        sources.add(src)
        if raw.time_name is not None:
            time = TimeSpec(column=raw.time_name, unit=raw.time_unit or "s")
        elif raw.times:
            time = TimeSpec()
        else:
            time = TimeSpec(rate_hz=1.0)
            todo.append(f"{path.name}: no time column; time.rate_hz 1.0 assumed: set the real rate")
        channels: dict[str, ChannelSpec] = {}
        first_of: dict[str, str] = {}       # base -> first column of this file mapped to it
        renamed: set[str] = set()
        for name, unit in zip(raw.names, raw.units):
            if name == raw.time_name:
                continue
            known_unit = unit_known(unit)
            base = match_channel(name, unit if known_unit else None)
            if base is None:
                channels[name] = ChannelSpec(delete=True, reason=UNMATCHED_REASON)
                unmatched.append(f"{path.name}: {name}" + ("" if known_unit else f" [{unit}]"))
                continue
            if base in first_of:
                # one file, two columns, one quantity: numbered instances (ap1/ap2, bt1..bt4)
                # get their number as an instance qualifier; anything else is not guessed
                first = first_of[base]
                inst, inst_first = _instance(name), _instance(first)
                if inst is None or inst_first is None or inst == inst_first:
                    channels[name] = ChannelSpec(delete=True, reason=(
                        f"also looks like {base}, already mapped from '{first}': map it by hand"))
                    todo.append(f"{path.name}: channel '{name}' also looks like {base} (mapped "
                                f"from '{first}'): not mapped; name it by hand if it is needed")
                    continue
                if channels[first].name and first not in renamed:
                    used.discard(channels[first].name)
                    renamed_to = _instance_name(base, inst_first, src, used)
                    channels[first] = channels[first].model_copy(update={"name": renamed_to})
                    used.add(renamed_to)
                    renamed.add(first)
                full = _instance_name(base, inst, src, used)
            else:
                first_of[base] = name
                full = _unique_name(base, src, name, used)
            used.add(full)
            spec = reg[base]
            if not known_unit:
                channels[name] = ChannelSpec(name=full, delete=True, reason=(
                    f"unit '{unit}' not understood: set 'unit', then remove 'delete'"))
                todo.append(f"{path.name}: channel '{name}' [{unit}] -> {full}: unit '{unit}' is "
                            f"unknown; set 'unit' (SI is {spec.unit}) and remove 'delete: true'")
                continue
            if unit is None and (guess := unit_from_name(name, spec.unit)) is not None:
                unit = guess
                todo.append(f"{path.name}: channel '{name}' -> {full}: the file gives no unit; "
                            f"'{guess}' taken from the channel name: check it")
            elif unit is None and not parse_unit(spec.unit).dimensionless:
                todo.append(f"{path.name}: channel '{name}' -> {full}: the file gives no unit; "
                            f"set 'unit' (SI is {spec.unit})")
            elif unit is None and spec.range[1] <= 1.0:
                todo.append(f"{path.name}: channel '{name}' -> {full}: the file gives no unit, so "
                            "values are taken as a fraction 0..1: set unit '%' if they are percent")
            if unit is not None and parse_unit(unit).dimensionality != parse_unit(spec.unit).dimensionality:
                todo.append(f"{path.name}: channel '{name}' [{unit}] -> {full}: volumetric fuel "
                            "flow needs the fuel density: declare the fuel ('fuel: diesel', a name of "
                            "the fuel table) or constants.fuel_density_kg_per_m3")
            channels[name] = ChannelSpec(name=full, unit=unit)
        entries.append(FileSpec(match=_glob_escape(path.name) if len(paths) > 1 else None,
                                source=src, format=cast(FileFormat, raw.fmt), time=time,
                                channels=channels))  # a reader's format name (pydantic checks it)
    t = Template(description=f"proposed by `vehval template init` from {', '.join(p.name for p in paths)}",
                 files=entries)
    t._todo = todo
    return t, unmatched


def _glob_escape(name: str) -> str:
    return re.sub(r"([\[\]*?])", r"[\1]", name)


def entry_for_file(t: Template, path: Path, taken: set[int] | None = None) -> int | None:
    """Index of the first ``files[]`` entry whose ``match`` glob fits the file name."""
    for i, f in enumerate(t.files):
        if taken and i in taken and len(t.files) > 1:
            continue
        if f.match is None or fnmatch.fnmatch(path.name, f.match):
            return i
    return None


def find_channel(raw: RawTable, key: str) -> str | None:
    """Raw channel of ``raw`` that a template key names: exact, then case/space-insensitive."""
    if key in raw.data:
        return key
    from vehval.nomenclature import normalise_raw
    norm = normalise_raw(key)
    for n in raw.names:
        if normalise_raw(n) == norm:
            return n
    return None


@dataclass
class CheckReport:
    """Result of :func:`check_template`: errors make ``vehval template check`` fail."""

    errors: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return not self.errors

    def format(self) -> str:
        """One line per distinct problem: the same problem in several files is said once,
        with the files it concerns."""
        errors, warnings = _merge_files(self.errors), _merge_files(self.warnings)
        lines = [f"error: {e}" for e in errors] + [f"warning: {w}" for w in warnings]
        lines.append(f"{len(errors)} error(s), {len(warnings)} warning(s)")
        return "\n".join(lines)


def _merge_files(messages: list[str], shown: int = 3) -> list[str]:
    """``a.txt: X`` and ``b.txt: X`` -> ``a.txt, b.txt: X`` (order of first appearance)."""
    by_text: dict[str, list[str]] = {}
    for m in messages:
        name, sep, text = m.partition(": ")
        key = text if sep else m
        by_text.setdefault(key, [])
        if sep and name not in by_text[key]:
            by_text[key].append(name)
    out = []
    for text, names in by_text.items():
        if not names:
            out.append(text)
            continue
        head = ", ".join(names[:shown]) + (f" and {len(names) - shown} more file(s)"
                                           if len(names) > shown else "")
        out.append(f"{head}: {text}")
    return out


def check_template(template: Template | str | Path, files: Sequence[str | Path]) -> CheckReport:
    """Compare a template with raw files without importing them.

    Errors: a file no entry matches, a template channel whose unit is missing or cannot be
    converted, volumetric fuel without density, no time. Warnings: channels in a file but not
    in the template and template channels missing from the file, header unit differing from
    the template unit.
    """
    t = as_template(template)
    reg = registry()
    rep = CheckReport()
    fuel = resolve_fuel(template=t)  # the template's fuel: or its constants
    density = fuel.density_kg_per_m3 if fuel is not None else None
    taken: set[int] = set()
    for f in files:
        path = Path(f)
        idx = entry_for_file(t, path, taken)
        if idx is None:
            rep.errors.append(f"{path.name}: no files[] entry of the template matches it")
            continue
        taken.add(idx)
        spec = t.files[idx]
        raw = read_raw(path, spec.format, **spec.options.model_dump())
        for note in raw.notes:
            rep.warnings.append(f"{path.name}: {note}")
        tcol = spec.time.column or raw.time_name
        if spec.time.rate_hz is None and not raw.times and (tcol is None or find_channel(raw, tcol) is None):
            rep.errors.append(f"{path.name}: no time column found and files[{idx}].time.rate_hz is not set")
        mapped = set()
        missing: list[str] = []
        for key, ch in spec.channels.items():
            col = find_channel(raw, key)
            if col is None:
                missing.append(key)
                continue
            mapped.add(col)
            if ch.delete:
                continue
            assert ch.name is not None  # a kept channel is named (checked by ChannelSpec)
            unit = ch.unit if ch.unit is not None else raw.unit_of(col)
            si = reg.spec_of(ch.name).unit
            if unit is None and not parse_unit(si).dimensionless:
                rep.errors.append(f"{path.name}: channel '{key}' -> {ch.name}: no unit in the file or "
                                  f"the template: set files[{idx}].channels.{key}.unit")
                continue
            try:
                conversion(unit, si, fuel_density_kg_per_m3=density)
            except UnitError as exc:
                rep.errors.append(f"{path.name}: channel '{key}' -> {ch.name}: {exc}")
                continue
            hdr = raw.unit_of(col)
            if ch.unit is not None and hdr is not None and not _same_unit(ch.unit, hdr):
                rep.warnings.append(f"{path.name}: channel '{key}': template unit '{ch.unit}' differs "
                                    f"from the header unit '{hdr}' (the template wins)")
        if spec.channels and not mapped:
            rep.errors.append(no_channel_found(path, len(spec.channels), idx, raw.names))
        extra = [n for n in raw.names if n not in mapped and n != raw.time_name and n != tcol]
        for key in missing:                 # a typo names the channel it probably meant
            hint = _did_you_mean(key, extra)[len(key):]
            rep.warnings.append(f"{path.name}: template channel '{key}' is not in the file{hint}")
        if extra:
            rep.warnings.append(f"{path.name}: channels not in the template (ignored at import): "
                                + ", ".join(extra))
    return rep


def no_channel_found(path: str | Path, n_channels: int, idx: int, names: Sequence[str]) -> str:
    """The problem of a file none of whose columns the template entry ``files[idx]`` maps
    (import refuses it; ``template check`` states it as an error)."""
    return (f"{path}: none of the {n_channels} channels of template entry files[{idx}] "
            f"is in this file (it has: {', '.join(names[:8])}"
            f"{'...' if len(names) > 8 else ''}): wrong template or wrong file? "
            "Run `vehval template check` or `vehval template init` on it")


def _did_you_mean(key: str, unmapped: list[str]) -> str:
    """``key`` with the closest raw channel the template leaves unmapped, if any:
    "Fuel_Flow_Modl (did you mean 'Fuel_Flow_Modal'? fix the key in the template)"."""
    import difflib

    close = difflib.get_close_matches(key, unmapped, n=1, cutoff=0.75)
    if not close:
        low = {n.lower(): n for n in unmapped}
        close = [low[c] for c in difflib.get_close_matches(key.lower(), list(low), n=1,
                                                           cutoff=0.75)]
    return (f"{key} (did you mean '{close[0]}'? fix the channel name in the template)"
            if close else key)


def _same_unit(a: str, b: str) -> bool:
    try:
        return conversion(a, str(parse_unit(b))) == (1.0, 0.0)
    except UnitError:
        return False
