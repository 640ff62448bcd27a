"""Writers of the virtual test files, in the byte layout of the real systems.

* D3 facility file (Argonne Downloadable Dynamometer Database style): TAB-delimited text,
  one header row ``Name[unit]``, CRLF line ends, every value with 3 decimals, empty cells for
  missing samples.
* OBD/CAN logger file: comma CSV, LF line ends, header of PID names without units (the
  template gives them), values written as the logger's floats (shortest repr), empty cells
  for missing samples.

A truncated file (fault ``truncated``) ends with a partial last line, as after a power loss,
optionally followed by NUL padding (seen in real logger files).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from vehval.io.atomic import atomic_path


def header_text(channel: str, unit: str | None, style: str) -> str:
    """Column header: ``Name[unit]`` (D3); the bare name for a logger file or without unit.

    OBD loggers write PID names only: the units are known from the PID definitions and are
    given by the import template.
    """
    if unit is None or style != "d3":
        return channel
    return f"{channel}[{unit}]"


def _fmt_fixed(values: np.ndarray, decimals: int, missing: str) -> list[str]:
    v = np.round(np.asarray(values, dtype=float), decimals) + 0.0  # no "-0.000"
    out = [f"{x:.{decimals}f}" for x in v.tolist()]
    if np.isnan(v).any():
        for i in np.flatnonzero(np.isnan(v)):
            out[i] = missing
    return out


def _fmt_repr(values: np.ndarray, decimals: int, missing: str) -> list[str]:
    v = np.round(np.asarray(values, dtype=float), decimals) + 0.0
    return [missing if x != x else repr(x) for x in v.tolist()]


def render_table(headers: list[str], columns: list[np.ndarray], *, style: str, decimals: int,
                 missing: str = "") -> list[str]:
    """Render a table to text lines (without line terminators).

    Parameters
    ----------
    headers : list of str
        Column headers, first one the time column.
    columns : list of numpy.ndarray
        Samples per column, equal lengths (NaN = missing).
    style : {'d3', 'csv'}
        ``d3``: TAB, fixed decimals; ``csv``: comma, shortest float repr.
    decimals : int
        Rounding of every value.
    missing : str
        Text of a missing sample (empty by default, as D3 exports).
    """
    sep = "\t" if style == "d3" else ","
    fmt = _fmt_fixed if style == "d3" else _fmt_repr
    cols = [fmt(c, decimals, missing) for c in columns]
    lines = [sep.join(headers)]
    lines.extend(sep.join(row) for row in zip(*cols))
    return lines


def write_table(path: str | Path, headers: list[str], columns: list[np.ndarray], *, style: str,
                decimals: int, missing: str = "", truncate_rows: int | None = None,
                nul_padding: int = 0) -> dict:
    """Write a virtual test file atomically and return facts about what was written.

    Parameters
    ----------
    path : path-like
        Output file.
    headers, columns, style, decimals, missing
        See :func:`render_table`.
    truncate_rows : int, optional
        Keep only this many complete data rows, then half of the next row with no line end
        (a power-loss truncation).
    nul_padding : int
        Number of NUL bytes appended after a truncation.

    Returns
    -------
    dict
        ``rows_written`` (complete data rows), ``partial_line`` (text of the cut line or
        ``None``), ``bytes``.
    """
    eol = "\r\n" if style == "d3" else "\n"
    lines = render_table(headers, columns, style=style, decimals=decimals, missing=missing)
    partial = None
    if truncate_rows is not None and truncate_rows + 1 < len(lines):
        nxt = lines[truncate_rows + 1]
        sep = "\t" if style == "d3" else ","
        cuts = [i for i, ch in enumerate(nxt) if ch == sep]
        # cut one character into a middle field: the partial line lacks whole fields, so a
        # reader cannot mistake it for a complete row
        if len(cuts) >= 2:
            cut = cuts[(len(cuts) - 1) // 2] + 1
            if cut < len(nxt) and nxt[cut] != sep:
                cut += 1
        else:
            cut = cuts[0] if cuts else max(1, len(nxt) // 2)
        partial = nxt[:cut]
        lines = lines[: truncate_rows + 1]
        text = eol.join(lines) + eol + partial
        data = text.encode("utf-8") + b"\x00" * int(nul_padding)
    else:
        data = (eol.join(lines) + eol).encode("utf-8")
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)
    return {"rows_written": len(lines) - 1, "partial_line": partial, "bytes": len(data)}


def write_test_folder(outdir: str | Path, data_name: str, lines: list[str], template: str,
                      truth: dict, holds: str) -> dict:
    """Write a virtual test into ``outdir`` (atomically): the data file ``data_name`` (its
    ``lines``), ``template.yaml``, ``truth.json`` and a README saying what truth.json
    ``holds``. Returns ``truth`` with the written ``files`` and ``template`` paths."""
    import json

    from vehval.io.atomic import atomic_dir, write_text_atomic

    outdir = Path(outdir)
    test_id = truth["test_id"]
    with atomic_dir(outdir) as stage:
        write_text_atomic(stage / data_name, "\n".join(lines) + "\n")
        write_text_atomic(stage / "template.yaml", template)
        write_text_atomic(stage / "truth.json", json.dumps(truth, indent=2) + "\n")
        write_text_atomic(stage / "README.txt",
                          f"VIRTUAL test {test_id}: simulated by vehval, not a measurement.\n"
                          f"truth.json holds {holds}.\n")
    truth["files"] = [str(outdir / data_name)]
    truth["template"] = str(outdir / "template.yaml")
    return truth
