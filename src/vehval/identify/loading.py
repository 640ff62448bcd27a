"""Dyno test files read for identification and prediction: one test per file, through the
workflow's loader (:meth:`vehval.workflow.TestRun.load`), with the refusal of what cannot be
read that way (a hybrid, the files of one test of several files)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from vehval.identify.traces import IdentificationError, Trace, hybrid_refusal, trace_from_test


def load_traces(files: Sequence[str | Path], template, dt: float = 0.1) -> list[Trace]:
    """Load every file as one test with ``template`` (the workflow's
    :meth:`~vehval.workflow.TestRun.load`, its time-repair policy included) and return
    their traces. Identification reads the imported signals as they are (no QA run): the
    fuel and force channels it needs must not be dropped for a QA finding; each quantity's
    signal is the one :meth:`vehval.test.Test.best` chooses (with QA's
    ``template_final.yaml`` as the template, the signals QA dropped are not imported). The results
    stage (:func:`vehval.results.compute_results`) runs on each test: predictions are
    compared with its per-phase fuel and uncertainty. A test given twice (the same file, or
    the same data under another name) is refused: it would count one run twice. So is a
    test whose speed covers its cycle's distance a factor off (QA's speed-scale error,
    :func:`vehval.qa.speed_scale.speed_scale_check`: a speed unit or scale slip would scale
    the identified mass, road load and gear ratios)."""
    from vehval.identify.traces import IdentificationError
    from vehval.qa.speed_scale import speed_scale_check
    from vehval.results import compute_results
    from vehval.workflow import TestRun
    from vehval.workflow.paths import refuse_repeated_data
    runs = [TestRun.load([f], template, use_qa=False) for f in files]
    refuse_repeated_data([run.test for run in runs], what="test")
    out = []
    for run in runs:
        test = run.test
        for f in speed_scale_check(test, template=run.template):
            raise IdentificationError(f"{test.meta.test_id}: {f.message}"
                                      + (f"; {f.fix}" if f.fix else ""))
        tr = trace_from_test(test, dt, run.vehicle)
        tr.results = compute_results(test)
        out.append(tr)
    return out


def refuse_one_test_of_several_files(files: Sequence[Path], template: Path) -> None:
    """Refuse, in one line, what identify cannot read one test per file: a hybrid (the
    template's vehicle says so, or the files are one test with battery or motor signals:
    :func:`vehval.identify.traces.hybrid_refusal`) and the files of one test of several
    files (the template has an entry per file)."""
    from vehval.errors import VehvalError
    from vehval.test import Test, TestMeta
    from vehval.workflow import TestRun, load_template_arg, load_vehicle_arg

    tpl = load_template_arg(template)
    names = [str(f) for f in files]
    refusal = hybrid_refusal(Test(meta=TestMeta(test_id=", ".join(names), files=names)),
                             load_vehicle_arg(getattr(tpl, "vehicle", None)))
    if refusal is None and len(files) > 1 and len(tpl.files) > 1:
        try:
            run = TestRun.load(list(files), tpl, use_qa=False)
        except VehvalError:
            return                       # not one test: each file is read as one below
        refusal = hybrid_refusal(run.test, run.vehicle) or (
            f"{', '.join(names)}: these files are one test (one per files[] entry of "
            f"{Path(template).name}); identify reads one file per test: give a template with "
            "the one entry of the file that has speed, tractive force, engine speed and fuel")
    if refusal:
        raise IdentificationError(refusal)
