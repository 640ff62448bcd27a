"""`vehval serve`: the local workbench over a workspace folder (docs/workbench.md)."""

from __future__ import annotations

from pathlib import Path

import typer

from vehval.cli.app import app
from vehval.cli.options import bounded


@app.command("serve")
def serve_cmd(
    workspace: Path = typer.Argument(Path("."), help="Workspace folder (default: the current one)."),
    port: int = typer.Option(8890, "--port", callback=bounded("port"), help="Port (0: any free port)."),
    host: str = typer.Option("127.0.0.1", "--host",
                             help="Address to listen on (default loopback only)."),
    no_browser: bool = typer.Option(False, "--no-browser", help="Do not open a browser."),
) -> None:
    """Start the workbench: template review, QA triage, catalog browser, model vs test.

    Prints a URL with its token (valid until the server stops); only files inside WORKSPACE are read or written.
    """
    from vehval.errors import ConfigError
    from vehval.io.paths import check_input_dir

    check_input_dir(workspace, "workspace")
    if host not in ("127.0.0.1", "localhost", "::1"):
        raise ConfigError(f"--host {host}: the workbench listens on this machine only "
                          "(127.0.0.1, localhost or ::1)")
    from vehval.serve.app import run_server

    run_server(workspace, host=host, port=port, open_browser=not no_browser, echo=typer.echo)
