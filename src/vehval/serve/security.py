"""What keeps the workbench private: token, CSRF, host check, content policy, workspace paths.

* **token**: a random one-time token printed in the URL (as Jupyter does). The first request
  with ``?token=`` sets an HTTP-only, same-site cookie; every other request needs the cookie
  (or the ``X-Vehval-Token`` header): no token -> 403.
* **CSRF**: a second random value is written into each page (``<meta name="vehval-csrf">``);
  every write (POST) must send it back in ``X-CSRF-Token`` and come from the workbench's
  own origin. A page elsewhere cannot read it, so it cannot forge a write.
* **host**: only ``127.0.0.1``, ``localhost`` and ``[::1]`` (plus the bound host) are
  answered, so a DNS-rebinding page cannot reach the server under another name.
* **content policy**: scripts and data only from the workbench itself; no request can leave
  the machine (``connect-src 'self'``, no remote source anywhere).
* **paths**: every path of a request is relative to the workspace and must stay inside it
  after symlinks are resolved (:func:`inside_workspace`).
"""

from __future__ import annotations

import hmac
import secrets
from pathlib import Path, PurePosixPath

from vehval.errors import InputFileError

#: Cookie holding the access token.
TOKEN_COOKIE = "vehval_workbench"
#: Header a write must carry with the page's CSRF value.
CSRF_HEADER = "x-csrf-token"
#: Header an API client may use instead of the cookie.
TOKEN_HEADER = "x-vehval-token"
#: Host names the server answers to (the bound address is added).
LOCAL_HOSTS = frozenset({"127.0.0.1", "localhost", "::1", "[::1]"})

#: Content-Security-Policy of every workbench page: nothing from elsewhere, no inline script.
PAGE_CSP = ("default-src 'none'; script-src 'self'; style-src 'self' 'unsafe-inline'; "
            "img-src 'self' data: blob:; font-src data:; connect-src 'self'; worker-src 'none'; "
            "object-src 'none'; frame-src 'self'; media-src 'none'; form-action 'self'; "
            "base-uri 'none'; frame-ancestors 'self'")
#: Policy added to a report served from the workspace (its own meta policy still applies):
#: sandboxed, so a hostile HTML file in the workspace cannot act as the workbench.
REPORT_CSP = ("default-src 'none'; script-src 'self' 'unsafe-inline'; style-src 'unsafe-inline'; "
              "img-src data: blob:; font-src data:; connect-src 'none'; worker-src 'none'; "
              "object-src 'none'; frame-src 'none'; form-action 'none'; base-uri 'none'; "
              "frame-ancestors 'self'; sandbox allow-scripts allow-popups")


class OutsideWorkspace(InputFileError):
    """A path of a request that leaves the workspace (refused with 403)."""


def new_secret() -> str:
    """A fresh random token (256 bits, URL-safe)."""
    return secrets.token_urlsafe(32)


def same(a: str | None, b: str) -> bool:
    """Constant-time comparison of a received value with the expected one."""
    return a is not None and hmac.compare_digest(a.encode("utf-8", "replace"), b.encode("utf-8"))


def host_allowed(host_header: str | None, extra: frozenset[str] = frozenset()) -> bool:
    """True when the ``Host`` header names this machine (or an extra allowed name)."""
    if not host_header:
        return False
    host = host_header.strip().lower()
    if host.startswith("["):  # [::1]:8890
        name = host.split("]", 1)[0] + "]"
    else:
        name = host.rsplit(":", 1)[0] if host.count(":") == 1 else host
    return name in LOCAL_HOSTS or name in extra


def inside_workspace(root: Path, rel: str | None, *, must_exist: bool = True) -> Path:
    """The absolute path of ``rel`` (relative to the workspace ``root``), refused outside it.

    Parameters
    ----------
    root : Path
        The workspace folder (resolved).
    rel : str
        A path relative to the workspace, ``/``-separated; ``""`` or ``"."`` is the workspace.
    must_exist : bool
        Refuse a path that does not exist.

    Raises
    ------
    OutsideWorkspace
        An absolute path, a ``..`` step, a NUL byte, or a symlink leading out of the workspace.
    """
    text = (rel or ".").replace("\\", "/")
    if "\x00" in text or len(text) > 4096:
        raise OutsideWorkspace("path refused: not a plain path inside the workspace")
    pure = PurePosixPath(text)
    if pure.is_absolute() or ".." in pure.parts or (pure.parts and ":" in pure.parts[0]):
        raise OutsideWorkspace(f"{text[:200]}: path outside the workspace refused: give a path "
                               "relative to the workspace folder")
    full = (root / Path(*pure.parts)).resolve() if pure.parts else root
    if not full.is_relative_to(root):
        raise OutsideWorkspace(f"{text[:200]}: leads outside the workspace (symlink?): refused")
    if must_exist and not full.exists():
        raise InputFileError(f"{text[:200]}: not found in the workspace")
    return full


def relative(root: Path, path: Path) -> str:
    """``path`` relative to the workspace, ``/``-separated (``"."`` for the workspace)."""
    rel = path.resolve().relative_to(root).as_posix()
    return rel or "."
