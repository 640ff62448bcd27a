"""Drive cycles: regulatory speed traces shipped with the package, user traces, steady runs.

The package cycles live in ``vehval/data/cycles/<name>.csv`` in one normalised format::

    # name: udds
    # regulation: US EPA 40 CFR Part 86 Appendix I (a) (UDDS, also FTP-72 / LA-4)
    # source: ...
    # description: ...
    # units: time s, speed m/s
    time_s,speed_mps
    0,0.000000
    ...

They are regenerated from the regulatory tables by ``scripts/make_cycles.py``.

Examples
--------
>>> from vehval.cycles import load_cycle
>>> udds = load_cycle("udds")
>>> round(udds.distance_m / 1000, 2), udds.duration_s
(11.99, 1369.0)
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, replace
from functools import lru_cache
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from vehval.constants import KMH_M_PER_S
from vehval.errors import InputFileError, UnitError, VehvalError
from vehval.integrals import integral
from vehval.units import conversion, split_header

#: Alternative spellings -> package cycle name. Keys are normalised with :func:`_norm`.
ALIASES: dict[str, str] = {
    "udds": "udds", "la4": "udds", "ftp72": "udds", "fudds72": "udds",
    "ftp75": "ftp75", "ftp": "ftp75",
    "hwfet": "hwfet", "hwy": "hwfet", "highway": "hwfet", "hfet": "hwfet", "hwfe": "hwfet",
    "us06": "us06",
    "sc03": "sc03",
    "la92": "la92", "unifiedcycle": "la92", "uc": "la92",
    "nedc": "nedc",
    "ece15": "ece15", "ece": "ece15", "r15": "ece15",
    "eudc": "eudc",
    "japan1015": "japan1015", "1015": "japan1015", "j1015": "japan1015",
    "1015mode": "japan1015", "jp1015": "japan1015",
    "jc08": "jc08", "jc08mode": "jc08",
    "wltc3b": "wltc3b", "wltc": "wltc3b", "wltp": "wltc3b", "wltcclass3b": "wltc3b",
    "wltc3": "wltc3b",
}

_STEADY = re.compile(
    r"^steady[:_]\s*(?P<v>\d+(?:\.\d*)?)\s*(?P<vu>kph|km/h|kmh|mph|mps|m/s)"
    r"(?:[:_]\s*(?P<d>\d+(?:\.\d*)?)\s*(?P<du>s|min)?)?$", re.IGNORECASE)
_SPEED_UNITS = {"kph": 1 / 3.6, "km/h": 1 / 3.6, "kmh": 1 / 3.6, "mph": 0.44704,
                "mps": 1.0, "m/s": 1.0}
#: Default hold time [s] of ``steady:<speed>`` when no duration is given.
STEADY_DEFAULT_HOLD_S = 300.0


def _norm(name: str) -> str:
    return re.sub(r"[\s_\-.]+", "", name.strip().lower())


@dataclass(frozen=True, eq=False)
class Cycle:
    """A speed-versus-time trace that a driver model follows.

    Parameters
    ----------
    name : str
        Short name, e.g. ``"udds"`` or ``"steady_60kph_300s"``.
    time_s : numpy.ndarray
        Strictly increasing time [s].
    speed_mps : numpy.ndarray
        Target vehicle speed [m/s], non-negative, same length as ``time_s``.
    regulation : str
        The regulation that defines the cycle ("" for user traces).
    description : str
        One-line description.
    source : str
        Where the numbers come from (file, table, conversion).
    """

    name: str
    time_s: np.ndarray
    speed_mps: np.ndarray
    regulation: str = ""
    description: str = ""
    source: str = ""

    def __post_init__(self) -> None:
        object.__setattr__(self, "time_s", _frozen(self.time_s))
        object.__setattr__(self, "speed_mps", _frozen(self.speed_mps))

    # ------------------------------------------------------------------ constructors
    @classmethod
    def from_trace(cls, time_s: Any, speed_mps: Any, name: str, *, regulation: str = "",
                   description: str = "", source: str = "",
                   clip_negative_mps: float = 0.0) -> "Cycle":
        """Build a cycle from a measured or synthetic trace, after validating it.

        Parameters
        ----------
        time_s : array_like
            Time [s], strictly increasing, finite.
        speed_mps : array_like
            Speed [m/s], finite, non-negative.
        name : str
            Cycle name.
        clip_negative_mps : float, optional
            Negative speeds no lower than ``-clip_negative_mps`` [m/s] (sensor noise at
            standstill) are set to zero; lower ones are an error. Default 0: any negative
            speed is an error.

        Raises
        ------
        VehvalError
            If the arrays differ in length, have fewer than two samples, contain NaN,
            time does not strictly increase or the speed is negative.
        """
        t = np.asarray(time_s, dtype=float).ravel()
        v = np.asarray(speed_mps, dtype=float).ravel()
        _validate(t, v, f"cycle '{name}'")
        if clip_negative_mps > 0:
            v = np.where((v < 0) & (v >= -clip_negative_mps), 0.0, v)
        bad = np.flatnonzero(v < 0)
        if bad.size:
            raise VehvalError(
                f"cycle '{name}': speed is negative ({v[bad[0]]:.4g} m/s) at t = {t[bad[0]]:g} s "
                f"(sample {bad[0]}, {bad.size} negative samples): a cycle speed must be >= 0; "
                "pass clip_negative_mps to zero small sensor noise")
        return cls(name, t, v, regulation=regulation, description=description, source=source)

    # ------------------------------------------------------------------ figures
    @property
    def duration_s(self) -> float:
        """Duration from first to last sample [s]."""
        return float(self.time_s[-1] - self.time_s[0])

    @property
    def distance_m(self) -> float:
        """Distance driven, trapezoidal integration of the speed [m]."""
        return integral(self.time_s, self.speed_mps)

    @property
    def max_speed_mps(self) -> float:
        """Top speed [m/s]."""
        return float(self.speed_mps.max())

    @property
    def mean_speed_mps(self) -> float:
        """Mean speed over the whole duration, stops included [m/s]."""
        d = self.duration_s
        return self.distance_m / d if d > 0 else 0.0

    @property
    def acceleration_mps2(self) -> np.ndarray:
        """Acceleration at each sample, central differences [m/s^2]."""
        return np.gradient(self.speed_mps, self.time_s)

    def speed_at(self, t: float | np.ndarray) -> float | np.ndarray:
        """Target speed at time ``t`` [m/s], linear between samples, held beyond the ends."""
        out = np.interp(t, self.time_s, self.speed_mps)
        return float(out) if np.ndim(out) == 0 else out

    def resampled(self, dt: float) -> "Cycle":
        """Return the cycle on a uniform grid of step ``dt`` [s] (linear interpolation).

        The grid starts at the first sample and ends at the last one whenever ``dt``
        divides the duration; otherwise it stops at the last grid point before the end.
        """
        if not (dt > 0 and math.isfinite(dt)):
            raise VehvalError(f"cycle '{self.name}': resampling step must be > 0 s, got {dt!r}")
        n = int(math.floor(self.duration_s / dt + 1e-9)) + 1
        grid = np.arange(n, dtype=float)
        grid *= dt
        grid += self.time_s[0]
        speed = np.interp(grid, self.time_s, self.speed_mps)
        grid.setflags(write=False)
        speed.setflags(write=False)
        return replace(self, time_s=grid, speed_mps=speed)

    def summary(self) -> dict[str, Any]:
        """Figures for listings: duration [s], distance [km], max and mean speed [km/h]."""
        dt = np.diff(self.time_s)
        return {
            "name": self.name,
            "regulation": self.regulation,
            "description": self.description,
            "source": self.source,
            "samples": int(self.time_s.size),
            "dt_s": float(np.median(dt)) if dt.size else 0.0,
            "duration_s": round(self.duration_s, 3),
            "distance_km": round(self.distance_m / 1000.0, 4),
            "max_speed_kph": round(self.max_speed_mps * 3.6, 2),
            "mean_speed_kph": round(self.mean_speed_mps * 3.6, 2),
            "idle_fraction": round(float(np.mean(self.speed_mps <= 0.0)), 4),
        }

    def __len__(self) -> int:
        return int(self.time_s.size)


def _frozen(values: Any) -> np.ndarray:
    """A read-only float copy of ``values`` (no copy if it already is one and owns its data)."""
    if (isinstance(values, np.ndarray) and values.dtype == np.float64 and values.base is None
            and not values.flags.writeable):
        return values
    arr = np.array(values, dtype=float)
    arr.setflags(write=False)
    return arr


#: Longest drive cycle accepted [s]: a day (a longer time base is a unit or file error).
MAX_CYCLE_S = 86_400.0


def _validate(t: np.ndarray, v: np.ndarray, label: str,
              lines: np.ndarray | None = None) -> None:
    """Check shape, finiteness and monotonic time; ``lines`` maps samples to file lines."""
    def where(i: int) -> str:
        return f" (line {int(lines[i])})" if lines is not None else f" (sample {i})"

    if t.ndim != 1 or v.ndim != 1 or t.size != v.size:
        raise VehvalError(f"{label}: time ({t.size} values) and speed ({v.size} values) "
                          "must be 1-D arrays of the same length")
    if t.size < 2:
        raise VehvalError(f"{label}: a cycle needs at least two samples, got {t.size}")
    for arr, what in ((t, "time"), (v, "speed")):
        bad = np.flatnonzero(~np.isfinite(arr))
        if bad.size:
            raise VehvalError(f"{label}: {what} is not a finite number{where(bad[0])}")
    if t[-1] - t[0] > MAX_CYCLE_S:
        raise VehvalError(f"{label}: the cycle spans {t[-1] - t[0]:.4g} s; a drive cycle longer "
                          f"than {MAX_CYCLE_S / 3600:.0f} h is not supported (check the time "
                          "column and its unit)")
    back = np.flatnonzero(np.diff(t) <= 0)
    if back.size:
        i = back[0] + 1
        raise VehvalError(f"{label}: time does not increase at t = {t[i]:g} s{where(i)} "
                          f"(previous {t[i - 1]:g} s): cycle time must be strictly increasing")


def _schedule_top_speed() -> float:
    """The registry's plausible top of ``veh_spd_target`` [m/s] (read when a cycle is made
    from a file or a steady spec: listing the shipped cycles needs numpy only)."""
    from vehval.nomenclature import registry

    return registry()["veh_spd_target"].range[1]


def _plausible_speed(t: np.ndarray | None, v: np.ndarray, label: str,
                     lines: np.ndarray | None = None) -> None:
    """Refuse a drive-schedule speed above the registry's plausible range of
    ``veh_spd_target`` (a file's speed unit mistaken, a steady speed typed in the wrong unit);
    a measured trace driven as a cycle is not held to it (QA flags its range)."""
    top = _schedule_top_speed()
    fast = np.flatnonzero(v > top)
    if fast.size:
        i = fast[0]
        at = (f" at t = {t[i]:g} s" if t is not None else "") + (
            f" (line {int(lines[i])})" if lines is not None else "")
        raise VehvalError(f"{label}: speed {v[i]:.4g} m/s ({v[i] / KMH_M_PER_S:.4g} km/h){at} "
                          f"is above the plausible {top:g} m/s of a drive-schedule speed: "
                          "check the speed and its unit")


# ---------------------------------------------------------------------- file parsing
def _column_unit(header: str) -> tuple[str, str | None]:
    """Name and unit of a header: ``Speed[mph]``, ``Speed (kph)``, ``speed_mps``, ``time_s``."""
    name, unit = split_header(header.strip().strip('"'))
    if unit is None:
        m = re.match(r"^(?P<n>.*?)[_ ](?P<u>s|sec|secs|mps|kph|kmh|mph)$", name, re.IGNORECASE)
        if m:
            name, unit = m.group("n"), m.group("u")
    return name.strip(), unit


def _parse_csv(text: str, label: str, *, user_file: bool = True
               ) -> tuple[dict[str, str], np.ndarray, np.ndarray]:
    """Parse a cycle text file -> (metadata, time [s], speed [m/s]).

    Comment lines ``# key: value`` before the header are metadata; the first other line is
    the header; the body is parsed by numpy, and only when that fails is it re-read line by
    line to name the faulty line.
    """
    meta: dict[str, str] = {}
    lines = text.splitlines()
    header_idx = None
    for i, raw in enumerate(lines):
        line = raw.strip().lstrip("\ufeff")
        if not line:
            continue
        if line.startswith("#"):
            m = re.match(r"#\s*([A-Za-z_]+)\s*:\s*(.*)$", line)
            if m:
                meta[m.group(1).lower()] = m.group(2).strip()
            continue
        header_idx = i
        break
    if header_idx is None:
        raise InputFileError(f"{label}: no header line found: the file needs a header such as "
                             "'time_s,speed_mps' or 'Time[s],Speed[mph]'")
    header_line = header_idx + 1
    head = lines[header_idx].strip().lstrip("\ufeff")
    delim = next((d for d in (",", "\t", ";") if d in head), ",")
    header = [f.strip() for f in head.split(delim)]
    it, iv, t_unit, v_unit = _pick_columns(header, label, header_line)
    try:
        t_scale, t_off = conversion(t_unit, "s")
        v_scale, v_off = conversion(v_unit, "m/s")
    except UnitError as exc:
        raise InputFileError(f"{label}: line {header_line}: {exc}") from None
    body = lines[header_idx + 1:]
    data = [(k, raw) for k, raw in enumerate(body, header_idx + 2)
            if raw.strip() and not raw.lstrip().startswith("#")]
    if not data:
        raise InputFileError(f"{label}: no data rows after the header on line {header_line}")
    ragged = next((k for k, raw in data if raw.count(delim) != len(header) - 1), None)
    if ragged is not None:
        n = body[ragged - header_idx - 2].count(delim) + 1
        raise InputFileError(f"{label}: line {ragged}: {n} fields, the header has "
                             f"{len(header)}: fix or remove the line")
    try:
        arr = np.loadtxt(body, delimiter=delim, comments="#", usecols=(it, iv), ndmin=2,
                         dtype=float)
        linenos = None
    except (ValueError, IndexError):
        arr, linenos = _parse_rows_slowly(body, header_idx + 2, delim, it, iv, header, label)
    if arr.shape[0] == 0:
        raise InputFileError(f"{label}: no data rows after the header on line {header_line}")
    t = arr[:, 0] * t_scale + t_off
    v = arr[:, 1] * v_scale + v_off
    neg = np.flatnonzero(v < 0)
    try:
        _validate(t, v, label)
    except VehvalError:
        linenos = _data_line_numbers(body, header_idx + 2) if linenos is None else linenos
        _validate(t, v, label, linenos)  # raises again, now naming the file line
    if neg.size:
        if linenos is None:
            linenos = _data_line_numbers(body, header_idx + 2)
        raise InputFileError(f"{label}: line {int(linenos[neg[0]])}: negative speed "
                             f"{arr[neg[0], 1]:g}: a cycle speed must be >= 0")
    if user_file and np.any(v > _schedule_top_speed()):  # a shipped schedule is known
        _plausible_speed(t, v, label, _data_line_numbers(body, header_idx + 2)
                         if linenos is None else linenos)
    return meta, t, v


def _data_line_numbers(body: list[str], first: int) -> np.ndarray:
    """1-based file line numbers of the data rows of ``body`` (blank/comment lines skipped)."""
    return np.array([first + k for k, raw in enumerate(body)
                     if raw.strip() and not raw.lstrip().startswith("#")], dtype=int)


def _parse_rows_slowly(body: list[str], first: int, delim: str, it: int, iv: int,
                       header: list[str], label: str) -> tuple[np.ndarray, np.ndarray]:
    """Line-by-line parse used when numpy rejects the body: names the faulty line."""
    rows: list[tuple[float, float]] = []
    linenos: list[int] = []
    for k, raw in enumerate(body):
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        fields = [f.strip() for f in line.split(delim)]
        try:
            rows.append((float(fields[it]), float(fields[iv])))
        except (ValueError, IndexError):
            raise InputFileError(
                f"{label}: line {first + k}: expected numbers in columns "
                f"'{header[it]}' and '{header[iv]}', got {line[:60]!r}") from None
        linenos.append(first + k)
    return np.asarray(rows, dtype=float).reshape(-1, 2), np.asarray(linenos, dtype=int)


def _pick_columns(header: list[str], label: str, lineno: int) -> tuple[int, int, str, str]:
    parsed = [_column_unit(h) for h in header]
    it = iv = None
    for i, (n, _) in enumerate(parsed):
        low = n.lower()
        if it is None and (low in ("t", "sec", "secs", "seconds", "cycsecs") or "time" in low):
            it = i
        elif iv is None and (low in ("v", "cycmps")
                             or any(k in low for k in ("speed", "spd", "velocity", "vel"))):
            iv = i
    if it is None or iv is None:
        raise InputFileError(
            f"{label}: line {lineno}: cannot find a time and a speed column in header "
            f"{header!r}: name them e.g. 'time_s,speed_mps' or 'Time[s],Speed[mph]'")
    t_unit = parsed[it][1] or "s"
    v_unit = parsed[iv][1]
    if v_unit is None:
        if parsed[iv][0].lower() == "cycmps":
            v_unit = "m/s"
        else:
            raise InputFileError(
                f"{label}: line {lineno}: speed column '{header[iv]}' has no unit: write it "
                "as 'speed[mph]', 'speed[km/h]' or 'speed_mps'")
    return it, iv, t_unit, v_unit


# ---------------------------------------------------------------------- package cycles
def _data_dir():
    return resources.files("vehval") / "data" / "cycles"


def list_cycles() -> list[str]:
    """Names of the drive cycles shipped with the package, sorted."""
    return list(_package_names())


@lru_cache(maxsize=1)
def _package_names() -> tuple[str, ...]:
    return tuple(sorted(p.name[:-4] for p in _data_dir().iterdir() if p.name.endswith(".csv")))


@lru_cache(maxsize=64)
def _load_package(name: str) -> Cycle:
    res = _data_dir() / f"{name}.csv"
    meta, t, v = _parse_csv(res.read_text(encoding="utf-8"), f"package cycle {name}.csv",
                            user_file=False)
    return Cycle(meta.get("name", name), t, v, regulation=meta.get("regulation", ""),
                 description=meta.get("description", ""), source=meta.get("source", ""))


# ---------------------------------------------------------------- regulatory parts
#: A regulatory part of a cycle: (part name, start, end) in cycle time [s].
Part = tuple[str, float, float]


@lru_cache(maxsize=1)
def _parts_table() -> dict[str, tuple[str, tuple[Part, ...]]]:
    """``data/cycles/parts.yaml``: cycle -> (rule, parts), read once."""
    from vehval.safe_yaml import read_yaml

    raw = read_yaml(_data_dir() / "parts.yaml")
    return {name: (str(e["rule"]), tuple((str(p), float(a), float(b)) for p, a, b in e["parts"]))
            for name, e in raw.items()}


def _parts_key(name: str) -> str:
    """Package cycle of ``name`` (alias, case, ``_x2`` repeats and ``_measured`` removed)."""
    base = _norm(re.sub(r"(_x\d+)?(_measured)?$", "", name.strip().lower()))
    return ALIASES.get(base, base)


def cycles_with_parts() -> list[str]:
    """Package cycles whose regulatory parts (emission bags) the part table defines."""
    return list(_parts_table())


def cycle_parts(name: str) -> list[Part]:
    """Regulatory parts of a package cycle, in time order: [(part, start, end)] [s].

    The one table of phase (bag) boundaries, ``vehval/data/cycles/parts.yaml``, kept beside
    the traces; [] for a cycle without standard parts. ``name`` may be an alias or carry
    a repeat / origin suffix (``us06_x2``, ``udds_measured``).

    >>> cycle_parts("us06")
    [('city', 0.0, 130.0), ('highway', 130.0, 495.0), ('city', 495.0, 600.0)]
    """
    entry = _parts_table().get(_parts_key(name))
    return list(entry[1]) if entry else []


def part_rule(name: str) -> str:
    """Where the parts of cycle ``name`` come from (regulation and boundaries); "" if none."""
    entry = _parts_table().get(_parts_key(name))
    return entry[0] if entry else ""


def part_boundary_s(name: str, part: str, end: bool = True) -> float:
    """End (or start) [s] of the first segment of ``part`` in cycle ``name``.

    Raises
    ------
    KeyError
        If the table has no such cycle or part.
    """
    for p, a, b in cycle_parts(name):
        if p == part:
            return b if end else a
    raise KeyError(f"cycle {name!r} has no part {part!r} in data/cycles/parts.yaml")


def load_cycle(name_or_path: str | Path | Cycle) -> Cycle:
    """Load a drive cycle by package name, alias, steady-run spec or file path.

    Parameters
    ----------
    name_or_path : str, Path or Cycle
        - a package cycle name or alias, case-insensitive: ``"udds"``, ``"FTP-75"``,
          ``"hwy"``, ``"10-15"``, ``"japan10-15"``, ``"wltc"``...;
        - a steady run ``"steady:60kph:300s"`` (speed in kph, km/h, mph or mps; hold time
          in s or min, default 300 s), see :func:`steady_cycle`;
        - a path to a CSV/TSV file with a time and a speed column whose header carries the
          unit: ``time_s,speed_mps``, ``Time[s],Speed[mph]``, ``Time (s),Speed (kph)``;
          ``# key: value`` comment lines before the header give name/regulation/description;
        - a :class:`Cycle`, returned unchanged.

    Returns
    -------
    Cycle

    Raises
    ------
    VehvalError
        If the name is unknown (the message lists the known names) or the file is invalid
        (the message names the file and line).
    """
    if isinstance(name_or_path, Cycle):
        return name_or_path
    text = str(name_or_path).strip()
    m = _STEADY.match(text)
    if m:
        speed = float(m.group("v")) * _SPEED_UNITS[m.group("vu").lower()]
        hold = float(m.group("d")) if m.group("d") else STEADY_DEFAULT_HOLD_S
        if (m.group("du") or "s").lower() == "min":
            hold *= 60.0
        return steady_cycle(speed, hold)
    path = Path(text)
    looks_like_path = (isinstance(name_or_path, Path) or path.suffix.lower() in
                       (".csv", ".txt", ".tsv", ".dat") or "/" in text or "\\" in text)
    if looks_like_path:
        if path.is_dir():
            raise InputFileError(f"cycle file {path}: is a directory: give a CSV file of time "
                                 "and speed (e.g. 'time_s,speed_mps') or a cycle name")
        if not path.is_file():
            raise InputFileError(f"cycle file {path} not found; known cycle names: "
                                 f"{', '.join(list_cycles())}")
        try:
            raw = path.read_bytes()
            content = raw.decode("utf-16") if raw[:2] in (b"\xff\xfe", b"\xfe\xff") \
                else raw.decode("utf-8-sig")
        except (OSError, UnicodeDecodeError) as exc:
            raise InputFileError(f"cycle file {path}: cannot read it as text: {exc}") from None
        meta, t, v = _parse_csv(content, f"cycle file {path}")
        return Cycle(meta.get("name", path.stem), t, v, regulation=meta.get("regulation", ""),
                     description=meta.get("description", ""),
                     source=meta.get("source", f"file {path.name}"))
    key = ALIASES.get(_norm(text), _norm(text))
    if key not in _package_names():
        raise VehvalError(
            f"unknown drive cycle '{text}': known cycles are {', '.join(list_cycles())} "
            "(aliases such as ftp-75, hwy, 10-15, wltc are accepted), 'steady:60kph:300s', "
            "or a path to a CSV file with time and speed columns")
    return _load_package(key)


def steady_cycle(speed_mps: float, duration_s: float, ramp_mps2: float = 1.0) -> Cycle:
    """A steady-speed run: ramp up from rest, hold, ramp down to rest.

    Parameters
    ----------
    speed_mps : float
        Hold speed [m/s], >= 0.
    duration_s : float
        Time held at ``speed_mps`` [s], >= 0. The total duration is
        ``duration_s + 2 * speed_mps / ramp_mps2``.
    ramp_mps2 : float, optional
        Acceleration of both ramps [m/s^2], > 0. Default 1.0.

    Returns
    -------
    Cycle
        Named ``steady_<kph>kph_<hold>s``, sampled at 1 Hz plus the ramp corners, so its
        trapezoidal distance is exact: ``speed * duration + speed**2 / ramp``.
    """
    if not (speed_mps >= 0 and math.isfinite(speed_mps)):
        raise VehvalError(f"steady cycle: speed must be >= 0 m/s, got {speed_mps!r}")
    if not (duration_s >= 0 and math.isfinite(duration_s)):
        raise VehvalError(f"steady cycle: hold duration must be >= 0 s, got {duration_s!r}")
    if not (ramp_mps2 > 0 and math.isfinite(ramp_mps2)):
        raise VehvalError(f"steady cycle: ramp must be > 0 m/s^2, got {ramp_mps2!r}")
    _plausible_speed(None, np.array([float(speed_mps)]), "steady cycle")
    t_ramp = speed_mps / ramp_mps2
    if duration_s + 2 * t_ramp > MAX_CYCLE_S:
        raise VehvalError(f"steady cycle: {duration_s + 2 * t_ramp:.4g} s long; a drive cycle "
                          f"longer than {MAX_CYCLE_S / 3600:.0f} h is not supported")
    corners = np.array([0.0, t_ramp, t_ramp + duration_s, 2 * t_ramp + duration_s])
    total = corners[-1]
    if total <= 0:
        raise VehvalError("steady cycle: speed and hold duration are both zero: nothing to drive")
    grid = np.union1d(np.arange(0.0, total, 1.0), corners)
    grid = grid[np.concatenate([[True], np.diff(grid) > 1e-9])]
    speed = np.interp(grid, corners, [0.0, speed_mps, speed_mps, 0.0])
    name = f"steady_{round(speed_mps * 3.6, 1):g}kph_{round(duration_s, 1):g}s"
    return Cycle(name, grid, speed, regulation="",
                 description=f"steady {speed_mps * 3.6:.4g} km/h for {duration_s:g} s with "
                             f"{ramp_mps2:g} m/s^2 ramps",
                 source="generated by vehval.cycles.steady_cycle")
