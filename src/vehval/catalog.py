"""Results catalog: every batch run and every test result in one embedded DuckDB file.

The catalog lives at ``OUTDIR/catalog.duckdb``. It is written by the batch driver process
only (workers return their results to the driver), so there is never a concurrent writer.
The schema is versioned (:data:`SCHEMA_VERSION`) and documented in ``docs/catalog.md``; its
DDL, the check of a file against it and the migration of an older catalog live in
:mod:`vehval.catalog_schema`.

Tables
------
``schema_info``  one row: schema version, creation time, vehval version.
``runs``         one row per batch run: id, start/finish, status, settings, counts.
``tests``        one row per test and run (status ``ok``, ``failed`` or ``skipped``),
                 with input hashes, key metrics [SI and mpg], QA summary and validation.
``findings``     one row per QA finding of a test in a run.
``set_verdicts``  the set verdict over the validated tests of a run, per vehicle (bias with
                 its interval, coverage of |En| <= 1, verdict).
``phase_results`` one row per phase, whole test and regulatory composite of a test in a run
                 (results stage: fuel economy with its expanded uncertainty, drive quality).
View ``latest_tests``: the most recent row of every test id.

The database is opened sandboxed: no file, network or extension access beyond the catalog
file itself, the configuration locked, a memory and thread budget. A catalog received from
elsewhere is checked against the schema this module creates before anything in it runs.
"""

from __future__ import annotations

import contextlib
import json
import math
import threading
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterable, Iterator

from vehval.catalog_schema import (  # noqa: F401 - re-exported: vehval.catalog's API
    CATALOG_FILE,
    DDL,
    EN_COLUMNS,
    EN_FLAGS,
    HEADLINE_COLUMNS,
    METRIC_COLUMNS,
    MIGRATABLE_VERSIONS,
    PHASE_COLUMNS,
    SANDBOX_CONFIG,
    SCHEMA_VERSION,
    open_schema,
)
from vehval.catalog_schema import duckdb_module as _duckdb
from vehval.catalog_schema import first_line as _first_line
from vehval.errors import InputFileError, VehvalError
from vehval.jsonsafe import clean

#: Metrics summarised by :func:`summary` (variability per vehicle, cycle and conditions).
SUMMARY_METRICS = ("headline_mpg", "headline_mpge", "fuel_economy_mpg", "fuel_mass_kg", "soc_change",
                   "fuel_energy_j", "ess_energy_j", "eng_energy_j", "tractive_energy_j")
#: The same figures as a metric reader reads them: each test's own L/100 km (kWh/100 km)
#: summarised, not the mean mpg converted (a mean of mpg is not a mean of L/100 km).
SUMMARY_METRICS_METRIC = tuple({"headline_mpg": "headline_l_per_100km",
                                "headline_mpge": "headline_kwh_per_100km",
                                "fuel_economy_mpg": "fuel_consumption_l_per_100km"}.get(m, m)
                               for m in SUMMARY_METRICS)

#: Defaults of ``vehval catalog query``: rows printed and wall-clock time [s].
DEFAULT_LIMIT = 10_000
DEFAULT_TIMEOUT_S = 30.0
#: Statement types ``vehval catalog query`` runs (SHOW, DESCRIBE, SUMMARIZE are SELECTs).
QUERY_STATEMENTS = ("SELECT", "EXPLAIN")


def to_json(value: Any) -> str | None:
    """Serialise ``value`` to a JSON string for a JSON column (None stays NULL)."""
    if value is None:
        return None
    return json.dumps(clean(value), sort_keys=True)


def _num(value: Any) -> float | None:
    try:
        f = float(value)
    except (TypeError, ValueError):
        return None
    return f if math.isfinite(f) else None


class Catalog:
    """An open catalog database.

    Parameters
    ----------
    path : str or Path
        The DuckDB file (created with the current schema when absent).
    read_only : bool
        Open for queries only; the file must exist.
    timeout_s : float, optional
        Wall-clock limit of every :meth:`query` [s] (None: none).

    Opening checks the schema version and that the file holds only the tables and view this
    module creates (:class:`ConfigError` naming the first other object); opened for writing,
    a catalog of an older version vehval migrates (:data:`MIGRATABLE_VERSIONS`) is migrated
    in place first (:func:`vehval.catalog_schema.migrate`).
    Use as a context manager, or call :meth:`close`.
    """

    def __init__(self, path: str | Path, *, read_only: bool = False,
                 timeout_s: float | None = None) -> None:
        duckdb = _duckdb()
        self.path = Path(path)
        self.timeout_s = timeout_s
        if read_only and self.path.is_dir():
            if not (self.path / CATALOG_FILE).is_file():
                raise InputFileError(f"catalog {self.path}: is a directory without "
                                     f"{CATALOG_FILE}: pass the output directory of `vehval "
                                     f"batch` or DIR/{CATALOG_FILE}")
            self.path = self.path / CATALOG_FILE  # a batch's output directory: its catalog
        if read_only and not self.path.is_file():
            raise InputFileError(f"catalog {self.path} does not exist: run `vehval batch ... -o DIR` "
                                 "first or pass --db DIR/catalog.duckdb")
        if read_only and self.path.stat().st_size == 0:
            raise InputFileError(f"catalog {self.path}: is an empty file, not a DuckDB catalog: "
                                 "pass the catalog.duckdb a `vehval batch` wrote")
        if not read_only:
            self.path.parent.mkdir(parents=True, exist_ok=True)
        try:
            self.con = duckdb.connect(str(self.path), read_only=read_only,
                                      config=dict(SANDBOX_CONFIG))
            self.con.execute("SET lock_configuration = true")
        except duckdb.Error as exc:
            raise InputFileError(f"cannot open catalog {self.path}: {_first_line(exc)}") from None
        try:
            if read_only:
                open_schema(self.con, self.path, read_only=True)
            else:
                self._create()
        except BaseException:
            self.close()
            raise

    # -- lifecycle ---------------------------------------------------------------------
    def __enter__(self) -> "Catalog":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        """Checkpoint and close the database."""
        try:
            self.con.close()
        except Exception:  # noqa: BLE001 - closing twice or after a failure is harmless
            pass

    def _create(self) -> None:
        from vehval import __version__

        existing = {r[0] for r in self.con.execute(
            "SELECT table_name FROM information_schema.tables").fetchall()}
        if existing:
            open_schema(self.con, self.path, read_only=False)
        for statement in DDL:
            self.con.execute(statement)
        if self.con.execute("SELECT count(*) FROM schema_info").fetchone()[0] == 0:
            self.con.execute("INSERT INTO schema_info VALUES (?, current_timestamp, ?)",
                             [SCHEMA_VERSION, __version__])

    # -- writing -----------------------------------------------------------------------
    def start_run(self, run_id: str, settings: dict) -> None:
        """Record the start of a batch run."""
        from vehval import __version__

        self.con.execute("INSERT INTO runs (run_id, started, status, vehval_version, settings) "
                         "VALUES (?, current_timestamp, 'running', ?, ?)",
                         [run_id, __version__, to_json(settings)])

    def finish_run(self, run_id: str, status: str = "done") -> dict[str, int]:
        """Record the end of a run (``done`` or ``interrupted``) and its counts."""
        counts = dict(self.con.execute(
            "SELECT status, count(*) FROM tests WHERE run_id = ? GROUP BY status", [run_id]).fetchall())
        n = {k: int(counts.get(k, 0)) for k in ("ok", "failed", "skipped")}
        self.con.execute("UPDATE runs SET finished = current_timestamp, status = ?, n_tests = ?, "
                         "n_ok = ?, n_failed = ?, n_skipped = ? WHERE run_id = ?",
                         [status, sum(n.values()), n["ok"], n["failed"], n["skipped"], run_id])
        return n

    def add_result(self, run_id: str, result: dict, *, status: str | None = None) -> None:
        """Insert one test result (the content of its ``result.json``) for ``run_id``.

        ``status`` overrides the result's own status (``skipped`` for a cached result);
        the run that computed the result is kept in ``source_run_id``.
        """
        metrics = result.get("metrics") or {}
        findings = result.get("findings") or []
        validation = result.get("validation")
        val_errors = validation.get("errors") if isinstance(validation, dict) else None
        row = [result["test_id"], run_id, status or result.get("status", "failed"),
               result.get("error"), result.get("error_type"), result.get("run_id", run_id),
               result.get("vehicle"), result.get("cycle"), [str(f) for f in result.get("files", [])],
               to_json(result.get("file_hashes")), result.get("input_hash"),
               _num(result.get("elapsed_s"))]
        row += [_num(metrics.get(c)) for c in METRIC_COLUMNS]
        res = result.get("results") or {}
        head = res.get("headline") or {}
        held = head.get("withheld") if not head.get("forced") else None
        elec = res.get("electric") or {}
        row += [res.get("fuel"), _num(res.get("cell_temp_c")), res.get("start"), res.get("ac"),
                head.get("name"), head.get("rule"), elec.get("scope"),
                None if held else _num(head.get("fuel_economy_mpg")),
                None if held else _num(head.get("fuel_economy_u_mpg")),
                None if held else _num(head.get("fuel_consumption_l_per_100km")),
                *(_num(elec.get(k)) for k in ("mpge", "u_mpge", "kwh_per_100km",
                                              "u_kwh_per_100km", "kwh_per_100mi",
                                              "u_kwh_per_100mi")),
                _num(res.get("battery_share")),
                (held or {}).get("reason"), res.get("withheld_count")]
        row += [len(findings), to_json(result.get("findings_by_severity") or {}),
                to_json(result.get("qa_summary")), to_json(validation), to_json(val_errors),
                [str(o) for o in result.get("outputs", [])]]
        ne = validation.get("normalised_error") if isinstance(validation, dict) else None
        ne = ne if isinstance(ne, dict) else {}
        row += [_num(ne.get(c.removeprefix("fuel_"))) for c in EN_COLUMNS]
        row += [v if isinstance(v := ne.get(c.removeprefix("fuel_")), bool) else None
                for c in EN_FLAGS]
        cols = (["test_id", "run_id", "status", "error", "error_type", "source_run_id", "vehicle",
                 "cycle", "files", "file_hashes", "input_hash", "elapsed_s"] + list(METRIC_COLUMNS)
                + ["fuel", "cell_temp_c", "start_condition", "ac", "headline_name", "headline_rule",
                   "headline_j1634_scope"]
                + list(HEADLINE_COLUMNS)
                + ["withheld_reason", "withheld_count", "n_findings", "n_findings_by_severity",
                   "qa_summary", "validation", "validation_errors", "outputs"]
                + list(EN_COLUMNS) + list(EN_FLAGS))
        self.con.execute("BEGIN TRANSACTION")
        try:
            self.con.execute("DELETE FROM tests WHERE test_id = ? AND run_id = ?", [row[0], run_id])
            self.con.execute("DELETE FROM findings WHERE test_id = ? AND run_id = ?", [row[0], run_id])
            self.con.execute("DELETE FROM phase_results WHERE test_id = ? AND run_id = ?",
                             [row[0], run_id])
            prow = [[row[0], run_id, r.get("scope"), r.get("kind"), r.get("part"), r.get("run")]
                    + [_num(r.get(c)) for c in PHASE_COLUMNS] + [r.get("withheld_reason")]
                    for r in res.get("rows") or [] if r.get("scope")]
            if prow:
                self.con.executemany(
                    f"INSERT INTO phase_results VALUES ({', '.join('?' * len(prow[0]))})", prow)
            self.con.execute(f"INSERT INTO tests ({', '.join(cols)}, recorded) VALUES "
                             f"({', '.join('?' * len(cols))}, current_timestamp)", row)
            if findings:
                self.con.executemany(
                    "INSERT INTO findings VALUES (?, ?, ?, ?, ?, ?, ?, ?)",
                    [[row[0], run_id, f.get("signal"), f.get("kind"), f.get("severity"),
                      _num(f.get("start_s")), _num(f.get("end_s")), f.get("message")]
                     for f in findings])
            self.con.execute("COMMIT")
        except BaseException as exc:
            # a failed COMMIT (disk full, read-only file) has ended the transaction already:
            # the ROLLBACK must not hide why the row could not be written
            with contextlib.suppress(_duckdb().Error):
                self.con.execute("ROLLBACK")
            if isinstance(exc, _duckdb().Error):
                raise VehvalError(
                    f"catalog {self.path}: recording test {row[0]} of run {run_id} failed "
                    f"({_first_line(exc)}); the earlier runs in it are unchanged: free disk "
                    "space (or make the folder writable) and run the batch again, it resumes "
                    "where it stopped") from None
            raise

    def mark_removed(self, run_id: str, present: Iterable[str]) -> list[str]:
        """Record as ``removed`` in run ``run_id`` every test of an earlier run that is not
        among ``present`` (this run's test ids) and none of whose files exists any more: its
        folder was deleted, or renamed (a new test id). Its latest row then says so, and the
        variability summaries leave it out. A test left out of the run whose files are still
        there (a narrower glob) is not touched. Returns the ids, sorted."""
        present = set(present)
        _, rows = self.query("SELECT test_id, source_run_id, vehicle, cycle, files, file_hashes, "
                             "input_hash FROM latest_tests WHERE status <> 'removed' "
                             "AND run_id <> ? ORDER BY test_id", [run_id])
        gone = [r for r in rows if r[0] not in present and r[4]
                and not any(Path(f).exists() for f in r[4])]
        if gone:
            self.con.executemany(
                "INSERT INTO tests (test_id, run_id, status, source_run_id, recorded, vehicle, "
                "cycle, files, file_hashes, input_hash, outputs) VALUES "
                "(?, ?, 'removed', ?, current_timestamp, ?, ?, ?, ?, ?, [])",
                [[r[0], run_id, *r[1:]] for r in gone])
        return [r[0] for r in gone]

    def add_set_verdicts(self, run_id: str, rows: Iterable[dict]) -> None:
        """Store the set verdicts of a run (:func:`vehval.batch.verdicts.batch_set_verdicts`); read back by
        :func:`vehval.batch.verdicts.stored_set_verdicts`."""
        self.con.execute("DELETE FROM set_verdicts WHERE run_id = ?", [run_id])
        for r in rows:
            sv = r.get("set_verdict") or {}
            lo, hi = sv.get("mean_error_ci_pct") or (None, None)
            clo, chi = sv.get("coverage_ci") or (None, None)
            self.con.execute(
                f"INSERT INTO set_verdicts VALUES ({', '.join('?' * 19)})",
                [run_id, r.get("vehicle") or "", r.get("figure") or "fuel_mass_kg",
                 r.get("n_validated"), sv.get("n"), _num(sv.get("mean_error_pct")), _num(lo),
                 _num(hi), _num(sv.get("bias_limit_pct")), sv.get("biased"),
                 sv.get("n_consistent"), _num(sv.get("coverage")), _num(clo), _num(chi),
                 sv.get("understated"), sv.get("n_uninformative"), sv.get("verdict"),
                 r.get("note") or None, to_json(r)])

    # -- reading -----------------------------------------------------------------------
    @contextlib.contextmanager
    def _guard(self, timeout_s: float | None) -> Iterator[None]:
        """Interrupt the running statement after ``timeout_s`` [s]; turn DuckDB errors (and a
        Python-side conversion failure) into one-line vehval errors."""
        duckdb = _duckdb()
        fired = threading.Event()

        def interrupt() -> None:
            fired.set()
            self.con.interrupt()

        timer = threading.Timer(timeout_s, interrupt) if timeout_s else None
        if timer is not None:
            timer.daemon = True
            timer.start()
        try:
            yield
        except (duckdb.Error, MemoryError, ModuleNotFoundError) as exc:
            if fired.is_set():
                raise VehvalError(f"catalog query stopped after the {timeout_s:g} s timeout: "
                                  "narrow it (WHERE, LIMIT) or raise --timeout") from None
            if isinstance(exc, MemoryError) or "Out of Memory" in str(exc):
                raise VehvalError("catalog query needs more than the "
                                  f"{SANDBOX_CONFIG['memory_limit']} memory budget: narrow it "
                                  "(WHERE, LIMIT, fewer columns)") from None
            raise VehvalError(f"catalog query failed: {_first_line(exc)}") from None
        finally:
            if timer is not None:
                timer.cancel()

    def query(self, sql: str, params: Iterable[Any] | None = None) -> tuple[list[str], list[tuple]]:
        """Run ``sql``; return column names and rows. A bad statement is a :class:`VehvalError`.

        The catalog's ``timeout_s`` applies (None: no limit)."""
        with self._guard(self.timeout_s):
            cur = self.con.execute(sql, list(params) if params is not None else None)
            if cur.description is None:
                return [], []
            return [d[0] for d in cur.description], cur.fetchall()

    def user_query(self, sql: str, *, limit: int = DEFAULT_LIMIT,
                   timeout_s: float | None = DEFAULT_TIMEOUT_S) -> "QueryResult":
        """Run one read-only statement a user typed (``vehval catalog query``).

        Parameters
        ----------
        sql : str
            One SELECT (SHOW, DESCRIBE, SUMMARIZE, FROM ..., VALUES) or EXPLAIN statement.
        limit : int
            At most this many rows are fetched; ``truncated`` says when more exist.
        timeout_s : float, optional
            Wall-clock limit [s]; the statement is interrupted when it is reached.

        Returns
        -------
        QueryResult
            Column names, rows (timestamps with a time zone as ISO strings) and ``truncated``.
        """
        duckdb = _duckdb()
        if limit < 1:
            raise VehvalError(f"--limit {limit}: give a positive number of rows")
        if timeout_s is not None and not (timeout_s > 0 and math.isfinite(timeout_s)):
            raise VehvalError(f"--timeout {timeout_s}: give a positive number of seconds")
        try:
            kinds = [st.type.name for st in self.con.extract_statements(sql)]
        except duckdb.Error as exc:
            raise VehvalError(f"catalog query failed: {_first_line(exc)}") from None
        if len(kinds) != 1:
            raise VehvalError(f"catalog query runs one statement; got {len(kinds)}")
        if kinds[0] not in QUERY_STATEMENTS:
            raise VehvalError(f"catalog query is read-only and runs one SELECT or EXPLAIN "
                              f"statement; got {kinds[0]}")
        with self._guard(timeout_s):
            rel = self.con.sql(sql)
            if rel is None:
                return QueryResult([], [], False)
            cols = list(rel.columns)
            # zoned timestamps need pytz to become Python objects: print them as text
            if any("TIME ZONE" in str(t) for t in rel.types):
                rel = rel.project(", ".join(
                    f'CAST("{c.replace(chr(34), chr(34) * 2)}" AS VARCHAR) AS "{c.replace(chr(34), chr(34) * 2)}"'
                    if "TIME ZONE" in str(t) else f'"{c.replace(chr(34), chr(34) * 2)}"'
                    for c, t in zip(cols, rel.types)))
            rows = rel.limit(limit + 1).fetchall()
        return QueryResult(cols, rows[:limit], len(rows) > limit)

    def summary(self, metrics: Iterable[str] = SUMMARY_METRICS) -> list[dict]:
        """Test-to-test variability per vehicle, cycle and test conditions over the latest
        result of each test.

        The conditions are the start (``cold``/``hot``), the cell temperature band
        (:data:`TEMPERATURE_BANDS_SQL`) and the A/C (``on``/``off``), each ``unknown`` when
        not known: a cold UDDS, a hot UDDS, a -7 degC UDDS and a 35 degC UDDS with the A/C on
        are separate groups. Returns one dict per (vehicle, cycle, start, temperature band,
        A/C, metric): ``n``, ``mean``, ``std`` (sample, ddof = 1), ``cv`` (std / |mean|, None
        when the mean is 0), ``min``, ``max``. Only tests whose latest result is ``ok``
        (computed or skipped as unchanged) count; ``headline_mpg`` is NULL (not counted) for a
        test whose headline was withheld.
        """
        known = {**METRIC_COLUMNS, **HEADLINE_COLUMNS}
        out: list[dict] = []
        for m in metrics:
            if m not in known:
                raise VehvalError(f"unknown metric '{m}'; known: {', '.join(known)}")
            _, rows = self.query(
                f"""SELECT coalesce(t.vehicle, ''), coalesce(t.cycle, ''),
                           coalesce(t.start_condition, 'unknown'), {TEMPERATURE_BANDS_SQL},
                           coalesce(t.ac, 'unknown'), count({m}), avg({m}),
                           stddev_samp({m}), min({m}), max({m})
                    FROM latest_tests t
                    WHERE t.status IN ('ok', 'skipped') AND t.error IS NULL AND {m} IS NOT NULL
                    GROUP BY 1, 2, 3, 4, 5 ORDER BY 1, 2, 3, 4, 5""")
            for veh, cyc, start, band, ac, n, mean, std, lo, hi in rows:
                cv = (std / abs(mean)) if (std is not None and mean) else None
                out.append({"vehicle": veh, "cycle": cyc, "start": start,
                            "temperature_band": band, "ac": ac, "metric": m, "n": int(n),
                            "mean": mean, "std": std, "cv": cv, "min": lo, "max": hi})
        return out


@dataclass
class QueryResult:
    """Rows of :meth:`Catalog.user_query`; ``truncated`` when the row limit cut them."""

    columns: list[str]
    rows: list[tuple]
    truncated: bool


#: Cell temperature bands of the variability grouping [degC]: the US ambient test conditions
#: (cold FTP -7 degC, standard 20-30 degC, SC03 35 degC).
TEMPERATURE_BANDS_SQL = ("CASE WHEN t.cell_temp_c IS NULL THEN 'unknown' "
                         "WHEN t.cell_temp_c < 10 THEN 'cold (< 10 degC)' "
                         "WHEN t.cell_temp_c <= 30 THEN 'standard (10-30 degC)' "
                         "ELSE 'hot (> 30 degC)' END")


def results_variability(catalog: "Catalog") -> list[dict]:
    """Fuel economy variability of the latest result of every test, grouped by vehicle,
    cycle, cell temperature band, cold or hot start, A/C and result scope (phase, whole test,
    composite): ``n``, ``mean``, ``std`` (ddof 1), ``cv``, ``mean_u`` (mean expanded
    uncertainty of one test, k = 2) [mpg]."""
    _, rows = catalog.query(
        f"""SELECT coalesce(t.vehicle, ''), coalesce(t.cycle, ''), {TEMPERATURE_BANDS_SQL},
                   coalesce(t.start_condition, 'unknown'), coalesce(t.ac, 'unknown'),
                   p.scope, p.kind, count(*),
                   avg(p.fuel_economy_mpg), stddev_samp(p.fuel_economy_mpg),
                   avg(p.fuel_economy_u_mpg)
            FROM latest_tests t JOIN phase_results p
              ON p.test_id = t.test_id AND p.run_id = t.run_id
            WHERE t.status IN ('ok', 'skipped') AND t.error IS NULL
              AND p.fuel_economy_mpg IS NOT NULL
            GROUP BY 1, 2, 3, 4, 5, 6, 7 ORDER BY 1, 2, 3, 4, 5, 7 DESC, 6""")
    out = []
    for veh, cyc, band, start, ac, scope, kind, n, mean, std, mu in rows:
        out.append({"vehicle": veh, "cycle": cyc, "temperature_band": band, "start": start,
                    "ac": ac, "scope": scope, "kind": kind, "n": int(n), "mean": mean, "std": std,
                    "cv": (std / abs(mean)) if (std is not None and mean) else None,
                    "mean_u": mu})
    return out


def open_catalog(path: str | Path, *, read_only: bool = False,
                 timeout_s: float | None = None) -> Catalog:
    """Open (or create) the catalog at ``path``; see :class:`Catalog`."""
    return Catalog(path, read_only=read_only, timeout_s=timeout_s)
