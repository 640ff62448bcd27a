"""The workbench in headless Chromium: a server with a recording page, waits, screenshots and
the one-unit-per-axis check, shared by the browser tests of this folder."""

from __future__ import annotations

import os
import time
from pathlib import Path
from urllib.parse import urlparse

TIMEOUT_MS = 60_000  # QA on a 1,370 s test, on a loaded 2-core machine


#: Screenshots of each view go to docs/workbench/ when VEHVAL_SCREENSHOTS=1 (`make
#: screenshots`); `make test` leaves the docs alone.
SHOTS = Path(__file__).resolve().parents[2] / "docs" / "workbench"


def shot(page, name: str, full_page: bool = False) -> None:
    """A screenshot of the view as ``docs/workbench/<name>.png`` when asked for."""
    if os.environ.get("VEHVAL_SCREENSHOTS") == "1":
        SHOTS.mkdir(parents=True, exist_ok=True)
        page.screenshot(path=str(SHOTS / f"{name}.png"), full_page=full_page)


def one_unit_per_axis(page, div_id: str) -> dict:
    """y axis -> units of the traces drawn on it, from the drawn figure; asserts one each."""
    units = page.evaluate(f"window.vehvalFigures.axisUnits(document.getElementById('{div_id}'))")
    assert units and all(len(v) == 1 for v in units.values()), units
    return units


class Visit:
    """A workbench server and a page recording its requests and console errors."""

    def __init__(self, browser, ws: Path) -> None:
        from vehval.serve.app import start

        self.server = start(ws)
        self.origin = "{0.scheme}://{0.netloc}".format(urlparse(self.server.url))
        self.context = browser.new_context(viewport={"width": 1300, "height": 900})
        self.requests: list[str] = []
        self.errors: list[str] = []
        self.context.on("request", lambda r: self.requests.append(r.url))
        self.page = self.context.new_page()
        self.page.set_default_timeout(TIMEOUT_MS)
        self.page.on("console", lambda m: self.errors.append(m.text) if m.type == "error" else None)
        self.page.on("pageerror", lambda e: self.errors.append(str(e)))

    def foreign(self) -> list[str]:
        return [u for u in self.requests if not (u.startswith(self.origin + "/")
                                                 or u.startswith(("data:", "blob:", "about:")))]

    def close(self) -> None:
        self.context.close()
        self.server.stop()


def _wait(page, expr: str, timeout_s: float = TIMEOUT_MS / 1000) -> None:
    """Poll a JS expression until true (``page.wait_for_function`` evaluates a string,
    which the page's policy forbids: no 'unsafe-eval')."""
    deadline = time.monotonic() + timeout_s
    # false while a navigation is under way (document.body is null for a moment)
    while not page.evaluate(f"() => {{ try {{ return Boolean({expr}); }} "
                            "catch (e) { return false; } }"):
        if time.monotonic() > deadline:
            shown = page.evaluate("() => (document.getElementById('error') || {}).textContent")
            raise AssertionError(f"timed out waiting for {expr} (page error: {shown!r})")
        page.wait_for_timeout(100)
