"""Progress of long library work, reported to whoever listens (the CLI's progress bar).

A library loop announces its steps with :func:`add` and reports each one done with
:func:`advance`; both do nothing unless a listener was installed with :func:`listening`
(the CLI does, for a command on a terminal). No output, no global setting: the listener is
a context variable of the running command.
"""

from __future__ import annotations

from contextlib import contextmanager
from contextvars import ContextVar
from typing import Any, Iterator, Protocol

__all__ = ["Listener", "add", "advance", "bar", "listening"]


class Listener(Protocol):
    """Receives the steps of long work."""

    def add(self, steps: int) -> None:
        """``steps`` more steps are to come."""

    def advance(self, steps: int = 1) -> None:
        """``steps`` steps are done."""


_listener: ContextVar[Listener | None] = ContextVar("vehval_progress", default=None)


def add(steps: int) -> None:
    """Announce ``steps`` more steps of work (no effect without a listener)."""
    lis = _listener.get()
    if lis is not None and steps > 0:
        lis.add(int(steps))


def advance(steps: int = 1) -> None:
    """Report ``steps`` steps done (no effect without a listener)."""
    lis = _listener.get()
    if lis is not None:
        lis.advance(int(steps))


@contextmanager
def listening(listener: Listener | None) -> Iterator[None]:
    """Install ``listener`` for the work run inside the block."""
    token = _listener.set(listener)
    try:
        yield
    finally:
        _listener.reset(token)


def bar(label: str, *, extra: tuple[str, ...] = (), **kwargs: Any) -> Any:
    """The package's one progress-bar layout (rich, imported on use): ``label``, the bar,
    done / total, ``extra`` text columns, elapsed time and the ETA. ``kwargs`` go to
    :class:`rich.progress.Progress` (``console``, ``transient``, ``disable``...)."""
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    return Progress(TextColumn(label), BarColumn(), MofNCompleteColumn(),
                    *(TextColumn(e) for e in extra), TimeElapsedColumn(), TextColumn("ETA"),
                    TimeRemainingColumn(), **kwargs)
