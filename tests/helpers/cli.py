"""A small D3-like test and its template, and the command line run in-process.

``write_d3`` writes a tab-separated 10 Hz file (time [s], vehicle speed [mph], engine speed
[rpm]) that ``TEMPLATE`` reads; ``run_cli`` runs ``vehval`` in this process and returns
``(exit code, stdout, stderr)``.
"""

from __future__ import annotations

import numpy as np

TEMPLATE = """\
template_version: 1
description: adversarial test template
vehicle: prius_2004
files:
  - source: dyno
    match: "*_d3.txt"
    time: {column: Time, unit: s}
    channels:
      Dyno_Speed: {name: veh_spd_test, unit: mph}
      Engine_Speed: {name: eng_spd_out_test, unit: rpm}
"""


def write_d3(path, n: int = 600, dt: float = 0.1, last_t: float | None = None) -> None:
    """A tab-separated D3-style file: time [s], vehicle speed [mph], engine speed [rpm]."""
    t = np.arange(n) * dt
    if last_t is not None:
        t[-1] = last_t
    v = 20 + 10 * np.sin(t / 10)
    e = 1200 + 300 * np.sin(t / 7)
    lines = ["Time[s]\tDyno_Speed[mph]\tEngine_Speed[rpm]"]
    lines += [f"{a:.9g}\t{b:.4f}\t{c:.2f}" for a, b, c in zip(t, v, e)]
    path.write_text("\n".join(lines) + "\n")


def run_cli(args, capsys):
    """Run the CLI in-process: ``(exit code, stdout, stderr)``."""
    from vehval.cli import main

    rc = main([str(a) for a in args])
    out = capsys.readouterr()
    return rc, out.out, out.err


def virtual_qa_output(root, vehicle: str, capsys) -> "object":
    """A one-minute steady virtual test of ``vehval synth --vehicle VEHICLE`` (no faults)
    run through ``vehval qa``: the QA output folder (``root / "q"``)."""
    from vehval.cli import main

    out = root / "virtual"
    assert main(["synth", "--vehicle", vehicle, "--cycle", "steady:15mps:60s", "--seed", "1",
                 "--faults", "none", "-o", str(out)]) == 0
    files = [str(f) for f in sorted(out.glob("virtual_*"))]
    assert main(["qa", *files, "-t", str(out / "template.yaml"), "-o", str(root / "q")]) == 0
    capsys.readouterr()
    return root / "q"
