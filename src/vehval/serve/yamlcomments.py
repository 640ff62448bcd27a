"""Keep a YAML file's comments when the workbench rewrites it.

The template is rewritten from its model (:meth:`vehval.io.template.Template.to_yaml`, the
text ``vehval template init`` writes); the comment lines of the file as it was (the
``# fuel:`` placeholder of ``template init``, the user's own notes) are put back before the
line they stood before, and an end-of-line comment stays on its key's line.
"""

from __future__ import annotations

import re

_KEY = re.compile(r"^(\s*(?:-\s+)?)((?:'[^']*'|\"[^\"]*\"|[^:#\s][^:#]*?)):(\s|$)")


def _is_comment(line: str) -> bool:
    s = line.strip()
    return not s or s.startswith("#")


def _key(line: str) -> str | None:
    m = _KEY.match(line)
    return (m.group(1) + m.group(2)) if m else None


def _inline_comment(line: str) -> str:
    """The end-of-line comment of a YAML line (`` # ...``), outside quotes; ``""`` if none."""
    quote = ""
    for i, ch in enumerate(line):
        if quote:
            if ch == quote:
                quote = ""
        elif ch in "'\"":
            quote = ch
        elif ch == "#" and i > 0 and line[i - 1] in " \t":
            j = i
            while j > 0 and line[j - 1] in " \t":
                j -= 1
            return line[j:].rstrip("\n")
    return ""


def _number(text: str) -> float | None:
    try:
        return float(text.replace("_", ""))
    except ValueError:
        return None


def _keep_number(old_line: str, new_line: str) -> str:
    """``new_line`` with ``old_line``'s number literal when both give the key the same number
    (``1727`` stays ``1727``, ``42.8e6`` stays ``42.8e6``, not ``1727.0``, ``42800000.0``)."""
    m_old, m_new = _KEY.match(old_line), _KEY.match(new_line)
    if not (m_old and m_new):
        return new_line
    old_val = old_line[m_old.end():]
    comment = _inline_comment(old_val)
    old_val = old_val[: len(old_val) - len(comment)].strip() if comment else old_val.strip()
    new_val = new_line[m_new.end():].strip()
    a, b = _number(old_val), _number(new_val)
    if a is None or b is None or a != b or old_val == new_val:
        return new_line
    return new_line[: m_new.end()] + old_val


def _placeholder_of(line: str, top_keys: set[str]) -> bool:
    """A comment line ``# KEY: ...`` (no indentation) standing for a top-level key the new
    text now has: the placeholder of ``template init`` is stale once the key is written."""
    m = re.match(r"^#\s*([A-Za-z_][A-Za-z0-9_]*):", line)
    return m is not None and m.group(1) in top_keys


def carry_comments(old: str, new: str) -> str:
    """``new`` with the comment lines of ``old`` put back.

    Parameters
    ----------
    old : str
        The file as it was (with comments).
    new : str
        The file as regenerated (no comments).

    Returns
    -------
    str
        ``new`` where each block of comment (and blank) lines of ``old`` precedes the line it
        preceded in ``old`` (found by exact text, else by its key at the same indentation,
        in order); blocks whose line is gone go where it was, at the end when nothing is left.
        A top-level ``# KEY: ...`` placeholder comment (with the comment lines following it,
        up to a blank or a YAML line) is dropped once ``new`` sets KEY, and
        a number keeps its literal when its value did not change.
    """
    top_keys = {m.group(2) for ln in new.splitlines() if (m := _KEY.match(ln)) and not m.group(1)}
    anchors: list[tuple[str, str | None, list[str]]] = []
    pending: list[str] = []
    dropping = False   # inside a stale placeholder block (up to a blank or a YAML line)
    for line in old.splitlines():
        if _is_comment(line):
            dropping = (dropping and bool(line.strip())) or _placeholder_of(line, top_keys)
            if not dropping:
                pending.append(line)
        else:
            dropping = False
            anchors.append((line, _key(line), pending))
            pending = []
    trailing = pending
    used = [False] * len(anchors)
    out: list[str] = []
    pos = 0  # anchors are searched from the last one used, so repeated keys pair in order

    def find(pred) -> int | None:
        for order in (range(pos, len(anchors)), range(0, pos)):
            for i in order:
                if not used[i] and pred(i):
                    return i
        return None

    for line in new.splitlines():
        i = find(lambda j: anchors[j][0] == line)
        key = _key(line)
        if i is None and key is not None:
            i = find(lambda j: anchors[j][1] == key)
        if i is not None:
            # comment blocks of anchors skipped on the way (lines removed) come first
            for j in range(pos, i):
                if not used[j] and anchors[j][2] and anchors[j][0] not in new:
                    out.extend(anchors[j][2])
                    anchors[j] = (anchors[j][0], anchors[j][1], [])
            used[i] = True
            out.extend(anchors[i][2])
            if anchors[i][0] != line:
                line = _keep_number(anchors[i][0], line)
            if anchors[i][0] != line and not _inline_comment(line):
                line += _inline_comment(anchors[i][0])
            pos = i + 1
        out.append(line)
    out.extend(c for i, a in enumerate(anchors) if not used[i] for c in a[2])
    out.extend(trailing)
    return "\n".join(out) + "\n"
