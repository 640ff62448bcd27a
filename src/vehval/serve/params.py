"""Requests of the workbench's API as typed models: query parameters and JSON bodies.

Every request is parsed by a pydantic model before anything runs; a bad one is answered
4xx with one line naming the parameter or key (:class:`BadRequest`). A body is bounded in
size (:data:`MAX_BODY_BYTES`) and nesting depth (:data:`MAX_DEPTH`) before it is parsed.
"""

from __future__ import annotations

import json
import re
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

from vehval.errors import VehvalError
from vehval.serve.series import MAX_POINTS

#: Largest request body read [bytes] (a template edit of every channel is a few kB).
MAX_BODY_BYTES = 1 << 20
#: largest report page [bytes] the workbench rewrites and serves (a report with its plots is
#: a few MiB; other files are streamed whatever their size)
MAX_PAGE_BYTES = 64 << 20
#: Deepest nesting of a body's arrays and objects (an edit nests 3 deep).
MAX_DEPTH = 32
#: Longest text of one query parameter or body string [characters].
MAX_TEXT = 4096
#: Largest ``n`` (points of one trace) a request may ask for.
MAX_N = 20_000
_STRING = re.compile(rb'"(?:[^"\\]|\\.)*"', re.DOTALL)
_BRACKET = re.compile(rb"[\[\]{}]")
_OF_MODEL = re.compile(r" or instance of \w+")


class BadRequest(VehvalError):
    """A request the API refuses before running anything (its HTTP status in ``status``)."""

    def __init__(self, message: str, status: int = 400) -> None:
        super().__init__(message)
        self.status = status


# ------------------------------------------------------------------ query parameters
class _Query(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, str_max_length=MAX_TEXT,
                              frozen=True)


class DirQuery(_Query):
    """``dir``: a test folder, relative to the workspace (default: the workspace); ``test``:
    one test of a folder of many (its id, the data file's name without extension)."""

    dir: str = "."
    test: str | None = Field(None, min_length=1, max_length=200)


class _Window(DirQuery):
    """A plot window ``t0..t1`` [s] (finite; whole trace when absent) and ``n`` points."""

    t0: float | None = None
    t1: float | None = None
    n: int = Field(MAX_POINTS, ge=10, le=MAX_N)

    @field_validator("t0", "t1", mode="before")
    @classmethod
    def _empty_is_none(cls, v: Any) -> Any:
        return None if v in ("", "null") else v

    @model_validator(mode="after")
    def _ordered(self) -> _Window:
        if self.t0 is not None and self.t1 is not None and self.t0 > self.t1:
            raise ValueError(f"t0 ({self.t0:g} s) is after t1 ({self.t1:g} s)")
        return self


class ChannelQuery(_Window):
    """``/api/channel``: one raw channel (``raw``) of one data file (``file``)."""

    file: str = Field(min_length=1)
    raw: str = Field(min_length=1)


class SignalQuery(_Window):
    """``/api/signal``: one imported signal (``name``) of a test whose QA has run."""

    name: str = Field(min_length=1)


class FindingQuery(DirQuery):
    """``/api/finding``: the figure of the test's finding number ``i`` (page order)."""

    i: int = Field(ge=0, le=100_000)


class CatalogQuery(_Query):
    """``/api/catalog``: a catalog (``db``) and the filters of its tests."""

    db: str = Field(min_length=1)
    vehicle: str | None = None
    cycle: str | None = None
    status: str | None = None
    start: str | None = None
    fuel: str | None = None


class TraceQuery(_Query):
    """``/api/catalog/trace``: one quantity ``q`` of one test of a catalog."""

    db: str = Field(min_length=1)
    test: str = Field(min_length=1)
    q: str = "speed"
    n: int = Field(MAX_POINTS, ge=10, le=MAX_N)
    axis: Literal["time", "phase"] = "time"


class OverlayQuery(_Query):
    """``/api/catalog/overlay``: one quantity ``q`` of the catalog tests ``tests`` (comma
    separated test ids) on one axis."""

    db: str = Field(min_length=1)
    tests: str = Field(min_length=1)
    q: str = "speed"
    n: int = Field(MAX_POINTS, ge=10, le=MAX_N)
    axis: Literal["time", "phase"] = "time"

    def ids(self) -> list[str]:
        """The test ids (at most 50, duplicates once)."""
        out: list[str] = []
        for t in self.tests.split(","):
            if t.strip() and t.strip() not in out:
                out.append(t.strip())
        return out[:50]


# ------------------------------------------------------------------ bodies
class _Body(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True, allow_inf_nan=False,
                              str_max_length=MAX_TEXT)


class NoBody(_Body):
    """A POST that takes no parameters (``{}``)."""


class ChannelEdit(_Body):
    """One channel edit: only the keys given change (``None`` or ``""`` removes the key)."""

    file: int = Field(ge=0, le=10_000)
    raw: str = Field(min_length=1)
    name: str | None = None
    unit: str | None = None
    reason: str | None = None
    delete: bool | None = None


class TemplateEdits(_Body):
    """``POST /api/template``: channel edits, file source tags (``{file index: tag}``), the
    fuel, ``vehicle`` and ``vehicle_name`` (``""`` or ``null`` leaves each out of the template;
    absent: unchanged) and ``constants`` (test mass, road-load A, B, C)."""

    channels: list[ChannelEdit] = Field(default_factory=list, max_length=10_000)
    sources: dict[str, str] = Field(default_factory=dict, max_length=10_000)
    fuel: str | None = None
    #: the vehicle model (a shipped name or a vehicle file) and the tested car's name
    vehicle: str | None = None
    vehicle_name: str | None = None
    #: test mass and road-load constants (``{key: value or null}``; null removes the key)
    constants: dict[Literal["test_mass_kg", "road_load_a_n", "road_load_b_n_per_mps",
                            "road_load_c_n_per_mps2"], float | None] = Field(default_factory=dict)

    def edits(self) -> dict:
        """The edits as :meth:`vehval.serve.bench.Bench.save_edits` takes them (only the
        keys the page sent)."""
        return self.model_dump(exclude_unset=True)


class Decision(_Body):
    """``POST /api/selection``: keep or drop a signal, or clear the user's decision."""

    signal: str = Field(min_length=1)
    action: Literal["keep", "drop", "clear"]
    reason: str = ""


# ------------------------------------------------------------------ parsing
def _messages(exc: ValidationError, where: str) -> str:
    from vehval.io.template import format_loc

    out = []
    for err in exc.errors()[:3]:
        loc = format_loc(tuple(err["loc"])) if err.get("loc") else ""
        kind = err.get("type", "")
        msg = ("unknown key" if kind == "extra_forbidden" else
               "required" if kind == "missing" else
               _OF_MODEL.sub("", str(err.get("msg", "invalid")).removeprefix("Value error, ")))
        out.append(f"{loc}: {msg}" if loc else msg)
    more = len(exc.errors()) - len(out)
    return f"bad {where}: " + "; ".join(out) + (f" (and {more} more)" if more > 0 else "")


def parse_query(model: type[BaseModel], items: list[tuple[str, str]]) -> Any:
    """The query parameters ``items`` as ``model`` (``token`` is the guard's, not the API's).

    Raises
    ------
    BadRequest
        A parameter given twice, unknown, missing, of the wrong type or out of range.
    """
    data: dict[str, str] = {}
    for key, value in items:
        if key == "token":
            continue
        if key in data:
            raise BadRequest(f"bad query: {key[:40]}: given twice")
        data[key] = value
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        raise BadRequest(_messages(exc, "query")) from None


def check_depth(raw: bytes, most: int = MAX_DEPTH) -> None:
    """Refuse a JSON text nesting arrays and objects deeper than ``most`` (before parsing)."""
    depth = 0
    for m in _BRACKET.finditer(_STRING.sub(b'""', raw)):
        depth += 1 if m.group() in (b"[", b"{") else -1
        if depth > most:
            raise BadRequest(f"the request body nests deeper than {most} levels: refused")


def parse_body(model: type[BaseModel], raw: bytes) -> Any:
    """A JSON request body (at most :data:`MAX_BODY_BYTES`, :data:`MAX_DEPTH` deep) as
    ``model``; an empty body is ``{}``.

    Raises
    ------
    BadRequest
        Too large (413), too deep, not JSON, not an object, or not what ``model`` expects.
    """
    if len(raw) > MAX_BODY_BYTES:
        raise BadRequest(f"the request body is over {MAX_BODY_BYTES:,} bytes: refused", 413)
    check_depth(raw)
    try:
        data = json.loads(raw) if raw.strip() else {}
    except (ValueError, RecursionError):
        raise BadRequest("the request body is not JSON") from None
    if not isinstance(data, dict):
        raise BadRequest(f"the request body must be a JSON object, not {type(data).__name__}")
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        raise BadRequest(_messages(exc, "request body")) from None
