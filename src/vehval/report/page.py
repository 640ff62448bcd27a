"""The one way vehval writes an HTML page: autoescaping templates, one policy, one plotly.js.

Every page (the test report, the EPA validation report, the identification and prediction
reports, the batch index, the sensitivity page) is a template of ``report/templates``
extending ``base.html.j2``, rendered by :func:`render_page` with autoescaping on for every
template: text from data files (channel names, units, test ids, an EPA list's columns)
reaches the page only as escaped text, never as markup. Figures are plotly JSON blocks
(``<script type="application/json">``, sanitised by :func:`vehval.report.figures.figure_json`)
drawn by ``render.js``. The page's Content-Security-Policy lists the SHA-256 hash of each
of its inline scripts (plotly.js, ``render.js``), so nothing else could run
(:mod:`vehval.report.safety`).

plotly.js is embedded once (:data:`INLINE`; gzip-compressed and base64-encoded, unpacked in
the browser by ``boot.js`` and run under its listed hash) or, for many pages side by side, read from one
local copy written by :func:`write_plotly_asset` (``plotly_js="<relative path>"``: still
offline, a relative ``file://`` path, no network).
"""

from __future__ import annotations

import hashlib
import json
import os
import re
from dataclasses import dataclass
from functools import lru_cache
from importlib import resources
from pathlib import Path
from typing import Any, Sequence

import jinja2

from vehval.errors import ConfigError
from vehval.io.atomic import atomic_path
from vehval.report.figures import FigSpec, prepare_figures
from vehval.report.safety import content_security_policy, script_hash

#: ``plotly_js`` value that embeds plotly.js in the page (the default).
INLINE = "inline"


def plotly_cache_dir() -> Path:
    """Where the compressed plotly.js is kept between runs: ``$VEHVAL_CACHE_DIR/plotly``,
    else ``~/.cache/vehval/plotly``."""
    env = os.environ.get("VEHVAL_CACHE_DIR")
    return (Path(env) if env else Path.home() / ".cache" / "vehval") / "plotly"


@lru_cache(maxsize=1)
def _plotly_gz() -> str:
    """The embedded plotly.js, gzip-compressed and base64-encoded (unpacked by ``boot.js``).

    About 1.9 MB instead of 4.8 MB; the unpacked text is exactly the hashed source (a copy
    that does not unpack to it would not run under the page's policy). Compressing takes
    about a second, so the result is kept in :func:`plotly_cache_dir`, named after the
    source's hash; without a writable cache it is computed each time.
    """
    import base64
    import gzip

    js, js_hash, version, _ = _plotly_assets()
    tag = hashlib.sha256(js_hash.encode()).hexdigest()[:16]
    path = plotly_cache_dir() / f"plotly-{version}-{tag}.js.gz.b64"
    try:
        return path.read_text(encoding="ascii")
    except (OSError, UnicodeDecodeError):
        pass
    text = base64.b64encode(gzip.compress(js.encode("utf-8"), compresslevel=9,
                                          mtime=0)).decode("ascii")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with atomic_path(path) as tmp:
            tmp.write_text(text, encoding="ascii")
    except OSError:
        pass
    return text


@lru_cache(maxsize=1)
def _plotly_assets() -> tuple[str, str, str, str]:
    """(plotly.js source, its CSP hash, its version, the shared layout template JSON)."""
    import plotly.io as pio
    from plotly.offline import get_plotlyjs, get_plotlyjs_version

    tmpl = pio.templates["plotly_white"].to_plotly_json()
    tmpl.setdefault("layout", {})
    tmpl["layout"].update({"font": {"family": "-apple-system, Segoe UI, Roboto, Arial, sans-serif",
                                    "size": 12, "color": "#212529"},
                           "colorway": ["#1f5fa8", "#d9480f", "#2b8a3e", "#7048e8", "#c2255c",
                                        "#0b7285", "#e67700", "#495057"]})
    js = get_plotlyjs().replace("</script", "<\\/script")
    tjson = json.dumps(tmpl, separators=(",", ":")).replace("</", "<\\/")
    return js, script_hash(js), get_plotlyjs_version(), tjson


def plotly_asset_name() -> str:
    """File name of the shared plotly.js copy: ``plotly-<plotly.js version>.min.js``."""
    from plotly.offline import get_plotlyjs_version

    return f"plotly-{get_plotlyjs_version()}.min.js"


def write_plotly_asset(directory: str | Path) -> Path:
    """Write plotly.js once as ``directory/plotly-<version>.min.js`` for pages to share.

    The file is written atomically, and only when it is absent or its content differs, so
    concurrent writers (batch workers) and reruns are safe and an unchanged file is left
    alone (its modification time too).

    Parameters
    ----------
    directory : str or Path
        Asset directory (created if needed).

    Returns
    -------
    Path
        The asset file.
    """
    from plotly.offline import get_plotlyjs

    path = Path(directory) / plotly_asset_name()
    data = get_plotlyjs().encode("utf-8")
    try:
        if path.stat().st_size == len(data) and path.read_bytes() == data:
            return path
    except OSError:
        pass
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)
    return path


#: A URL scheme (``https:``, ``C:``), an absolute path, a backslash or nothing.
_UNSAFE_SRC = re.compile(r"^[a-zA-Z][a-zA-Z0-9+.-]*:|^/|\\|^\s*$")


def plotly_src(plotly_js: str) -> str | None:
    """None to embed plotly.js, else the checked relative path of the shared copy."""
    if plotly_js == INLINE:
        return None
    if not isinstance(plotly_js, str) or _UNSAFE_SRC.search(plotly_js):
        raise ConfigError(f"plotly_js must be '{INLINE}' or a relative path to a local copy of "
                          f"plotly.js (e.g. ../../assets/{plotly_asset_name()}), got {plotly_js!r}: "
                          "a URL or an absolute path would not keep the report offline and movable")
    return plotly_js


def read_asset(name: str) -> str:
    """Text of a file of ``report/templates`` (template, stylesheet or script)."""
    return resources.files("vehval.report").joinpath("templates", name).read_text(encoding="utf-8")


@lru_cache(maxsize=1)
def env() -> jinja2.Environment:
    """The template environment: autoescaping on for every template, undefined is an error."""
    loader = jinja2.FunctionLoader(read_asset)
    return jinja2.Environment(loader=loader, autoescape=True, undefined=jinja2.StrictUndefined,
                              trim_blocks=False, lstrip_blocks=False)


@dataclass(frozen=True)
class PlotlyScripts:
    """The scripts of a page with figures: plotly.js (inline or ``src``), the shared
    layout template and ``render.js``."""

    js: str
    src: str | None
    version: str
    template_json: str
    render_js: str
    gz: str = ""
    boot_js: str = ""


def render_page(template: str, *, title: str, css: str, figures: Sequence[FigSpec] = (),
                plotly: bool | None = None, plotly_js: str = INLINE, **context: Any) -> str:
    """Render one page of the template family.

    Parameters
    ----------
    template : str
        Template name in ``report/templates`` (extends ``base.html.j2``).
    title : str
        Page title (text: escaped).
    css : str
        Stylesheet name in ``report/templates``.
    figures : sequence of FigSpec
        Figures of the page, in page order: numbered and encoded here unless already
        (``json`` set).
    plotly : bool, optional
        Load plotly.js and ``render.js``; default: when there are figures.
    plotly_js : str
        :data:`INLINE` or a relative path to a copy from :func:`write_plotly_asset`.
    **context
        Template variables (text is escaped by the template).

    Returns
    -------
    str
        The HTML page.
    """
    todo = [f for f in figures if not f.json]
    if todo:
        prepare_figures(todo, start=sum(1 for f in figures if f.json))
    scripts, hashes = None, []
    if bool(figures) if plotly is None else plotly:
        src = plotly_src(plotly_js)
        js, js_hash, version, tjson = _plotly_assets()
        render_js = read_asset("render.js")
        boot_js = "" if src else read_asset("boot.js")
        # inline: the compressed copy, boot.js unpacks it and runs it under its hash
        hashes = [script_hash(render_js)] + ([] if src else [script_hash(boot_js), js_hash])
        scripts = PlotlyScripts("", src, version, tjson, render_js,
                                gz="" if src else _plotly_gz(), boot_js=boot_js)
    csp = content_security_policy(hashes, local_scripts=scripts is not None and scripts.src is not None)
    return env().get_template(template).render(title=title, css=read_asset(css), csp=csp,
                                               plotly=scripts, **context)
