"""Start-up of the CLI: `vehval --help` and the help of every command load only typer and
the light command modules; a command imports its libraries when it runs.

Checked on the modules a fresh interpreter imports (``-X importtime`` and ``sys.modules``
in a subprocess), not on time, which depends on the machine.
"""

from __future__ import annotations

import json
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


def _modules_after(*argvs: list[str], env: dict[str, str] | None = None,
                   ) -> tuple[set[str], str]:
    """``sys.modules`` of one interpreter once ``vehval ARGV`` ran for every ARGV."""
    code = ("import sys\nfrom vehval.cli import main\nrc = 0\n"
            f"for argv in {list(argvs)!r}:\n    rc = rc or main(argv)\n"
            "print('MODULES', ' '.join(sorted(sys.modules)))\nsys.exit(rc)")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env={**_env(), **(env or {})}, timeout=120)
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


# --------------------------------------------------------------------------- commands that run
#: Never needed by a single-test command that neither simulates nor writes Excel: pandas is
#: pyarrow's optional companion (vehval.io.arrow converts without it), scipy's filters and
#: optimisers serve other stages, numba loads with the first simulation or rule replay.
NOT_FOR_DATA = ("pandas", "numba", "llvmlite", "plotly", "narwhals", "xlsxwriter", "duckdb",
                "distributed", "starlette", "uvicorn", "asammdf", "scipy.ndimage",
                "scipy.optimize", "scipy.signal", "scipy.linalg", "scipy.special",
                "scipy.interpolate", "scipy.stats")
TEMPLATE = """\
template_version: 1
description: start-up test
constants: {test_mass_kg: 1500}
files:
  - source: dyno
    format: auto
    time: {column: Time, unit: s}
    channels:
      Dyno_Speed: {name: veh_spd_test, unit: mph}
      Engine_Speed: {name: eng_spd_out_test, unit: rpm}
"""


def _loaded(names: set[str], libraries: tuple[str, ...]) -> list[str]:
    return sorted(n for n in names for lib in libraries if n == lib or n.startswith(lib + "."))


def _udds_d3(tmp_path: Path) -> tuple[Path, Path]:
    """A 10 Hz D3 file driving the UDDS (speed and a plausible engine speed) and its template."""
    import numpy as np

    from vehval.cycles import load_cycle

    cyc = load_cycle("udds")
    t = np.arange(-1.0, cyc.time_s[-1] + 5.0, 0.1)
    mph = np.interp(t, cyc.time_s, cyc.speed_mps, left=0.0, right=0.0) / 0.44704
    rows = ["Time[sec]\tDyno_Speed[mph]\tEngine_Speed[rpm]"]
    rows += [f"{a:.3f}\t{v:.3f}\t{800.0 + 30.0 * v:.1f}" for a, v in zip(t, mph)]
    raw = tmp_path / "udds_d3.txt"
    raw.write_bytes(("\r\n".join(rows) + "\r\n").encode())
    tpl = tmp_path / "T.yaml"
    tpl.write_text(TEMPLATE, encoding="utf-8")
    return raw, tpl


def test_data_commands_load_no_library_they_do_not_use(tmp_path) -> None:
    """`info`, `import`, `qa` and `results` of a D3 file: numpy, pyarrow and yaml; pint only
    for units not seen before (the first run); `info` of the Test Parquet and `report
    --no-excel` never need the unit registry."""
    raw, tpl = _udds_d3(tmp_path)
    out = tmp_path / "out"
    env = {"VEHVAL_CACHE_DIR": str(tmp_path / "cache")}  # no units known yet
    runs = {"info": ["info", str(raw)],
            "import": ["import", str(raw), "-t", str(tpl), "-o", str(out / "t.parquet")],
            "qa": ["qa", str(raw), "-t", str(tpl), "-o", str(out / "qa")],
            "results": ["results", str(raw), "-t", str(tpl), "-o", str(out / "res")]}
    for first in (True, False):
        for name, argv in runs.items():
            names, _ = _modules_after(argv, env=env)
            assert "pyarrow" in names, name            # the check sees what was imported
            assert _loaded(names, NOT_FOR_DATA) == [], name
            if first and name == "info":
                assert "pint" in names                 # the units are new: pint answers
            elif not first:
                assert _loaded(names, ("pint", "dask")) == [], name  # kept from the first
    assert (out / "qa" / "validated.parquet").is_file()
    names, _ = _modules_after(["info", str(out / "t.parquet")], env=env)
    assert "pyarrow" in names
    assert _loaded(names, (*NOT_FOR_DATA, "pint", "dask")) == []
    names, _ = _modules_after(["report", str(out / "qa"), "-o", str(out / "r.html"),
                               "--no-excel"], env=env)
    assert (out / "r.html").is_file() and {"pyarrow", "plotly", "jinja2"} <= names
    plots = ("plotly", "narwhals")                     # the report draws its figures
    assert _loaded(names, (*(n for n in NOT_FOR_DATA if n not in plots), "pint", "dask")) == []


#: The compiled-code stack: loaded by a simulation or a hybrid's engine-rule fit only.
COMPILER = ("numba", "llvmlite", "vehval.sim.supervisor", "vehval.sim.kernel",
            "vehval.sim.stack", "vehval.analysis.replay_kernel")
HYBRID_TEMPLATE = """\
template_version: 1
constants: {test_mass_kg: 1300}
files:
  - source: dyno
    format: csv
    time: {column: Time, unit: s}
    channels:
      Speed: {name: veh_spd_test, unit: m/s}
      Force: {name: veh_frc_in_test, unit: N}
      Engine: {name: eng_spd_out_test, unit: rpm}
"""


def _drive_csv(tmp_path: Path, name: str, *, engine_stops: bool) -> Path:
    """400 s of a speed wave with its tractive force; the engine at 1500 rpm above 8 kW of
    wheel power (stopping below: a hybrid's drive) or all the time (a conventional car's)."""
    import numpy as np

    t = np.arange(0.0, 400.0, 0.1)
    v = 12.0 + 8.0 * np.sin(t / 20.0)
    frc = 1300.0 * np.gradient(v, t) + 90.0 + 0.36 * v * v
    rpm = np.where(frc * v > 8000.0, 1500.0, 0.0) if engine_stops else np.full(t.size, 1500.0)
    rows = ["Time,Speed,Force,Engine"] + [f"{a:.1f},{b:.3f},{c:.1f},{d:.0f}"
                                          for a, b, c, d in zip(t, v, frc, rpm)]
    path = tmp_path / name
    path.write_text("\n".join(rows) + "\n", encoding="utf-8")
    return path


def test_analyze_loads_numba_only_for_a_hybrids_rule(tmp_path) -> None:
    """`analyze` of a conventional car (the engine runs whenever it moves; the D3 file and
    the CSV) estimates no engine on/off rule and loads no compiled code; a hybrid's drive
    fits the rule with the compiled replay (numba imported then)."""
    raw, tpl = _udds_d3(tmp_path)
    names, out = _modules_after(["analyze", str(raw), "-t", str(tpl), "-o",
                                 str(tmp_path / "d3")])
    assert "a conventional vehicle" in out and (tmp_path / "d3" / "control.json").is_file()
    assert "vehval.analysis.summary" in names            # the check sees the analysis ...
    assert _loaded(names, COMPILER) == []                # ... without the compiled stack
    (tmp_path / "t.yaml").write_text(HYBRID_TEMPLATE, encoding="utf-8")
    for name, stops in (("conv", False), ("hybrid", True)):
        csv = _drive_csv(tmp_path, f"{name}.csv", engine_stops=stops)
        names, out = _modules_after(["analyze", str(csv), "-t", str(tmp_path / "t.yaml"),
                                     "-o", str(tmp_path / name), "--no-qa"])
        control = json.loads((tmp_path / name / "control.json").read_text(encoding="utf-8"))
        if stops:
            assert control["rule_agreement"] is not None and control["controller"], out
            assert {"numba", "vehval.sim.supervisor", "vehval.analysis.replay_kernel"} <= names
        else:
            assert control["rule_agreement"] is None and control["controller"] == {}
            assert _loaded(names, COMPILER) == [], name
