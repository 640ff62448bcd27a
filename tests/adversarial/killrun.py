"""Run the vehval CLI and kill -9 the process at the K-th rename (test helper).

Usage: ``python killrun.py K vehval-args...``. Every ``os.replace``/``os.rename`` and the
directory exchange of :mod:`vehval.io.atomic` counts as one rename step; at step K (1-based)
the process sends itself SIGKILL just before the rename. K = 0 never kills; the number of
steps seen is printed on stderr as ``renames=N`` at exit.
"""

from __future__ import annotations

import os
import signal
import sys


def main() -> int:
    kill_at = int(sys.argv[1])
    count = [0]

    def step():
        count[0] += 1
        if count[0] == kill_at:
            os.kill(os.getpid(), signal.SIGKILL)

    def wrap(fn):
        def inner(*a, **kw):
            step()
            return fn(*a, **kw)
        return inner

    os.replace = wrap(os.replace)
    os.rename = wrap(os.rename)
    from vehval.io import atomic

    atomic._rename_exchange = wrap(atomic._rename_exchange)
    from vehval.cli import main as cli

    rc = cli(sys.argv[2:])
    print(f"renames={count[0]}", file=sys.stderr)
    return rc


if __name__ == "__main__":
    sys.exit(main())
