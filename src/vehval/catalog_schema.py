"""Schema of the results catalog: its DDL, the check of a file against it, and the in-place
migration of a catalog written by an older vehval.

:data:`SCHEMA_VERSION` is the version this vehval writes. A catalog of an older version
whose tables are exactly those an older vehval created (one of :data:`SHAPES`) is migrated
when the batch opens it for writing: versions 3 and 4, and a version-5 catalog written before
the kWh/100 mi columns. The migration rebuilds each table that changed with the current
definition (columns in the current order, the current keys), copies the old rows, fills the
columns the old vehval did not write with NULL (kWh/100 mi from kWh/100 km when the old file
has it), records the new version in ``schema_info``, and commits once: a failure rolls back
and leaves the file as it was. Versions 1 and 2, a version newer than this vehval, and a
missing or corrupt ``schema_info`` are refused with one line naming the file.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from vehval.constants import MILE_M
from vehval.errors import ConfigError

SCHEMA_VERSION = 5
#: The catalog's file name in a batch's output directory.
CATALOG_FILE = "catalog.duckdb"

#: Key metrics stored as DOUBLE columns of ``tests`` (name -> description [unit]).
METRIC_COLUMNS: dict[str, str] = {
    "duration_s": "test duration [s]",
    "distance_m": "distance driven [m]",
    "fuel_mass_kg": "fuel mass used [kg]",
    "fuel_economy_mpg": "fuel economy [mile/US gal]",
    "fuel_consumption_l_per_100km": "fuel consumption [L/100 km]",
    "soc_initial": "battery SOC at the start [-]",
    "soc_final": "battery SOC at the end [-]",
    "soc_change": "battery SOC change, final - initial [-]",
    "fuel_energy_j": "fuel chemical energy used [J]",
    "ess_energy_j": "net battery terminal energy, positive discharged [J]",
    "eng_energy_j": "positive engine brake energy [J]",
    "tractive_energy_j": "positive tractive energy at the wheels [J]",
}

#: Per-phase results stored as DOUBLE columns of ``phase_results`` (name -> description).
PHASE_COLUMNS: dict[str, str] = {
    "duration_s": "phase duration [s]",
    "distance_m": "distance [m]",
    "fuel_mass_kg": "fuel mass [kg]",
    "fuel_economy_mpg": "fuel economy [mile/US gal]",
    "fuel_economy_u_mpg": "its expanded uncertainty U, k = 2 [mile/US gal]",
    "fuel_consumption_l_per_100km": "fuel consumption [L/100 km]",
    "co2_g_per_km": "CO2 per distance [g/km]",
    "ess_energy_net_j": "battery net energy, positive discharged [J]",
    "iwr_pct": "SAE J2951 inertial work rating [%]",
    "rmsse_mps": "SAE J2951 RMS speed error [m/s]",
}

#: The headline of a test (the regulatory figure of its cycle, docs/results.md) in ``tests``.
HEADLINE_COLUMNS: dict[str, str] = {
    "headline_mpg": "headline fuel economy [mile/US gal]; NULL when withheld",
    "headline_u_mpg": "its expanded uncertainty U, k = 2 [mile/US gal]",
    "headline_l_per_100km": "headline fuel consumption [L/100 km]; NULL when withheld",
    "headline_mpge": "SAE J1634 MPGe of a test without fuel economy (battery-electric) "
                     "[mile/gal equivalent at 33.705 kWh]",
    "headline_u_mpge": "its expanded uncertainty U, k = 2 [mile/gal equivalent]",
    "headline_kwh_per_100km": "SAE J1634 AC (wall) energy consumption [kWh/100 km]",
    "headline_u_kwh_per_100km": "its expanded uncertainty U, k = 2 [kWh/100 km]",
    "headline_kwh_per_100mi": "the same in [kWh/100 mi]",
    "headline_u_kwh_per_100mi": "its expanded uncertainty U, k = 2 [kWh/100 mi]",
    "headline_battery_share": "net battery energy over the fuel energy of the whole test "
                              "(SAE J1711 NEC ratio, signed: positive discharged) [-]",
}

#: The validate step's normalised error of the fuel mass in ``tests`` (name -> description);
#: the keys of ``result.json``'s ``validation.normalised_error`` without the ``fuel_`` prefix.
EN_COLUMNS: dict[str, str] = {
    "fuel_en": "normalised error En of the fuel mass, (model - measured) / sqrt(U_model^2 + "
               "U_meas^2) [-]",
    "fuel_error_pct": "fuel mass error, model / measured - 1 (signed) [%]",
    "fuel_u_model_kg": "U_model of the fuel mass, k = 2 [kg]",
    "fuel_u_meas_kg": "U_meas of the fuel mass, k = 2 (results-stage U with s_r) [kg]",
    "fuel_s_r": "repeatability s_r of the test's procedure used in U_meas [-]",
}
#: Flags of the normalised error in ``tests`` (BOOLEAN columns).
EN_FLAGS: dict[str, str] = {
    "fuel_consistent": "|En| <= 1",
    "fuel_uninformative": "combined U over 10 % of the measured fuel mass",
    "in_sample": "the vehicle file was calibrated on this test (a fit, not a prediction)",
}

#: Columns of ``tests`` each schema version added (the older versions' rows hold NULL).
ADDED_COLUMNS: dict[int, tuple[str, ...]] = {
    4: (*EN_COLUMNS, *EN_FLAGS),
    5: ("headline_j1634_scope", "headline_mpge", "headline_u_mpge", "headline_kwh_per_100km",
        "headline_u_kwh_per_100km", "headline_kwh_per_100mi", "headline_u_kwh_per_100mi",
        "headline_battery_share"),
}
#: The two kWh/100 mi columns, added to version 5 after its first catalogs were written.
MILE_COLUMNS = ("headline_kwh_per_100mi", "headline_u_kwh_per_100mi")

_SET_VERDICTS = """CREATE TABLE IF NOT EXISTS set_verdicts (
        run_id VARCHAR NOT NULL, vehicle VARCHAR NOT NULL, figure VARCHAR NOT NULL,
        n_validated INTEGER, n INTEGER, mean_error_pct DOUBLE, mean_error_lo_pct DOUBLE,
        mean_error_hi_pct DOUBLE, bias_limit_pct DOUBLE, biased BOOLEAN, n_consistent INTEGER,
        coverage DOUBLE, coverage_lo DOUBLE, coverage_hi DOUBLE, understated BOOLEAN,
        n_uninformative INTEGER, verdict VARCHAR, note VARCHAR, detail JSON,
        PRIMARY KEY (run_id, vehicle, figure))"""
_VIEW = """CREATE OR REPLACE VIEW latest_tests AS
        SELECT t.* FROM tests t JOIN runs r USING (run_id)
        QUALIFY row_number() OVER (PARTITION BY t.test_id
                                   ORDER BY r.started DESC, t.recorded DESC) = 1"""


def ddl(omit: frozenset[str] = frozenset(), *, phase_key: str = "kind, scope",
        set_verdicts: bool = True) -> list[str]:
    """The CREATE statements of a catalog: the current one by default; an older one without
    the ``tests`` columns in ``omit``, with the ``phase_results`` key ``(test_id, run_id,
    <phase_key>)`` and without ``set_verdicts`` when ``set_verdicts`` is false."""
    def cols(names, sql_type: str) -> str:
        return "".join(f"    {c} {sql_type},\n" for c in names if c not in omit)

    scope = "" if "headline_j1634_scope" in omit else " headline_j1634_scope VARCHAR,"
    tests = ("CREATE TABLE IF NOT EXISTS tests (\n"
             "    test_id VARCHAR NOT NULL, run_id VARCHAR NOT NULL, status VARCHAR NOT NULL,\n"
             "    error VARCHAR, error_type VARCHAR, source_run_id VARCHAR, recorded TIMESTAMP,\n"
             "    vehicle VARCHAR, cycle VARCHAR, files VARCHAR[], file_hashes JSON,\n"
             "    input_hash VARCHAR, elapsed_s DOUBLE,\n"
             + cols(METRIC_COLUMNS, "DOUBLE")
             + "    fuel VARCHAR, cell_temp_c DOUBLE, start_condition VARCHAR, ac VARCHAR,\n"
             f"    headline_name VARCHAR, headline_rule VARCHAR,{scope}\n"
             + cols(HEADLINE_COLUMNS, "DOUBLE")
             + "    withheld_reason VARCHAR, withheld_count INTEGER,\n"
             "    n_findings INTEGER, n_findings_by_severity JSON, qa_summary JSON,\n"
             "    validation JSON, validation_errors JSON, outputs VARCHAR[],\n"
             + cols(EN_COLUMNS, "DOUBLE") + cols(EN_FLAGS, "BOOLEAN")
             + "    PRIMARY KEY (test_id, run_id))")
    out = [
        """CREATE TABLE IF NOT EXISTS schema_info (
        version INTEGER NOT NULL, created TIMESTAMP NOT NULL, vehval_version VARCHAR)""",
        """CREATE TABLE IF NOT EXISTS runs (
        run_id VARCHAR PRIMARY KEY, started TIMESTAMP NOT NULL, finished TIMESTAMP,
        status VARCHAR NOT NULL, vehval_version VARCHAR NOT NULL, settings JSON,
        n_tests INTEGER, n_ok INTEGER, n_failed INTEGER, n_skipped INTEGER)""",
        tests,
        """CREATE TABLE IF NOT EXISTS findings (
        test_id VARCHAR NOT NULL, run_id VARCHAR NOT NULL, signal VARCHAR, kind VARCHAR,
        severity VARCHAR, start_s DOUBLE, end_s DOUBLE, message VARCHAR)""",
        "CREATE TABLE IF NOT EXISTS phase_results (\n"
        "    test_id VARCHAR NOT NULL, run_id VARCHAR NOT NULL, scope VARCHAR NOT NULL,\n"
        "    kind VARCHAR NOT NULL, part VARCHAR, run INTEGER,\n"
        + "".join(f"    {c} DOUBLE,\n" for c in PHASE_COLUMNS)
        + "    withheld_reason VARCHAR,\n"
        # a phase and a composite may share a name (a one-run hwfet): keyed by kind and scope
        f"    PRIMARY KEY (test_id, run_id, {phase_key}))",
    ]
    return out + ([_SET_VERDICTS] if set_verdicts else []) + [_VIEW]


#: The CREATE statements of the current schema.
DDL = ddl()


@dataclass(frozen=True)
class Shape:
    """The tables an older vehval created: its ``schema_info`` version and DDL."""

    name: str
    version: int
    statements: tuple[str, ...]


_V4 = frozenset(ADDED_COLUMNS[5])
_V3 = _V4 | frozenset(ADDED_COLUMNS[4])
#: The older catalogs this vehval migrates (every other version is refused).
SHAPES: tuple[Shape, ...] = (
    Shape("3 (phase_results keyed by scope)", 3,
          tuple(ddl(_V3, phase_key="scope", set_verdicts=False))),
    Shape("3", 3, tuple(ddl(_V3, set_verdicts=False))),
    Shape("4", 4, tuple(ddl(_V4))),
    Shape("5 (without kWh/100 mi)", 5, tuple(ddl(frozenset(MILE_COLUMNS)))),
)
#: The older schema versions :data:`SHAPES` covers (3 and 4).
MIGRATABLE_VERSIONS = tuple(sorted({s.version for s in SHAPES if s.version < SCHEMA_VERSION}))

#: DuckDB settings of every catalog connection: no access to other files, the network or
#: extensions (``read_csv``, ``COPY ... TO``, ``ATTACH``, ``INSTALL`` are refused) and a
#: memory and thread budget. ``lock_configuration`` is set right after opening.
SANDBOX_CONFIG: dict[str, Any] = {
    "enable_external_access": False,
    "autoinstall_known_extensions": False,
    "autoload_known_extensions": False,
    "allow_community_extensions": False,
    "memory_limit": "2GB",
    "threads": 2,
}


def duckdb_module():
    """The ``duckdb`` module, imported lazily: the CLI starts faster without it."""
    import duckdb

    return duckdb


def first_line(exc: BaseException) -> str:
    """The first line of a DuckDB error (no ``LINE 1:`` caret, no embedded traceback)."""
    text = str(exc).strip().splitlines()
    line = text[0] if text else type(exc).__name__
    return line if len(line) <= 300 else line[:297] + "..."


def _norm_sql(sql: str | None) -> str:
    return re.sub(r"\s+", " ", sql or "").strip().rstrip(";").strip()


_REFERENCES: dict[tuple[str, ...], dict[str, dict[str, str]]] = {}


def reference_schema(statements: tuple[str, ...] | list[str] = tuple(DDL)) -> dict[str, dict[str, str]]:
    """``{"table": {name: sql}, "view": {name: sql}}`` as DuckDB stores ``statements``."""
    key = tuple(statements)
    if key not in _REFERENCES:
        con = duckdb_module().connect(":memory:", config=dict(SANDBOX_CONFIG))
        try:
            for statement in key:
                con.execute(statement)
            _REFERENCES[key] = schema_objects(con, "memory")
        finally:
            con.close()
    return _REFERENCES[key]


def schema_objects(con, database: str) -> dict[str, dict[str, str]]:
    """The tables and views of ``database`` as ``{"table": {name: sql}, "view": {...}}``."""
    tables = con.execute("SELECT table_name, sql FROM duckdb_tables() WHERE database_name = ?",
                         [database]).fetchall()
    views = con.execute("SELECT view_name, sql FROM duckdb_views() WHERE NOT internal "
                        "AND database_name = ?", [database]).fetchall()
    return {"table": {n: _norm_sql(q) for n, q in tables},
            "view": {n: _norm_sql(q) for n, q in views}}


def schema_problems(con, reference: dict[str, dict[str, str]], *,
                    complete: bool = False) -> list[str]:
    """What the open database holds beyond ``reference`` (tables and views that differ or are
    unknown, any macro, sequence, index, user type, schema or attached database); with
    ``complete``, also each table or view of ``reference`` it lacks."""
    db = con.execute("SELECT current_database()").fetchone()[0]
    have = schema_objects(con, db)
    bad: list[str] = []
    for kind in ("table", "view"):
        for name, sql in sorted(have[kind].items()):
            if name not in reference[kind]:
                bad.append(f"unknown {kind} '{name}'")
            elif sql != reference[kind][name]:
                bad.append(f"{kind} '{name}' differs from the one vehval creates")
    for kind in ("table", "view") if complete else ():
        bad += [f"no {kind} '{name}'" for name in sorted(set(reference[kind]) - set(have[kind]))]
    others = [
        ("macro", "SELECT function_name FROM duckdb_functions() WHERE NOT internal"),
        ("sequence", "SELECT sequence_name FROM duckdb_sequences()"),
        ("index", "SELECT index_name FROM duckdb_indexes()"),
        ("type", "SELECT type_name FROM duckdb_types() WHERE NOT internal "
                 "AND database_name NOT IN ('system', 'temp')"),
        ("schema", "SELECT schema_name FROM duckdb_schemas() WHERE NOT internal "
                   "AND schema_name <> 'main'"),
        ("database", "SELECT database_name FROM duckdb_databases() WHERE NOT internal "
                     f"AND database_name <> '{db.replace(chr(39), chr(39) * 2)}'"),
    ]
    for kind, sql in others:
        bad += [f"unknown {kind} '{r[0]}'" for r in con.execute(sql).fetchall()]
    return bad


def altered(path: Path, bad: list[str]) -> ConfigError:
    """The error of a catalog holding what vehval does not create (``bad``, first named)."""
    more = f" (and {len(bad) - 1} more)" if len(bad) > 1 else ""
    return ConfigError(f"catalog {path} holds {bad[0]}{more}: it was not written by vehval or "
                       "was altered; nothing in it was run (use a catalog written by `vehval batch`)")


def stored_version(con, path: Path) -> int:
    """The schema version in ``schema_info`` (one row, an integer), else a one-line
    :class:`ConfigError` naming the file and what to do."""
    try:
        rows = con.execute("SELECT version FROM schema_info").fetchall()
    except Exception:  # noqa: BLE001 - any DuckDB error here means 'not a catalog'
        raise ConfigError(f"{path} is not a vehval catalog (no schema_info table): pass a "
                          "catalog written by `vehval batch`, or use a new output directory") from None
    if len(rows) != 1 or not isinstance(rows[0][0], int):
        got = f"{len(rows)} rows" if len(rows) != 1 else f"version {rows[0][0]!r}"
        raise ConfigError(f"catalog {path} has a corrupt schema_info ({got}, one integer "
                          "version expected): use a new output directory")
    return rows[0][0]


def version_refusal(path: Path, version: int) -> ConfigError:
    """The one-line error of a catalog this vehval does not read as it is (``version``)."""
    if version > SCHEMA_VERSION:
        return ConfigError(f"catalog {path} has schema version {version}, newer than the "
                           f"version {SCHEMA_VERSION} this vehval reads: use the vehval that "
                           "wrote it, or a new output directory")
    known = ", ".join(str(v) for v in MIGRATABLE_VERSIONS)
    return ConfigError(f"catalog {path} has schema version {version}, this vehval reads version "
                       f"{SCHEMA_VERSION} and migrates versions {known} only: use a new output "
                       "directory")


def find_shape(con, version: int) -> Shape | None:
    """The older shape of ``version`` the open database has exactly, if any."""
    for shape in SHAPES:
        if shape.version == version and not schema_problems(con, reference_schema(shape.statements),
                                                                complete=True):
            return shape
    return None


def _rebuild_table(con, name: str, statement: str, old_columns: list[str]) -> None:
    """Re-create table ``name`` with the current ``statement`` and copy its rows (the
    columns of ``old_columns``; every other column NULL)."""
    tmp = f"{name}__migrating"
    con.execute(statement.replace(f"CREATE TABLE IF NOT EXISTS {name} (",
                                  f"CREATE TABLE {tmp} (", 1))
    cols = ", ".join(f'"{c}"' for c in old_columns)
    con.execute(f"INSERT INTO {tmp} ({cols}) SELECT {cols} FROM {name}")
    con.execute(f"DROP TABLE {name}")
    con.execute(f"ALTER TABLE {tmp} RENAME TO {name}")


def _migrate_tables(con) -> None:
    """Bring every table and the view of the open database to :data:`DDL` (inside the
    caller's transaction)."""
    db = con.execute("SELECT current_database()").fetchone()[0]
    have = schema_objects(con, db)["table"]
    want = reference_schema()["table"]
    con.execute("DROP VIEW IF EXISTS latest_tests")
    for statement in DDL:
        found = re.match(r"CREATE TABLE IF NOT EXISTS (\w+) \(", statement)
        if found is None:
            continue
        name = found.group(1)
        if name not in have:
            con.execute(statement)
        elif have[name] != want[name]:
            old = [r[0] for r in con.execute(
                "SELECT column_name FROM duckdb_columns() WHERE database_name = ? AND "
                "table_name = ? ORDER BY column_index", [db, name]).fetchall()]
            _rebuild_table(con, name, statement, old)
            if name == "tests" and MILE_COLUMNS[0] not in old and "headline_kwh_per_100km" in old:
                # a version-5 catalog written before the kWh/100 mi columns: derived exactly
                km_per_mile = MILE_M / 1000.0
                con.execute(f"UPDATE tests SET headline_kwh_per_100mi = headline_kwh_per_100km * "
                            f"{km_per_mile!r}, headline_u_kwh_per_100mi = "
                            f"headline_u_kwh_per_100km * {km_per_mile!r}")
    con.execute(_VIEW)
    con.execute("UPDATE schema_info SET version = ?", [SCHEMA_VERSION])


def migrate(con, path: Path, shape: Shape) -> None:
    """Migrate the open catalog of ``shape`` to :data:`SCHEMA_VERSION` in one transaction.

    Rows written before keep every value; the columns their vehval did not have hold NULL
    (kWh/100 mi is derived from kWh/100 km for a version-5 catalog without it). On any
    failure the transaction is rolled back (the file is unchanged) and a one-line
    :class:`ConfigError` names the file and what to do.
    """
    con.execute("BEGIN TRANSACTION")
    try:
        _migrate_tables(con)
        bad = schema_problems(con, reference_schema(), complete=True)
        if bad:
            raise RuntimeError(f"the migrated catalog holds {bad[0]}")
        con.execute("COMMIT")
    except BaseException as exc:
        con.execute("ROLLBACK")
        if not isinstance(exc, Exception):
            raise
        raise ConfigError(f"catalog {path}: migrating schema version {shape.name} to "
                          f"{SCHEMA_VERSION} failed ({first_line(exc)}); the file is unchanged: "
                          "free disk space or memory and run the batch again, or use a new "
                          "output directory") from None


def open_schema(con, path: Path, *, read_only: bool) -> None:
    """Check the schema of the catalog open on ``con`` before anything in it runs: the
    current schema is accepted, an older shape of :data:`SHAPES` is migrated when writing
    (refused with what to do when ``read_only``), anything else is refused with one line."""
    version = stored_version(con, path)
    bad = schema_problems(con, reference_schema()) if version == SCHEMA_VERSION else []
    if version == SCHEMA_VERSION and not bad:
        return
    if version != SCHEMA_VERSION and version not in MIGRATABLE_VERSIONS:
        raise version_refusal(path, version)
    shape = find_shape(con, version)
    if shape is None:
        if not bad:   # an older version whose tables are none of those vehval created
            first = next(s.statements for s in SHAPES if s.version == version)
            bad = schema_problems(con, reference_schema(first)) or [
                f"tables of schema version {version} unlike those vehval created"]
        raise altered(path, bad)
    if read_only:
        raise ConfigError(f"catalog {path} has the older schema version {shape.name}, this "
                          f"vehval reads version {SCHEMA_VERSION}: run `vehval batch ... -o DIR` "
                          "on its folder once to migrate it in place")
    migrate(con, path, shape)
