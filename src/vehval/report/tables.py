"""Tables of the report: one structure shared by the HTML report and the Excel export.

Every table the report shows is a :class:`Table` (title, column names, rows of plain
values). The HTML page formats the cells for reading; the Excel workbook writes the raw
values, so both show exactly the same data as ``findings.json``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Iterable

import numpy as np


@dataclass
class Table:
    """A titled table of plain values.

    Attributes
    ----------
    title : str
        Caption shown above the table (and the Excel sheet title).
    columns : list of str
        Column names.
    rows : list of list
        Cell values: str, int, float, bool or None (nested values are JSON text).
    key : str
        Short identifier (HTML anchor and Excel sheet name stem).
    note : str
        Optional explanation shown under the caption.
    """

    title: str
    columns: list[str]
    rows: list[list[Any]]
    key: str = ""
    note: str = ""
    highlight: dict[int, str] = field(default_factory=dict)  # row index -> css class

    def __post_init__(self) -> None:
        if not self.key:
            self.key = slug(self.title)


def slug(text: str) -> str:
    """A lower-case identifier made of letters, digits and dashes."""
    out = "".join(c.lower() if c.isalnum() else "-" for c in str(text))
    while "--" in out:
        out = out.replace("--", "-")
    return out.strip("-") or "table"


def plain(value: Any) -> Any:
    """A JSON/Excel friendly scalar: numpy scalars unwrapped; containers as readable text
    (``limit = 0.5; count = 3``, numbers to 4 significant digits, a key naming its SI unit
    by suffix shown in its display unit: :func:`vehval.display.format_keyed`)."""
    if value is None or isinstance(value, (str, bool, int)):
        return value
    if isinstance(value, float):
        return value
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, dict):
        return "; ".join(f"{k} = {_readable(v, str(k))}" for k, v in value.items())
    if isinstance(value, (list, tuple, np.ndarray)):
        return ", ".join(_readable(v) for v in value)
    return str(value)


def _readable(value: Any, key: str = "") -> str:
    """One value inside a container, as a person reads it (no JSON)."""
    from vehval.display import format_keyed, number

    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, bool) or value is None:
        return "n/a" if value is None else str(value).lower()
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return format_keyed(key, value) if key else number(value)
    if isinstance(value, (dict, list, tuple, np.ndarray)):
        inner = plain(value)
        return f"({inner})" if inner else "()"
    return str(value)


def rows_table(title: str, rows: Iterable[dict], *, key: str = "", note: str = "",
               columns: list[str] | None = None) -> Table:
    """A table from a list of dicts; columns are the union of keys in first-seen order."""
    rows = [r for r in rows if isinstance(r, dict)]
    if columns is None:
        columns = []
        for r in rows:
            for k in r:
                if k not in columns:
                    columns.append(k)
    data = [[plain(r.get(c)) for c in columns] for r in rows]
    return Table(title=title, columns=[str(c) for c in columns], rows=data, key=key, note=note)


def to_tables(obj: Any, title: str, *, key: str = "") -> list[Table]:
    """Render any JSON-like object as one or more tables.

    * a list of dicts becomes one table (one row per dict);
    * a dict of scalars becomes a two-column ``item``/``value`` table;
    * a dict of dicts becomes one table with the outer key as first column, unless the
      inner values are lists of dicts, which become sub-tables;
    * a list of scalars becomes a one-column table.
    """
    key = key or slug(title)
    if obj is None:
        return []
    if isinstance(obj, list):
        if not obj:
            return [Table(title, ["(empty)"], [], key=key)]
        if all(isinstance(r, dict) for r in obj):
            return [rows_table(title, obj, key=key)]
        return [Table(title, ["value"], [[plain(v)] for v in obj], key=key)]
    if not isinstance(obj, dict):
        return [Table(title, ["value"], [[plain(obj)]], key=key)]
    scalars = {k: v for k, v in obj.items() if not isinstance(v, (dict, list))}
    nested = {k: v for k, v in obj.items() if isinstance(v, (dict, list))}
    tables: list[Table] = []
    if scalars:
        tables.append(Table(title, ["item", "value"], [[str(k), plain(v)] for k, v in scalars.items()],
                            key=key))
    dict_of_dicts = {k: v for k, v in nested.items()
                     if isinstance(v, dict) and v and all(not isinstance(x, (dict, list)) for x in v.values())}
    same_keys = len({tuple(v) for v in dict_of_dicts.values()}) == 1
    if len(dict_of_dicts) == len(nested) and len(nested) > 1 and not scalars and same_keys:
        rows = [{"name": k, **v} for k, v in dict_of_dicts.items()]
        return [rows_table(title, rows, key=key)]
    for k, v in nested.items():
        sub = f"{title}: {k}"
        if isinstance(v, dict) and v and all(isinstance(x, dict) for x in v.values()):
            rows = [{"name": kk, **vv} for kk, vv in v.items()]
            tables.append(rows_table(sub, rows, key=f"{key}-{slug(k)}"))
        elif isinstance(v, dict) and v and all(_scalar_list(x) for x in v.values()):
            # e.g. not computed: name -> reasons: one list, not one table per name
            tables.append(Table(sub, ["name", "value"],
                                [[str(a), "; ".join(str(plain(y)) for y in b)] for a, b in v.items()],
                                key=f"{key}-{slug(k)}"))
        elif isinstance(v, dict) and v and all(not isinstance(x, (dict, list)) for x in v.values()):
            tables.append(Table(sub, ["item", "value"], [[str(a), plain(b)] for a, b in v.items()],
                                key=f"{key}-{slug(k)}"))
        else:
            tables.extend(to_tables(v, sub, key=f"{key}-{slug(k)}"))
    return tables


def _scalar_list(x: Any) -> bool:
    return isinstance(x, list) and all(not isinstance(y, (dict, list)) for y in x)


def table_from_spec(spec: dict, default_title: str) -> Table:
    """A table from ``{title, columns, rows}`` (rows: lists or dicts) as control/validation give."""
    title = str(spec.get("title") or default_title)
    rows = spec.get("rows") or []
    columns = spec.get("columns")
    if rows and isinstance(rows[0], dict):
        return rows_table(title, rows, columns=columns, note=str(spec.get("note") or ""))
    columns = [str(c) for c in (columns or [f"col{i + 1}" for i in range(len(rows[0]) if rows else 0)])]
    return Table(title, columns, [[plain(v) for v in r] for r in rows], note=str(spec.get("note") or ""))


def fmt_cell(value: Any) -> str:
    """Human formatting of one cell: 4 significant digits for floats, blanks for None."""
    if value is None:
        return ""
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, float):
        if math.isnan(value):
            return "–"
        if value == 0.0:
            return "0"
        a = abs(value)
        if 1e-3 <= a < 1e6:
            return f"{value:.4g}"
        return f"{value:.3e}"
    return str(value)
