"""docs/nomenclature.md carries the table of base names generated from signals.yaml.

Regenerate it after editing the registry with ``python tests/io/test_docs.py``.
"""

from __future__ import annotations

import re
from pathlib import Path

from vehval.nomenclature import registry

DOC = Path(__file__).resolve().parents[2] / "docs" / "nomenclature.md"
BEGIN, END = "<!-- BEGIN signals table (generated) -->", "<!-- END signals table -->"


def signals_table() -> str:
    """Markdown table of every base name: unit, category, range, resample, description."""
    lines = ["| base name | SI unit | category | plausible range | resample | description |",
             "|---|---|---|---|---|---|"]
    for b, s in registry().specs.items():
        lines.append(f"| `{b}` | {s.unit} | {s.category} | {s.range[0]:g} .. {s.range[1]:g} | "
                     f"{s.resample} | {s.description} |")
    return "\n".join(lines)


def _block(text: str) -> str:
    m = re.search(re.escape(BEGIN) + r"\n(.*?)\n" + re.escape(END), text, re.S)
    assert m, f"{DOC}: markers {BEGIN!r} ... {END!r} not found"
    return m.group(1)


def test_nomenclature_table_matches_registry():
    assert _block(DOC.read_text(encoding="utf-8")) == signals_table(), (
        "docs/nomenclature.md is out of date with signals.yaml: run `python tests/io/test_docs.py`")


if __name__ == "__main__":  # regenerate the table in place
    text = DOC.read_text(encoding="utf-8")
    text = text.replace(_block(text), signals_table())
    from vehval.io.atomic import write_text_atomic
    write_text_atomic(DOC, text)
    print(f"updated {DOC}")
