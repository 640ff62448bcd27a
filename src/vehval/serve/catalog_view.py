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

from vehval.display import as_unit
from vehval.errors import InputFileError, VehvalError
from vehval.serve.security import classify, inside_workspace, regular_file
from vehval.serve.series import series

#: Catalog columns read for the page (the API's ``rows`` hold them as the catalog stores
#: them: SI, mpg).
COLUMNS = ("test_id", "status", "vehicle", "cycle", "start_condition", "cell_temp_c", "fuel",
           "duration_s", "distance_m", "fuel_mass_kg", "fuel_economy_mpg",
           "fuel_consumption_l_per_100km", "soc_change", "n_findings", "error",
           "headline_name", "headline_mpg", "headline_u_mpg", "headline_l_per_100km",
           "headline_j1634_scope", "headline_mpge", "headline_u_mpge", "headline_kwh_per_100km",
           "headline_u_kwh_per_100km", "headline_kwh_per_100mi", "headline_u_kwh_per_100mi",
           "headline_battery_share", "withheld_reason")
#: What the page shows (``view``): key -> (heading, SI unit or None, digits); units are the
#: user's display units (:mod:`vehval.display`).
VIEW = {"test_id": ("test", None, 0), "status": ("status", None, 0),
        "vehicle": ("vehicle", None, 0), "cycle": ("cycle", None, 0),
        "start_condition": ("start", None, 0), "cell_temp_c": ("cell", "degC", 1),
        "fuel": ("fuel", None, 0), "headline": ("headline (U, k = 2)", None, 0),
        "duration_s": ("duration", "min", 1), "distance_m": ("distance", "m", 2),
        "fuel_mass_kg": ("fuel used", "kg", 3), "soc_change": ("SOC change", "%", 1),
        "headline_battery_share": ("battery share", "%", 2),
        "n_findings": ("findings", None, 0), "error": ("error", None, 0)}
#: Filters the page offers: query key -> column.
FILTERS = {"vehicle": "vehicle", "cycle": "cycle", "status": "status",
           "start": "start_condition", "fuel": "fuel"}
#: Quantities an overlay may show: key -> (standard base names tried in order, label).
OVERLAY = {"speed": (("veh_spd",), "vehicle speed"),
           "fuel": (("fuel_rate",), "fuel rate"),
           "engine": (("eng_spd_out",), "engine speed"),
           "soc": (("ess_soc",), "battery SOC")}


class NoSignal(VehvalError):
    """A test of the catalog has no signal for the overlay's quantity (answered as a message
    beside the plot, not an error: an SOC overlay of a conventional car)."""


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
    out_rows = [dict(zip(cols, r)) for r in data]
    heads, cells = view(out_rows)
    return {"columns": list(cols), "rows": out_rows, "options": options,
            "view": {"columns": heads, "rows": cells}}


def _electric(row: dict) -> dict | None:
    """The row's SAE J1634 headline figures as :attr:`Headline.electric` holds them, None for
    a row without them."""
    keys = ("mpge", "kwh_per_100km", "kwh_per_100mi")
    if any(row.get(f"headline_{k}") is None for k in keys):
        return None
    return {"scope": row.get("headline_j1634_scope") or "test",
            **{k: row[f"headline_{k}"] for k in keys},
            **{f"u_{k}": row.get(f"headline_u_{k}") for k in keys}}


def _headline_cell(row: dict) -> str:
    """``hwfet: 54.80 ± 0.66 mpg (4.29 L/100 km)`` in the user's system (the results layer's
    :class:`~vehval.results.headline.Headline`); ``whole test: 183.3 ± 1.7 MPGe (18.39 ±
    0.17 kWh/100 mi)`` for a battery-electric test; or why it is withheld. (A hybrid's
    battery share of the fuel energy has its own column, ``battery share``.)"""
    from vehval.display import system
    from vehval.results.headline import Headline

    name = row.get("headline_name")
    if not name:
        return ""
    electric = _electric(row)
    if row.get("headline_mpg") is None and electric is None:
        why = row.get("withheld_reason")
        return f"{name}: withheld" + (f" ({why})" if why else "")
    mpg, u_mpg, lkm = (row.get(k) for k in ("headline_mpg", "headline_u_mpg",
                                            "headline_l_per_100km"))
    # L/100 km is inversely proportional to mpg: the same relative U (the catalog keeps U
    # of mpg only; the metric headline leads with L/100 km and states its U as the test's page)
    u_lkm = (lkm * u_mpg / mpg if mpg is not None and u_mpg is not None and lkm is not None
             and mpg > 0 else None)
    h = Headline(kind="headline", scope=str(electric["scope"] if electric and mpg is None
                                            else name), mpg=mpg, u_mpg=u_mpg,
                 l_per_100km=lkm, u_l_per_100km=u_lkm, electric=electric, system=system())
    return f"{h.shown}: {h.figure()}"


def view(rows_in: list[dict]) -> tuple[list[dict], list[dict]]:
    """The page's table: headings with display units (``[{"key", "label"}]``) and one dict
    of display texts per row (key -> text), numbers rounded in the user's units."""
    from vehval.display import unit_for

    heads, units = [], {}
    for key, (label, si, _) in VIEW.items():
        unit = None
        if si == "min":
            unit = "min"
        elif si == "%":
            unit = "%"
        elif si:
            unit = unit_for(si).label
        units[key] = unit
        heads.append({"key": key, "label": f"{label} [{unit}]" if unit else label})
    cells = []
    for row in rows_in:
        out: dict[str, str] = {}
        for key, (_, si, digits) in VIEW.items():
            v = _headline_cell(row) if key == "headline" else row.get(key)
            if isinstance(v, (int, float)) and not isinstance(v, bool) and si:
                if si == "min":
                    v = v / 60.0
                elif si == "%":
                    v = as_unit(v, "%")
                else:
                    v = float(unit_for(si).convert(v))
                out[key] = f"{v:,.{digits}f}"
            else:
                out[key] = "" if v is None else str(v)
        cells.append(out)
    return heads, cells


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


def _overlay_test(root: Path, db: Path, test_id: str) -> Any | None:
    """The validated overlay signals the batch kept for the test (``tests/ID/overlay.parquet``
    beside the catalog), or None when the batch kept none."""
    from vehval.batch.task import OVERLAY_FILE
    from vehval.io.parquet import read_test

    if not test_id or test_id.startswith(".") or "/" in test_id or "\\" in test_id:
        return None
    path = db.parent / "tests" / test_id / OVERLAY_FILE
    try:
        real = regular_file(root, path, OVERLAY_FILE)
    except VehvalError:
        return None
    if real is None:
        return None
    key = (str(real), real.stat().st_mtime)
    with _cache_lock:
        hit = _tests.get(key)
    if hit is None:
        hit = read_test(real)
        with _cache_lock:
            if len(_tests) > 32:
                _tests.clear()
            _tests[key] = hit
    return hit


def _catalog_test(root: Path, db: Path, test_id: str) -> Any:
    """The test's overlay signals: the batch's validated ones, else imported again from the
    recorded raw files with the batch's template (both inside the workspace)."""
    kept = _overlay_test(root, db, test_id)
    if kept is not None:
        return kept
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
    return test


def test_traces(root: Path, db: Path, test_id: str, quantity: str, n: int,
                per_phase: bool = False) -> dict:
    """One quantity of one catalog test in its display unit (the batch's validated signals,
    else imported again from its raw files); with ``per_phase`` one trace per phase, each
    from its own start.

    Raises
    ------
    NoSignal
        The test has no signal of the quantity (an SOC of a conventional car).
    """
    from vehval.display import to_display

    if quantity not in OVERLAY:
        raise InputFileError(f"overlay: unknown quantity '{quantity}' ({', '.join(OVERLAY)})")
    test = _catalog_test(root, db, test_id)
    bases, label = OVERLAY[quantity]
    for base in bases:
        sig = test.best(base, ("test", "calc"))
        if sig is not None:
            y, unit = to_display(np.asarray(sig.values, float), sig.unit, signal=sig.name)
            out = {"test_id": test_id, "signal": sig.name, "unit": unit,
                   "label": f"{label} [{unit}]" if unit else label,
                   **series(sig.time, y, None, None, n)}
            if per_phase:
                out["phases"] = _per_phase(test, np.asarray(sig.time, float), y, n)
            return out
    raise NoSignal(f"{test_id}: no {label} signal in the test"
                   + (" (a conventional car has no traction battery)" if quantity == "soc"
                      else ""))


def overlay_figure(root: Path, db: Path, test_ids: list[str], quantity: str, n: int,
                   per_phase: bool = False) -> dict:
    """The overlay of ``quantity`` over catalog tests on one axis in its display unit (the
    report's figure layer); tests without the signal, or that cannot be read (a failed
    test of the batch), are named in ``missing``: the others are drawn."""
    from vehval.report.figures import one_axis_figure
    from vehval.serve.security import OutsideWorkspace

    traces, missing, unit = [], [], None
    for tid in test_ids:
        try:
            s = test_traces(root, db, tid, quantity, n, per_phase)
        except OutsideWorkspace:
            raise                                          # a refusal, not a missing trace
        except NoSignal as exc:
            missing.append(str(exc))
            continue
        except VehvalError as exc:
            missing.append(f"{exc}: not overlaid")
            continue
        if unit is not None and s["unit"] != unit:       # one unit per axis
            missing.append(f"{tid}: {quantity} in {s['unit']}, not {unit}: not overlaid")
            continue
        unit = s["unit"]
        parts = s.get("phases") if per_phase else [dict(s, phase=None)]
        for p in parts or []:
            name = tid if p.get("phase") is None else f"{tid} phase {p['phase']}"
            traces.append({"name": name, "t": np.asarray(p["t"], float),
                           "y": np.asarray(p["y"], dtype=float)})
    label = OVERLAY[quantity][1]
    fig = one_axis_figure(traces, unit=unit or "", ylabel=label,
                          xlabel="time from each phase's start [s]" if per_phase else "time [s]")
    fig["layout"]["title"] = {"text": label + (" per phase" if per_phase else ""),
                              "font": {"size": 13}, "x": 0.01}
    return {"figure": fig, "missing": missing, "traces": len(traces)}
