"""Run the vehval benchmarks: ``python -m benchmarks [--only NAME] [--out DIR]``.

Every module ``benchmarks/bench_*.py`` is discovered and its ``run() -> list[dict]`` called.
Rows are ``{name, value, unit, baseline, ratio, target, note}`` (see
:func:`benchmarks.common.row`). A module that raises is reported as failed and the others
still run. The table is printed with rich and all rows are written atomically to
``<out>/results.json`` (default ``bench_out/``). Exit status: 0 when every module ran,
1 when at least one failed.
"""

from __future__ import annotations

import argparse
import datetime as _dt
import importlib
import json
import platform
import sys
import time
import traceback
from pathlib import Path
from typing import Any

from vehval.io.atomic import write_text_atomic

HERE = Path(__file__).resolve().parent
REQUIRED = ("name", "value", "unit")


def discover() -> list[str]:
    """Module names ``bench_*`` in this package, sorted."""
    return sorted(p.stem for p in HERE.glob("bench_*.py"))


def _selected(mod: str, only: list[str] | None) -> bool:
    if not only:
        return True
    short = mod.removeprefix("bench_")
    return any(o in (mod, short) or o.removeprefix("bench_") == short for o in only)


def _meets(r: dict[str, Any]) -> bool | None:
    target = r.get("target")
    if target is None:
        return None
    got = r.get("ratio") if r.get("ratio") is not None else r.get("value")
    if got is None:
        return None
    return got >= target if r.get("better") == "higher" else got <= target


def run_module(mod: str) -> dict[str, Any]:
    """Import and run one benchmark module; never raises."""
    t0 = time.perf_counter()
    try:
        module = importlib.import_module(f"benchmarks.{mod}")
        rows = list(module.run())
        for r in rows:
            missing = [k for k in REQUIRED if k not in r]
            if missing:
                raise ValueError(f"row {r!r} misses {missing}")
            for k in ("baseline", "ratio", "target", "note"):
                r.setdefault(k, None if k != "note" else "")
            if r["ratio"] is None and r["baseline"]:
                r["ratio"] = r["value"] / r["baseline"]
            r["meets_target"] = _meets(r)
        return {"ok": True, "error": None, "seconds": time.perf_counter() - t0, "rows": rows}
    except Exception as exc:  # noqa: BLE001 - a failing benchmark is reported, not fatal
        return {"ok": False, "error": f"{type(exc).__name__}: {exc}",
                "traceback": traceback.format_exc(), "seconds": time.perf_counter() - t0,
                "rows": []}


def _fmt(x: Any) -> str:
    if x is None:
        return ""
    if isinstance(x, float):
        return f"{x:.4g}"
    return str(x)


def print_table(results: dict[str, dict[str, Any]]) -> None:
    from rich.console import Console
    from rich.markup import escape
    from rich.table import Table

    table = Table(title="vehval benchmarks (ratio = value / baseline, same run)")
    for col in ("module", "name", "value", "unit", "baseline", "ratio", "target", "ok", "note"):
        table.add_column(col, overflow="fold", no_wrap=col in ("module", "name"))
    for mod, res in results.items():
        if not res["ok"]:
            table.add_row(mod, "[red]FAILED[/red]", "", "", "", "", "", "",
                          escape(res["error"] or ""))
            continue
        for r in res["rows"]:
            ok = {True: "yes", False: "[red]no[/red]", None: ""}[r.get("meets_target")]
            table.add_row(mod.removeprefix("bench_"), escape(str(r["name"])), _fmt(r["value"]),
                          escape(str(r["unit"])), _fmt(r["baseline"]), _fmt(r["ratio"]),
                          _fmt(r["target"]), ok, escape(str(r.get("note") or "")))
    console = Console() if sys.stdout.isatty() else Console(width=160)
    console.print(table)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks",
                                     description="Run the vehval benchmarks.")
    parser.add_argument("--only", action="append", metavar="NAME",
                        help="run only this module (e.g. 'cycles' or 'bench_cycles'); "
                             "repeatable")
    parser.add_argument("--out", type=Path, default=Path("bench_out"),
                        help="output directory for results.json (default: bench_out)")
    parser.add_argument("--list", action="store_true", help="list the benchmark modules")
    args = parser.parse_args(argv)

    mods = discover()
    if args.list:
        print("\n".join(mods))
        return 0
    chosen = [m for m in mods if _selected(m, args.only)]
    if not chosen:
        print(f"no benchmark matches {args.only}; available: {', '.join(mods)}",
              file=sys.stderr)
        return 2
    results: dict[str, dict[str, Any]] = {}
    for mod in chosen:
        print(f"running {mod} ...", file=sys.stderr, flush=True)
        results[mod] = run_module(mod)
        if not results[mod]["ok"]:
            print(f"{mod} FAILED: {results[mod]['error']}", file=sys.stderr)
    print_table(results)
    doc = {
        "generated_utc": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "python": sys.version.split()[0],
        "platform": platform.platform(),
        "machine": platform.machine(),
        "modules": results,
    }
    out = args.out / "results.json"
    write_text_atomic(out, json.dumps(doc, indent=1, default=str) + "\n")
    print(f"wrote {out}", file=sys.stderr)
    return 0 if all(r["ok"] for r in results.values()) else 1


if __name__ == "__main__":
    sys.exit(main())
