"""Atomic output: a failed run leaves no half-written file or directory.

Every temporary carries the id of the process that made it: a file
``.<name>.vehval-tmp.<pid>.<rand>.tmp`` (:func:`atomic_path`) or a staging directory
``.<name>.vehval-stage.<pid>.<rand>`` (:func:`atomic_dir`, :func:`atomic_files`). Those of a
process that is no longer alive are debris of a killed run; :func:`clean_stale_stages` and
:func:`sweep_debris` remove them.

Every final rename re-checks its target at commit time (:func:`check_commit_target`, the
output policy of :mod:`vehval.io.paths`): a file is never renamed over a device node, a
FIFO, a socket or a directory that appeared while the run computed.
"""

from __future__ import annotations

import contextlib
import ctypes
import errno
import json
import os
import shutil
import stat
import sys
import tempfile
from pathlib import Path
from typing import Iterator, Sequence


def check_commit_target(target: str | os.PathLike, *, directory: bool = False) -> None:
    """Refuse, at commit time, a target the output policy does not allow to be replaced
    (:func:`vehval.io.paths.output_problem`): one :class:`VehvalError` line, nothing renamed."""
    from vehval.errors import VehvalError
    from vehval.io.paths import output_problem

    problem = output_problem(target, directory=directory)
    if problem:
        what = "an output directory" if directory else "the path of a new or regular file"
        raise VehvalError(f"{target}: {problem}; the output was not written (give {what})")


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
    # temporaries of killed runs (a live process's, this one's included, are left alone)
    _remove_debris([p for p in _stale_beside(target, own=False) if p.is_file()])
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}{_TMP_TAG}{os.getpid()}.", suffix=".tmp",
                               dir=target.parent)
    os.close(fd)
    tmp_path = Path(tmp)
    try:
        yield tmp_path
        if tmp_path.exists():
            os.chmod(tmp_path, 0o666 & ~_umask())
        check_commit_target(target)
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
#: Name of the temporary files of :func:`atomic_path`: ``.<name>.vehval-tmp.<pid>.<rand>.tmp``.
_TMP_TAG = ".vehval-tmp."
#: File in a staging directory of :func:`atomic_files` listing its renames once committed.
_COMMIT = ".vehval-commit.json"


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


def _owner(name: str) -> int | None:
    """Process id in the name of a staging directory or temporary; None when not one."""
    for tag in (_STAGE_TAG, _TMP_TAG):
        if name.startswith(".") and tag in name:
            pid = name.rsplit(tag, 1)[1].split(".", 1)[0]
            return int(pid) if pid.isdigit() else None
    return None


def is_debris(p: Path) -> bool:
    """Is ``p`` a staging directory or temporary of a process that is no longer alive?"""
    pid = _owner(p.name)
    return pid is not None and not p.is_symlink() and pid != os.getpid() and not _alive(pid)


def _remove_debris(items: list[Path]) -> None:
    """Remove dead staging directories and temporaries; committed stagings of
    :func:`atomic_files` are completed first (before any of their siblings goes)."""
    for p in items:
        if p.is_dir():
            _roll_forward(p)
    for p in items:
        if p.is_dir():
            shutil.rmtree(p, ignore_errors=True)
        else:
            p.unlink(missing_ok=True)


def _stale_beside(target: Path, own: bool = True) -> list[Path]:
    if not target.parent.is_dir():
        return []
    prefixes = (f".{target.name}{_STAGE_TAG}", f".{target.name}{_TMP_TAG}")
    out = []
    for p in sorted(target.parent.iterdir()):
        if not p.name.startswith(prefixes) or p.is_symlink():
            continue
        pid = _owner(p.name)
        if pid is not None and (pid != os.getpid() or not own) and _alive(pid):
            continue
        out.append(p)
    return out


def clean_stale_stages(*targets: str | os.PathLike) -> list[Path]:
    """Remove the staging directories and temporaries that killed runs left beside each
    of ``targets``.

    They belong to a killed run when the process id in their name is no longer alive (or
    is this process: one run per process and target). A staging directory of
    :func:`atomic_files` whose commit had begun is completed first. Returns what was removed."""
    found = [p for t in targets for p in _stale_beside(Path(t))]
    _remove_debris(found)
    return found


def _debris(root: Path, depth: int) -> list[Path]:
    if not root.is_dir() or root.is_symlink():
        return []
    out: list[Path] = []
    for p in sorted(root.iterdir()):
        if is_debris(p):
            out.append(p)
        elif depth > 0 and p.is_dir() and not p.is_symlink():
            out += _debris(p, depth - 1)
    return out


def sweep_debris(directory: str | os.PathLike, depth: int = 1) -> list[Path]:
    """Remove every staging directory and temporary of a dead process in ``directory`` and
    its subdirectories down to ``depth`` levels (0: the directory alone); returns them."""
    found = _debris(Path(directory), depth)
    _remove_debris(found)
    return found


def _carry_over(old: Path, stage: Path) -> None:
    """Hard-link (else copy) into ``stage`` what ``old`` holds and the run did not write, so
    files of other commands (``control.json`` beside ``findings.json``) survive the swap."""
    for item in sorted(old.iterdir()):
        dest = stage / item.name
        if dest.exists() or dest.is_symlink() or _owner(item.name) is not None:
            continue                    # written by the run, or another run's temporary
        if item.is_symlink():
            os.symlink(os.readlink(item), dest)
        elif item.is_dir():
            shutil.copytree(item, dest, symlinks=True, copy_function=_link_or_copy)
        else:
            _link_or_copy(item, dest)


def _link_or_copy(src, dst) -> None:
    """Hard-link ``src`` to ``dst``, else copy a regular file; a device node, FIFO or socket
    is linked, never opened (copying ``/dev/zero`` would never end): one that cannot be
    linked stops the commit, and the directory holding it is left as it was."""
    try:
        os.link(src, dst)
    except OSError as exc:
        if not stat.S_ISREG(os.lstat(src).st_mode):
            from vehval.errors import VehvalError

            raise VehvalError(f"{src}: not a regular file and cannot be carried over into the "
                              f"new output directory ({exc.strerror}); move it out of the "
                              "output directory") from None
        shutil.copy2(src, dst)


def _move_files(stage: Path, target: Path) -> None:
    items = sorted(stage.rglob("*"))
    for item in items:                  # every target checked before the first move
        if not item.is_dir():
            check_commit_target(target / item.relative_to(stage))
    target.mkdir(parents=True, exist_ok=True)
    for item in items:
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
        check_commit_target(target, directory=True)
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


def _roll_forward(stage: Path) -> None:
    """Finish the renames of a committed :func:`atomic_files` staging directory (a run killed
    in the middle of its commit): every file still staged goes to its target."""
    try:
        plan = json.loads((stage / _COMMIT).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return                          # not committed: the run's outputs are dropped
    from vehval.io.paths import output_problem

    for staged, target in plan if isinstance(plan, list) else ():
        src = Path(staged)
        if src.is_file() and not src.is_symlink() and output_problem(target) is None:
            with contextlib.suppress(OSError):
                os.replace(src, target)


@contextlib.contextmanager
def atomic_files(paths: Sequence[str | os.PathLike]) -> Iterator[list[Path]]:
    """Yield staged paths for several output files written as one unit.

    The run writes each output to its staged path (in a staging directory beside the
    target, as :func:`atomic_dir`). On success the commit is recorded first (a list of the
    renames, written into the first staging directory), then every file is renamed onto its
    target. A run killed before the commit leaves the old files, and its staging directories
    are removed by the next run on the same targets; a run killed during the commit is
    completed by that next run (the remaining renames), so the set ends wholly old or wholly
    new, never a new file beside an old one. On error nothing is written.
    """
    targets = [Path(os.path.abspath(p)) for p in paths]
    if len(set(targets)) != len(targets):
        raise ValueError("atomic_files: the same output is given twice")
    stages: list[Path] = []
    try:
        for t in targets:
            t.parent.mkdir(parents=True, exist_ok=True)
        clean_stale_stages(*targets)
        for t in targets:
            stages.append(Path(tempfile.mkdtemp(prefix=f".{t.name}{_STAGE_TAG}{os.getpid()}.",
                                                dir=t.parent)))
        staged = [st / t.name for st, t in zip(stages, targets)]
        yield staged
        missing = [str(t) for s, t in zip(staged, targets) if not s.is_file()]
        if missing:
            raise FileNotFoundError(errno.ENOENT, "output not written", missing[0])
        for s in staged:
            os.chmod(s, 0o666 & ~_umask())
        for t in targets:               # before the commit record: all renamed or none
            check_commit_target(t)
        commit = stages[0] / _COMMIT
        tmp = commit.with_name(commit.name + ".tmp")
        tmp.write_text(json.dumps([[str(s), str(t)] for s, t in zip(staged, targets)]),
                       encoding="utf-8")
        os.replace(tmp, commit)         # from here on the run counts as done
        for s, t in zip(staged, targets):
            os.replace(s, t)
    finally:
        for st in stages:
            shutil.rmtree(st, ignore_errors=True)
