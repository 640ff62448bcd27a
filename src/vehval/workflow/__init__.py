"""The workflow of one test, in one place: load -> qa -> results -> analyze -> validate -> report.

:class:`TestRun` owns the sequence every command and the batch runner follow (in the
spirit of pvlib's ``ModelChain``): each step is a method that runs the earlier steps it
needs once, keeps its outcome on the run, and returns a typed outcome. The command line
and :mod:`vehval.batch` only parse arguments and write files.

Policies decided here, once:

* time stamps that go backwards or repeat are repaired with a note (``REPAIR_TIME``), in
  every command: the same files pass or fail alike in ``qa``, ``analyze``, ``validate``,
  ``calibrate`` and ``batch``;
* the analysis runs on QA's validated test (plus the battery signals QA dropped only for
  their sign, which the analysis checks itself);
* validation runs on QA's validated test.

Grouping of command-line paths into tests (:func:`group_args`, :func:`runs_from_args`):

* a directory is one test: its ``validated.parquet`` (output of ``vehval qa``) when present,
  else the raw files matching the template's ``files[].match`` globs;
* a ``.parquet`` file is one already validated test;
* all other loose files given together form one test (its acquisition files);
* ``--test A,B`` (repeatable) is one test made of the comma-separated files or directory.

Raw tests are imported with the template (``-t``, else the directory's ``template.yaml``).

The package: :mod:`vehval.workflow.run` (:class:`TestRun` and the outcomes of its steps),
:mod:`vehval.workflow.paths` (grouping of paths into tests, calibration runs) and
:mod:`vehval.workflow.suite` (several tests validated together); every public name is
importable from ``vehval.workflow``.
"""

from vehval.workflow.each import EachOutcome, validate_each
from vehval.workflow.paths import calibration_runs, group_args, runs_from_args
from vehval.workflow.run import (
    REPAIR_TIME,
    AnalysisOutcome,
    QAOutcome,
    ReportOutcome,
    ResultsOutcome,
    TestRun,
    ValidationOutcome,
    load_template_arg,
    load_vehicle_arg,
)
from vehval.workflow.suite import (
    SuiteOutcome,
    fuel_normalised_error,
    model_uncertainty_by_cycle,
    validate_runs,
)

__all__ = ["AnalysisOutcome", "EachOutcome", "QAOutcome", "REPAIR_TIME", "ReportOutcome", "ResultsOutcome", "SuiteOutcome", "TestRun", "ValidationOutcome", "calibration_runs", "fuel_normalised_error", "group_args", "load_template_arg", "load_vehicle_arg", "model_uncertainty_by_cycle", "runs_from_args", "validate_each", "validate_runs"]
