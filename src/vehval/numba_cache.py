"""Where numba keeps vehval's compiled kernels, one directory per version of the sources.

numba's ``cache=True`` keys a cached kernel on its own file only: a kernel whose callee, or
whose index constants (generated from :mod:`vehval.sim.layout`), changed in another file
would be loaded stale. So the cache directory is named after a fingerprint of every module
of the package (path, size, modification time) and of the numba and Python versions; a
changed source gets a fresh directory and the three most recent are kept.

Base directory: ``$VEHVAL_NUMBA_CACHE``, else ``$NUMBA_CACHE_DIR``, else
``~/.cache/vehval/numba``. :func:`configure` must run before the first ``@njit(cache=True)``
decorator of the package executes: every compiled kernel of the package is decorated with
this module's :func:`njit`, which configures first. So numba is imported only by the modules
that hold kernels, when they are imported (a command that neither simulates nor replays the
engine rule never loads it).
"""

from __future__ import annotations

import hashlib
import os
import shutil
import sys
from pathlib import Path
from typing import Any

PACKAGE = Path(__file__).resolve().parent
KEEP = 3
_configured: str | None = None


def fingerprint(package: Path = PACKAGE) -> str:
    """16 hex digits identifying the package's sources and the numba/Python versions."""
    import numba

    h = hashlib.sha256(f"{numba.__version__}|{sys.version}".encode())
    for path in sorted(package.rglob("*.py")):
        st = path.stat()
        h.update(f"{path.relative_to(package)}|{st.st_size}|{st.st_mtime_ns}\n".encode())
    return h.hexdigest()[:16]


def base_dir() -> Path:
    """Root of vehval's numba caches (see the module docstring)."""
    env = os.environ.get("VEHVAL_NUMBA_CACHE") or os.environ.get("NUMBA_CACHE_DIR")
    return Path(env) if env else Path.home() / ".cache" / "vehval" / "numba"


def _prune(root: Path, keep: str) -> None:
    """Remove all but the ``KEEP`` most recently used fingerprint directories."""
    try:
        dirs = sorted((d for d in root.iterdir() if d.is_dir() and len(d.name) == 16),
                      key=lambda d: d.stat().st_mtime, reverse=True)
    except OSError:
        return
    for d in dirs[KEEP:]:
        if d.name != keep:
            shutil.rmtree(d, ignore_errors=True)


def configure() -> str:
    """Point numba's cache at this source version's directory; returns the directory.

    Falls back to numba's own default (next to the sources) when the base directory cannot
    be created. Idempotent.
    """
    global _configured
    if _configured is not None:
        return _configured
    from numba.core import config

    fp = fingerprint()
    root = base_dir()
    target = root / fp
    try:
        target.mkdir(parents=True, exist_ok=True)
        os.utime(target)
    except OSError:
        _configured = str(config.CACHE_DIR or "")  # type: ignore[attr-defined]  # set at run time
        return _configured
    _prune(root, fp)
    config.CACHE_DIR = str(target)  # type: ignore[attr-defined]  # numba reads it at run time
    _configured = str(target)
    return _configured


def njit(*args: Any, **kwargs: Any) -> Any:
    """numba's ``njit`` (same arguments) once the cache directory is configured.

    The package's kernels are decorated with it (``from vehval.numba_cache import njit``),
    so a kernel's module may be imported first, alone, and still be cached in this source
    version's directory.
    """
    configure()
    import numba

    return numba.njit(*args, **kwargs)


_announced: set[str] = set()


def is_cached(module: str, function: str, directory: str | Path | None = None) -> bool:
    """True when the cache holds a compiled ``module.function`` (numba's ``.nbi`` index).

    ``directory`` defaults to this source version's cache (:func:`configure`).
    """
    d = Path(directory if directory is not None else configure())
    if not d.is_dir():
        return False
    return any(True for _ in d.rglob(f"{module}.{function}-*.nbi"))


def compile_notice(module: str, function: str, what: str, *, stream=None,
                   directory: str | Path | None = None) -> bool:
    """Say once per process, on stderr, that ``what`` is compiled now (not in the cache).

    The first simulation after an install or a source change compiles the kernel (about
    20 s); this one line says so before the wait. Returns True when the line was written.
    """
    key = f"{module}.{function}"
    if key in _announced or is_cached(module, function, directory):
        return False
    _announced.add(key)
    out = stream if stream is not None else sys.stderr
    out.write(f"vehval: compiling the {what} (first run after an install or an update, "
              "about 20 s; cached for the next runs)\n")
    out.flush()
    return True
