"""Parquet: our own Test file (one file, all signals, units and provenance) and plain tables.

Layout of a Test file: signals are grouped by time base (:meth:`Test.time_bases`); each group
has one time column ``time__<group>`` and its signal columns; shorter groups are padded with
nulls to the longest. Each field carries metadata (unit, source, raw_name, raw_unit, file,
resample, group, notes); the file carries the TestMeta and the group lengths as JSON under the
schema metadata key ``vehval``.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from vehval.errors import ConfigError, InputFileError
from vehval.io.arrow import float_array, float_values
from vehval.io.atomic import atomic_path
from vehval.io.budget import check_decoded
from vehval.io.delimited import MAX_COLUMNS, check_exists
from vehval.io.raw import RawTable, find_time_column
from vehval.safe_yaml import load_json
from vehval.test import Signal, Test, TestMeta
from vehval.units import split_header

if TYPE_CHECKING:  # pyarrow is imported where a Parquet file is read or written
    import pyarrow as pa
    import pyarrow.parquet as pq

FORMAT = "vehval-test"
FORMAT_VERSION = 1
_META_KEY = b"vehval"
_TIME_PREFIX = "time__"


def _padded(values: np.ndarray, n: int) -> pa.Array:
    """float64 array of length ``n``: ``values`` then nulls (NaN samples stay NaN)."""
    return float_array(values, n)


def _field_meta(**kw) -> dict[bytes, bytes]:
    return {k.encode(): ("" if v is None else str(v)).encode() for k, v in kw.items()}


def table_of_test(test: Test) -> pa.Table:
    """The Test as a wide Arrow table with per-field and file metadata (see module doc)."""
    import pyarrow as pa

    groups = test.time_bases()
    n_max = max((test[names[0]].time.size for names in groups.values()), default=0)
    fields, arrays, info = [], [], {}
    for label, names in groups.items():
        t = test[names[0]].time
        info[label] = {"n": int(t.size), "signals": list(names)}
        fields.append(pa.field(f"{_TIME_PREFIX}{label}", pa.float64(),
                               metadata=_field_meta(unit="s", group=label, role="time")))
        arrays.append(_padded(t, n_max))
        for name in names:
            s = test[name]
            fields.append(pa.field(name, pa.float64(), metadata=_field_meta(
                unit=s.unit, source=s.source, raw_name=s.raw_name, raw_unit=s.raw_unit,
                file=s.file, resample=s.resample, group=label, role="signal",
                notes=json.dumps(s.notes))))
            arrays.append(_padded(s.values, n_max))
    meta = {"format": FORMAT, "format_version": FORMAT_VERSION, "meta": test.meta.to_dict(),
            "groups": info}
    schema = pa.schema(fields, metadata={_META_KEY: json.dumps(meta).encode()})
    return pa.Table.from_arrays(arrays, schema=schema)


def write_test(test: Test, path: str | Path) -> Path:
    """Write a Test to one Parquet file, atomically.

    Parameters
    ----------
    test : Test
        Signals in SI with provenance and metadata.
    path : str or Path
        Output file; replaced only when the write succeeded.

    Returns
    -------
    Path
        The file written.
    """
    import pyarrow.parquet as pq

    path = Path(path)
    table = table_of_test(test)
    with atomic_path(path) as tmp:
        pq.write_table(table, tmp, compression="zstd")
    return path


def _vehval_meta(schema: pa.Schema, path: Path | str = "Parquet file") -> dict | None:
    raw = (schema.metadata or {}).get(_META_KEY)
    if raw is None:
        return None
    try:
        meta = load_json(raw.decode("utf-8", errors="replace"), f"{path}: vehval metadata")
    except ConfigError as exc:
        raise InputFileError(str(exc)) from None
    if not isinstance(meta, dict) or meta.get("format") != FORMAT:
        return None
    groups = meta.get("groups")
    ok = isinstance(groups, dict) and isinstance(meta.get("meta", {}), dict) and all(
        isinstance(g, dict) and isinstance(g.get("n"), int) and g["n"] >= 0
        and isinstance(g.get("signals"), list) and all(isinstance(s, str) for s in g["signals"])
        for g in groups.values())
    if not ok:
        raise InputFileError(f"{path}: damaged vehval metadata (groups of signals): re-import "
                             "the test from its raw files")
    return meta


#: Most rows a Parquet data file may declare (10 Hz for 58 days; a test is hours).
MAX_ROWS = 50_000_000


def _declared_bytes(md: pq.FileMetaData, schema: pa.Schema) -> float:
    """Bytes the file decodes to, from the footer: rows x width of each fixed-width column,
    plus the declared uncompressed size (and a 4-byte offset a row) of variable-width ones.

    The declared uncompressed size alone is not enough: a dictionary- or run-length-encoded
    column of 10^8 zeros declares a few kB and decodes to 800 MB.
    """
    rows = md.num_rows
    var = [0] * len(schema)
    for rg in range(md.num_row_groups):
        group = md.row_group(rg)
        for ci in range(min(group.num_columns, len(schema))):
            var[ci] += group.column(ci).total_uncompressed_size
    total = 0.0
    for ci, f in enumerate(schema):
        try:
            width = f.type.bit_width / 8 if f.type.bit_width else None
        except ValueError:  # variable width (strings, lists)
            width = None
        total += rows * (width + 0.125) if width else var[ci] + 4.0 * rows
    return total


def _open(path: str | Path) -> tuple[Path, pa.Table]:
    import pyarrow as pa
    import pyarrow.parquet as pq

    path = Path(path)
    check_exists(path)
    try:
        pf = pq.ParquetFile(path)
        try:
            schema = pf.schema_arrow
            n = len(schema)
            if n > MAX_COLUMNS:
                raise InputFileError(f"{path}: {n} columns, more than the {MAX_COLUMNS} a test "
                                     "file may have: not a test's data file")
            md = pf.metadata
            if md.num_rows > MAX_ROWS:
                raise InputFileError(f"{path}: the Parquet footer declares {md.num_rows:,} rows, "
                                     f"more than the {MAX_ROWS:,} a test file may have (10 Hz "
                                     "for 58 days): split the file by test")
            if md.num_rows == 0:
                raise InputFileError(f"{path}: the Parquet file has no rows (0 samples): not "
                                     "a test's data; export the test again")
            check_decoded(path, "Parquet footer", _declared_bytes(md, schema),
                          advice="split the file into tests of a few hours, or read it on a "
                                 "machine with more memory")
            return path, pf.read()
        finally:
            pf.close()
    except (pa.ArrowException, OSError) as exc:
        raise InputFileError(f"{path}: not a readable Parquet file ({exc})") from None


def read_test(path: str | Path) -> Test:
    """Read a Test written by :func:`write_test` (units, provenance and metadata restored).

    Raises
    ------
    InputFileError
        When the file is missing, unreadable or not a vehval Test file.
    """
    import pyarrow as pa

    path, table = _open(path)
    info = _vehval_meta(table.schema, path)
    if info is None:
        raise InputFileError(f"{path}: not a vehval Test file (no 'vehval' metadata): import it "
                             "with `vehval import FILE -t TEMPLATE`")
    version = info.get("format_version", 0)
    if not isinstance(version, int) or version > FORMAT_VERSION:
        raise InputFileError(f"{path}: written by a newer vehval (format version "
                             f"{info['format_version']}): upgrade vehval")
    try:
        return _test_from(table, info)
    except (KeyError, ValueError, TypeError, IndexError, pa.ArrowException) as exc:
        raise InputFileError(f"{path}: damaged vehval metadata ({type(exc).__name__}: "
                             f"{str(exc)[:100]}): re-import the test from its raw files") from None


#: TestMeta fields and the JSON types their values must have in the file's metadata.
_META_TYPES: dict[str, tuple[type, ...]] = {
    "test_id": (str,), "vehicle": (str,), "cycle": (str,), "files": (list,),
    "template": (str, type(None)), "constants": (dict,), "offsets_s": (dict,),
    "deleted": (list,), "notes": (list,), "synthetic": (bool,),
    "fuel": (str, dict, type(None)), "cycle_match": (dict,)}
#: Numeric entries of ``meta.cycle_match`` the later stages compute with (None allowed).
_MATCH_NUMBERS = ("score", "rms_mps", "offset_s", "source_offset_s", "coverage", "explained",
                  "repeats")


def _checked_meta(meta_d: dict) -> dict:
    """The TestMeta fields of the file's metadata, each of the right JSON type."""
    out = {}
    for key, raw in meta_d.items():
        value: Any = raw
        if key not in _META_TYPES:
            continue
        if not isinstance(raw, _META_TYPES[key]):
            raise TypeError(f"meta.{key} is {type(value).__name__} "
                            f"{str(value)[:40]!r}, expected {_META_TYPES[key][0].__name__}")
        if key in ("files", "notes") and not all(isinstance(v, str) for v in value):
            raise TypeError(f"meta.{key} must be a list of strings")
        if key in ("constants", "offsets_s") and not all(
                isinstance(v, (int, float)) and not isinstance(v, bool) for v in value.values()):
            raise TypeError(f"meta.{key} must map names to numbers")
        if key == "deleted" and not all(isinstance(v, dict) for v in value):
            raise TypeError("meta.deleted must be a list of mappings")
        if key == "cycle_match":
            _check_match(value)
        out[key] = value
    return out


def _check_match(match: dict) -> None:
    """``meta.cycle_match`` holds numbers where the later stages compute with them."""
    def number(v: Any) -> bool:
        return isinstance(v, (int, float)) and not isinstance(v, bool)

    bad = [k for k in _MATCH_NUMBERS if match.get(k) is not None and not number(match[k])]
    offs, wins = match.get("offsets_s", []), match.get("windows_s", [])
    if not (isinstance(offs, list) and all(number(v) for v in offs)):
        bad.append("offsets_s")
    if not (isinstance(wins, list) and all(isinstance(w, list) and len(w) == 2
                                           and all(number(v) for v in w) for w in wins)):
        bad.append("windows_s")
    if bad:
        raise TypeError(f"meta.cycle_match.{bad[0]} must be numbers")


def _test_from(table: pa.Table, info: dict) -> Test:
    meta = TestMeta(**_checked_meta(info.get("meta", {})))
    meta.test_id = str(meta.test_id or "")
    test = Test(meta=meta)
    for label, g in info["groups"].items():
        n = int(g["n"])
        t = float_values(table.column(f"{_TIME_PREFIX}{label}"))[:n]
        for name in g["signals"]:
            fmeta = {k.decode(): v.decode() for k, v in (table.schema.field(name).metadata or {}).items()}
            test.add(Signal(
                name=name, time=t.copy(), values=float_values(table.column(name))[:n].copy(),
                unit=fmeta.get("unit", ""), source=fmeta.get("source", ""),
                raw_name=fmeta.get("raw_name") or None, raw_unit=fmeta.get("raw_unit") or None,
                file=fmeta.get("file") or None, resample=fmeta.get("resample") or "linear",
                notes=json.loads(fmeta.get("notes") or "[]")))
    return test


def read_parquet_raw(path: str | Path, **_opts) -> RawTable:
    """Read a Parquet file as raw channels.

    A vehval Test file gives one channel per signal with its own time array; a plain wide
    table gives its numeric columns (``Name[unit]`` column names or a ``unit`` field metadata
    give the unit) and its time column, if any. Timestamp columns become seconds since the
    first sample; other non-numeric columns are skipped with a note.
    """
    import pyarrow as pa

    path, table = _open(path)
    info = _vehval_meta(table.schema, path)
    notes: list[str] = []
    if info is not None:
        names, units, data, times = [], [], {}, {}
        for label, g in info["groups"].items():
            n = int(g["n"])
            t = float_values(table.column(f"{_TIME_PREFIX}{label}"))[:n]
            for name in g["signals"]:
                f = table.schema.field(name)
                names.append(name)
                units.append(((f.metadata or {}).get(b"unit") or b"").decode() or None)
                data[name] = float_values(table.column(name))[:n].astype(float)
                times[name] = t
        headers = [f"{n}[{u}]" if u else n for n, u in zip(names, units)]
        return RawTable(path=path, fmt="parquet", headers=headers, names=names, units=units,
                        data=data, times=times, notes=notes, meta={"vehval": info})
    headers, names, units, data = [], [], [], {}
    for f, col in zip(table.schema, table.columns):
        name, unit = split_header(f.name)
        if f.metadata and f.metadata.get(b"unit"):
            unit = f.metadata[b"unit"].decode()
        if pa.types.is_timestamp(f.type):
            ns = col.cast(pa.timestamp("ns")).fill_null(0).to_numpy().astype("int64").astype(float)
            ns[col.is_null().to_numpy(zero_copy_only=False)] = np.nan   # a null time: no time
            first = ns[np.isfinite(ns)]
            values = (ns - first[0]) * 1e-9 if first.size else ns
            unit = "s"
            notes.append(f"column '{f.name}': timestamps converted to seconds since the first row"
                         + (f" ({int(np.isnan(ns).sum())} empty)" if np.isnan(ns).any() else ""))
        elif pa.types.is_integer(f.type) or pa.types.is_floating(f.type) or pa.types.is_boolean(f.type):
            values = float_values(col.cast(pa.float64()))
        else:
            notes.append(f"column '{f.name}' ({f.type}) is not numeric: skipped")
            continue
        if name in data:
            raise InputFileError(f"{path}: duplicate channel name '{name}' in the columns")
        headers.append(f.name)
        names.append(name)
        units.append(unit or None)
        data[name] = np.asarray(values, dtype=float)
    if not names:
        raise InputFileError(f"{path}: no numeric column in the Parquet file")
    time_name = find_time_column(names, units)
    return RawTable(path=path, fmt="parquet", headers=headers, names=names, units=units, data=data,
                    time_name=time_name, notes=notes,
                    time_unit=(units[names.index(time_name)] or "s") if time_name else None)
