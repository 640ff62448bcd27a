"""Start-up of the CLI: `vehval --help` and the help of every command load only typer and
the light command modules; a command imports its libraries when it runs.

Checked on the modules a fresh interpreter imports (``-X importtime`` and ``sys.modules``
in a subprocess), not on time, which depends on the machine.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

SRC = Path(__file__).resolve().parents[1] / "src"

#: Libraries that cost tenths of a second each to import; never needed to print help.
HEAVY = ("numpy", "pandas", "numba", "scipy", "pyarrow", "duckdb", "dask", "plotly", "pint",
         "pydantic", "yaml", "jinja2", "asammdf", "xlsxwriter", "distributed", "llvmlite")


def _env() -> dict[str, str]:
    return dict(os.environ, PYTHONPATH=os.pathsep.join([str(SRC), *sys.path]))


def _imported_modules(*args: str) -> tuple[set[str], subprocess.CompletedProcess]:
    """Modules imported by ``python -X importtime -m vehval ARGS`` (read from its report)."""
    proc = subprocess.run([sys.executable, "-X", "importtime", "-m", "vehval", *args],
                          capture_output=True, text=True, env=_env(), timeout=120)
    names = {line.rsplit("|", 1)[1].strip() for line in proc.stderr.splitlines()
             if line.startswith("import time:") and "|" in line}
    return names - {"package"}, proc


def _heavy(names: set[str], allowed: tuple[str, ...] = ()) -> list[str]:
    return sorted(n for n in names if n.split(".")[0] in HEAVY and n.split(".")[0] not in allowed)


def test_help_imports_no_heavy_library() -> None:
    names, proc = _imported_modules("--help")
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "Usage: vehval" in proc.stdout and "cycles" in proc.stdout
    assert "vehval.cli.commands_cycles" in names  # every command is registered ...
    assert _heavy(names) == []                    # ... without its libraries
    assert not any(n.startswith("rich") for n in names), "typer imported rich for --help"


#: A command of every module (a group's help and a sub-command's).
COMMANDS = [["simulate"], ["validate"], ["calibrate"], ["qa"], ["report"], ["batch"],
            ["epa", "validate"], ["identify"], ["predict"], ["synth"], ["sensitivity"],
            ["import"], ["info"], ["signals"], ["results"], ["analyze"], ["cycles"],
            ["cycles", "show"], ["vehicle", "show"], ["catalog", "query"], ["template", "init"]]


def _modules_after(*argvs: list[str]) -> tuple[set[str], str]:
    """``sys.modules`` of one interpreter once ``vehval ARGV`` ran for every ARGV."""
    code = ("import sys\nfrom vehval.cli import main\nrc = 0\n"
            f"for argv in {list(argvs)!r}:\n    rc = rc or main(argv)\n"
            "print('MODULES', ' '.join(sorted(sys.modules)))\nsys.exit(rc)")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env=_env(), timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]
    line = next(x for x in proc.stdout.splitlines() if x.startswith("MODULES "))
    return set(line.split()[1:]), proc.stdout


def test_sys_modules_after_help() -> None:
    """The same seen from inside the process: ``sys.modules`` once the help is printed."""
    names, out = _modules_after(["--help"])
    assert "Usage: vehval" in out
    assert _heavy(names) == []


def test_command_helps_import_no_heavy_library() -> None:
    names, out = _modules_after(*[[*c, "--help"] for c in COMMANDS])
    assert out.count("Usage: vehval") == len(COMMANDS)
    # typer (>= 0.2x) checks option values with pydantic as soon as it parses a command line
    assert _heavy(names, allowed=("pydantic",)) == []


def test_cycles_list_needs_numpy_only() -> None:
    """`vehval cycles list` reads the package cycles (numpy) without the unit registry
    (pint), the data frames or the simulator; pydantic comes with typer's option parsing."""
    names, proc = _imported_modules("cycles", "list", "--json")
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert '"name": "udds"' in proc.stdout
    assert "numpy" in names
    assert _heavy(names, allowed=("numpy", "pydantic")) == []
