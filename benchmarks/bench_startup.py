"""CLI start-up: `vehval --help` and `vehval cycles list` in a fresh interpreter, against
`python -c pass` (the interpreter's own start-up) in the same run.

Each command runs as a subprocess of the benchmark's interpreter, with the package sources
the benchmark itself imports first on ``PYTHONPATH``; the time is the best of 5 wall times
of the whole process (start, imports, output, exit) after one untimed warm-up run that
fills the OS file cache. The ratio says how many interpreter start-ups the command costs:
the help loads typer and the light command modules only, `cycles list` adds numpy and the
package cycle files (no unit registry, data frames or simulator).
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

from benchmarks.common import best_of, row

#: Goals [s] on the reference machine (2 cores): the ratio targets below follow from them
#: with an interpreter start-up of about 20 ms.
HELP_TARGET_S, CYCLES_TARGET_S = 0.3, 0.6


def _runner(args: list[str]):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in sys.path if p))
    env.pop("VEHVAL_DEBUG", None)

    def run() -> None:
        subprocess.run(args, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                       check=True, timeout=120)
    return run


def run() -> list[dict]:
    py = sys.executable
    t_pass = best_of(_runner([py, "-c", "pass"]), n=5)
    rows = []
    t_help = best_of(_runner([py, "-m", "vehval", "--help"]), n=5)
    rows.append(row("cli_help_startup", t_help, "s", baseline=t_pass, target=15.0,
                    note=f"python -m vehval --help (goal {HELP_TARGET_S} s); baseline "
                         "python -c pass"))
    t_list = best_of(_runner([py, "-m", "vehval", "cycles", "list"]), n=5)
    rows.append(row("cli_cycles_list_startup", t_list, "s", baseline=t_pass, target=30.0,
                    note=f"python -m vehval cycles list (goal {CYCLES_TARGET_S} s); baseline "
                         "python -c pass"))
    script = Path(py).with_name("vehval")
    if script.is_file():
        t_script = best_of(_runner([str(script), "--help"]), n=5)
        rows.append(row("cli_help_startup_entry_point", t_script, "s", baseline=t_pass,
                        target=15.0, note="the installed `vehval --help` console script; "
                                          "baseline python -c pass"))
    return rows
