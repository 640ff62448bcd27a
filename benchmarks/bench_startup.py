"""CLI start-up: `vehval --help` and `vehval cycles list` in a fresh interpreter, against
`python -c pass` (the interpreter's own start-up) in the same run.

Each command runs as a subprocess of the benchmark's interpreter, with the package sources
the benchmark itself imports first on ``PYTHONPATH``; the time is the best of 5 wall times
of the whole process (start, imports, output, exit) after one untimed warm-up run that
fills the OS file cache. The ratio says how many interpreter start-ups the command costs:
the help loads typer and the light command modules only, `cycles list` adds numpy and the
package cycle files (no unit registry, data frames or simulator).

Single-test commands on the Cruze D3 UDDS 61410013 (``info``, ``import``, ``results``,
``qa``, ``analyze``, ``report``; skipped without ../shared): the cold command (a fresh
process, as a user runs it) against its own compute time, the same command run again in a
process that already ran it once (libraries imported, kernels loaded). The difference is
what start-up costs the user; the goal is at most 1 s.

Byte code: the child processes write and reuse compiled byte code (in a private
``PYTHONPYCACHEPREFIX`` of the run, even when ``PYTHONDONTWRITEBYTECODE`` is set around the
benchmark), as an installed package has it; the warm-up run compiles the sources once.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from benchmarks.common import best_of, row

#: Goals [s] on the reference machine (2 cores): the ratio targets below follow from them
#: with an interpreter start-up of about 20 ms.
HELP_TARGET_S, CYCLES_TARGET_S = 0.3, 0.6
#: Start-up cost allowed on top of a single-test command's own compute time [s].
OVERHEAD_TARGET_S = 1.0
ROOT = Path(__file__).resolve().parents[1]
REAL = Path(os.environ.get("VEHVAL_SHARED_DATA", ROOT / ".." / "shared" / "data")) / "real"
CRUZE_UDDS = REAL / "d3_2014_chevrolet_cruze_diesel" / "61410013 Test Data.txt"
TEMPLATE = ROOT / "tests" / "qa" / "templates" / "cruze.yaml"
#: The timed second run inside one process (prints its wall time [s] on the last line).
_WARM = """import sys, time
from vehval.cli import main
args = sys.argv[1:]
main([a.replace("@RUN@", "1") for a in args])
t0, c0 = time.perf_counter(), time.process_time()
main([a.replace("@RUN@", "2") for a in args])
print("WARM", time.perf_counter() - t0, time.process_time() - c0)
"""


#: The run's byte-code cache directory (set by :func:`run`).
_PYCACHE = ""


def _env() -> dict[str, str]:
    """The child processes' environment: these sources first, byte code cached (docstring)."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in sys.path if p),
               PYTHONPYCACHEPREFIX=_PYCACHE)
    env.pop("VEHVAL_DEBUG", None)
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    return env


def _runner(args: list[str]):
    env = _env()

    def run() -> None:
        subprocess.run(args, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                       check=True, timeout=120)
    return run


def _commands(tmp: Path) -> list[tuple[str, list[str]]]:
    f, t, q = str(CRUZE_UDDS), str(TEMPLATE), str(tmp / "qa@RUN@")
    return [("info", ["info", f]),
            ("import", ["import", f, "-t", t, "-o", str(tmp / "imp@RUN@.parquet")]),
            ("results", ["results", f, "-t", t, "-o", str(tmp / "res@RUN@")]),
            ("qa", ["qa", f, "-t", t, "-o", q]),
            ("analyze", ["analyze", f, "-t", t, "-o", str(tmp / "an@RUN@")]),
            ("report", ["report", str(tmp / "qa1"), "-o", str(tmp / "rep@RUN@.html"),
                        "--no-excel"])]


def _child_cpu() -> float:
    """CPU time [s] (user + system) of the finished child processes so far."""
    import resource

    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def _overheads(env: dict) -> list[dict]:
    """Cold command wall time against its warm compute time (see the module docstring)."""
    rows = []
    py = sys.executable
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        for name, args in _commands(tmp):
            out = subprocess.run([py, "-c", _WARM, *args], env=env, capture_output=True,
                                 text=True, check=True, timeout=600)
            _, warm, warm_cpu = out.stdout.strip().splitlines()[-1].split()
            cold = cold_cpu = float("inf")
            for k in range(3):
                cargs = [a.replace("@RUN@", f"c{k}") for a in args]
                t0, c0 = time.perf_counter(), _child_cpu()
                subprocess.run([py, "-m", "vehval", *cargs], env=env, check=True,
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, timeout=600)
                cold = min(cold, time.perf_counter() - t0)
                cold_cpu = min(cold_cpu, _child_cpu() - c0)
            rows.append(row(f"cli_{name}_startup_overhead", cold - float(warm), "s",
                            note=f"vehval {name} on the Cruze UDDS: {cold:.2f} s cold, own "
                                 f"compute {float(warm):.2f} s (goal: at most "
                                 f"{OVERHEAD_TARGET_S:g} s more); wall time"))
            rows.append(row(f"cli_{name}_startup_overhead_cpu", cold_cpu - float(warm_cpu), "s",
                            note=f"the same in CPU time (user + system, steadier on a loaded "
                                 f"machine): {cold_cpu:.2f} s cold, own compute "
                                 f"{float(warm_cpu):.2f} s"))
    return rows


def run() -> list[dict]:
    global _PYCACHE
    with tempfile.TemporaryDirectory(prefix="vehval-bench-pycache-") as pycache:
        _PYCACHE = pycache
        return _run()


def _run() -> list[dict]:
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
    if CRUZE_UDDS.is_file():
        rows += _overheads(_env())
    return rows
