"""The catalog browser: tests of a batch output (``catalog.duckdb``), filters and overlays.

Rows come from the catalog's ``latest_tests`` view, read-only and sandboxed
(:func:`vehval.catalog.open_catalog`); the numbers shown are the catalog's own. Traces of a
test are imported again from its recorded raw files with the batch's template (both must lie
in the workspace), cached while the files are unchanged.
"""

from __future__ import annotations

import os
import threading
from pathlib import Path
from typing import Any

import numpy as np

from vehval.errors import InputFileError, VehvalError
from vehval.serve.security import classify, inside_workspace, regular_file
from vehval.serve.series import series

#: Catalog columns listed on the page (metrics [SI] and the fuel economy [mpg]).
COLUMNS = ("test_id", "status", "vehicle", "cycle", "start_condition", "cell_temp_c", "fuel",
           "duration_s", "distance_m", "fuel_mass_kg", "fuel_economy_mpg",
           "fuel_consumption_l_per_100km", "soc_change", "n_findings", "error")
#: Filters the page offers: query key -> column.
FILTERS = {"vehicle": "vehicle", "cycle": "cycle", "status": "status",
           "start": "start_condition", "fuel": "fuel"}
#: Quantities an overlay may show: key -> (standard base names tried in order, label).
OVERLAY = {"speed": (("veh_spd",), "vehicle speed [m/s]"),
           "fuel": (("fuel_rate",), "fuel rate [kg/s]"),
           "engine": (("eng_spd_out",), "engine speed [rad/s]"),
           "soc": (("ess_soc",), "battery SOC [-]")}

_cache_lock = threading.Lock()
#: One catalog connection at a time: DuckDB shares one database per file and process, and a
#: second connect would try to set the locked configuration again.
_db_lock = threading.Lock()
_tests: dict[tuple, Any] = {}


def find_catalogs(root: Path, limit: int = 200) -> tuple[list[Path], list[dict]]:
    """``catalog.duckdb`` files under the workspace (at most ``limit``, 4 levels deep), and
    those left out (``[{"name", "why"}]``: a link leading out of the workspace, a loop...)."""
    out: list[Path] = []
    left: list[dict] = []
    for depth in range(0, 4):
        for p in sorted(root.glob("/".join(["*"] * depth + ["catalog.duckdb"]))):
            rel = p.relative_to(root)
            if any(part.startswith(".") for part in rel.parts):
                continue
            kind, _, why = classify(root, p)
            if kind != "file":
                left.append({"name": rel.as_posix(), "why": why or "a folder, not a catalog"})
                continue
            out.append(p)
            if len(out) >= limit:
                return out, left
    return out, left


def rows(db: Path, filters: dict[str, str]) -> dict:
    """Tests of the catalog (latest row of each), filtered; plus the values each filter offers."""
    from vehval.catalog import open_catalog

    with _db_lock, open_catalog(db, read_only=True, timeout_s=20.0) as cat:
        where, params = [], []
        for key, col in FILTERS.items():
            val = filters.get(key)
            if val:
                where.append(f"{col} = ?")
                params.append(val)
        sql = (f"SELECT {', '.join(COLUMNS)} FROM latest_tests"
               + (f" WHERE {' AND '.join(where)}" if where else "") + " ORDER BY test_id")
        cols, data = cat.query(sql, params)
        options = {}
        for key, col in FILTERS.items():
            _, vals = cat.query(f"SELECT DISTINCT {col} FROM latest_tests WHERE {col} IS NOT NULL "
                                f"ORDER BY 1")
            options[key] = [v[0] for v in vals]
    return {"columns": list(cols), "rows": [dict(zip(cols, r)) for r in data],
            "options": options}


def _test_record(db: Path, test_id: str) -> tuple[list[str], dict]:
    from vehval.catalog import open_catalog
    from vehval.safe_yaml import load_json

    with _db_lock, open_catalog(db, read_only=True, timeout_s=20.0) as cat:
        _, data = cat.query("SELECT t.files, r.settings, t.outputs FROM latest_tests t "
                            "JOIN runs r USING (run_id) WHERE t.test_id = ?", [test_id])
    if not data:
        raise InputFileError(f"{db.name}: no test '{test_id}' in the catalog")
    files, settings, _ = data[0]
    conf = load_json(settings, "runs.settings") if isinstance(settings, str) else (settings or {})
    return list(files or []), conf if isinstance(conf, dict) else {}


def _workspace_path(root: Path, p: str) -> Path:
    """A file the catalog records, read only when it resolves to a regular file inside the
    workspace (a loop, a FIFO or a link leading out is refused with one line)."""
    full = Path(os.path.realpath(p))  # never raises: a loop is named by the checks below
    if not full.is_relative_to(root):
        raise InputFileError(f"{Path(p).name}: recorded outside the workspace: not read")
    path = inside_workspace(root, full.relative_to(root).as_posix())
    if regular_file(root, path, Path(p).name) is None:
        raise InputFileError(f"{Path(p).name}: recorded in the catalog, not found")
    return path


def _per_phase(test: Any, time: np.ndarray, values: np.ndarray, n: int) -> list[dict]:
    """The trace cut at the test's phase (bag) changes, each on its own time from 0 [s]."""
    ph = test.best("test_phase", ("test",))
    if ph is None:
        raise VehvalError(f"{test.meta.test_id}: no phase channel (test_phase_test): "
                          "overlay on the time axis instead")
    k = np.round(ph.at(time))
    out = []
    for num in np.unique(k[np.isfinite(k) & (k > 0)]):
        sel = k == num
        t = time[sel]
        out.append({"phase": int(num), **series(t - t[0], values[sel], None, None, n)})
    return out


def test_traces(root: Path, db: Path, test_id: str, quantity: str, n: int,
                per_phase: bool = False) -> dict:
    """One quantity of one catalog test, imported again from its raw files [SI]; with
    ``per_phase`` one trace per phase, each from its own start."""
    if quantity not in OVERLAY:
        raise InputFileError(f"overlay: unknown quantity '{quantity}' ({', '.join(OVERLAY)})")
    files, settings = _test_record(db, test_id)
    tpl = settings.get("template")
    if not files or not tpl:
        raise InputFileError(f"{test_id}: the catalog records no raw files or template")
    paths = [_workspace_path(root, f) for f in files]
    tpath = _workspace_path(root, str(tpl))
    key = (str(db), test_id, tuple((str(p), p.stat().st_mtime) for p in [*paths, tpath]))
    with _cache_lock:
        test = _tests.get(key)
    if test is None:
        from vehval.workflow import TestRun

        test = TestRun.load(paths, tpath, test_id=test_id).test
        with _cache_lock:
            if len(_tests) > 32:
                _tests.clear()
            _tests[key] = test
    bases, label = OVERLAY[quantity]
    for base in bases:
        sig = test.best(base, ("test",))
        if sig is not None:
            out = {"test_id": test_id, "signal": sig.name, "unit": sig.unit, "label": label,
                   **series(sig.time, sig.values, None, None, n)}
            if per_phase:
                out["phases"] = _per_phase(test, np.asarray(sig.time, float),
                                           np.asarray(sig.values, float), n)
            return out
    raise VehvalError(f"{test_id}: no {label.split(' [')[0]} signal in the test")
