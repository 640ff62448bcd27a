"""Command-line interface: a thin layer over the library.

Each command group lives in its own module and registers itself on :data:`app`.
"""

from __future__ import annotations

import os
import sys

import typer

try:  # typer >= 0.20 vendors click
    from typer._click import exceptions as _cx
except ImportError:  # pragma: no cover
    from click import exceptions as _cx  # type: ignore[no-redef]  # the same module, from click

from vehval.cli.app import app  # noqa: E402 - the application the commands register on
from vehval.errors import VehvalError
from vehval.io.budget import system_allocator_under_limit


def _register() -> None:
    # Imported on first use: each module registers its commands on `app` (vehval.cli.app).
    # the order of registration is the order of `vehval --help`
    # isort: off
    from vehval.cli import (
        commands_analyze,  # noqa: F401
        commands_batch,  # noqa: F401
        commands_cycles,  # noqa: F401
        commands_epa,  # noqa: F401
        commands_fleet,  # noqa: F401 - registers on the epa group
        commands_identify,  # noqa: F401
        commands_predict,  # noqa: F401
        commands_import,  # noqa: F401
        commands_precision,  # noqa: F401
        commands_qa,  # noqa: F401
        commands_report,  # noqa: F401
        commands_results,  # noqa: F401
        commands_sensitivity,  # noqa: F401
        commands_serve,  # noqa: F401
        commands_sim,  # noqa: F401
        commands_synth,  # noqa: F401
        commands_validate,  # noqa: F401
    )
    # isort: on


def main(argv: list[str] | None = None) -> int:
    """Entry point: run the CLI, turn user errors into one clear line and an exit code.

    ``--units`` is in force for this run only: the unit system the caller's environment
    had is restored afterwards (an in-process caller runs several commands)."""
    from vehval.constants import UNITS_ENV_VAR as ENV_VAR

    system_allocator_under_limit()
    before = os.environ.get(ENV_VAR)
    try:
        return _main(argv)
    finally:
        if before is None:
            os.environ.pop(ENV_VAR, None)
        else:
            os.environ[ENV_VAR] = before


def _main(argv: list[str] | None) -> int:
    _register()
    args = list(sys.argv[1:] if argv is None else argv)
    try:
        rc = app(args=args, standalone_mode=False, prog_name="vehval")
        if isinstance(rc, int) and rc:  # typer.Exit(n) is returned, not raised, here
            return rc
    except VehvalError as exc:
        typer.echo(f"vehval: error: {exc}", err=True)
        return exc.exit_code
    except typer.Exit as exc:
        return exc.exit_code
    except typer.Abort:
        typer.echo("vehval: aborted", err=True)
        return 130
    except _cx.ClickException as exc:
        exc.show()
        return exc.exit_code
    except SystemExit as exc:
        code = exc.code
        return code if isinstance(code, int) else (0 if code is None else 1)
    except BrokenPipeError:
        return 0
    except OSError as exc:  # the file system refused: a path too long, no space, no permission
        name = str(exc.filename or "")
        name = name if len(name) <= 120 else name[:117] + "..."
        typer.echo(f"vehval: error: {name + ': ' if name else ''}{exc.strerror or exc} "
                   "(check the path, its permissions and the free space)", err=True)
        return 2
    except KeyboardInterrupt:
        typer.echo("vehval: interrupted", err=True)
        return 130
    except Exception as exc:  # noqa: BLE001 - last line of defence: never a bare traceback
        if os.environ.get("VEHVAL_DEBUG"):
            raise
        typer.echo(f"vehval: internal error: {type(exc).__name__}: {exc} "
                   "(set VEHVAL_DEBUG=1 for the traceback and please report it)", err=True)
        return 3
    return 0


def run() -> None:  # pragma: no cover - console script wrapper
    sys.exit(main())
