"""Import raw files into a :class:`~vehval.test.Test` with a template.

Each file is matched to a template ``files[]`` entry by its ``match`` glob, read, and every
kept channel is converted to the SI unit of its registry base name (pint, affine for
temperatures, fuel density for volumetric fuel flow), then the template's scale and offset are
applied. Sentinel values become NaN; deleted channels are recorded in ``meta.deleted``; every
repair and mismatch is written to ``meta.notes`` (warnings start with ``warning:``).
"""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path
from typing import Sequence

import numpy as np

from vehval.errors import ConfigError, InputFileError, UnitError
from vehval.fuels import resolve_fuel
from vehval.io.paths import check_input_file
from vehval.io.propose import _did_you_mean, entry_for_file, find_channel, no_channel_found
from vehval.io.raw import RawTable
from vehval.io.readers import read_raw
from vehval.io.template import FileSpec, Template, as_template
from vehval.nomenclature import registry
from vehval.test import Signal, Test, TestMeta
from vehval.units import conversion, is_dimensionless

__all__ = ["import_test", "check_time", "set_cycle", "speed_signals"]


@lru_cache(maxsize=1024)
def _conv(raw_unit: str | None, si_unit: str, density: float | None) -> tuple[float, float]:
    return conversion(raw_unit, si_unit, fuel_density_kg_per_m3=density)


def _same_conv(unit: str, conv: tuple[float, float], si_unit: str,
               density: float | None) -> bool:
    """True when ``unit`` converts to ``si_unit`` as ``conv`` does (the same unit spelled
    otherwise); the conversions are cached facts, so no unit library is loaded for it."""
    try:
        return _conv(unit, si_unit, density) == conv
    except UnitError:
        return False


#: A first/last timestamp further than this many median periods (and STRAY_MIN_GAP_S) from
#: its neighbour is a stray value (a clock glitch), dropped with a warning.
STRAY_GAP_PERIODS = 1000.0
STRAY_MIN_GAP_S = 3600.0
#: Longest accepted time span per sample: beyond, the time base cannot be a test's (one row
#: per hour on average); refused before any grid over the span is built.
MAX_SPAN_PER_SAMPLE_S = 3600.0
#: Words that mark a time base repaired at import (in the test's and the signal's notes);
#: QA turns each into a ``rate_irregular`` error (docs/qa.md).
TIME_REPAIRED = "time base repaired on import"
#: Shortest accepted median sample period [s] (1 µs: far beyond any dyno logger).
MIN_PERIOD_S = 1e-6


def check_time(t: np.ndarray, *, path: Path, raw: RawTable | None, label: str,
               repair: bool) -> tuple[np.ndarray, np.ndarray | None, list[str]]:
    """Strictly increasing time (see :func:`_ordered_time`) with stray end samples removed
    and the span checked against the number of samples."""
    ts, order, notes = _ordered_time(t, path=path, raw=raw, label=label, repair=repair)
    keep = _stray_free(ts)
    if keep is not None:
        dropped = [f"{x:.6g} s" for x in ts[~keep]]
        notes.append(f"warning: {path.name}: {label}: stray timestamp(s) {', '.join(dropped)} "
                     f"far from the others (more than {STRAY_GAP_PERIODS:g} sample periods and "
                     f"{STRAY_MIN_GAP_S:g} s): row(s) dropped")
        base = order if order is not None else np.arange(t.size)
        ts, order = ts[keep], base[keep]
    if ts.size >= 2:
        span, med = float(ts[-1] - ts[0]), float(np.median(np.diff(ts)))
        if span / ts.size > MAX_SPAN_PER_SAMPLE_S:
            raise InputFileError(f"{path}: {label} spans {span:.3g} s with only {ts.size} samples:"
                                 " not the time base of a test; check the time column and unit")
        if med < MIN_PERIOD_S:
            raise InputFileError(f"{path}: {label} has a median step of {med:.3g} s (below "
                                 f"{MIN_PERIOD_S:g} s): check the time unit in the template")
    return ts, order, notes


def _stray_free(ts: np.ndarray) -> np.ndarray | None:
    """Mask of the samples to keep when the first or last ones are strays (else None)."""
    if ts.size < 4:
        return None
    d = np.diff(ts)
    thr = max(STRAY_GAP_PERIODS * float(np.median(d)), STRAY_MIN_GAP_S)
    keep = np.ones(ts.size, bool)
    i, j = 0, ts.size - 1
    while i < j - 2 and d[i] > thr:        # leading strays
        keep[i] = False
        i += 1
    while j > i + 2 and d[j - 1] > thr:    # trailing strays
        keep[j] = False
        j -= 1
    return None if keep.all() else keep


def _ordered_time(t: np.ndarray, *, path: Path, raw: RawTable | None, label: str,
                  repair: bool) -> tuple[np.ndarray, np.ndarray | None, list[str]]:
    """Check that a time array [s] is finite and strictly increasing.

    Parameters
    ----------
    t : numpy.ndarray
        Sample times [s] in file order.
    path : Path
        File (for messages).
    raw : RawTable, optional
        Gives the file line of a row.
    label : str
        What the time belongs to (``time column 'Time'``, ``channel 'X'``).
    repair : bool
        Sort, drop duplicates (first kept) and drop NaN times instead of raising.

    Returns
    -------
    time : numpy.ndarray
        Strictly increasing times [s].
    index : numpy.ndarray or None
        Row indices to apply to the samples (``None`` when nothing was changed).
    notes : list of str
        What was repaired.

    Raises
    ------
    InputFileError
        Decreasing, repeated or missing timestamps without ``repair`` (names file and line).
    """
    def where(i: int) -> str:
        line = raw.line_of(i) if raw is not None else None
        return f"{path} line {line}" if line else f"{path} sample {i}"

    finite = np.isfinite(t)
    d = np.diff(t)
    ok_order = bool(np.all(d > 0)) if finite.all() else False
    if ok_order:
        return t, None, []
    if not repair:
        if not finite.all():
            i = int(np.flatnonzero(~finite)[0])
            raise InputFileError(f"{where(i)}: missing timestamp in the {label}: fix the file or "
                                 "pass --repair-time to drop rows without a time")
        i = int(np.flatnonzero(~(d > 0))[0]) + 1
        kind = "repeated" if d[i - 1] == 0 else "decreasing"
        raise InputFileError(
            f"{where(i)}: {kind} timestamp {t[i]:g} s after {t[i - 1]:g} s in the {label}: fix the "
            "file or pass --repair-time to sort the rows and drop duplicate times")
    idx = np.flatnonzero(finite)
    _refuse_restart(t[idx], idx, where, label)
    n_nan = t.size - idx.size
    n_dec = int(np.sum(np.diff(t[idx]) < 0))
    order = idx[np.argsort(t[idx], kind="stable")]
    ts = t[order]
    keep = np.r_[True, np.diff(ts) > 0]
    n_dup = int(np.sum(~keep))
    first = int(np.flatnonzero(~(np.diff(t[idx]) > 0))[0]) + 1 if idx.size > 1 and (
        n_dec or n_dup) else None
    at = f", first at {where(int(idx[first]))} ({t[idx][first]:g} s)" if first is not None else ""
    note = (f"warning: {path.name}: {label}: {TIME_REPAIRED} ({n_dec} decreasing step(s) sorted, "
            f"{n_dup} repeated timestamp(s) dropped (first kept), {n_nan} row(s) without time "
            f"dropped{at})")
    return ts[keep], order[keep], [note]


#: Share of the rows (and least number) that may fall back inside the time already covered
#: for ``--repair-time`` to sort them in: more is a second run, not a clock glitch.
RESTART_MAX_SHARE = 0.01
RESTART_MIN_ROWS = 50


def _refuse_restart(t: np.ndarray, idx: np.ndarray, where, label: str) -> None:
    """Refuse a time base that restarts: two runs concatenated, or a logger restarted.

    The rows are cut into increasing stretches at each backward step; a row counts as
    fallen back when it lies at or before the time the earlier stretches had reached
    (their last row left out, so that one stray high or low time is a glitch, not a
    restart). Sorting such rows into the others would interleave two runs (or drop the
    second as repeated times), so more than :data:`RESTART_MAX_SHARE` of them is an error.
    """
    starts = np.flatnonzero(np.diff(t) < 0) + 1
    if starts.size == 0:
        return
    inner = t.copy()
    inner[np.r_[starts - 1, t.size - 1]] = -np.inf      # each stretch's last row left out
    reached = np.maximum.accumulate(inner)[starts - 1]  # covered before each stretch
    seg = np.repeat(np.arange(starts.size), np.diff(np.r_[starts, t.size]))
    rows = np.arange(starts[0], t.size)
    back = (t[rows] <= reached[seg]) & ~np.isin(rows, starts)
    n_back = int(back.sum())
    if n_back <= max(RESTART_MIN_ROWS, RESTART_MAX_SHARE * t.size):
        return
    first = int(rows[np.flatnonzero(back)[0]])
    s = int(starts[np.searchsorted(starts, first, side="right") - 1])
    raise InputFileError(
        f"{where(int(idx[s]))}: the {label} restarts ({t[s]:g} s after {t[s - 1]:g} s) and "
        f"{n_back} row(s) fall again inside the time already covered: the file holds more "
        "than one run (files concatenated or a logger restart), which --repair-time cannot "
        "sort into one; split the file at this line and import each run as its own test")


def _time_unit(spec: FileSpec, header_unit: str | None) -> str:
    if "unit" in spec.time.model_fields_set:
        return spec.time.unit
    return header_unit or "s"


def _shared_time(raw: RawTable, spec: FileSpec, idx: int, path: Path, repair: bool,
                 notes: list[str]) -> tuple[np.ndarray | None, np.ndarray | None, str | None]:
    """The file's shared time [s], row index after repair, and the time column used."""
    if spec.time.rate_hz is not None:
        n = raw.n_rows
        return spec.time.start_s + np.arange(n) / spec.time.rate_hz, None, None
    col = None
    if spec.time.column is not None:
        col = find_channel(raw, spec.time.column)
        if col is None:
            raise InputFileError(
                f"{path}: time column '{spec.time.column}' (files[{idx}].time.column) is not in the "
                f"file; its columns are: {', '.join(raw.names)}")
    elif raw.time_name is not None:
        col = raw.time_name
    elif raw.times:
        return None, None, None
    else:
        raise InputFileError(
            f"{path}: no time column found (looked for Time, t, Timestamp...) and the template "
            f"gives no rate: set files[{idx}].time.column or files[{idx}].time.rate_hz")
    scale, offset = _conv(_time_unit(spec, raw.unit_of(col)), "s", None)
    t = raw.data[col] * scale + offset
    t, order, tn = check_time(t, path=path, raw=raw, label=f"time column '{col}'", repair=repair)
    notes.extend(tn)
    return t, order, col


def _check_units(raw: RawTable, spec: FileSpec, idx: int) -> None:
    """Every kept channel has a unit (template or file header) unless it is dimensionless:
    one error naming all that have none (fixed in one round, not one per run)."""
    reg = registry()
    lacking = []
    for key, ch in spec.channels.items():
        col = find_channel(raw, key)
        if col is None or ch.delete or ch.name is None or ch.unit is not None \
                or raw.unit_of(col) is not None:
            continue
        si = reg.spec_of(ch.name).unit
        if not is_dimensionless(si):
            lacking.append((key, ch.name, si))
    if len(lacking) == 1:
        key, name, si = lacking[0]
        raise ConfigError(
            f"{raw.path.name}: channel '{key}' -> {name}: no unit in the file header or the "
            f"template: set files[{idx}].channels.{key}.unit (SI unit is {si})")
    if lacking:
        raise ConfigError(
            f"{raw.path.name}: {len(lacking)} channels have no unit in the file header or the "
            f"template: set files[{idx}].channels.NAME.unit for each: "
            + ", ".join(f"'{k}' -> {n} (SI {si})" for k, n, si in lacking))


def _import_file(raw: RawTable, spec: FileSpec, idx: int, t: Template, test: Test,
                 repair: bool) -> None:
    reg = registry()
    path = raw.path
    meta = test.meta
    notes = [f"{path.name}: {n}" for n in raw.notes]
    fuel = resolve_fuel(template=t)
    density = fuel.density_kg_per_m3 if fuel is not None else None
    t_shared, order, time_col = _shared_time(raw, spec, idx, path, repair, notes)
    shared_repair = [n.removeprefix("warning: ") for n in notes if TIME_REPAIRED in n]
    _check_units(raw, spec, idx)
    mapped: set[str] = set()
    missing: list[str] = []
    for key, ch in spec.channels.items():
        col = find_channel(raw, key)
        if col is None:
            missing.append(key)
            continue
        mapped.add(col)
        if ch.delete:
            meta.deleted.append({"name": key, "file": path.name, "source": spec.source,
                                 "reason": ch.reason or "deleted in the template"})
            continue
        assert ch.name is not None  # a kept channel is named (checked by ChannelSpec)
        sspec = reg.spec_of(ch.name)
        unit = ch.unit if ch.unit is not None else raw.unit_of(col)
        if unit is None and not is_dimensionless(sspec.unit):
            raise ConfigError(
                f"{path.name}: channel '{key}' -> {ch.name}: no unit in the file header or the "
                f"template: set files[{idx}].channels.{key}.unit (SI unit is {sspec.unit})")
        try:
            scale, offset = _conv(unit, sspec.unit, density)
        except UnitError as exc:
            raise UnitError(f"{path.name}: channel '{key}' -> {ch.name}: {exc}") from None
        values = raw.data[col]
        sig_notes: list[str] = []
        if ch.invalid_values:
            bad = np.zeros(values.shape, dtype=bool)
            for v in ch.invalid_values:
                bad |= np.abs(values - v) <= 1e-9 * max(1.0, abs(v))
            n_bad = int(bad.sum())
            if n_bad:
                values = np.where(bad, np.nan, values)
                sig_notes.append(f"{n_bad} sample(s) equal to invalid value(s) "
                                 f"{ch.invalid_values} replaced by NaN")
        si = values * (scale * ch.scale)
        off = offset * ch.scale + ch.offset
        if off:
            si = si + off
        if t_shared is not None:
            time = t_shared
            sig_notes.extend(shared_repair)
            if order is not None:
                si = si[order]
        else:
            ts, tu = raw.times[col], _time_unit(spec, raw.time_unit)
            s_t, o_t = _conv(tu, "s", None)
            time, ord_c, tn = check_time(ts * s_t + o_t, path=path, raw=None,
                                         label=f"timestamps of channel '{col}'", repair=repair)
            notes.extend(tn)
            sig_notes.extend(n.removeprefix("warning: ") for n in tn if TIME_REPAIRED in n)
            if ord_c is not None:
                si = si[ord_c]
        hdr = raw.unit_of(col)            # 'degC' for a header 'C' is the same unit: no note
        if ch.unit is not None and hdr is not None and not _same_conv(hdr, (scale, offset),
                                                                        sspec.unit, density):
            sig_notes.append(f"template unit '{ch.unit}' used instead of header unit '{hdr}'")
        test.add(Signal(name=ch.name, time=time, values=si, unit=sspec.unit, source=spec.source,
                        raw_name=col, raw_unit=unit, file=str(path), resample=sspec.resample,
                        notes=sig_notes))
        if sig_notes:
            notes.extend(f"{ch.name}: {n}" for n in sig_notes)
    if spec.channels and not mapped:
        raise InputFileError(no_channel_found(path, len(spec.channels), idx, raw.names))
    extra = [n for n in raw.names if n not in mapped and n != time_col]
    if missing:
        notes.append(f"warning: {path.name}: template channel(s) not in the file: "
                     + ", ".join(_did_you_mean(k, extra) for k in missing))
    if extra:
        notes.append(f"warning: {path.name}: channel(s) in the file but not in the template "
                     "(not imported): " + ", ".join(extra))
    meta.notes.extend(notes)


def speed_signals(test: Test) -> list[Signal]:
    """Measured vehicle speeds of a test, best first for cycle identification: the dyno
    source, then the others by sample count."""
    sigs = [s for s in test.by_base("veh_spd", "test") if s.values.size]
    return sorted(sigs, key=lambda s: (s.source != "dyno", -s.values.size, s.name))


def set_cycle(test: Test, template: Template | None = None, *, identify: bool = True) -> None:
    """Fill ``test.meta.cycle`` and ``test.meta.cycle_match``: the template's ``cycle`` when
    given (located in the record), else the cycle identified from the measured vehicle speed
    (:func:`vehval.cycles_match.identify_cycle`).

    ``meta.cycle_match`` keeps the whole match (name, score, offsets, windows, rms...) with
    the speed signal and the time offset of its source when it was found, so later stages
    (the results phases) use it instead of searching again. How the cycle was found is
    written to ``meta.notes`` (``cycle identified as udds (rms 0.21 m/s, offset 0.0 s) from
    veh_spd_test``); an unidentified cycle leaves ``meta.cycle`` empty with a note saying why.
    """
    from vehval.cycles import list_cycles
    from vehval.cycles_match import identify_cycle
    from vehval.cycles_text import cycle_note

    meta = test.meta
    sigs = speed_signals(test)

    def keep(name: str | None, score: float, details: dict, sig: Signal) -> None:
        meta.cycle_match = {"name": name, "score": score, "signal": sig.name,
                            "source": sig.source,
                            "source_offset_s": meta.offsets_s.get(sig.source, 0.0), **details}

    if template is not None and template.cycle:
        meta.cycle = template.cycle
        meta.notes.append(f"cycle from the template: {template.cycle}")
        base = template.cycle.split("_x")[0]
        if identify and sigs and base in list_cycles():
            name, score, details = identify_cycle(sigs[0].time, sigs[0].values, cycles=[base])
            keep(name, score, details, sigs[0])
        return
    if not identify:
        return
    if not sigs:
        meta.notes.append("cycle not identified: no measured vehicle speed (veh_spd_*_test)")
        return
    first = ""  # set by the first signal (there is one)
    for sig in sigs:
        name, score, details = identify_cycle(sig.time, sig.values)
        if name is not None:
            meta.cycle = name
            keep(name, score, details, sig)
            meta.notes.append(cycle_note(meta.cycle_match))
            return
        if not meta.cycle_match:
            keep(name, score, details, sig)
            first = cycle_note(meta.cycle_match)
    meta.notes.append(first)


#: Largest gap [s] between the time spans of two files of one test: beyond, they are not
#: on one clock (epoch seconds beside seconds from the start, a file of another day).
MAX_FILE_GAP_S = 86400.0


def _check_clocks(test: Test) -> None:
    """Refuse files of one test whose time spans lie more than a day apart (one grid over
    both would be unbounded, and no alignment spans it)."""
    spans: dict[str, tuple[float, float]] = {}
    for sig in test:
        t = sig.time[np.isfinite(sig.time)]
        if t.size and sig.file:
            a, b = spans.get(sig.file, (np.inf, -np.inf))
            spans[sig.file] = (min(a, float(t[0])), max(b, float(t[-1])))
    items = sorted(spans.items(), key=lambda kv: kv[1][0])
    f0, (a0, b0) = items[0] if items else ("", (0.0, 0.0))
    for f1, (a1, b1) in items[1:]:
        if a1 - b0 > MAX_FILE_GAP_S:
            raise InputFileError(
                f"{f1}: its time runs {a1:.10g}..{b1:.10g} s, {a1 - b0:.3g} s after {f0} "
                f"({a0:.10g}..{b0:.10g} s): the files of one test are not on one clock (epoch "
                "or clock time beside seconds from the start, or a file of another day); "
                "give every file the test's time base (the time column's unit, or "
                "files[].time.start_s), or import the file with its own test")
        if b1 > b0:
            f0, a0, b0 = f1, a1, b1


def import_test(files: Sequence[str | Path] | str | Path, template: Template | str | Path, *,
                repair_time: bool = False, test_id: str | None = None,
                identify: bool = True) -> Test:
    """Import the raw files of one test with a template.

    Parameters
    ----------
    files : list of str or Path
        Raw files of the test (one per acquisition system); each must match one template
        ``files[]`` entry.
    template : Template or str or Path
        Template instance or YAML file.
    repair_time : bool
        Sort decreasing and drop repeated timestamps (with a note) instead of raising.
    test_id : str, optional
        Test identifier (default: stem of the first file).
    identify : bool
        Identify the drive cycle from the measured vehicle speed when the template gives no
        ``cycle`` (see :func:`set_cycle`).

    Returns
    -------
    Test
        Signals in SI with provenance; ``meta`` has files, template, constants, deleted
        channels, the cycle, the synthetic flag and notes (warnings start with
        ``warning:``).

    Raises
    ------
    InputFileError, ConfigError, UnitError, SignalError
        Any bad input, with a message naming file, line and channel.
    """
    paths = [Path(files)] if isinstance(files, (str, Path)) else [Path(f) for f in files]
    if not paths:
        raise InputFileError("no input file given")
    t = as_template(template)
    tname = t.path.name if t.path else "template"
    meta = TestMeta(test_id=test_id or paths[0].stem, vehicle=t.vehicle or "",
                    files=[str(p) for p in paths], template=str(t.path) if t.path else None,
                    constants=t.constants_dict(), synthetic=t.synthetic,
                    fuel=(t.fuel if t.fuel is None or isinstance(t.fuel, str)
                          else t.fuel.model_dump(exclude_none=True)))
    test = Test(meta=meta)
    used: dict[int, Path] = {}
    for path in paths:
        check_input_file(path)       # a directory, unreadable file or PDF: one clear line
        idx = entry_for_file(t, path)
        if idx is None:
            globs = ", ".join(repr(f.match) for f in t.files)
            raise ConfigError(f"{path}: no files[] entry of {tname} matches this file name "
                              f"(match globs: {globs})")
        if idx in used:
            raise ConfigError(f"{path} and {used[idx]} both match files[{idx}] of {tname}: one "
                              "entry takes one file per test; import them separately or add "
                              "an entry with its own 'match'")
        used[idx] = path
        spec = t.files[idx]
        raw = read_raw(path, spec.format, **spec.options.model_dump())
        _import_file(raw, spec, idx, t, test, repair_time)
    missing = [i for i, f in enumerate(t.files) if i not in used and not f.optional]
    if missing and len(t.files) > 1:
        i = missing[0]
        raise InputFileError(
            f"this test has no file for files[{i}] of {tname} (source '{t.files[i].source}', "
            f"match {t.files[i].match!r}); give its file, or mark the entry 'optional: true' "
            "when tests may lack it")
    _check_clocks(test)
    for name, reason in t.selection.drop.items():
        if name in test:
            test.drop(name)
            meta.deleted.append({"name": name, "reason": reason, "by": "selection.drop"})
    set_cycle(test, t, identify=identify)
    return test
