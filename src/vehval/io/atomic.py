"""Atomic output: a failed run leaves no half-written file or directory."""

from __future__ import annotations

import contextlib
import ctypes
import errno
import os
import shutil
import sys
import tempfile
from pathlib import Path
from typing import Iterator


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; on success it replaces ``path`` atomically.

    On error the temporary file is removed and ``path`` is left untouched.
    """
    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
    os.close(fd)
    tmp_path = Path(tmp)
    try:
        yield tmp_path
        if tmp_path.exists():
            os.chmod(tmp_path, 0o666 & ~_umask())
        os.replace(tmp_path, target)
    except BaseException:
        tmp_path.unlink(missing_ok=True)
        raise


def write_text_atomic(path: str | os.PathLike, text: str) -> None:
    """Write ``text`` (UTF-8) to ``path`` atomically."""
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")


#: Name of the staging directories of :func:`atomic_dir`: ``.<name>.vehval-stage.<pid>.<rand>``.
_STAGE_TAG = ".vehval-stage."


def _rename_exchange(a: Path, b: Path) -> bool:
    """Atomically swap the paths ``a`` and ``b`` (Linux ``renameat2(RENAME_EXCHANGE)``).

    Returns False when the system cannot (the caller then falls back to two renames)."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        fn = libc.renameat2
    except (OSError, AttributeError):
        return False
    fn.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_uint]
    at_fdcwd, rename_exchange = -100, 2
    if fn(at_fdcwd, os.fsencode(a), at_fdcwd, os.fsencode(b), rename_exchange) == 0:
        return True
    err = ctypes.get_errno()
    if err in (errno.EINVAL, errno.ENOSYS, errno.EPERM, errno.ENOTSUP):
        return False
    raise OSError(err, os.strerror(err), str(b))


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def clean_stale_stages(target: str | os.PathLike) -> list[Path]:
    """Remove the staging directories that killed runs left beside ``target``.

    A staging directory belongs to a killed run when its process id (in its name) is no
    longer alive. Returns the directories removed."""
    target = Path(target)
    removed: list[Path] = []
    if not target.parent.is_dir():
        return removed
    prefix = f".{target.name}{_STAGE_TAG}"
    for p in target.parent.iterdir():
        if not p.name.startswith(prefix) or p.is_symlink() or not p.is_dir():
            continue
        pid = p.name[len(prefix):].split(".", 1)[0]
        if pid.isdigit() and int(pid) != os.getpid() and _alive(int(pid)):
            continue
        shutil.rmtree(p, ignore_errors=True)
        removed.append(p)
    return removed


def _carry_over(old: Path, stage: Path) -> None:
    """Hard-link (else copy) into ``stage`` what ``old`` holds and the run did not write, so
    files of other commands (``control.json`` beside ``findings.json``) survive the swap."""
    for item in sorted(old.iterdir()):
        dest = stage / item.name
        if dest.exists() or dest.is_symlink():
            continue
        if item.is_symlink():
            os.symlink(os.readlink(item), dest)
        elif item.is_dir():
            shutil.copytree(item, dest, symlinks=True, copy_function=_link_or_copy)
        else:
            _link_or_copy(item, dest)


def _link_or_copy(src, dst) -> None:
    try:
        os.link(src, dst)
    except OSError:
        shutil.copy2(src, dst)


def _move_files(stage: Path, target: Path) -> None:
    target.mkdir(parents=True, exist_ok=True)
    for item in sorted(stage.rglob("*")):
        dest = target / item.relative_to(stage)
        if item.is_dir():
            dest.mkdir(parents=True, exist_ok=True)
        else:
            dest.parent.mkdir(parents=True, exist_ok=True)
            os.replace(item, dest)


@contextlib.contextmanager
def atomic_dir(path: str | os.PathLike, *, whole: bool = True) -> Iterator[Path]:
    """Yield a staging directory; on success it replaces ``path`` as a whole, in one step.

    The run writes every output into the staging directory; entries of an existing
    ``path`` that the run did not write are carried over (hard links); then the staging
    directory and ``path`` are exchanged atomically, so a reader (or a run killed at any
    point) sees either the whole old directory or the whole new one. On error the staging
    directory is removed and ``path`` is untouched; staging directories of killed runs are
    removed by the next run on the same ``path``.

    With ``whole=False`` (a report written into a folder the user chose, possibly the
    current directory) the staged files are moved in one by one instead: each file is
    atomic, the set is not.
    """
    target = Path(os.path.abspath(path))
    if Path.cwd() == target or Path.cwd().is_relative_to(target):
        whole = False            # never swap away the directory the process stands in
    target.parent.mkdir(parents=True, exist_ok=True)
    clean_stale_stages(target)
    stage = Path(tempfile.mkdtemp(prefix=f".{target.name}{_STAGE_TAG}{os.getpid()}.",
                                  dir=target.parent))
    try:
        yield stage
        os.chmod(stage, 0o777 & ~_umask())
        if not whole:
            _move_files(stage, target)
        elif target.is_dir() and not target.is_symlink():
            _carry_over(target, stage)
            if not _rename_exchange(stage, target):
                old = stage.with_name(stage.name + ".old")
                os.rename(target, old)          # fallback: two renames (not one step)
                os.rename(stage, target)
                stage = old
        else:
            os.rename(stage, target)
    finally:
        shutil.rmtree(stage, ignore_errors=True)
