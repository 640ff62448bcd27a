"""Grouping of command-line paths into tests (the rule of :mod:`vehval.workflow`): one
:class:`~vehval.workflow.run.TestRun` per test, and the tuning / held-out runs of a
calibration."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Sequence

from vehval.workflow.run import TestRun, load_vehicle_arg


def group_args(files: Sequence[Path], groups: Sequence[str]) -> list[list[Path]]:
    """Apply the grouping rule of the module docstring to positional paths and ``--test`` groups."""
    out: list[list[Path]] = []
    loose: list[Path] = []
    for f in files:
        f = Path(f)
        if f.is_dir() or f.suffix.lower() == ".parquet":
            out.append([f])
        else:
            loose.append(f)
    if loose:
        out.append(loose)
    for g in groups:
        items = [Path(x.strip()) for x in str(g).split(",") if x.strip()]
        if items:
            out.append(items)
    return out


def runs_from_args(files: Sequence[Path], groups: Sequence[str] = (), template: Any = None,
                   vehicle: Any = None, *, use_qa: bool = True) -> list[TestRun]:
    """One :class:`TestRun` per test named on the command line, with unique test ids."""
    veh = load_vehicle_arg(vehicle)
    out = [TestRun.from_paths(g, template, veh, use_qa=use_qa) for g in group_args(files, groups)]
    seen: dict[str, int] = {}
    for run in out:  # test ids must be unique: they key the results
        tid = run.test.meta.test_id or "test"
        if tid in seen:
            seen[tid] += 1
            run.test.meta.test_id = f"{tid}_{seen[tid]}"
        else:
            seen[tid] = 1
            run.test.meta.test_id = tid
    return out


def calibration_runs(files: Sequence[Path], groups: Sequence[str], holdout: Sequence[str],
                     template: Any, vehicle: Any, *, per_file: bool,
                     use_qa: bool) -> tuple[list[TestRun], list[TestRun]]:
    """The tuning and held-out runs of a calibration: with ``per_file`` every file and every
    ``--test A,B`` group is one test read without a vehicle; else the command line's grouping
    (:func:`runs_from_args`) with ``vehicle``. Each ``holdout`` entry is one test
    (comma-separated files or a directory)."""
    def paths(text: str) -> list[Path]:
        return [Path(x.strip()) for x in text.split(",") if x.strip()]

    if per_file:
        tune = [TestRun.load(g, template, use_qa=use_qa)
                for g in [[f] for f in files] + [paths(g) for g in groups]]
        hold = [TestRun.load(paths(h), template, use_qa=use_qa) for h in holdout]
    else:
        tune = runs_from_args(files, groups, template, vehicle, use_qa=use_qa)
        hold = [TestRun.from_paths(paths(h), template, vehicle, use_qa=use_qa)
                for h in holdout]
    refuse_repeated_data([r.test for r in tune], [r.test for r in hold])
    return tune, hold


def refuse_repeated_data(tests: Sequence[Any], holdout: Sequence[Any] = (),
                         what: str = "tuning test") -> None:
    """Refuse, in one line, a test given twice (the same file, or the same data under
    another name: :meth:`vehval.test.Test.data_digest`): as two ``what`` it would count one
    run twice (narrower intervals, a doubled weight), as a held-out test a fit would be
    judged as a prediction."""
    from vehval.errors import ConfigError

    seen: dict[str, str] = {}
    for k, test in enumerate([*tests, *holdout]):
        tid, digest = test.meta.test_id or "test", test.data_digest()
        if digest not in seen:
            seen[digest] = tid
            continue
        first = seen[digest]
        same = "the same test" if first == tid else f"the same data as {first}"
        if k >= len(tests):
            raise ConfigError(f"--holdout {tid}: it is {same}, a {what}; a held-out test must "
                              f"be another test run (drop it from the {what}s or the holdout)")
        raise ConfigError(f"{tid}: it is {same}, given twice"
                          f"{'' if what == 'test' else ' as a ' + what}; give each test run once")
