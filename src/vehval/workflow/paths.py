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
        return tune, [TestRun.load(paths(h), template, use_qa=use_qa) for h in holdout]
    tune = runs_from_args(files, groups, template, vehicle, use_qa=use_qa)
    return tune, [TestRun.from_paths(paths(h), template, vehicle, use_qa=use_qa)
                  for h in holdout]
