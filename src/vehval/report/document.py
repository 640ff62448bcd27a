"""Simple pages as a list of blocks: headings, paragraphs, lists, tables and figures.

The identification, prediction, batch index and sensitivity pages are such documents. A
block holds text only (numbers already formatted by the page module); the template
``document.html.j2`` escapes every piece of it, so a test id or a file name with markup in
it shows as text.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import Any, Sequence

from vehval.errors import ConfigError
from vehval.report.figures import FigSpec
from vehval.report.page import INLINE, render_page


@dataclass
class Block:
    """One block of a document.

    Attributes
    ----------
    kind : str
        ``h1``, ``h2``, ``p``, ``ul``, ``table`` or ``figure``.
    text : str
        Heading text.
    runs : list
        Paragraph: strings and ``(text, css class)`` pairs (a styled span).
    items : list of str
        List items.
    head, rows : list
        Table header and rows; a cell is text or a :func:`cell` dict.
    figure : FigSpec or None
        The figure of a ``figure`` block.
    """

    kind: str
    text: str = ""
    runs: list = field(default_factory=list)
    items: list = field(default_factory=list)
    head: list = field(default_factory=list)
    rows: list = field(default_factory=list)
    figure: FigSpec | None = None


def h1(text: str) -> Block:
    """The page heading."""
    return Block("h1", text=str(text))


def h2(text: str) -> Block:
    """A section heading."""
    return Block("h2", text=str(text))


def para(*runs: Any) -> Block:
    """A paragraph of text pieces: strings, or ``(text, css class)`` for a styled span."""
    return Block("p", runs=[r if isinstance(r, tuple) else str(r) for r in runs])


def bullets(items: Sequence[Any]) -> Block:
    """A bulleted list of texts."""
    return Block("ul", items=[str(i) for i in items])


def table(head: Sequence[Any], rows: Sequence[Sequence[Any]]) -> Block:
    """A table; cells are text (``None`` shows empty) or :func:`cell` dicts."""
    def norm(c: Any) -> Any:
        return c if isinstance(c, dict) else ("" if c is None else str(c))

    return Block("table", head=[norm(h) for h in head], rows=[[norm(c) for c in r] for r in rows])


def figure(spec: FigSpec) -> Block:
    """A plotly figure (drawn by ``render.js``)."""
    return Block("figure", figure=spec)


#: A URL scheme, an absolute path, a backslash, a parent step or nothing.
_BAD_HREF = re.compile(r"^[a-zA-Z][a-zA-Z0-9+.-]*:|^/|\\|(^|/)\.\.(/|$)|^\s*$")


def cell(text: Any, cls: str = "", href: str | None = None) -> dict:
    """A table cell with a CSS class and/or a link to a file below the page.

    Raises
    ------
    ConfigError
        ``href`` is not a relative path below the page (a URL, an absolute path, ``..``).
    """
    if href is not None and _BAD_HREF.search(href):
        raise ConfigError(f"link {href!r}: a page links only to files below it (relative path)")
    return {"text": "" if text is None else str(text), "cls": cls, "href": href}


def render_document(blocks: Sequence[Block], *, title: str, css: str,
                    plotly_js: str = INLINE) -> str:
    """The HTML page of ``blocks`` (see :func:`vehval.report.page.render_page`)."""
    figs = [b.figure for b in blocks if b.kind == "figure" and b.figure is not None]
    return render_page("document.html.j2", title=title, css=css, figures=figs,
                       plotly_js=plotly_js, blocks=list(blocks))
