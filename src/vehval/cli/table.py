"""Plain-text tables that fit the terminal (80 columns by default), for the CLI.

Columns never wrap one word per line: a table too wide first groups rows under a header
line (``group_by``), then shortens the columns marked ``shrink`` with an ellipsis, then the
widest text column. Numbers are right-aligned, text left-aligned.
"""

from __future__ import annotations

import os
import shutil
from typing import Sequence

ELLIPSIS = "…"


def terminal_width(default: int = 80) -> int:
    """Columns of the terminal (``COLUMNS`` first), ``default`` when unknown."""
    env = os.environ.get("COLUMNS")
    if env and env.isdigit():
        return int(env)
    return shutil.get_terminal_size((default, 24)).columns


def _numeric(values: Sequence[str]) -> bool:
    def num(v: str) -> bool:
        try:
            float(v.replace("%", ""))
            return True
        except ValueError:
            return v in ("", "n/a", "-")
    return all(num(v) for v in values)


def _cut(text: str, width: int) -> str:
    return text if len(text) <= width else text[: max(width - 1, 0)] + ELLIPSIS


def render(columns: Sequence[str], rows: Sequence[Sequence[str]], *, width: int | None = None,
           shrink: Sequence[str] = (), group_by: Sequence[str] = (), title: str | None = None,
           gap: int = 2) -> str:
    """The table as text no wider than ``width`` (default: the terminal's)."""
    width = width or terminal_width()
    cells = [[str(c) for c in r] for r in rows]
    cols = list(columns)
    groups: list[tuple[str, list[list[str]]]] = [("", cells)]
    natural = sum(max([len(c)] + [len(r[i]) for r in cells]) for i, c in enumerate(cols))
    if group_by and natural + gap * (len(cols) - 1) > width:
        gi = [cols.index(g) for g in group_by]
        keep = [i for i in range(len(cols)) if i not in gi]
        grouped: dict[str, list[list[str]]] = {}
        for r in cells:
            grouped.setdefault(" / ".join(r[i] for i in gi), []).append([r[i] for i in keep])
        groups = list(grouped.items())
        cols = [cols[i] for i in keep]
    body = [r for _, g in groups for r in g]
    widths = [max([len(c)] + [len(r[i]) for r in body]) for i, c in enumerate(cols)]
    right = [_numeric([r[i] for r in body]) for i in range(len(cols))]

    def total() -> int:
        return sum(widths) + gap * (len(widths) - 1)

    for name in shrink:                       # shrinkable columns first
        if name in cols and total() > width:
            i = cols.index(name)
            widths[i] = max(len(cols[i]), widths[i] - (total() - width), 8)
    while total() > width:                    # then the widest text column
        text = [i for i in range(len(cols)) if not right[i] and widths[i] > 8]
        if not text:
            break
        i = max(text, key=lambda k: widths[k])
        widths[i] = max(8, widths[i] - (total() - width))

    def line(cells: Sequence[str], indent: str = "") -> str:
        out = [(_cut(c, w).rjust(w) if r else _cut(c, w).ljust(w))
               for c, w, r in zip(cells, widths, right)]
        return (indent + (" " * gap).join(out)).rstrip()

    indent = "  " if len(groups) > 1 or groups[0][0] else ""
    if indent:
        widths = [w for w in widths]
        while total() + len(indent) > width and any(not r and w > 8 for w, r in zip(widths, right)):
            i = max((k for k in range(len(widths)) if not right[k]), key=lambda k: widths[k])
            widths[i] -= 1
    out = [title] if title else []
    out.append(line(cols, indent))
    out.append(indent + "-" * min(total(), width - len(indent)))
    for head, g in groups:
        if head:
            out.append(head)
        out += [line(r, indent) for r in g]
    return "\n".join(out)
