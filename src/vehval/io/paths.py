"""One home for path policy: what a command may read, where it may write, how an id
becomes a file name.

- :func:`sanitize_id` is the only way a test id (from a folder name, a file name or any
  metadata) becomes part of a path: ``[A-Za-z0-9._-]`` only, no leading dot, never ``..``.
- :func:`check_input_file` / :func:`check_input_dir` refuse a directory where a file is
  expected (and the reverse), an unreadable file and a document that is not data (PDF,
  image, spreadsheet, archive), with one line naming the path.
- The output policy, one rule for every command that writes: an output file must be a
  regular file or absent, an output directory a directory or absent. A device node, a
  FIFO, a socket (or a symbolic link to one of them) is never replaced, and an output is
  never one of the run's inputs (the same file, hard links included).
  :func:`output_problem` states the rule, :func:`check_output_path` refuses one path (the
  CLI's output options call it while parsing, :mod:`vehval.io.atomic` again at the final
  rename) and :func:`check_outputs` refuses a command's outputs against its inputs.
"""

from __future__ import annotations

import contextlib
import os
import re
import stat
from pathlib import Path
from typing import Callable, Iterable

from vehval.errors import InputFileError, VehvalError

_ID_BAD = re.compile(r"[^A-Za-z0-9._-]+")
#: Longest id kept [characters] (file systems allow 255 bytes per name).
MAX_ID_LENGTH = 120

#: Leading bytes of documents that are not data files, with the name shown to the user.
NON_DATA_MAGIC: tuple[tuple[bytes, str], ...] = (
    (b"%PDF", "a PDF document"),
    (b"\x89PNG", "a PNG image"),
    (b"\xff\xd8\xff", "a JPEG image"),
    (b"GIF8", "a GIF image"),
    (b"PK\x03\x04", "a ZIP archive (or an XLSX/DOCX document)"),
    (b"PK\x05\x06", "an empty ZIP archive"),
    (b"\xd0\xcf\x11\xe0", "an MS Office document (XLS/DOC)"),
    (b"\x1f\x8b", "a gzip archive"),
    (b"7z\xbc\xaf", "a 7-Zip archive"),
    (b"Rar!", "a RAR archive"),
    (b"\x7fELF", "an executable"),
    (b"DUCK", "a DuckDB database"),
    (b"SQLite format 3", "an SQLite database"),
)


def sanitize_id(name: object, default: str = "test") -> str:
    """A test id safe as one path component: ``[A-Za-z0-9._-]``, no leading or trailing
    ``.``/``_``, at most :data:`MAX_ID_LENGTH` characters; ``default`` when nothing is left.

    ``'..'`` becomes ``default``, ``'../../etc'`` becomes ``'etc'``, ``'Prius c #3'`` becomes
    ``'Prius_c_3'``.
    """
    s = _ID_BAD.sub("_", str(name or "")).strip("._")[:MAX_ID_LENGTH].strip("._")
    return s or default


def non_data_kind(path: str | Path) -> str | None:
    """What ``path`` is when its first bytes say it is not a data file (else None)."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(16)
    except OSError:
        return None
    for magic, kind in NON_DATA_MAGIC:
        if head.startswith(magic):
            return kind
    return None


def check_input_file(path: str | Path, what: str = "data file", *, data: bool = True) -> Path:
    """``path`` as a readable regular file, or one clear :class:`InputFileError`.

    Parameters
    ----------
    path : str or Path
        The file given by the user.
    what : str
        What the file is for, in the message (``data file``, ``template``...).
    data : bool
        Also refuse documents that are not data (PDF, PNG, XLSX, ZIP...).
    """
    p = Path(path)
    if not p.exists():
        raise InputFileError(f"{p}: {what} not found: check the path")
    if p.is_dir():
        raise InputFileError(f"{p}: is a directory, a {what} is expected")
    if not p.is_file():
        raise InputFileError(f"{p}: not a regular file, a {what} is expected")
    try:
        with open(p, "rb") as fh:
            fh.read(1)
    except OSError as exc:
        raise InputFileError(f"{p}: cannot read the {what} ({exc.strerror or 'permission denied'})"
                             ) from None
    if data:
        kind = non_data_kind(p)
        if kind:
            raise InputFileError(f"{p}: is {kind}, not a {what}: give the test's data files "
                                 "(D3/CSV text, MDF4 or Parquet)")
    return p


def check_input_dir(path: str | Path, what: str = "directory") -> Path:
    """``path`` as a readable directory, or one clear :class:`InputFileError`."""
    p = Path(path)
    if not p.exists():
        raise InputFileError(f"{p}: {what} not found: check the path")
    if not p.is_dir():
        raise InputFileError(f"{p}: is a file, a {what} is expected")
    if not os.access(p, os.R_OK | os.X_OK):
        raise InputFileError(f"{p}: cannot read the {what} (permission denied)")
    return p


def inside(child: str | Path, parent: str | Path) -> bool:
    """Is ``child`` (resolved) ``parent`` or below it?"""
    try:
        Path(child).resolve().relative_to(Path(parent).resolve())
        return True
    except ValueError:
        return False


#: Kinds of file system node an output never replaces, by ``stat`` test.
_SPECIAL_NODES: tuple[tuple[Callable[[int], bool], str], ...] = (
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISFIFO, "a FIFO (named pipe)"),
    (stat.S_ISSOCK, "a socket"),
)


def output_problem(path: str | os.PathLike, *, directory: bool = False) -> str | None:
    """Why ``path`` cannot be written as an output, or None when it can.

    An output file may be absent or a regular file (a symbolic link to one: the link is
    replaced); an output directory absent or a directory. Anything else, a device node, a
    FIFO, a socket or a symbolic link to one of them, would be destroyed by the rename that
    commits the output (a device node of ``/dev`` replaced by a regular file) and is refused.
    A dangling symbolic link is replaced like a file. Paths the system cannot look at (a
    parent that is a file, a name too long) are left to the write, which fails with its
    own message.
    """
    try:
        st = os.lstat(path)
    except OSError:
        return None
    link = stat.S_ISLNK(st.st_mode)
    if link:
        try:
            st = os.stat(path)
        except OSError:
            return None                  # dangling link or loop: the link itself is replaced
    what = "a symbolic link to " if link else ""
    mode = st.st_mode
    for test, kind in _SPECIAL_NODES:
        if test(mode):
            return (f"is {what}{kind}, not {'a directory' if directory else 'a regular file'}"
                    ": writing the output would replace it")
    if directory and not stat.S_ISDIR(mode):
        return f"exists and is {what}a file, not a directory"
    if not directory and stat.S_ISDIR(mode):
        return f"is {what}a directory, a file name is expected"
    return None


def check_output_path(path: str | Path, option: str = "-o", *, directory: bool = False) -> Path:
    """``path`` if it may be written as an output (see :func:`output_problem`), else one
    :class:`VehvalError` line naming ``option`` and the path."""
    problem = output_problem(path, directory=directory)
    if problem:
        what = "an output directory" if directory else "the path of a new or regular file"
        raise VehvalError(f"{option} {path}: {problem}; give {what} (nothing was written)")
    return Path(path)


def _same_file(a: os.stat_result, b: os.stat_result) -> bool:
    return (a.st_dev, a.st_ino) == (b.st_dev, b.st_ino)


def shared_file(paths: Iterable[str | Path | None],
                others: Iterable[str | Path | None]) -> tuple[Path, Path] | None:
    """The first ``(path, other)`` naming one file (same device and inode: a symbolic or
    hard link to a file is that file), or None; paths that do not exist are skipped."""
    def stats(ps: Iterable[str | Path | None]) -> list[tuple[Path, os.stat_result]]:
        out = []
        for p in ps:
            if p is not None:
                with contextlib.suppress(OSError):
                    out.append((Path(p), os.stat(p)))
        return out

    mine = stats(paths)
    for o, so in stats(others):
        for p, sp in mine:
            if _same_file(sp, so):
                return p, o
    return None


def check_outputs(*, outdir: str | Path | None = None, writes: Iterable[str] = (),
                  outfile: str | Path | None = None,
                  inputs: Iterable[str | Path | None] = (), option: str = "-o") -> None:
    """Refuse outputs that would destroy what the run reads, or a device, FIFO or socket,
    before anything is computed.

    Parameters
    ----------
    outdir : path, optional
        An output directory: absent or a directory, and not one of the inputs.
    writes : names
        The files the run writes into ``outdir``; each must be absent or a regular file and
        none of them an input (a ``template_final.yaml`` given as ``-t``).
    outfile : path, optional
        An output file: absent or a regular file, and not one of the inputs.
    inputs : paths
        Every file or directory the run reads (None entries are ignored). An output is the
        same as an input when both name one file (same device and inode: a symbolic or hard
        link to the input is the input).
    option : str
        The option that names the output, for the message.
    """
    targets: list[Path] = []
    if outdir is not None:
        d = check_output_path(outdir, option, directory=True)
        targets += [d] + [check_output_path(d / name, option) for name in writes]
    if outfile is not None:
        targets.append(check_output_path(outfile, option))
    read = list(inputs)
    for t in targets:  # in order: the first output that is an input is named
        same = shared_file(read, [t])
        if same is not None:
            raise VehvalError(f"{option} {t}: is also an input ('{same[0]}'): writing it would "
                              f"replace the input; choose another {option}")


def vehicle_path(name: str | Path | None) -> Path | None:
    """The file behind a ``--vehicle``/``--cycle`` value when it names an existing file
    (a shipped name such as ``prius_2004`` is not a path: None)."""
    if name is None:
        return None
    p = Path(str(name))
    return p if p.exists() else None


def special_kind(path: str | Path) -> str | None:
    """What ``path`` (a symlink followed) is when it is neither a regular file nor a directory:
    a FIFO, a socket, a character or block device (the words of :data:`_SPECIAL_NODES`); None
    otherwise (also when it cannot be stat'ed: the caller reports that itself). Reading a
    FIFO blocks until a writer comes, a device may never end: inputs are regular files."""
    try:
        mode = Path(path).stat().st_mode
    except OSError:
        return None
    return next((kind for test, kind in _SPECIAL_NODES if test(mode)), None)
