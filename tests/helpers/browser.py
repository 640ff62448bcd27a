"""Headless Chromium for the page tests: the binary, its command-line flags, and the URL schemes
a self-contained page may load (anything else is a network request)."""

from __future__ import annotations

import os
import shutil

CHROMIUM = os.environ.get("VEHVAL_CHROMIUM") or shutil.which("chromium") or "/usr/bin/chromium"


ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
        "--disable-background-networking", "--disable-component-update", "--disable-sync"]


LOCAL = ("file:", "data:", "about:", "blob:")
