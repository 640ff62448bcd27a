"""Figure building blocks: decimated time traces, scatter-with-fit, and the JSON encoding.

Figures are plain plotly JSON dicts (``{"data": [...], "layout": {...}}``). Numeric arrays
are encoded as plotly typed arrays (``{"dtype": "f4", "bdata": <base64>}``), which plotly.js
decodes natively: a 15,000-sample trace costs 4 bytes a sample instead of ~18 characters.
"""

from __future__ import annotations

import base64
import json
from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

import numpy as np

from vehval.report.decimate import DEFAULT_BUCKETS, decimate_minmax
from vehval.report.safety import safe_figure
from vehval.report.tables import slug

PALETTE = ("#1f5fa8", "#d9480f", "#2b8a3e", "#7048e8", "#c2255c", "#0b7285", "#e67700",
           "#495057")
ROW_HEIGHT_PX = 170
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


def time_traces_figure(panels: Sequence[dict], *, n_buckets: int = DEFAULT_BUCKETS,
                       row_height: int = ROW_HEIGHT_PX) -> dict:
    """Stacked time-trace panels on one shared time axis.

    Parameters
    ----------
    panels : sequence of dict
        Each panel: ``ylabel`` (str), ``traces`` (list of dicts with ``name``, ``t`` [s],
        ``y``, optional ``color``, ``dash``, ``width``), optional ``band`` ``(lo, hi)`` drawn
        as a shaded plausible range, optional ``spans`` list of ``(t0, t1)`` [s] shaded red.
    n_buckets : int
        Min/max decimation buckets per trace.
    row_height : int
        Height of one panel [px].

    Returns
    -------
    dict
        plotly figure JSON; all x axes match the first one (zooming one zooms all).
    """
    n = max(len(panels), 1)
    gap = 0.035 if n > 1 else 0.0
    h = (1.0 - gap * (n - 1)) / n
    data: list[dict] = []
    layout: dict[str, Any] = {
        "height": int(row_height * n + 70), "margin": {"l": 70, "r": 20, "t": 30, "b": 40},
        "hovermode": "x unified", "showlegend": True,
        "shapes": [],
    }
    for i, panel in enumerate(panels):
        ax = "" if i == 0 else str(i + 1)
        top = 1.0 - i * (h + gap)
        xa: dict[str, Any] = {"anchor": f"y{ax}", "showticklabels": i == n - 1, "showspikes": True,
                              "spikemode": "across", "spikethickness": 1}
        if i:
            xa["matches"] = "x"
        if i == n - 1:
            xa["title"] = {"text": "time [s]"}
        layout[f"xaxis{ax}"] = xa
        layout[f"yaxis{ax}"] = {"domain": [max(top - h, 0.0), top], "anchor": f"x{ax}",
                                "title": {"text": panel.get("ylabel", ""), "font": {"size": 11}}}
        lo, hi = np.inf, -np.inf
        for j, tr in enumerate(panel.get("traces", [])):
            t, y = decimate_minmax(tr["t"], tr["y"], n_buckets)
            if np.isfinite(y).any():
                lo, hi = min(lo, float(np.nanmin(y))), max(hi, float(np.nanmax(y)))
            data.append({
                "type": "scatter", "mode": "lines", "name": tr["name"], "x": t, "y": y,
                "xaxis": f"x{ax}", "yaxis": f"y{ax}", "connectgaps": False,
                "line": {"color": tr.get("color", PALETTE[j % len(PALETTE)]),
                         "width": tr.get("width", 1.3), "dash": tr.get("dash", "solid")},
                "legend": f"legend{ax}", "hovertemplate": "%{y:.4g}",
            })
        layout[f"legend{ax}"] = {"x": 1.0, "xanchor": "right", "y": top, "yanchor": "bottom" if i == 0 else "top",
                                 "orientation": "h", "bgcolor": "rgba(255,255,255,0.75)",
                                 "font": {"size": 11}}
        band = panel.get("band")
        if np.isfinite(lo):
            # y range from the data; a range-band edge is included when it is close enough
            # to matter (the data crosses it or comes within a quarter of its span)
            span = max(hi - lo, abs(hi) * 1e-3, 1e-9)
            ylo, yhi = lo, hi
            if band is not None and all(np.isfinite(band)):
                if band[0] >= lo - 0.25 * span:
                    ylo = min(ylo, float(band[0]))
                if band[1] <= hi + 0.25 * span:
                    yhi = max(yhi, float(band[1]))
            pad = 0.06 * max(yhi - ylo, span)
            layout[f"yaxis{ax}"]["range"] = [ylo - pad, yhi + pad]
        if band is not None and all(np.isfinite(band)):
            layout["shapes"].append({
                "type": "rect", "xref": f"x{ax} domain", "yref": f"y{ax}", "x0": 0, "x1": 1,
                "y0": float(band[0]), "y1": float(band[1]), "fillcolor": "rgba(43,138,62,0.08)",
                "line": {"width": 1, "color": "rgba(43,138,62,0.5)", "dash": "dot"}, "layer": "below"})
        for t0, t1 in panel.get("spans", [])[:300]:
            if t1 <= t0:
                t0, t1 = t0 - 0.5, t1 + 0.5
            layout["shapes"].append({
                "type": "rect", "xref": f"x{ax}", "yref": f"y{ax} domain", "x0": float(t0),
                "x1": float(t1), "y0": 0, "y1": 1, "fillcolor": "rgba(224,49,49,0.18)",
                "line": {"width": 0}, "layer": "below"})
    return {"data": data, "layout": layout}


def scatter_fit_figure(x: np.ndarray, y: np.ndarray, *, xlabel: str, ylabel: str,
                       slope: float | None, intercept: float | None, r2: float | None,
                       max_points: int = 2500) -> dict:
    """Correlation scatter of two signals on a common grid with the 1:1 line and a fit.

    Parameters
    ----------
    x, y : numpy.ndarray
        Paired samples (NaN pairs are dropped).
    xlabel, ylabel : str
        Axis titles (name and unit).
    slope, intercept : float or None
        Fit ``y = slope * x + intercept`` as stated by QA; fitted here by least squares
        when absent.
    r2 : float or None
        Coefficient of determination to show in the legend (computed when absent).
    max_points : int
        Points drawn (evenly strided subset, extremes of both axes always included).
    """
    ok = np.isfinite(x) & np.isfinite(y)
    x, y = np.asarray(x, float)[ok], np.asarray(y, float)[ok]
    data: list[dict] = []
    if x.size:
        if slope is None or intercept is None:
            if x.size >= 2 and np.ptp(x) > 0:
                slope, intercept = (float(v) for v in np.polyfit(x, y, 1))
        if r2 is None and x.size >= 2 and np.std(x) > 0 and np.std(y) > 0:
            r2 = float(np.corrcoef(x, y)[0, 1] ** 2)
        idx = np.arange(x.size)
        if x.size > max_points:
            idx = np.unique(np.r_[np.linspace(0, x.size - 1, max_points).astype(int),
                                  np.argmin(x), np.argmax(x), np.argmin(y), np.argmax(y)])
        data.append({"type": "scatter", "mode": "markers", "name": "samples", "x": x[idx], "y": y[idx],
                     "marker": {"size": 4, "color": PALETTE[0], "opacity": 0.45}})
        lo, hi = float(min(x.min(), y.min())), float(max(x.max(), y.max()))
        data.append({"type": "scatter", "mode": "lines", "name": "1:1", "x": [lo, hi], "y": [lo, hi],
                     "line": {"color": "#868e96", "dash": "dot", "width": 1}})
        if slope is not None and intercept is not None:
            xs = np.array([x.min(), x.max()])
            label = f"fit y = {slope:.4g}·x {'+' if intercept >= 0 else '−'} {abs(intercept):.4g}"
            if r2 is not None:
                label += f" (R² = {r2:.4f})"
            data.append({"type": "scatter", "mode": "lines", "name": label, "x": xs,
                         "y": slope * xs + intercept, "line": {"color": PALETTE[1], "width": 2}})
    layout = {"height": 380, "margin": {"l": 70, "r": 20, "t": 30, "b": 50},
              "xaxis": {"title": {"text": xlabel}}, "yaxis": {"title": {"text": ylabel}},
              "legend": {"x": 0.01, "y": 0.99, "bgcolor": "rgba(255,255,255,0.7)"}}
    return {"data": data, "layout": layout}


def histogram_figure(groups: dict[str, Sequence[float]], *, xlabel: str,
                     bin_size: float | None = None, scale: float = 1.0) -> dict:
    """Overlaid histograms, one per group (name -> values, times ``scale``), bars of
    ``bin_size`` (in scaled units; plotly's choice when None)."""
    data = []
    for k, (name, vals) in enumerate(groups.items()):
        v = np.asarray(vals, float) * scale
        trace: dict[str, Any] = {"type": "histogram", "name": f"{name} (n = {v.size})",
                                 "x": v[np.isfinite(v)], "opacity": 0.6,
                                 "marker": {"color": PALETTE[k % len(PALETTE)]}}
        if bin_size:
            trace["xbins"] = {"size": bin_size}
        data.append(trace)
    layout = {"height": 360, "barmode": "overlay", "margin": {"l": 60, "r": 20, "t": 30, "b": 50},
              "xaxis": {"title": {"text": xlabel}}, "yaxis": {"title": {"text": "rows"}}}
    return {"data": data, "layout": layout}


def scatter_groups_figure(groups: Mapping[str, tuple[Sequence[float], Sequence[float],
                                                     Sequence[str]]],
                          *, xlabel: str, ylabel: str, hlines: Sequence[float] = ()) -> dict:
    """Markers per group (name -> (x, y, hover text)) with dotted horizontal lines at
    ``hlines`` (e.g. the tolerance band)."""
    data = []
    for k, (name, (x, y, text)) in enumerate(groups.items()):
        data.append({"type": "scatter", "mode": "markers", "name": name,
                     "x": np.asarray(x, float), "y": np.asarray(y, float), "text": list(text),
                     "marker": {"size": 5, "color": PALETTE[k % len(PALETTE)], "opacity": 0.6}})
    shapes = [{"type": "line", "xref": "paper", "x0": 0, "x1": 1, "y0": h, "y1": h,
               "line": {"color": "#868e96", "dash": "dot", "width": 1}} for h in hlines]
    layout = {"height": 380, "margin": {"l": 70, "r": 20, "t": 30, "b": 50}, "shapes": shapes,
              "xaxis": {"title": {"text": xlabel}}, "yaxis": {"title": {"text": ylabel}}}
    return {"data": data, "layout": layout}
