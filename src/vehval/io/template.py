"""Import templates: how the channels of each raw file become standard SI signals.

A template is YAML validated by pydantic models that reject unknown keys. Errors name the
file and the key path (``T.yaml: files[0].channels.Engine_Speed.unti: unknown key (did you
mean 'unit'?)``). See docs/templates.md for the schema and the init/check/import workflow.
"""

from __future__ import annotations

import difflib
import re
import typing
from collections.abc import Mapping
from pathlib import Path
from typing import Any, Literal

import yaml
from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    NonNegativeFloat,
    PositiveFloat,
    PrivateAttr,
    ValidationError,
    field_validator,
    model_validator,
)

from vehval.errors import ConfigError
from vehval.io.atomic import write_text_atomic
from vehval.io.template_semantics import semantic_errors
from vehval.safe_yaml import read_yaml

__all__ = [
    "AccuracySpec",
    "ChannelSpec",
    "Constants",
    "FileSpec",
    "FuelSpec",
    "ReadOptions",
    "Selection",
    "Template",
    "TimeSpec",
    "format_loc",
    "load_template",
    "semantic_errors",
]


#: Longest free text accepted in a template (description, reasons) [characters].
MAX_TEXT = 20_000

#: A raw file format a template may name (``auto``: by extension, then content).
FileFormat = Literal["auto", "d3", "csv", "mdf4", "parquet"]


class _Strict(BaseModel):
    # strict: a number must be written as a number ('scale: yes' is YAML's true, not 1.0)
    model_config = ConfigDict(extra="forbid", validate_assignment=True, allow_inf_nan=False,
                              strict=True)


#: Sample rates a template may declare [Hz] (also the QA plausibility bound of a time base).
RATE_HZ_RANGE = (1e-3, 1e5)


class TimeSpec(_Strict):
    """Where the time of a file comes from.

    Attributes
    ----------
    column : str, optional
        Raw name of the time column (without unit); detected when omitted.
    unit : str
        Unit of the time column (default ``s``).
    rate_hz : float, optional
        Sample rate [Hz] for files without a time column: ``t = start_s + i / rate_hz``;
        1e-3 to 1e5 Hz (:data:`RATE_HZ_RANGE`: a sample every 17 min to a 100 kHz DAQ;
        beyond, ``i / rate_hz`` loses the time base or underflows to no time at all).
    start_s : float
        Time of the first row [s] when ``rate_hz`` is used.
    """

    column: str | None = None
    unit: str = "s"
    rate_hz: float | None = None
    start_s: float = Field(default=0.0, ge=-1e9, le=1e9)

    @field_validator("rate_hz")
    @classmethod
    def _rate_bounded(cls, v: float | None) -> float | None:
        lo, hi = RATE_HZ_RANGE
        if v is not None and not lo <= v <= hi:
            raise ValueError(f"{v:g} Hz is outside {lo:g} to {hi:g} Hz (one sample every "
                             "17 min to a 100 kHz DAQ): give the file's real sample rate")
        return v

    @model_validator(mode="after")
    def _one_source(self) -> TimeSpec:
        if self.column is not None and self.rate_hz is not None:
            raise ValueError("give either 'column' or 'rate_hz', not both")
        return self


#: Magnitude range of a channel's ``scale`` and the largest ``offset`` [SI units].
MIN_SCALE, MAX_SCALE = 1e-9, 1e9


class ChannelSpec(_Strict):
    """One raw channel: its standard name and raw unit, or its deletion.

    Attributes
    ----------
    name : str
        Full standard name, e.g. ``veh_spd_test``.
    unit : str, optional
        Raw unit (pint expression or header spelling); the header unit when omitted.
    scale, offset : float
        Applied after the SI conversion: ``si = to_si(raw) * scale + offset``.
    invalid_values : list of float
        Raw sentinel values replaced by NaN (e.g. ``-327.68``).
    delete : bool
        Drop the channel (recorded in ``meta.deleted`` with ``reason``).
    reason : str, optional
        Why the channel is deleted.
    """

    name: str | None = None
    unit: str | None = None
    scale: float = 1.0
    offset: float = 0.0
    invalid_values: list[float] = Field(default_factory=list)
    delete: bool = False
    reason: str | None = Field(default=None, max_length=MAX_TEXT)

    @model_validator(mode="after")
    def _named(self) -> ChannelSpec:
        # a unit factor beyond 1e9 (or below 1e-9) is a typing error, and 1e308 overflows the
        # samples to inf; an offset beyond 1e9 SI units is no physical zero shift
        if self.scale == 0.0 or not (MIN_SCALE <= abs(self.scale) <= MAX_SCALE):
            raise ValueError(f"scale {self.scale:g} is outside [{MIN_SCALE:g}, {MAX_SCALE:g}] "
                             "in magnitude (and not 0): give the unit in 'unit' and a plain factor")
        if abs(self.offset) > MAX_SCALE:
            raise ValueError(f"offset {self.offset:g} is beyond +-{MAX_SCALE:g} SI units: "
                             "give the offset in the signal's SI unit")
        if not self.delete and not self.name:
            raise ValueError("give the standard 'name' or set 'delete: true' with a 'reason'")
        return self


class ReadOptions(_Strict):
    """Reader options for text files (all detected when omitted)."""

    delimiter: str | None = None
    decimal: Literal[".", ","] | None = None
    encoding: str | None = None


#: A cycle name: what a template's ``cycle`` and ``vehval batch --cycle`` accept.
CYCLE_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.:+\-]{0,63}")


def _cycle_name_error(v: str) -> str:
    return (f"'{v[:80]}' is not a cycle name: use up to 64 letters, digits and _ . : + - "
            "(e.g. udds, hwfet_x2, steady_60kph)")


def check_cycle_name(v: str, where: str = "cycle") -> str:
    """``v`` when it is a valid cycle name, else a :class:`ConfigError` naming ``where``."""
    if not CYCLE_NAME.fullmatch(v):
        raise ConfigError(f"{where}: {_cycle_name_error(v)}")
    return v


class FileSpec(_Strict):
    """One acquisition system / raw file of a test."""

    match: str | None = None
    optional: bool = False
    source: str = Field(pattern=r"^[a-z][a-z0-9]*$")
    format: FileFormat = "auto"
    time: TimeSpec = Field(default_factory=TimeSpec)
    options: ReadOptions = Field(default_factory=ReadOptions)
    channels: dict[str, ChannelSpec] = Field(default_factory=dict)


class Constants(_Strict):
    """Test constants in SI; the unit is in the key name."""

    test_mass_kg: PositiveFloat | None = None
    road_load_a_n: float | None = None
    road_load_b_n_per_mps: float | None = None
    road_load_c_n_per_mps2: float | None = None
    fuel_density_kg_per_m3: float | None = Field(default=None, gt=0, le=2_000)
    fuel_lhv_j_per_kg: float | None = Field(default=None, ge=5e6, le=1.5e8)  # methanol to H2
    wheel_radius_m: PositiveFloat | None = None
    final_drive_ratio: PositiveFloat | None = None
    inertia_fraction: float | None = None
    soc_correction_fuel_j_per_battery_j: PositiveFloat | None = None
    #: AC energy measured at the wall recharging the battery after a battery-electric test
    #: [J] (SAE J1634 recharge energy): the whole test's AC figures use it instead of DC
    #: energy / charger efficiency.
    ac_recharge_energy_j: PositiveFloat | None = None


class Selection(_Strict):
    """Signal selection: names forced kept, and dropped names with their reason."""

    keep: list[str] = Field(default_factory=list)
    drop: dict[str, str] = Field(default_factory=dict)


class FuelSpec(_Strict):
    """Explicit fuel properties (or a table ``name`` whose values the explicit ones override).

    Attributes
    ----------
    name : str, optional
        A fuel of the packaged table (``vehval/data/fuels.yaml``).
    density_kg_per_m3 : float, optional
        Density [kg/m^3].
    lhv_j_per_kg : float, optional
        Lower heating value [J/kg].
    carbon_mass_fraction : float, optional
        Carbon mass per fuel mass, 0 < x <= 1 [-].
    """

    name: str | None = None
    density_kg_per_m3: float | None = Field(default=None, gt=0, le=2_000)
    lhv_j_per_kg: float | None = Field(default=None, ge=5e6, le=1.5e8)  # methanol to H2
    carbon_mass_fraction: float | None = Field(default=None, gt=0.0, le=1.0)


class AccuracySpec(_Strict):
    """Declared accuracy of one channel: a limit of error held over the test.

    Attributes
    ----------
    reading_pct : float
        Error limit proportional to the reading [% of reading].
    full_scale_pct : float
        Error limit as a share of ``full_scale`` [% of full scale].
    full_scale : float, optional
        Full scale of the instrument, in ``unit``.
    offset : float
        Zero-offset error limit, in ``unit``.
    unit : str, optional
        Unit of ``full_scale`` and ``offset`` (default: the signal's SI unit).
    """

    reading_pct: NonNegativeFloat = 0.0
    full_scale_pct: NonNegativeFloat = 0.0
    full_scale: NonNegativeFloat | None = None
    offset: NonNegativeFloat = 0.0
    unit: str | None = None

    @model_validator(mode="after")
    def _scale_given(self) -> AccuracySpec:
        if self.full_scale_pct and self.full_scale is None:
            raise ValueError("'full_scale_pct' needs 'full_scale' (in 'unit')")
        return self


class Template(_Strict):
    """An import template (schema version 1).

    Attributes
    ----------
    vehicle : str, optional
        Vehicle file (name or path) for limits and parameters.
    vehicle_name : str, optional
        What was tested (make, model, year), for the catalog and the batch index when no
        vehicle file is given (a conventional car has none until ``vehval identify``).
    cycle : str, optional
        Drive cycle of every test imported with this template (for templates dedicated to
        one cycle); when omitted the importer identifies the cycle from the vehicle speed.
    synthetic : bool
        The files are virtual-dyno output (``vehval synth``), not measurements: sets
        ``Test.meta.synthetic`` so reports show the virtual-test banner.
    fuel : str or FuelSpec, optional
        The test fuel: a name of the fuel table (``diesel``, ``gasoline_e10``...) or explicit
        properties. Without it, no volume-based result (mpg, L/100 km) is given.
    accuracy : dict
        Standard signal name -> :class:`AccuracySpec`; signals without one get the documented
        default of their class, flagged as assumed (docs/results.md).
    phase_channel : str, optional
        Standard name of the signal holding the test phase (bag) number; default
        ``test_phase_test`` when the template maps it.
    architecture : str, optional
        Powertrain architecture of the tested car (``power_split``, ``conventional``,
        ``battery_electric``): a ``battery_electric`` template maps no engine or fuel
        channel, declares no fuel and maps the battery voltage and current (or power).
    """

    template_version: Literal[1] = 1
    vehicle: str | None = None
    architecture: str | None = None
    vehicle_name: str | None = Field(default=None, max_length=MAX_TEXT)
    cycle: str | None = None
    synthetic: bool = False
    description: str = Field(default="", max_length=MAX_TEXT)
    constants: Constants = Field(default_factory=Constants)
    files: list[FileSpec] = Field(min_length=1)
    selection: Selection = Field(default_factory=Selection)
    fuel: str | FuelSpec | None = None
    accuracy: dict[str, AccuracySpec] = Field(default_factory=dict)
    phase_channel: str | None = None
    _path: Path | None = PrivateAttr(default=None)
    _todo: list[str] = PrivateAttr(default_factory=list)

    @field_validator("cycle")
    @classmethod
    def _cycle_name(cls, v: str | None) -> str | None:
        if v is not None and not CYCLE_NAME.fullmatch(v):
            raise ValueError(_cycle_name_error(v) + ", or leave 'cycle' out to have the cycle "
                             "identified from the vehicle speed")
        return v

    @property
    def path(self) -> Path | None:
        """File the template was loaded from (``None`` when built in memory)."""
        return self._path

    @property
    def todo(self) -> list[str]:
        """Things :func:`propose_template` could not decide (units to fill in...)."""
        return self._todo

    def constants_dict(self) -> dict[str, float]:
        """Constants that are set, as ``{key: value}`` in SI."""
        return {k: float(v) for k, v in self.constants.model_dump().items() if v is not None}

    def to_yaml(self) -> str:
        """YAML text of the template (defaults left out, one flow mapping per channel)."""
        data = self.model_dump(mode="json", exclude_defaults=True)
        out: dict[str, Any] = {"template_version": 1}
        for key in ("vehicle", "vehicle_name", "architecture", "cycle", "synthetic", "description", "fuel", "phase_channel",
                    "constants", "accuracy", "files", "selection"):
            if key in data:
                out[key] = data[key]
        for f in out.get("files", []):
            f["channels"] = {k: _Flow(v) for k, v in f.get("channels", {}).items()}
            if "time" in f:
                f["time"] = _Flow(f["time"])
        if "accuracy" in out:
            out["accuracy"] = {k: _Flow(v) for k, v in out["accuracy"].items()}
        return yaml.dump(out, Dumper=_Dumper, sort_keys=False, allow_unicode=True, width=100)

    def mapped_names(self) -> set[str]:
        """Standard names the template's channels map to (deleted channels left out)."""
        return {ch.name for f in self.files for ch in f.channels.values()
                if not ch.delete and ch.name}

    def save(self, path: str | Path, *, placeholders: bool = False) -> Path:
        """Write the template as YAML, atomically.

        With ``placeholders``, keys the user should fill in and the template leaves out
        (``fuel:``) are written as commented lines saying what to put there.
        """
        path = Path(path)
        text = self.to_yaml()
        if placeholders and self.fuel is None:
            from vehval.fuels import known_fuels
            text = ("# fuel: declare the test fuel, e.g. 'fuel: diesel' (known: "
                    f"{', '.join(known_fuels())}),\n"
                    "# or 'fuel: {density_kg_per_m3: ..., lhv_j_per_kg: ..., carbon_mass_fraction: ...}'.\n"
                    "# Without it no volume-based result (mpg, L/100 km) is given.\n"
                    "# fuel: diesel\n") + text
        write_text_atomic(path, text)
        return path


class _Flow(dict):
    """A mapping dumped in YAML flow style: ``{name: veh_spd_test, unit: mph}``."""


class _Dumper(yaml.SafeDumper):
    pass


_Dumper.add_representer(_Flow, lambda d, v: d.represent_mapping(
    "tag:yaml.org,2002:map", dict(v), flow_style=True))


# --------------------------------------------------------------------------- loading


def format_loc(loc: tuple) -> str:
    """``('files', 0, 'channels', 'X', 'unti')`` -> ``files[0].channels.X.unti``."""
    out = ""
    for part in loc:
        if isinstance(part, int):
            out += f"[{part}]"
        else:
            out += ("." if out else "") + str(part)
    return out or "(top level)"


def _unwrap(tp: Any) -> Any:
    """Strip Optional/list/dict wrappers down to a model class (or None)."""
    while True:
        origin = typing.get_origin(tp)
        if origin is None:
            return tp
        args = [a for a in typing.get_args(tp) if a is not type(None)]
        if not args:
            return None
        tp = args[-1]


def _model_at(loc: tuple) -> type[BaseModel] | None:
    """Model class that owns the key at ``loc`` (``loc`` without the key itself)."""
    cur: Any = Template
    for part in loc:
        if isinstance(cur, type) and issubclass(cur, BaseModel) and part in cur.model_fields:
            cur = cur.model_fields[part].annotation
            origin = typing.get_origin(cur)
            if origin in (list, dict) or _unwrap(cur) is not cur:
                cur = ("container", _unwrap(cur))
            continue
        if isinstance(cur, tuple) and cur[0] == "container":
            cur = cur[1]
            continue
        return None
    if isinstance(cur, tuple):
        cur = cur[1]
    return cur if isinstance(cur, type) and issubclass(cur, BaseModel) else None


def _message(err: Mapping[str, Any]) -> str:
    loc = tuple(err.get("loc", ()))
    kind = err.get("type", "")
    if kind == "extra_forbidden":
        key = str(loc[-1])
        model = _model_at(loc[:-1])
        allowed = list(model.model_fields) if model else []
        close = difflib.get_close_matches(key, allowed, n=1, cutoff=0.6)
        hint = f" (did you mean '{close[0]}'?)" if close else (
            f" (allowed: {', '.join(allowed)})" if allowed else "")
        return f"{format_loc(loc)}: unknown key{hint}"
    if kind == "missing":
        return f"{format_loc(loc)}: required key missing"
    if kind in ("float_type", "int_type") and "input" in err:
        got = err["input"]
        hint = (" (YAML reads yes/no/on/off/true/false as a boolean)"
                if isinstance(got, bool) else "")
        return f"{format_loc(loc)}: must be a number, not {str(got)[:40]!r}{hint}"
    msg = str(err.get("msg", "invalid"))
    msg = msg.removeprefix("Value error, ")
    return f"{format_loc(loc)}: {msg}"


def template_from_data(data: dict, label: str) -> Template:
    """A template model from parsed YAML data, every problem named after ``label`` (the
    file name) on its own line, as :func:`load_template` reports them.

    Raises
    ------
    ConfigError
        Unknown or misspelled key, bad value, unknown signal name or unit.
    """
    try:
        t = Template.model_validate(data)
    except ValidationError as exc:
        msgs = [_message(e) for e in exc.errors()]
        raise ConfigError(f"{label}: " + f"\n  {label}: ".join(msgs)) from None
    problems = semantic_errors(t)
    if problems:
        raise ConfigError(f"{label}: " + f"\n  {label}: ".join(problems))
    return t


def load_template(path: str | Path) -> Template:
    """Load and validate a template file.

    Raises
    ------
    ConfigError
        Missing file, YAML syntax error (with line), unknown or misspelled key (with the key
        path and a did-you-mean), bad value, unknown signal name or unit (naming the channel).
    """
    path = Path(path)
    if not path.exists():
        raise ConfigError(f"{path}: template file not found")
    if path.is_dir():
        raise ConfigError(f"{path}: is a directory, a template YAML file is expected")
    data = read_yaml(path)
    if not isinstance(data, dict):
        raise ConfigError(f"{path}: a template must be a YAML mapping with 'files:' "
                          "(see docs/templates.md)")
    t = template_from_data(data, path.name)
    t._path = path
    return t


def as_template(template: Template | str | Path) -> Template:
    """A :class:`Template` from an instance or a path (validated either way)."""
    if isinstance(template, Template):
        problems = semantic_errors(template)
        if problems:
            raise ConfigError("template: " + "\n  template: ".join(problems))
        return template
    return load_template(template)

