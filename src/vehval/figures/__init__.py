"""The figure layer: every plotly figure vehval draws is built here, as a plain figure dict.

``{"data": [...], "layout": {...}}`` specifications: the report embeds them, the workbench
sends them to the page (whose script only draws them), the identification, sensitivity and
control-strategy pages use them. The rules held here: one axis per unit (each trace keeps
its display unit as ``meta.unit`` where the caller gives it), stacked channels on one linked
time axis (:func:`time_traces_figure`), display units chosen by the caller through
:mod:`vehval.display`. No other module builds a plotly layout (``tests/test_owner_figures.py``).
"""

from __future__ import annotations

from typing import Any, Mapping, Sequence

import numpy as np

from vehval.figures.decimate import DEFAULT_BUCKETS, decimate_minmax

PALETTE = ("#1f5fa8", "#d9480f", "#2b8a3e", "#7048e8", "#c2255c", "#0b7285", "#e67700",
           "#495057")
ROW_HEIGHT_PX = 170

__all__ = ["PALETTE", "ROW_HEIGHT_PX", "bar_figure", "histogram_figure", "layout_figure",
           "markers_figure", "one_axis_figure", "scatter_fit_figure", "scatter_groups_figure", "time_traces_figure"]


def time_traces_figure(panels: Sequence[dict], *, n_buckets: int = DEFAULT_BUCKETS,
                       row_height: int = ROW_HEIGHT_PX) -> dict:
    """Stacked time-trace panels on one shared time axis.

    Parameters
    ----------
    panels : sequence of dict
        Each panel: ``ylabel`` (str), ``traces`` (list of dicts with ``name``, ``t`` [s],
        ``y``, optional ``color``, ``dash``, ``width``, ``unit`` (the display unit, kept as
        the trace's ``meta.unit``)), optional ``band`` ``(lo, hi)`` drawn
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
                **({"meta": {"unit": tr["unit"]}} if "unit" in tr else {}),
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


def one_axis_figure(traces: Sequence[dict], *, unit: str, ylabel: str,
                    xlabel: str = "time [s]", n_buckets: int = DEFAULT_BUCKETS) -> dict:
    """Traces of one quantity in one display unit on one axis (an overlay of tests).

    ``traces``: dicts with ``name``, ``t`` [s], ``y`` (already in ``unit``), optional
    ``color``, ``dash``; each keeps ``meta.unit`` (one unit per axis, checked by the tests).
    ``n_buckets``: min/max decimation beyond twice that many samples (0: as given, for
    traces a caller already cut to a window).
    """
    data = []
    for j, tr in enumerate(traces):
        t, y = np.asarray(tr["t"], float), np.asarray(tr["y"], float)
        if n_buckets and t.size > 2 * n_buckets:
            t, y = decimate_minmax(t, y, n_buckets)
        data.append({"type": "scatter", "mode": "lines", "name": tr["name"], "x": t, "y": y,
                     "line": {"color": tr.get("color", PALETTE[j % len(PALETTE)]), "width": 1.3,
                              "dash": tr.get("dash", "solid")},
                     "hovertemplate": "%{y:.4g}", "meta": {"unit": unit}})
    layout = {"height": 380, "margin": {"l": 70, "r": 20, "t": 40, "b": 45},
              "hovermode": "x unified", "showlegend": True,
              "xaxis": {"title": {"text": xlabel}},
              "yaxis": {"title": {"text": f"{ylabel} [{unit}]" if unit else ylabel}},
              "meta": {"units": [unit]}}
    return {"data": data, "layout": layout}


def bar_figure(series: Sequence[dict], *, xlabel: str, ylabel: str = "", title: str = "",
               horizontal: bool = False, stacked: bool = False, overlay: bool = False,
               height: int | None = None, margin: dict | None = None) -> dict:
    """Bars of one or more series on one pair of axes (a histogram by category, a ranked
    tornado). ``series``: dicts with ``name``, ``x``, ``y`` (categories on y when
    ``horizontal``), optional ``color``."""
    data = []
    for j, s in enumerate(series):
        tr: dict[str, Any] = {"type": "bar", "x": list(s["x"]), "y": list(s["y"]),
                              "marker": {"color": s.get("color", PALETTE[j % len(PALETTE)])}}
        if s.get("name"):
            tr["name"] = s["name"]
        if horizontal:
            tr["orientation"] = "h"
        data.append(tr)
    layout: dict[str, Any] = {"xaxis": {"title": {"text": xlabel}},
                              "yaxis": {"title": {"text": ylabel}},
                              "margin": margin or {"l": 70, "r": 20, "t": 40, "b": 50}}
    if title:
        layout["title"] = {"text": title}
    if stacked or overlay:
        layout["barmode"] = "stack" if stacked else "overlay"
    if height:
        layout["height"] = int(height)
    return {"data": data, "layout": layout}


def markers_figure(series: Sequence[dict], *, xlabel: str, ylabel: str, title: str = "",
                   height: int | None = None) -> dict:
    """Points and curves on one pair of axes (operating points with a fitted map).

    ``series``: dicts with ``name``, ``x``, ``y``, ``mode`` (``markers`` or ``lines``),
    optional ``color`` (a colour, or an array coloured on ``colorscale`` with a colour bar
    titled ``color_title``), ``size``, ``opacity``.
    """
    data = []
    for j, s in enumerate(series):
        mode = s.get("mode", "markers")
        color = s.get("color", PALETTE[j % len(PALETTE)])
        tr: dict[str, Any] = {"type": "scatter", "mode": mode, "name": s.get("name", ""),
                              "x": np.asarray(s["x"], float), "y": np.asarray(s["y"], float)}
        if mode == "markers":
            marker: dict[str, Any] = {"size": s.get("size", 4), "opacity": s.get("opacity", 0.6),
                                      "color": color}
            if not isinstance(color, str):
                marker.update(colorscale="Viridis", color=np.asarray(color, float),
                              colorbar={"title": {"text": s.get("color_title", "")}})
            tr["marker"] = marker
        else:
            tr["line"] = {"color": color, "width": s.get("width", 1.5)}
        data.append(tr)
    layout: dict[str, Any] = {"xaxis": {"title": {"text": xlabel}},
                              "yaxis": {"title": {"text": ylabel}},
                              "margin": {"l": 70, "r": 20, "t": 40, "b": 50}}
    if title:
        layout["title"] = {"text": title}
    if height:
        layout["height"] = int(height)
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


def layout_figure(data: Sequence[dict], *, xlabel: str | None = None, ylabel: str | None = None,
                  title: str | None = None, height: int | None = None,
                  margin: dict | None = None, legend: dict | None = None,
                  barmode: str | None = None, categories: Sequence[str] | None = None) -> dict:
    """Traces a page built (plotly trace dicts: markers with error bars, timelines, bubbles)
    on one pair of axes: axis titles, ``title``, ``height`` [px], ``margin``, ``legend``,
    ``barmode`` and the category order of the y axis (``categories``, top last)."""
    layout: dict[str, Any] = {}
    if title:
        layout["title"] = {"text": title}
    if height:
        layout["height"] = int(height)
    if barmode:
        layout["barmode"] = barmode
    if margin:
        layout["margin"] = dict(margin)
    if xlabel is not None:
        layout["xaxis"] = {"title": {"text": xlabel}}
    if ylabel is not None or categories is not None:
        yaxis: dict[str, Any] = {"title": {"text": ylabel}} if ylabel is not None else {}
        if categories is not None:
            yaxis.update(categoryorder="array", categoryarray=list(categories))
        layout["yaxis"] = yaxis
    if legend:
        layout["legend"] = dict(legend)
    return {"data": list(data), "layout": layout}
