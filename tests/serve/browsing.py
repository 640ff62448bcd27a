"""Chromium for the workbench's browser tests: the ``browser`` fixture, a :class:`Visit`
(a server and a page recording its requests and errors) and :func:`_wait` (poll a JS
expression: the page's policy forbids the eval of ``wait_for_function``)."""

from __future__ import annotations

import time
from pathlib import Path
from urllib.parse import urlparse

import pytest

from helpers.browser import ARGS, CHROMIUM

TIMEOUT_MS = 60_000  # QA on a 1,370 s test, on a loaded 2-core machine


@pytest.fixture()
def browser():
    if not Path(CHROMIUM).exists():
        pytest.skip("chromium not installed (run `make browser`)")
    sync_api = pytest.importorskip("playwright.sync_api")
    pytest.importorskip("uvicorn")
    with sync_api.sync_playwright() as p:
        try:
            b = p.chromium.launch(executable_path=CHROMIUM, args=ARGS)
        except Exception as exc:  # noqa: BLE001 - a broken browser install is a skip
            pytest.skip(f"chromium does not start: {exc}")
        yield b
        b.close()


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
    while not page.evaluate(f"() => Boolean({expr})"):
        if time.monotonic() > deadline:
            shown = page.evaluate("() => (document.getElementById('error') || {}).textContent")
            raise AssertionError(f"timed out waiting for {expr} (page error: {shown!r})")
        page.wait_for_timeout(100)
