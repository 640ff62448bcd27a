"""One test through the workflow: :class:`TestRun`, the outcome of each step, and how a
directory or a group of files becomes one test (the rules of :mod:`vehval.workflow`)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Sequence

from vehval.errors import ConfigError, InputFileError
from vehval.protocols import TemplateLike, VehicleLike
from vehval.test import Test

if TYPE_CHECKING:  # the stages' result types (the stages are imported when they run)
    from vehval.analysis.summary import AnalysisResult
    from vehval.qa.pipeline import QAResult
    from vehval.results.compute import TestResults
    from vehval.validate.validation import Validation

#: One policy for time stamps that go backwards or repeat: sort/drop them with a note.
REPAIR_TIME = True


@dataclass
class QAOutcome:
    """The ``qa`` step: the QA result and its ``findings.json`` document."""

    result: QAResult
    document: dict

    @property
    def validated(self) -> Test:
        """The validated test (aligned, calculated, selected)."""
        return self.result.validated


@dataclass
class ResultsOutcome:
    """The ``results`` step: per-phase, whole-test and regulatory results with uncertainty."""

    results: TestResults

    @property
    def document(self) -> dict:
        """The ``results.json`` document (contract in docs/results.md)."""
        return self.results.to_dict()


@dataclass
class AnalysisOutcome:
    """The ``analyze`` step: the control-strategy analysis and notes on its inputs."""

    result: AnalysisResult
    notes: list[str] = field(default_factory=list)

    @property
    def document(self) -> dict:
        """The ``control.json`` document."""
        return self.result.to_dict()


@dataclass
class ValidationOutcome:
    """The ``validate`` step: the model against the test, as the vehicle's architecture
    compares them (:mod:`vehval.architectures`): the simulation on the test's conditions
    (:class:`~vehval.validate.validation.Validation`, :attr:`validation`) or the fuel
    prediction of a conventional car (:class:`~vehval.identify.comparison.PredictionComparison`)."""

    comparison: Any

    @property
    def validation(self) -> Validation:
        """The simulation on the test's conditions; ConfigError when the architecture
        compares otherwise (its :attr:`comparison` is then the fuel prediction)."""
        from vehval.validate.validation import Validation

        if not isinstance(self.comparison, Validation):
            raise ConfigError(f"vehicle '{self.comparison.vehicle.name}' is "
                              f"'{self.comparison.vehicle.architecture}': its validation is "
                              "the fuel prediction per phase (no simulation on the test's "
                              "conditions to overlay or rank)")
        return self.comparison

    @property
    def document(self) -> dict:
        """The per-test validation summary (``validation.json`` of a batch test)."""
        return self.comparison.to_dict()

    @property
    def overlays(self) -> Any:
        """Measured and simulated traces on the simulation's time grid (a DataFrame of
        ``time`` [s] and ``<base>_test`` / ``<base>_simu`` in SI), whatever the architecture
        compares; None when the comparison has no traces (a fuel prediction per phase)."""
        own = getattr(self.comparison, "overlays", None)
        if own is not None:
            return own
        return getattr(getattr(self.comparison, "comparison", None), "overlays", None)

    def payload(self, figures: bool = True) -> dict:
        """The report's validation section: ``{tables, figures, notes}``."""
        return self.comparison.payload(figures=figures)


@dataclass
class ReportOutcome:
    """The ``report`` step: the files written (``report`` and ``tables`` when present)."""

    paths: dict[str, Path]


def load_template_arg(template: Any) -> Any:
    """A template from a path (loaded) or an already loaded template (unchanged)."""
    from vehval.io.template import load_template

    return load_template(template) if isinstance(template, (str, Path)) else template


def load_vehicle_arg(vehicle: Any) -> Any:
    """A vehicle from a name or path (loaded), None, or an already loaded vehicle."""
    if vehicle is None or not isinstance(vehicle, (str, Path)):
        return vehicle
    from vehval.vehicle import load_vehicle

    return load_vehicle(vehicle)


class TestRun:
    """One test through the workflow: ``load``, ``qa``, ``results``, ``analyze``, ``validate``,
    ``report``.

    Each step runs once per run; later steps use the outcome of earlier ones (``analyze``
    and ``validate`` run ``qa`` first unless the run was built with ``use_qa=False`` or
    from an already validated test). The ``results`` step (test results from the
    validated signals) joins the sequence between ``qa`` and ``analyze``.

    Attributes
    ----------
    test : Test
        The test as loaded (imported, or read back validated).
    template, vehicle : optional
        Import template and vehicle model (loaded objects).
    origin : str
        Where the test came from (paths), for messages and for results stored beside it.
    validated_input : bool
        True when the test was read back already validated (``validated.parquet``): QA is
        not run again; its ``findings.json`` beside it (``vehval qa``'s, of the same test)
        gates the results as QA's findings would.
    """

    __test__ = False  # not a pytest test class

    def __init__(self, test: Test, template: TemplateLike | None = None,
                 vehicle: VehicleLike | None = None, *,
                 origin: str = "", validated_input: bool = False, use_qa: bool = True,
                 qa: QAOutcome | None = None) -> None:
        self.test = test
        self.template: TemplateLike | None = template
        self.vehicle: VehicleLike | None = vehicle
        self.origin = origin
        self.validated_input = validated_input
        self.use_qa = use_qa and not validated_input
        self._qa = qa
        self._analysis: AnalysisOutcome | None = None
        self._results: ResultsOutcome | None = None
        self._validation: ValidationOutcome | None = None
        #: QA findings stored beside a validated input (its ``findings.json``)
        self.stored_findings: list[Any] = []

    # ------------------------------------------------------------------ load
    @classmethod
    def load(cls, files: Sequence[str | Path], template: Any, vehicle: Any = None, *,
             repair_time: bool = REPAIR_TIME, test_id: str | None = None,
             use_qa: bool = True) -> "TestRun":
        """Import the raw files of one test with a template.

        Parameters
        ----------
        files : list of paths
            Raw files of the test (one per acquisition system).
        template : Template or path
            Import template.
        vehicle : Vehicle or name/path, optional
            Vehicle model; default the template's ``vehicle:`` when it names one.
        repair_time : bool
            Repair backwards/repeated time stamps with a note (the policy of every command).
        test_id : str, optional
            Test identifier (default: stem of the first file).
        use_qa : bool
            Later steps use QA's validated test (default) or the imported signals as they are.
        """
        from vehval.io.importer import import_test

        paths = [Path(f) for f in files]
        for p in paths:
            if not p.exists():
                raise InputFileError(f"{p}: file not found: check the path")
        tpl = load_template_arg(template)
        if vehicle is None and getattr(tpl, "vehicle", None):
            vehicle = tpl.vehicle
        veh = load_vehicle_arg(vehicle)
        test = import_test(paths, tpl, repair_time=repair_time, test_id=test_id)
        return cls(test, tpl, veh, origin=", ".join(map(str, paths)), use_qa=use_qa)

    @classmethod
    def from_paths(cls, paths: Sequence[str | Path], template: Any = None, vehicle: Any = None,
                   *, use_qa: bool = True, repair_time: bool = REPAIR_TIME) -> "TestRun":
        """One test from a directory, a validated Parquet test or a group of raw files
        (the grouping rule of the module docstring)."""
        given = [Path(p) for p in paths]
        for p in given:
            if not p.exists():
                raise InputFileError(f"{p}: not found")
        veh = load_vehicle_arg(vehicle)
        one = given[0] if len(given) == 1 else None
        if one is not None and one.is_dir() and (one / "validated.parquet").is_file():
            return cls._validated(one / "validated.parquet", one, veh)
        if one is not None and one.is_file() and one.suffix.lower() == ".parquet":
            return cls._validated(one, one, veh)
        if one is not None and one.is_dir():
            tpl = _template_for(one, template)
            return cls.load(_dir_files(one, tpl), tpl, veh, repair_time=repair_time,
                            test_id=one.name, use_qa=use_qa)
        if any(p.is_dir() for p in given):
            raise InputFileError("a test group mixes directories and files: give one directory "
                                 "or the files of one test")
        tpl = (_template_for(None, template) if template is not None
               else _template_for(given[0].parent, None))
        return cls.load(given, tpl, veh, repair_time=repair_time, use_qa=use_qa)

    @classmethod
    def _validated(cls, path: Path, origin: Path, vehicle: Any) -> "TestRun":
        """A validated test read back, with the QA findings stored beside it (an error
        there withholds the figures it touches, as when QA ran; a findings.json of
        another test is refused)."""
        from vehval.io.parquet import read_test
        from vehval.report.inputs import checked_document, refuse_other_test, results_beside

        test = read_test(path)
        run = cls(test, None, vehicle, origin=str(origin), validated_input=True)
        found = results_beside(origin, ("findings",)).get("findings")
        if found is not None:
            where = path.parent / "findings.json"
            checked_document(found, "findings", where)
            refuse_other_test(test, path, [(found, where)])
            run.stored_findings = _stored_findings(found.get("findings"), where)
        return run

    # ------------------------------------------------------------------ steps
    def qa(self, **options: Any) -> QAOutcome:
        """Alignment, QA levels 1-3, calculations and selection (once per run).

        ``options`` go to :func:`vehval.qa.pipeline.run_qa` (e.g. ``max_offset_s``).
        """
        if self._qa is None:
            if self.validated_input:
                raise ConfigError(f"{self.origin}: already a validated test: QA is not run again")
            from vehval.io.budget import check_qa_memory
            from vehval.qa.pipeline import run_qa

            check_qa_memory(self.test)  # refused up front rather than a MemoryError halfway
            res = run_qa(self.test, self.vehicle, self.template, **options)
            self._qa = QAOutcome(res, res.to_dict())
        return self._qa

    @property
    def qa_outcome(self) -> QAOutcome | None:
        """The QA outcome when QA ran, else None."""
        return self._qa

    @property
    def validated(self) -> Test:
        """The test the later steps use: QA's validated test (QA runs when needed), the
        validated test read back, or the imported test when QA is off."""
        if self.use_qa:
            return self.qa().validated
        return self.test

    def results(self, *, method: str = "first_order", draws: int = 1000, seed: int = 0,
                hot_start_bag1: dict | None = None, force: bool = False) -> ResultsOutcome:
        """Test results from the validated signals with the template's ``fuel``, ``accuracy``
        and ``phase_channel`` (see :func:`vehval.results.compute_results`), gated by QA's
        error findings (:func:`vehval.results.gate.apply_gate`; ``force`` states withheld
        figures anyway); runs once per run unless called again with other options."""
        from vehval.results import results_from_template
        from vehval.results.compute import results_of_validated
        from vehval.results.gate import apply_gate

        opts: dict[str, Any] = {"method": method, "draws": draws, "seed": seed,
                                "hot_start_bag1": hot_start_bag1}
        if (self._results is None or getattr(self, "_results_opts", None) != opts
                or self._results.results.forced != force):
            test = self.validated
            if self.template is not None:
                res = results_from_template(test, self.template, self.vehicle, **opts)
            else:       # a validated test read back: its vehicle may make it battery-electric
                res = results_of_validated(test, self.vehicle, **opts)
            apply_gate(res, self._qa.result.findings if self._qa is not None
                       else self.stored_findings, force=force)
            self._results = ResultsOutcome(res)
            self._results_opts = opts
        return self._results

    @property
    def results_outcome(self) -> ResultsOutcome | None:
        """The results outcome when the step ran, else None."""
        return self._results

    def analyze(self) -> AnalysisOutcome:
        """Control-strategy analysis (engine on/off rule, SOC regulation, modes, braking)."""
        if self._analysis is None:
            from vehval.architectures import require

            notes: list[str] = []
            excluded: list = []
            if self.use_qa:
                from vehval.analysis.inputs import after_qa, mask_flagged_samples

                work, notes = after_qa(self.qa().result, self.test)
                # samples QA flagged are not analysed (a SOC of 0 is not the minimum SOC)
                excluded = mask_flagged_samples(work, self.qa().result.findings)
            else:
                work = self.test
            result = require(self.vehicle, "analyze")(work, self.vehicle)
            result.findings[:0] = [f.to_dict() for f in excluded]
            self._analysis = AnalysisOutcome(result, notes)
        return self._analysis

    def validate(self, *, dt: float = 0.1, window_s: float = 2.0,
                 smooth_hz: float | None = None, overrides: dict | None = None) -> ValidationOutcome:
        """Simulate the vehicle on the test's own conditions and compare with the test."""
        if self.vehicle is None:
            raise ConfigError("validation needs a vehicle model: pass --vehicle or set "
                              "'vehicle:' in the template")
        from vehval.architectures import require

        self._validation = ValidationOutcome(require(self.vehicle, "validate")(
            self, dt=dt, window_s=window_s, smooth_hz=smooth_hz, overrides=overrides))
        return self._validation

    def report(self, outdir: str | Path, *, control: Any = None, validation: Any = None,
               qa: Any = None, title: str | None = None, raw: Test | None = None,
               results: Any = None,
               html_name: str = "report.html", excel: bool = True,
               plotly_js: str | None = None) -> ReportOutcome:
        """Write ``report.html`` (and ``tables.xlsx``) with every step that ran.

        ``control``, ``validation``, ``qa`` and ``results`` override the run's own outcomes (e.g. the
        documents of earlier commands read back from disk).
        """
        from vehval.report import build_reports, write_report

        if qa is None and self._qa is not None:
            qa = self._qa.result
        if control is None and self._analysis is not None:
            control = self._analysis.document
        if validation is None and self._validation is not None:
            validation = self._validation.payload()
        if results is None and self._results is not None:
            results = self._results.document
        kw: dict[str, Any] = {"vehicle": self.vehicle, "control": control,
                              "validation": validation, "title": title, "raw": raw,
                              "results": results}
        if plotly_js is not None:
            kw["plotly_js"] = plotly_js
        test = self.validated
        if excel:
            paths = build_reports(Path(outdir), test, qa, self.template, html_name=html_name, **kw)
        else:
            paths = {"report": write_report(Path(outdir) / html_name, test=test, qa=qa,
                                            template=self.template, **kw)}
        return ReportOutcome(paths)


# ---------------------------------------------------------------------- grouping of paths
def _template_for(path: Path | None, template: Any) -> Any:
    if template is not None:
        return load_template_arg(template)
    if path is not None and path.is_dir() and (path / "template.yaml").is_file():
        return load_template_arg(path / "template.yaml")
    raise ConfigError(f"no template for {path}: give -t TEMPLATE.yaml (or put template.yaml in "
                      "the test directory)")


def _dir_files(d: Path, template: Any) -> list[Path]:
    from vehval.io.folder import data_files, match_globs

    out = data_files(sorted(p for p in d.iterdir() if p.is_file()), template)
    if not out:
        raise InputFileError(f"{d}: no data file matches the template "
                             f"({', '.join(match_globs(template)) or 'any data file'})")
    return out


def _stored_findings(items: Any, where: Path) -> list[Any]:
    """The findings of a stored ``findings.json`` (``where``) as :class:`Finding` objects;
    :class:`InputFileError` naming the entry when one is damaged."""
    from vehval.qa.findings import Finding

    if not isinstance(items, list):
        raise InputFileError(f"{where}: 'findings' is not a list: re-run `vehval qa`")
    out = []
    for k, item in enumerate(items):
        try:
            out.append(Finding.from_dict(item))
        except (KeyError, ValueError, TypeError, AttributeError) as exc:
            raise InputFileError(f"{where}: finding {k} is damaged ({type(exc).__name__}: "
                                 f"{str(exc)[:80]}): re-run `vehval qa`") from None
    return out
