"""What a report may load: a Content-Security-Policy and figure sanitising.

A report is opened from disk, often from a shared drive, and its figures may come from JSON
files written by other tools (``validation.json``, ``control.json``). The page must never
reach the network: the policy below allows scripts and styles inline (the report embeds
plotly.js) or from local files (a batch shares one plotly.js beside its reports), images
only as ``data:``/``blob:`` URLs, and no connection, frame, form or base URL at all. Figures
are sanitised before embedding: trace types that fetch map tiles or topology from a CDN are
dropped, layout images must be ``data:`` URLs, and links, images and CSS ``url()`` are
removed from every text.
"""

from __future__ import annotations

import re
from typing import Any

#: The policy of every HTML page vehval writes (see the module docstring).
CSP = ("default-src 'none'; script-src 'unsafe-inline' 'unsafe-eval' file: blob:; "
       "style-src 'unsafe-inline'; img-src data: blob:; font-src data:; worker-src blob:; "
       "connect-src 'none'; media-src 'none'; object-src 'none'; frame-src 'none'; "
       "form-action 'none'; base-uri 'none'")

#: ``<meta>`` element carrying :data:`CSP`, first in every ``<head>``.
CSP_META = f'<meta http-equiv="Content-Security-Policy" content="{CSP}">'

#: Trace types a report may draw (none of them loads anything).
SAFE_TRACES = frozenset({
    "scatter", "scattergl", "bar", "barpolar", "box", "violin", "histogram", "histogram2d",
    "histogram2dcontour", "heatmap", "contour", "sankey", "pie", "table", "parcoords",
    "parcats", "scatterpolar", "scatterpolargl", "scatterternary", "waterfall", "funnel",
    "indicator", "surface", "mesh3d", "scatter3d", "splom", "carpet", "contourcarpet",
    "scattercarpet", "icicle", "sunburst", "treemap", "candlestick", "ohlc"})

_MAP_LAYOUT = re.compile(r"^(geo|mapbox|map)\d*$")
_LINK_TAG = re.compile(r"</?\s*(a|img|image|iframe|script|link|object|embed)\b[^>]*>", re.I)
_CSS_URL = re.compile(r"url\s*\(", re.I)
_URL = re.compile(r"\b(https?|ftp|file|javascript):", re.I)


def safe_text(s: str) -> str:
    """Text with links, images, scripts and CSS ``url()`` removed (plotly renders a subset
    of HTML in texts: ``<a href>`` would be a link out of the report)."""
    s = _LINK_TAG.sub("", s)
    s = _CSS_URL.sub("url_(", s)
    return _URL.sub(lambda m: m.group(1) + "\u2236", s)  # "http∶//..." stays readable, inert


def _clean(obj: Any) -> Any:
    if isinstance(obj, str):
        return safe_text(obj)
    if isinstance(obj, dict):
        return {k: _clean(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_clean(v) for v in obj]
    return obj  # numbers, arrays


def _data_url(x: Any) -> bool:
    return isinstance(x, str) and x.startswith("data:image/")


def safe_figure(fig: dict) -> dict:
    """A copy of the plotly figure dict with nothing in it that could load a resource."""
    data = [t for t in fig.get("data") or []
            if isinstance(t, dict) and t.get("type", "scatter") in SAFE_TRACES]
    layout = {k: v for k, v in dict(fig.get("layout") or {}).items() if not _MAP_LAYOUT.match(k)}
    if "images" in layout:
        layout["images"] = [im for im in layout["images"] or []
                            if isinstance(im, dict) and _data_url(im.get("source"))]
    out = {k: v for k, v in fig.items() if k not in ("data", "layout", "frames")}
    out["data"], out["layout"] = _clean(data), _clean(layout)
    return out
