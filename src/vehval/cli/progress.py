"""The progress bar of a long command: rich, on stderr, with the elapsed time and an ETA.

Shown only when stderr is a terminal and the command does not print JSON; otherwise the
command runs silently as before. The library reports its steps through
:mod:`vehval.progress`; a command wraps its work in :func:`bar`.
"""

from __future__ import annotations

import sys
from contextlib import contextmanager
from typing import Any, Iterator

from vehval import progress as _progress

__all__ = ["bar", "enabled"]


def enabled(as_json: bool = False) -> bool:
    """A bar is drawn: not under ``--json``, and stderr is a terminal."""
    return not as_json and sys.stderr.isatty()


class _RichListener:
    def __init__(self, prog: Any, task: Any) -> None:
        self.prog, self.task, self.total = prog, task, 0

    def add(self, steps: int) -> None:
        self.total += steps
        self.prog.update(self.task, total=self.total)

    def advance(self, steps: int = 1) -> None:
        self.prog.advance(self.task, steps)


@contextmanager
def bar(description: str, *, as_json: bool = False, show: bool | None = None) -> Iterator[None]:
    """Draw a progress bar for the work inside the block (see the module docstring).

    Parameters
    ----------
    description : str
        What runs (``simulating EPA tests``).
    as_json : bool
        The command prints JSON: no bar.
    show : bool, optional
        Force the bar on or off (default :func:`enabled`).
    """
    if not (enabled(as_json) if show is None else show):
        with _progress.listening(None):
            yield
        return
    from rich.console import Console

    with _progress.bar("{task.description}", console=Console(stderr=True),
                       transient=True) as prog:
        task = prog.add_task(description, total=None)
        with _progress.listening(_RichListener(prog, task)):
            yield
