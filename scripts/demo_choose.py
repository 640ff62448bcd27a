"""Choose the test files and the vehicle of `make demo DEMO_DATA=DIR` (called by demo.sh).

Prints the vehicle choice on the first line, then one data file per line:

* ``vehicle <name or path>``: DEMO_VEHICLE, else the template's ``vehicle:`` (``predict
  <name or path>`` when it is a conventional car: predicted, not validated);
* ``identify``: the template maps no hybrid signal (battery, motor, generator): a
  conventional car, whose model is identified from the test itself;
* ``none``: a hybrid with no vehicle file named: the model stages are skipped (the package's
  2004 Prius is not compared with another car).

A folder holding several tests (one template entry matching several files, e.g. a whole D3
vehicle folder) gives its first test, or the one whose file name contains DEMO_TEST.
"""

from __future__ import annotations

import fnmatch
import os
import sys
from pathlib import Path

HYBRID_PREFIXES = ("ess_", "mot_", "gen_", "pg_", "boost_")


def main(data: str, template: str) -> int:
    from vehval.errors import VehvalError
    from vehval.io.template import load_template
    from vehval.workflow import _dir_files

    try:
        tpl = load_template(template)
        files = _dir_files(Path(data), tpl)
    except VehvalError as exc:
        print(f"vehval: error: {exc}", file=sys.stderr)
        return 2
    pick = os.environ.get("DEMO_TEST", "")
    entries = [f.match for f in tpl.files if f.match]
    if entries:  # one file per template entry: the first test, or the one asked for
        chosen = []
        for g in entries:
            cands = [p for p in files if fnmatch.fnmatch(p.name, g)]
            if pick:
                cands = [p for p in cands if pick in p.name] or cands
            if cands:
                chosen.append(cands[0])
        files = chosen
    names = [ch.name or "" for f in tpl.files for ch in f.channels.values()]
    vehicle = os.environ.get("DEMO_VEHICLE") or tpl.vehicle
    if vehicle:
        from vehval.vehicle import load_vehicle

        try:
            arch = getattr(load_vehicle(vehicle), "architecture", "power_split")
        except VehvalError as exc:
            print(f"vehval: error: {exc}", file=sys.stderr)
            return 2
        print(f"{'predict' if arch == 'conventional' else 'vehicle'} {vehicle}")
    elif any(n.startswith(HYBRID_PREFIXES) for n in names):
        print("none")
    else:
        print("identify")
    for p in files:
        print(p)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1], sys.argv[2]))
