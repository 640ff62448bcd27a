"""The fleet: every conventional row of one or more EPA Test Car Lists, predicted or accounted for.

:func:`plan_fleet` groups the rows of each list into cars (one test vehicle configuration:
list, year, make, model, test vehicle ID, configuration number) and decides for every row
whether it is run, or why not (:data:`REASONS`): a hybrid or plug-in, an electric or other
fuel, a procedure the simulator has no plan for (SC03, cold CO), an analytically derived
figure (never judged as a test), a placeholder result, missing road-load coefficients, a
transmission or a specification the model from specs cannot build
(:func:`vehval.epa.specs.specs_from_tests` says why). The rows run form one
:class:`CarJob` per car and fuel: :func:`predict_car` builds the car once from its specs
(:func:`vehval.epa.specs.vehicle_from_specs`) and predicts each row on its own procedure,
weight and road load (:func:`vehval.epa.validation.predict_test`). :func:`predict_jobs` runs
the jobs in a plain loop or on a ``dask.distributed`` client (the caller makes the client:
:mod:`vehval.batch.fleet`).

Every row ends as one flat record (:data:`ROW_COLUMNS`, SI units, fuel economy in mpg):
``status`` ``run``, ``not_run`` or ``failed`` with its ``reason_code`` and ``reason``.
"""

from __future__ import annotations

import functools
import hashlib
import math
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterable, Sequence

from vehval.epa.procedures import RUNNABLE, UNRUNNABLE, fuel_family, plan_for, procedure_key
from vehval.epa.reader import EpaTest, find_list_files, read_test_car_list
from vehval.epa.specs import ENGINE_FUELS
from vehval.errors import VehvalError

#: reason code -> what it means (every row not run carries one, with a line naming the row)
REASONS = {
    "hybrid": "hybrid or plug-in hybrid (the model from specs is a conventional car)",
    "electric": "electric test (charge-depleting or battery-electric)",
    "fuel_not_modelled": "a test fuel the model has no engine for (hydrogen, CNG)",
    "procedure_not_modelled": "a procedure without a simulation plan (SC03, cold CO...)",
    "analytically_derived": "analytically derived: a computed figure, never judged as a test",
    "placeholder_values": "no measured result (0 or empty: the list's placeholder), or a "
                          "unit other than mpg",
    "missing_coefficients": "no road-load target coefficients (or no test weight)",
    "transmission_not_modelled": "a transmission the model from specs does not build",
    "specs_not_usable": "the car's specification is missing, impossible or ambiguous",
    "model_error": "the simulation of this row failed",
}
#: the report's name of each transmission family (vehval.epa.transmissions owns the codes)
CLASS_OF_FAMILY = {"automatic": "automatic", "cvt": "CVT", "automated_manual": "dual-clutch",
                   "manual": "manual"}
#: simulation step of the fleet [s] (``epa validate``'s default: at 1 s the HWFET reads
#: about 1.5 % higher)
FLEET_DT_S = 0.2
#: cars per Dask task are chosen so that each worker gets about this many tasks (a car takes
#: 5-20 ms: one task per car would cost more in scheduling than in simulation)
TASKS_PER_WORKER = 8

#: the flat record of a row, in order (SI; fuel economy in mpg; error = predicted / measured - 1)
ROW_COLUMNS = (
    "row_id", "list", "source", "car", "year", "make", "model", "vehicle_id", "config",
    "test_number", "originator", "procedure", "procedure_code", "fuel", "fuel_family",
    "transmission", "transmission_class", "gears", "cylinders", "aspiration",
    "displacement_l", "rated_power_w", "specific_power_w_per_l", "mass_kg", "axle_ratio",
    "n_v_ratio", "target_a_n", "target_b_n_per_mps", "target_c_n_per_mps2",
    "measured_mpg", "predicted_mpg", "error",
    "measured_bag1", "measured_bag2", "measured_bag3", "measured_bag4",
    "predicted_bag1", "predicted_bag2", "predicted_bag3", "predicted_bag4",
    "judged", "list_doubtful", "trace_n_miss", "status", "reason_code", "reason",
    "in_sample", "coefficients", "u_model_mpg", "u_meas_mpg", "en",
)


def _f(x: float) -> float | None:
    """A float for a record (NaN -> None)."""
    return None if x is None or not math.isfinite(float(x)) else float(x)


def aspiration(t: EpaTest) -> str:
    """``diesel``, ``turbocharged`` or ``naturally aspirated`` (the technology rule of
    :func:`vehval.epa.technology.engine_technology`); ``unknown`` without power or
    displacement."""
    from vehval.epa.technology import engine_technology

    if fuel_family(t.fuel) == "diesel":
        return "diesel"
    if not (t.displacement_l > 0 and t.rated_power_w > 0):
        return "unknown"
    turbo = engine_technology(t.rated_power_w, t.displacement_l) == "spark_turbo"
    return "turbocharged" if turbo else "naturally aspirated"


def transmission_class(t: EpaTest) -> str:
    """``automatic``, ``CVT``, ``dual-clutch``, ``manual`` or ``other`` of the listed code."""
    from vehval.epa.transmissions import FAMILY_OF_CODE

    fam = FAMILY_OF_CODE.get((t.transmission or "").strip().upper())
    return CLASS_OF_FAMILY.get(fam or "", "other")


def car_key(t: EpaTest) -> str:
    """The car a row belongs to: list file, year, make, model, test vehicle, configuration."""
    return f"{t.source.rsplit(':', 1)[0]}|{t.year}|{t.make}|{t.model}|{t.vehicle_id}|{t.config}"


def base_record(t: EpaTest) -> dict[str, Any]:
    """The row's own values as a record (status not yet set)."""
    spec = t.rated_power_w / t.displacement_l if t.displacement_l > 0 else math.nan
    rec: dict[str, Any] = dict.fromkeys(ROW_COLUMNS)
    rec.update(
        row_id=t.source, list=t.source.rsplit(":", 1)[0], source=t.source, car=car_key(t),
        year=t.year, make=t.make, model=t.model, vehicle_id=t.vehicle_id, config=t.config,
        test_number=t.test_number, originator=t.originator, procedure=procedure_key(t),
        procedure_code=t.procedure_code, fuel=t.fuel, fuel_family=fuel_family(t.fuel),
        transmission=t.transmission, transmission_class=transmission_class(t),
        gears=t.gears, cylinders=t.cylinders, aspiration=aspiration(t),
        displacement_l=_f(t.displacement_l), rated_power_w=_f(t.rated_power_w),
        specific_power_w_per_l=_f(spec), mass_kg=_f(t.mass_kg), axle_ratio=_f(t.axle_ratio),
        n_v_ratio=_f(t.n_v_ratio), target_a_n=_f(t.target_a_n),
        target_b_n_per_mps=_f(t.target_b_n_per_mps),
        target_c_n_per_mps2=_f(t.target_c_n_per_mps2), measured_mpg=_f(t.fe),
        judged=False, list_doubtful=False)
    for k in range(4):
        rec[f"measured_bag{k + 1}"] = _f(t.bags[k])
    return rec


def not_run(t: EpaTest, code: str, why: str) -> dict[str, Any]:
    """The record of a row not run: ``code`` from :data:`REASONS`, ``why`` one line."""
    return {**base_record(t), "status": "not_run", "reason_code": code,
            "reason": f"{t.source}: {why}"}


#: what a stored car's prediction depends on besides its rows: the sources of the model from
#: specs, the simulator and the vehicle files, and the package data they read (relative to
#: the vehval package)
MODEL_SOURCES = ("epa/*.py", "sim/*.py", "sim/**/*.py", "vehicle/*.py", "data/epa/**/*",
                 "data/fuels.yaml", "data/cycles/**/*")


@functools.lru_cache(maxsize=1)
def model_fingerprint() -> str:
    """Hash of the vehval version and of every file of :data:`MODEL_SOURCES`: a stored car
    is reused only by the same model (a changed coefficient file or kernel runs it again)."""
    from vehval import __version__

    root = Path(__file__).resolve().parents[1]
    h = hashlib.sha256(__version__.encode())
    files = sorted({p for pat in MODEL_SOURCES for p in root.glob(pat) if p.is_file()})
    for p in files:
        h.update(str(p.relative_to(root)).encode())
        h.update(p.read_bytes())
    return h.hexdigest()[:16]


@dataclass
class CarJob:
    """The rows of one car on one fuel to predict, with the car's specification."""

    key: str
    fuel: str
    specs: Any  # vehval.epa.specs.Specs
    tests: list[EpaTest] = field(default_factory=list)
    dt: float = FLEET_DT_S
    #: technology coefficients the car is built with (None: the package's file)
    coefficients: Any = None  # vehval.epa.technology.Coefficients
    #: the rows' list is one the coefficients were fitted on
    in_sample: bool = False
    #: rows (``source``) that are the same test (number and vehicle) as a row of a list the
    #: coefficients were fitted on: a test carried over from one list year to the next
    in_sample_rows: frozenset[str] = frozenset()

    @functools.cached_property
    def digest(self) -> str:
        """Hash of what the job's results depend on: specs, rows, step, the technology
        coefficients and the model (:func:`model_fingerprint`); computed once per job (the
        dataclasses' reprs hold every field: exact floats, in order)."""
        coef = self.coefficients.digest if self.coefficients is not None else None
        payload = "\n".join([repr(self.specs), repr(self.dt), self.fuel, str(coef),
                              model_fingerprint(), *map(repr, self.tests)])
        return hashlib.sha256(payload.encode()).hexdigest()[:20]


@dataclass
class FleetPlan:
    """What :func:`plan_fleet` found: jobs to run and the rows not run, per list file."""

    jobs: list[CarJob] = field(default_factory=list)
    not_run: list[dict[str, Any]] = field(default_factory=list)
    lists: list[str] = field(default_factory=list)
    n_rows: int = 0

    @property
    def n_to_run(self) -> int:
        return sum(len(j.tests) for j in self.jobs)


def read_fleet(paths: Sequence[str | Path]) -> tuple[list[EpaTest], list[str]]:
    """Every row of every list file in ``paths`` (files or directories), each list read on
    its own (a test carried over to a later list is a row of each); and the file names."""
    files = find_list_files(paths)
    tests: list[EpaTest] = []
    for f in files:
        tests.extend(read_test_car_list(f))
    return tests, [f.name for f in files]


def _row_reason(t: EpaTest, fam: str) -> tuple[str, str] | None:
    """Why a row of a conventional car is not run ((code, line) or None: runnable)."""
    if fam == "other" and "ELECTRIC" in t.fuel.upper():
        return "electric", f"test fuel '{t.fuel}': an electric test"
    key = procedure_key(t)  # first: a cold CO row's fuel is the cold CO fuel, not its reason
    if key in UNRUNNABLE or key not in RUNNABLE:
        return "procedure_not_modelled", (UNRUNNABLE.get(key) or f"procedure code "
                                          f"{t.procedure_code} ('{t.procedure}') has no plan")
    if fam not in ENGINE_FUELS:  # the fuel families run, each on its own engine fuel
        return "fuel_not_modelled", f"test fuel '{t.fuel}': no engine model for this fuel"
    if t.analytically_derived:
        src = f" from test {t.adfe_test_number}" if t.adfe_test_number else ""
        return "analytically_derived", (f"analytically derived{src} ('Analytically Derived "
                                        "FE?' Yes): a computed figure, not a test")
    _, why = plan_for(t, fam)
    if why:
        return ("placeholder_values" if "unit" in why else "missing_coefficients"), why
    if math.isnan(t.fe):
        return "placeholder_values", ("no measured whole-test result (RND_ADJ_FE 0 or empty: "
                                      "the list's placeholder)")
    return None


def _spec_reason(exc: VehvalError, tests: list[EpaTest]) -> str:
    """Reason code of a car :func:`specs_from_tests` refuses."""
    text = str(exc)
    if "transmission" in text and "differ" not in text:
        return "transmission_not_modelled"
    return "hybrid" if "hybrid" in text else "specs_not_usable"


def plan_fleet(tests: Iterable[EpaTest], dt: float = FLEET_DT_S,
               coefficients: Sequence[Any] | None = None) -> FleetPlan:
    """Group rows into cars and decide for each row: a job to run, or not run with its reason.

    ``coefficients``: technology coefficient sets (:class:`vehval.epa.technology.Coefficients`;
    default the package's file); each list's cars are built with the first set not fitted
    on that list (:func:`vehval.epa.technology.for_list`), else the first, in-sample.
    Every row given ends either in one :class:`CarJob` or in ``FleetPlan.not_run``."""
    from vehval.epa import technology as tech
    from vehval.epa.specs import hybrid_mark, specs_from_tests

    choices = list(coefficients or [tech.load_coefficients()])

    plan = FleetPlan()
    cars: dict[str, list[EpaTest]] = defaultdict(list)
    lists_of_test: dict[tuple[str, str], set[str]] = defaultdict(set)
    for t in tests:
        cars[car_key(t)].append(t)
        lists_of_test[(t.test_number, t.vehicle_id)].add(t.source.rsplit(":", 1)[0])
        plan.n_rows += 1
    plan.lists = sorted({k.split("|", 1)[0] for k in cars})
    for key, rows in cars.items():
        mark = hybrid_mark(rows)
        if mark:
            # a car with electricity rows only is battery-electric, not a hybrid
            kind = ("a battery-electric car" if all("ELECTRIC" in t.fuel.upper() for t in rows)
                    else "a hybrid or plug-in hybrid")
            plan.not_run.extend(
                not_run(t, "electric" if "ELECTRIC" in t.fuel.upper() else "hybrid",
                        f"{t.make} {t.model}: {mark}: {kind} ("
                        f"{'electricity' if 'ELECTRIC' in t.fuel.upper() else fuel_family(t.fuel)}"
                        " test); "
                        "the model from specs is a conventional car")
                for t in rows)
            continue
        by_fuel: dict[str, list[EpaTest]] = defaultdict(list)
        for t in rows:
            fam = fuel_family(t.fuel)
            why = _row_reason(t, fam)
            if why is not None:
                plan.not_run.append(not_run(t, *why))
            else:
                by_fuel[fam].append(t)
        for fam, run in by_fuel.items():
            spec_rows = [t for t in rows if fuel_family(t.fuel) == fam]
            try:
                specs = specs_from_tests(spec_rows, fam)
            except VehvalError as exc:
                code = _spec_reason(exc, spec_rows)
                plan.not_run.extend(not_run(t, code, str(exc)) for t in run)
                continue
            coef, inside = tech.for_list(key.split("|", 1)[0], choices)
            carried = frozenset(t.source for t in run if t.test_number and
                                lists_of_test[(t.test_number, t.vehicle_id)] & set(coef.fit_lists))
            plan.jobs.append(CarJob(key=key, fuel=fam, specs=specs, tests=run, dt=dt,
                                    coefficients=coef, in_sample=inside,
                                    in_sample_rows=carried))
    return plan


def training_jobs(plan: FleetPlan) -> list[CarJob]:
    """The cars to simulate only to fit the learned residual year to year: for every
    coefficient set that judges a list, the cars of the other lists it was fitted on, built
    with it (in-sample; see :mod:`vehval.epa.fleet_baseline`). None when no list of the run
    is one a judging set was fitted on."""
    judging = {id(j.coefficients): j.coefficients for j in plan.jobs
               if j.coefficients is not None}
    out = []
    for coef in judging.values():
        for j in plan.jobs:
            lst = j.key.split("|", 1)[0]
            if j.coefficients is not coef and lst in coef.fit_lists:
                out.append(CarJob(key=j.key, fuel=j.fuel, specs=j.specs, tests=j.tests,
                                  dt=j.dt, coefficients=coef, in_sample=True))
    return out


def _marks(job: CarJob, source: str | None) -> dict[str, Any]:
    """The row ``source``'s in-sample mark and the coefficients its car was built with."""
    coef = job.coefficients
    return {"in_sample": job.in_sample or source in job.in_sample_rows,
            "coefficients": coef.label if coef is not None else None}


def _job_record(job: CarJob, t: EpaTest) -> dict[str, Any]:
    """The row's own values and its marks (:func:`_marks`)."""
    return {**base_record(t), **_marks(job, t.source)}


def relabel(job: CarJob, records: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Stored records of ``job``'s car with this run's in-sample marks (they depend on the
    lists read beside it, not on the prediction)."""
    return [{**r, **_marks(job, r.get("source"))} for r in records]


def model_u_rel(job: CarJob) -> float:
    """Relative standard uncertainty [-] of the car's fuel economy from the technology
    coefficients' intervals: the indicated efficiency of its engine and the gearbox
    efficiency of its family (mpg is proportional to both), each a uniform range (half
    width / sqrt 3); 0 without intervals. The grid coefficients (friction, idle, pumping,
    accessories, shift) are not propagated."""
    from vehval.epa import technology as tech

    coef = job.coefficients or tech.load_coefficients()
    parts = [coef.engine_value(job.specs.engine_technology, "indicated_efficiency"),
             coef.transmission_value(job.specs.family, "efficiency")]
    u2 = sum((0.5 * (c.interval[1] - c.interval[0]) / math.sqrt(3) / c.value) ** 2
             for c in parts if c is not None and c.value > 0)
    return math.sqrt(u2)


def verdict(t: EpaTest, predicted: float, u_rel: float) -> dict[str, float | None]:
    """U_model, U_meas [mpg] (k = 2) and En of a row: U_meas from the packaged precision of
    the procedure (conventional cars, vehicle level s_R: the model never saw this car;
    :func:`vehval.uncertainty.defaults.precision_default`), U_model from ``u_rel``."""
    from vehval.uncertainty import measurement_uncertainty, normalised_error
    from vehval.uncertainty.defaults import precision_default

    try:
        d = precision_default(procedure_key(t), "conventional")
    except VehvalError:
        return {"u_model_mpg": None, "u_meas_mpg": None, "en": None}
    s_r = d.s_r or 0.0
    u_meas = measurement_uncertainty(t.fe, s_r=s_r, s_R=d.s_R_vehicle or d.s_R or s_r,
                                     different_source=True)
    u_model = 2.0 * u_rel * predicted
    en = normalised_error(predicted, t.fe, u_model, u_meas).en
    return {"u_model_mpg": u_model, "u_meas_mpg": u_meas, "en": _f(en)}


def _predicted(job: CarJob, t: EpaTest, pred: Any, u_rel: float) -> dict[str, Any]:
    from vehval.epa.consistency import check_listed_figures

    check = check_listed_figures(t)
    rec = {**_job_record(job, t), "status": "run", "reason_code": None, "reason": None,
           "predicted_mpg": _f(pred.overall_mpg), "trace_n_miss": int(pred.trace_n_miss),
           "list_doubtful": not check.ok, "judged": bool(check.ok)}
    if not check.ok:
        rec["reason"] = f"{t.source}: list figures doubtful, not judged: {check.note}"
    for k, v in pred.bags_mpg.items():
        rec[f"predicted_bag{k}"] = _f(v)
    if rec["predicted_mpg"] is not None and rec["measured_mpg"]:
        rec["error"] = rec["predicted_mpg"] / rec["measured_mpg"] - 1.0
        if check.ok:  # judged: its normalised error
            rec.update(verdict(t, rec["predicted_mpg"], u_rel))
    return rec


def predict_car(job: CarJob) -> list[dict[str, Any]]:
    """Build the car of ``job`` once and predict each of its rows (one record per row).

    A row whose simulation fails is a ``failed`` record naming the row and the error; the
    other rows go on."""
    from vehval.epa.specs import vehicle_from_specs
    from vehval.epa.validation import predict_test

    try:
        veh: Any = vehicle_from_specs(job.specs, coefficients=job.coefficients)
    except VehvalError as exc:
        return [{**_job_record(job, t), "status": "failed", "reason_code": "specs_not_usable",
                 "reason": f"{t.source}: {exc}"} for t in job.tests]
    out = []
    u_rel = model_u_rel(job)  # the car's, for every row
    for t in job.tests:
        proc, why = plan_for(t, job.fuel)
        try:
            if proc is None:
                raise VehvalError(why)
            out.append(_predicted(job, t, predict_test(veh, t, proc, job.dt), u_rel))
        except Exception as exc:  # noqa: BLE001 - one failed row is recorded, the rest go on
            out.append({**_job_record(job, t), "status": "failed", "reason_code": "model_error",
                        "reason": f"{t.source}: {type(exc).__name__}: {exc}"})
    return out


def predict_chunk(jobs: Sequence[CarJob]) -> list[list[dict[str, Any]]]:
    """:func:`predict_car` of each job (one Dask task)."""
    return [predict_car(job) for job in jobs]


def chunks(jobs: Sequence[CarJob], n_workers: int,
           per_worker: int = TASKS_PER_WORKER) -> list[list[CarJob]]:
    """Jobs cut into about ``n_workers x per_worker`` tasks, rows balanced."""
    n = max(1, min(len(jobs), max(n_workers, 1) * per_worker))
    out: list[list[CarJob]] = [[] for _ in range(n)]
    load = [0] * n
    for job in sorted(jobs, key=lambda j: -len(j.tests)):
        k = load.index(min(load))
        out[k].append(job)
        load[k] += len(job.tests)
    return [c for c in out if c]


def _lost(job: CarJob, exc: BaseException) -> list[dict[str, Any]]:
    return [{**_job_record(job, t), "status": "failed", "reason_code": "model_error",
             "reason": f"{t.source}: task lost ({type(exc).__name__}: {exc})"}
            for t in job.tests]


def predict_jobs(jobs: Sequence[CarJob], client: Any = None,
                 on_result: Callable[[CarJob, list[dict[str, Any]]], None] | None = None
                 ) -> list[dict[str, Any]]:
    """Predict every job: a plain loop without ``client``, else on that ``dask.distributed``
    client (jobs cut into a few tasks per worker, :func:`chunks`; results taken as they
    land). ``on_result(job, records)`` is called for each car as it lands (in this
    process). Returns every record."""
    out: list[dict[str, Any]] = []

    def land(job: CarJob, recs: list[dict[str, Any]]) -> None:
        out.extend(recs)
        if on_result is not None:
            on_result(job, recs)

    if client is None:
        for job in jobs:
            land(job, predict_car(job))
        return out
    from distributed import as_completed

    n_workers = len(client.scheduler_info().get("workers", {})) or 1
    parts = chunks(jobs, n_workers)
    futs = {client.submit(predict_chunk, part, pure=False,
                          key=f"vehval-fleet-{part[0].digest}-{k}"): part
            for k, part in enumerate(parts)}
    try:
        for fut in as_completed(list(futs)):
            part = futs[fut]
            try:
                results = fut.result()
            except Exception as exc:  # noqa: BLE001 - a lost task is recorded, not fatal
                results = [_lost(job, exc) for job in part]
            for job, recs in zip(part, results):
                land(job, recs)
    except BaseException:
        for f in futs:
            f.cancel()
        raise
    return out


def predict_rows(tests: Iterable[EpaTest], client: Any = None,
                 dt: float = FLEET_DT_S) -> list[dict[str, Any]]:
    """Every row of ``tests`` as a record: predicted, or not run with its reason."""
    plan = plan_fleet(tests, dt)
    return [*plan.not_run, *predict_jobs(plan.jobs, client)]
