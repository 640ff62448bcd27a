"""Screenshots of the workbench's views for docs/workbench.md, taken by the browser tests.

With ``VEHVAL_SCREENSHOTS=1`` a browser test writes the page it checked to
``docs/workbench/NAME.png`` (the docs' pictures are the real pages); otherwise nothing is
written.
"""

from __future__ import annotations

import os
from pathlib import Path

DOCS = Path(__file__).resolve().parents[2] / "docs" / "workbench"


def shot(page, name: str, full_page: bool = False) -> Path | None:
    """Write ``docs/workbench/NAME.png`` of ``page`` when ``VEHVAL_SCREENSHOTS=1``."""
    if os.environ.get("VEHVAL_SCREENSHOTS") != "1":
        return None
    DOCS.mkdir(parents=True, exist_ok=True)
    path = DOCS / f"{name}.png"
    page.screenshot(path=str(path), full_page=full_page)
    return path
