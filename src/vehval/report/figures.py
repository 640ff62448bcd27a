"""The report's figures: :class:`FigSpec`, the builders of the figure layer
(:mod:`vehval.figures`, re-exported here) and the JSON encoding.

Figures are plain plotly JSON dicts (``{"data": [...], "layout": {...}}``). Numeric arrays
are encoded as plotly typed arrays (``{"dtype": "f4", "bdata": <base64>}``), which plotly.js
decodes natively: a 15,000-sample trace costs 4 bytes a sample instead of ~18 characters.
"""

from __future__ import annotations

import base64
import json
from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np

from vehval.figures import (
    PALETTE,
    ROW_HEIGHT_PX,
    histogram_figure,
    one_axis_figure,
    scatter_fit_figure,
    scatter_groups_figure,
    time_traces_figure,
)
from vehval.figures.decimate import decimate_minmax
from vehval.report.safety import safe_figure
from vehval.report.tables import slug

DEFAULT_FIG_HEIGHT_PX = 450
#: A trace drawn as SVG keeps at most this many points; a longer one (a WebGL trace of a
#: payload, which pages draw as SVG: see :func:`vehval.report.safety.safe_figure`) is
#: thinned (min/max decimation of a line over increasing x, an even stride otherwise).
MAX_SVG_POINTS = 20_000
#: Per-point arrays thinned with x and y.
_POINT_KEYS = ("text", "hovertext", "customdata", "ids")


@dataclass
class FigSpec:
    """One figure of the report.

    Attributes
    ----------
    title : str
        Caption.
    figure : dict
        plotly figure JSON (``data`` and ``layout``); numpy arrays allowed.
    linked : bool
        True for time traces whose x axis follows the other linked traces.
    note : str
        Optional explanation under the figure.
    """

    title: str
    figure: dict
    linked: bool = False
    note: str = ""
    key: str = ""
    height: int = field(default=0)
    json: str = ""


def typed_array(a: np.ndarray) -> dict | list:
    """plotly.js typed-array spec for a numeric array (float64 kept where float32 loses)."""
    a = np.asarray(a)
    if a.dtype.kind == "b":
        a = a.astype(np.uint8)
    if a.dtype.kind in "iu":
        a = a.astype(np.int32)
    elif a.dtype.kind == "f":
        a = a.astype(np.float64)
        finite = a[np.isfinite(a)]
        # float32 keeps 7 significant digits: enough for display unless the values sit on a
        # large offset (e.g. absolute timestamps), where float64 is kept.
        span = float(np.ptp(finite)) if finite.size else 0.0
        big = float(np.max(np.abs(finite))) if finite.size else 0.0
        if big == 0.0 or span == 0.0 or big / span < 1e3:
            a = a.astype(np.float32)
    else:
        return a.tolist()
    dtype = {np.dtype(np.float32): "f4", np.dtype(np.float64): "f8", np.dtype(np.int32): "i4",
             np.dtype(np.uint8): "u1"}[a.dtype]
    return {"dtype": dtype, "bdata": base64.b64encode(np.ascontiguousarray(a).tobytes()).decode("ascii")}


def _default(obj: Any) -> Any:
    if isinstance(obj, np.ndarray):
        if obj.ndim == 1 and obj.dtype.kind in "fiub":
            return typed_array(obj)
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    if hasattr(obj, "to_plotly_json"):
        return obj.to_plotly_json()
    raise TypeError(f"cannot encode {type(obj).__name__} in a figure")


def _clean(obj: Any) -> Any:
    """Replace non-finite Python floats by None (JSON has no NaN); arrays are left to the encoder."""
    if isinstance(obj, float):
        return obj if np.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: _clean(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_clean(v) for v in obj]
    if isinstance(obj, np.ndarray) and obj.dtype == object:
        return [_clean(v) for v in obj.tolist()]
    return obj


def _thin(trace: dict) -> dict:
    """``trace`` with at most :data:`MAX_SVG_POINTS` points (see there)."""
    x, y = trace.get("x"), trace.get("y")
    if not isinstance(x, (list, tuple, np.ndarray)) or not isinstance(y, (list, tuple, np.ndarray)):
        return trace
    n = len(x)
    if n <= MAX_SVG_POINTS or len(y) != n:
        return trace
    out = dict(trace)
    xa = np.asarray(x, dtype=float)
    ya = np.asarray([np.nan if v is None else v for v in y], dtype=float)
    per_point = [k for k in _POINT_KEYS if isinstance(trace.get(k), (list, tuple, np.ndarray))]
    if "lines" in str(trace.get("mode", "lines")) and not per_point \
            and bool(np.all(np.diff(xa) >= 0)):
        out["x"], out["y"] = decimate_minmax(xa, ya, MAX_SVG_POINTS // 2)
        return out
    step = -(-n // MAX_SVG_POINTS)
    out["x"], out["y"] = xa[::step], ya[::step]
    for k in per_point:
        if len(trace[k]) == n:
            out[k] = list(trace[k])[::step]
    return out


#: A numeric list this long or longer in a trace's ``x``/``y``/``z`` is sent as a typed array.
TYPED_MIN_LEN = 64


def _typed_lists(trace: dict) -> dict:
    """``trace`` with its long all-numeric ``x``/``y``/``z`` lists as numpy arrays (encoded
    as typed arrays; a None becomes NaN, which plotly.js draws as a gap as it does None)."""
    out = None
    for k in ("x", "y", "z"):
        v = trace.get(k)
        if not isinstance(v, (list, tuple)) or len(v) < TYPED_MIN_LEN:
            continue
        if not all(e is None or (isinstance(e, (int, float, np.number)) and not isinstance(e, bool))
                   for e in v):
            continue
        out = dict(trace) if out is None else out
        out[k] = np.array([np.nan if e is None else e for e in v], dtype=float)
    return trace if out is None else out


def figure_json(fig: Any) -> str:
    """Compact JSON of a figure (dict or plotly Figure), safe to embed in a ``<script>``.

    The figure is sanitised first (:func:`vehval.report.safety.safe_figure`): nothing in it
    can load a resource or link out of the report.

    The per-figure ``layout.template`` is dropped: the page applies one shared template.
    """
    if hasattr(fig, "to_plotly_json"):
        fig = fig.to_plotly_json()
    fig = dict(fig)
    layout = dict(fig.get("layout") or {})
    layout.pop("template", None)
    fig["layout"] = layout
    fig = safe_figure(fig)
    fig["data"] = [_typed_lists(_thin(t) if t.get("type", "scatter") == "scatter" else t)
                   for t in fig["data"]]
    text = json.dumps(_clean(fig), default=_default, separators=(",", ":"), allow_nan=False)
    return text.replace("</", "<\\/").replace("<!--", "<\\!--")


def prepare_figures(figures: Sequence[FigSpec], start: int = 0) -> int:
    """Give every figure of a page its element id, height [px] and embedded JSON.

    Parameters
    ----------
    figures : sequence of FigSpec
        Figures in page order; ``key`` (unless given), ``height`` and ``json`` are set
        in place.
    start : int
        Figures already numbered on the page.

    Returns
    -------
    int
        Figures numbered on the page so far.
    """
    n = start
    for f in figures:
        n += 1
        f.key = f.key or f"fig-{n}-{slug(f.title)[:40]}"
        fig = f.figure.to_plotly_json() if hasattr(f.figure, "to_plotly_json") else dict(f.figure)
        layout = dict(fig.get("layout") or {})
        # an explicit height: the plot div has no height of its own to autosize into
        f.height = int(layout.get("height") or DEFAULT_FIG_HEIGHT_PX)
        layout["height"] = f.height
        fig["layout"] = layout
        f.json = figure_json(fig)
    return n


__all__ = ["DEFAULT_FIG_HEIGHT_PX", "PALETTE", "ROW_HEIGHT_PX", "FigSpec", "figure_json", "histogram_figure",
           "one_axis_figure", "prepare_figures", "scatter_fit_figure", "scatter_groups_figure", "time_traces_figure",
           "typed_array"]
