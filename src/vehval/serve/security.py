"""What keeps the workbench private: token, CSRF, host check, content policy, workspace paths.

* **token**: a random token printed in the URL (as Jupyter does), valid while the server
  runs: not one-time (the printed URL opens any number of sessions until the server stops,
  so keep it private; a new server makes a new token). The first request
  with ``?token=`` sets an HTTP-only, same-site cookie; every other request needs the cookie
  (or the ``X-Vehval-Token`` header): no token -> 403.
* **CSRF**: a second random value is written into each page (``<meta name="vehval-csrf">``);
  every write (POST) must send it back in ``X-CSRF-Token`` and come from the workbench's
  own origin (scheme, host and port: :func:`same_origin`). A page elsewhere cannot read it,
  so it cannot forge a write.
* **host**: only ``127.0.0.1``, ``localhost`` and ``[::1]`` (plus the bound host) are
  answered, so a DNS-rebinding page cannot reach the server under another name.
* **content policy**: scripts and data only from the workbench itself; no request can leave
  the machine (``connect-src 'self'``, no remote source anywhere).
* **paths**: every path of a request is relative to the workspace and must stay inside it
  after symlinks are resolved (:func:`inside_workspace`); every file listed or read is
  resolved too (:func:`list_folder`, :func:`regular_file`), and what a listing leaves out is
  named. The filesystem root and the home directory are no workspace
  (:func:`check_workspace`).
"""

from __future__ import annotations

import errno
import hmac
import os
import secrets
import stat
from dataclasses import dataclass, field
from pathlib import Path, PurePosixPath
from urllib.parse import urlsplit

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
        Refuse a path that does not exist (or ends in a symlink loop).

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
    # realpath never raises on a loop (it stops inside it); the strict pass below names it
    full = Path(os.path.realpath(root / Path(*pure.parts))) if pure.parts else root
    if not full.is_relative_to(root):
        raise OutsideWorkspace(f"{text[:200]}: leads outside the workspace (symlink?): refused")
    if must_exist:
        try:
            os.stat(full)
        except OSError as exc:
            if exc.errno == errno.ELOOP:
                raise InputFileError(f"{text[:200]}: symlink loop: refused") from None
            raise InputFileError(f"{text[:200]}: not found in the workspace") from None
    return full


#: Why an entry of a folder is left out of a listing (the words the page shows).
LINK_OUTSIDE = "links outside the workspace"
LINK_LOOP = "symlink loop"
LINK_BROKEN = "broken symlink (its target does not exist)"
NOT_REGULAR = "not a regular file (a FIFO, device or socket)"
UNREADABLE = "cannot be read"
#: Most entries of one folder looked at by a listing (the rest are left out, with a count).
MAX_ENTRIES = 10_000
#: Most left-out entries named one by one (the rest are counted).
MAX_NAMED = 50


def classify(root: Path, path: Path) -> tuple[str, Path | None, str | None]:
    """What ``path`` (inside the folder being listed) is, after its symlinks are resolved.

    Returns
    -------
    (kind, real, why)
        ``kind`` is ``"file"`` (a regular file), ``"dir"`` or ``"out"`` (left out);
        ``real`` the resolved path (None when left out); ``why`` the reason it is left out
        (:data:`LINK_OUTSIDE`, :data:`LINK_LOOP`, :data:`LINK_BROKEN`, :data:`NOT_REGULAR`).
    """
    try:
        real = Path(os.path.realpath(path, strict=True))
    except OSError as exc:
        why = {errno.ELOOP: LINK_LOOP, errno.ENOENT: LINK_BROKEN}.get(exc.errno or 0, UNREADABLE)
        return "out", None, why
    if not real.is_relative_to(root):
        return "out", None, LINK_OUTSIDE
    try:
        mode = os.stat(real).st_mode
    except OSError:
        return "out", None, UNREADABLE
    if stat.S_ISREG(mode):
        return "file", real, None
    if stat.S_ISDIR(mode):
        return "dir", real, None
    return "out", None, NOT_REGULAR


@dataclass
class Listing:
    """The entries of one workspace folder, symlinks resolved, and what was left out.

    ``files`` and ``dirs`` are the entries' own paths (``folder/name``), sorted by name, each
    resolving inside the workspace; ``left_out`` is ``[{"name", "why"}]``; hidden entries
    (``.name``) are skipped without a word, as everywhere in vehval.
    """

    files: list[Path] = field(default_factory=list)
    dirs: list[Path] = field(default_factory=list)
    left_out: list[dict] = field(default_factory=list)


def list_folder(root: Path, folder: Path, *, max_entries: int = MAX_ENTRIES) -> Listing:
    """The regular files and folders of ``folder`` that resolve inside the workspace ``root``.

    At most ``max_entries`` entries are looked at (by name): a larger folder's listing says so
    in ``left_out``. A symlinked folder is listed (when inside) but never followed by
    :meth:`Workbench.tests`.
    """
    out = Listing()
    names: list[str] = []
    stopped = False
    try:
        with os.scandir(folder) as it:
            for entry in it:
                if len(names) >= 2 * max_entries:  # a folder this large is not one test
                    stopped = True
                    break
                names.append(entry.name)
    except OSError as exc:
        out.left_out.append({"name": folder.name, "why": f"{UNREADABLE}: {exc.strerror or exc}"})
        return out
    names = sorted(n for n in names if not n.startswith("."))
    if len(names) > max_entries:
        more = f"more than {len(names) - max_entries:,}" if stopped else \
            f"{len(names) - max_entries:,}"
        out.left_out.append({"name": f"({more} more entries)",
                             "why": f"too many files: at most {max_entries:,} entries of a "
                                    "folder are listed"})
        names = names[:max_entries]
    for name in names:
        kind, _, why = classify(root, folder / name)
        if kind == "file":
            out.files.append(folder / name)
        elif kind == "dir":
            out.dirs.append(folder / name)
        else:
            out.left_out.append({"name": name, "why": why})
    out.left_out = bounded_left_out(out.left_out)
    return out


def bounded_left_out(items: list[dict], most: int = MAX_NAMED) -> list[dict]:
    """``items`` (``{"name", "why"}``) with at most ``most`` named; the rest counted in one."""
    if len(items) <= most:
        return items
    return [*items[:most - 1], {"name": f"({len(items) - most + 1:,} more)",
                                "why": "left out for the reasons above (not all named)"}]


def regular_file(root: Path, path: Path, label: str) -> Path | None:
    """``path`` resolved when it is a regular file inside the workspace; None when absent.

    Raises
    ------
    OutsideWorkspace
        ``path`` is a symlink leading out of the workspace (nothing of it is read).
    InputFileError
        A symlink loop, a broken link, or not a regular file.
    """
    if not os.path.lexists(path):
        return None
    kind, real, why = classify(root, path)
    if kind == "file":
        return real
    if why == LINK_OUTSIDE:
        raise OutsideWorkspace(f"{label}: {LINK_OUTSIDE}: refused (make it a file of the test "
                               "folder)")
    raise InputFileError(f"{label}: {why or 'a folder, a file is expected'}: refused")


def vehicle_inside(root: Path, name: str | None, label: str = "template.yaml") -> None:
    """Refuse a template's vehicle that is a file outside the workspace ``root`` (a shipped
    name is no file of the user's: allowed). A vehicle file is named as the command line
    names it: a path ending ``.yaml``/``.yml`` or an existing path (relative: from the
    directory the server started in); an absolute path or a ``..`` step is checked whether
    or not it exists, so a refusal says nothing of the file.

    Raises
    ------
    OutsideWorkspace
        The vehicle file resolves outside the workspace (nothing of it is read).
    """
    if not name:
        return
    path = Path(name)
    if not (path.is_absolute() or ".." in path.parts or path.suffix in (".yaml", ".yml")
            or path.exists()):
        return
    if not Path(os.path.realpath(path)).is_relative_to(root):
        raise OutsideWorkspace(f"{label}: vehicle: {name[:200]}: a vehicle file "
                               "outside the workspace: refused (put the vehicle file in "
                               "the workspace folder, or name a shipped vehicle)")


def check_workspace(root: Path) -> Path:
    """``root`` (resolved) when it may be a workspace: not the filesystem root, not the
    user's home directory nor a folder holding it (the workbench would list everything).

    Raises
    ------
    InputFileError
        The one line the CLI prints (exit 2).
    """
    if root == Path(root.anchor):
        raise InputFileError(f"{root}: the filesystem root cannot be the workspace: give the "
                             "folder holding your tests (vehval serve FOLDER)")
    try:
        home = Path.home().resolve()
    except (RuntimeError, KeyError, OSError):  # no home directory known
        return root
    if home == root or home.is_relative_to(root):
        what = "your home directory" if home == root else "a folder holding your home directory"
        raise InputFileError(f"{root}: is {what}: it cannot be the workspace: give the "
                             "folder holding your tests (vehval serve FOLDER)")
    return root


def same_origin(origin: str, scheme: str, host_header: str | None) -> bool:
    """True when the ``Origin`` header names the server's own scheme, host and port.

    ``Origin: null`` (a sandboxed page, a file) and a page on another port of this machine are
    other origins.
    """
    if not host_header:
        return False
    try:
        o = urlsplit(origin.strip())
        h = urlsplit(f"{scheme}://{host_header.strip()}")
        default = {"http": 80, "https": 443}.get(scheme)
        return (o.scheme.lower() == scheme.lower() and o.hostname is not None
                and o.hostname == h.hostname and (o.port or default) == (h.port or default)
                and not o.path.strip("/") and not o.query)
    except ValueError:  # a port that is not a number
        return False


def relative(root: Path, path: Path) -> str:
    """``path`` relative to the workspace, ``/``-separated (``"."`` for the workspace).

    ``path`` is the path as listed (its symlinks are not resolved: the caller checked it)."""
    rel = Path(os.path.abspath(path)).relative_to(root).as_posix()
    return rel or "."
