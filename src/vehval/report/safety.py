"""What a page may load and run: the Content-Security-Policy and figure sanitising.

A page is opened from disk, often from a shared drive, and its text and figures come from
files written elsewhere (a downloaded EPA Test Car List, ``validation.json``,
``control.json``, raw-file channel names). Text reaches the page only through the
autoescaping templates of :mod:`vehval.report.page`; this module adds two more layers:

* the policy of every page (:func:`content_security_policy`): no network at all, scripts
  only when their exact text has a listed SHA-256 hash (the page's own scripts and the
  embedded plotly.js) or come from a local file (a batch shares one plotly.js beside its
  reports): no ``'unsafe-inline'``, no ``'unsafe-eval'`` for scripts, so markup that
  slipped into a page could not run. Styles keep ``'unsafe-inline'``: plotly.js sets
  ``style`` attributes and injects its own ``<style>`` element while drawing.
* figure sanitising (:func:`safe_figure`): trace types that fetch map tiles or topology from
  a CDN, or that need ``eval`` (plotly.js's WebGL ``regl`` traces), are dropped or drawn as
  SVG; layout images must be ``data:`` URLs; links, images and CSS ``url()`` are removed
  from every text (plotly.js renders a subset of HTML in its texts).
"""

from __future__ import annotations

import base64
import hashlib
import re
from typing import Any, Iterable

#: Directives of every page besides ``script-src``.
_OTHER_DIRECTIVES = ("style-src 'unsafe-inline'; img-src data: blob:; font-src data:; "
                     "worker-src 'none'; connect-src 'none'; media-src 'none'; "
                     "object-src 'none'; frame-src 'none'; form-action 'none'; base-uri 'none'")


def script_hash(text: str) -> str:
    """CSP source of an inline script: ``'sha256-<base64>'`` of its exact UTF-8 text."""
    digest = hashlib.sha256(text.encode("utf-8")).digest()
    return f"'sha256-{base64.b64encode(digest).decode('ascii')}'"


def content_security_policy(script_hashes: Iterable[str] = (), *,
                            local_scripts: bool = False) -> str:
    """The policy of a page (see the module docstring).

    Parameters
    ----------
    script_hashes : iterable of str
        :func:`script_hash` of every inline script of the page.
    local_scripts : bool
        True when the page loads plotly.js with ``<script src="relative/path">`` (adds
        ``file:``).

    Returns
    -------
    str
        ``script-src 'none'`` for a page without script.
    """
    sources = list(dict.fromkeys(script_hashes)) + (["file:"] if local_scripts else [])
    script = " ".join(sources) if sources else "'none'"
    return f"default-src 'none'; script-src {script}; {_OTHER_DIRECTIVES}"


#: The policy of a page without any script.
CSP = content_security_policy()

#: Trace types a page may draw: none of them loads anything or needs ``eval``.
SAFE_TRACES = frozenset({
    "scatter", "bar", "barpolar", "box", "violin", "histogram", "histogram2d",
    "histogram2dcontour", "heatmap", "contour", "sankey", "pie", "table", "parcats",
    "scatterpolar", "scatterternary", "waterfall", "funnel", "indicator", "surface", "mesh3d",
    "scatter3d", "carpet", "contourcarpet", "scattercarpet", "icicle", "sunburst", "treemap",
    "candlestick", "ohlc"})
#: WebGL traces drawn by plotly.js's ``regl`` (which compiles code with ``Function``) and
#: the SVG trace that shows the same data. ``splom`` and ``parcoords`` have none: dropped.
GL_TO_SVG = {"scattergl": "scatter", "scatterpolargl": "scatterpolar"}

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


def _svg_trace(t: dict) -> dict | None:
    """The trace itself, its SVG equivalent (a WebGL trace), or None (not drawable safely)."""
    kind = t.get("type", "scatter")
    if kind in GL_TO_SVG:
        return {**t, "type": GL_TO_SVG[kind]}
    return t if kind in SAFE_TRACES else None


def safe_figure(fig: dict) -> dict:
    """A copy of the plotly figure dict with nothing in it that could load a resource or
    need ``eval``."""
    data = [s for s in (_svg_trace(t) for t in fig.get("data") or [] if isinstance(t, dict))
            if s is not None]
    layout = {k: v for k, v in dict(fig.get("layout") or {}).items() if not _MAP_LAYOUT.match(k)}
    if "images" in layout:
        layout["images"] = [im for im in layout["images"] or []
                            if isinstance(im, dict) and _data_url(im.get("source"))]
    out = {k: v for k, v in fig.items() if k not in ("data", "layout", "frames")}
    out["data"], out["layout"] = _clean(data), _clean(layout)
    return out
