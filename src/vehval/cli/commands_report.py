"""`vehval report`: one HTML report (and Excel tables) from the outputs of `vehval qa`, `analyze` and `validate`."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import typer

from vehval.cli.app import app
from vehval.cli.options import output_file
from vehval.errors import InputFileError

FINDINGS = "findings.json"
VALIDATED = "validated.parquet"


def collect_inputs(paths: list[Path]) -> dict[str, Path]:
    """Find findings.json, the validated Parquet test and optional control/validation JSON.

    ``paths`` are output directories (of ``vehval qa``, ``analyze``, ``validate``) and/or
    files. In a directory only ``validated.parquet``, ``findings.json``, ``control.json``,
    ``validation.json`` and ``results.json`` are read (other Parquet files, e.g. ``overlays_*.parquet`` of
    ``vehval validate``, are not tests). A file given by name is recognised by its name
    (``*findings*.json``, ``*control*.json``, ``*validation*.json``) or, for the test, by
    its ``.parquet`` extension; later paths override earlier ones.
    """
    found: dict[str, Path] = {}
    tests: list[Path] = []
    for p in paths:
        if not p.exists():
            raise InputFileError(f"{p}: not found: give the output directory of `vehval qa` "
                                 f"(with {FINDINGS} and {VALIDATED}) or those files")
        if p.is_dir():
            for kind, name in (("findings", FINDINGS), ("test", VALIDATED),
                               ("control", "control.json"), ("validation", "validation.json"),
                               ("results", "results.json")):
                if (p / name).is_file():
                    found[kind] = p / name
                    if kind == "test":
                        tests.append(p / name)
            continue
        name = p.name.lower()
        if name.endswith(".parquet"):
            found["test"] = p
            tests.append(p)
        elif name.endswith(".json"):
            json_kind = next((k for k in ("findings", "control", "validation", "results")
                              if k in name), None)
            if json_kind is None:
                raise InputFileError(f"{p}: unknown JSON input: name it *findings*.json, *results*.json, "
                                     "*control*.json or *validation*.json, or use --control / "
                                     "--validation")
            found[json_kind] = p
        else:
            raise InputFileError(f"{p}: not a report input: expected a directory, a .parquet "
                                 "test or a .json result")
    if len({t.resolve() for t in tests}) > 1:
        raise InputFileError(f"two tests given ({', '.join(map(str, tests))}): a report shows one "
                             "test; run `vehval report` once per test (or `vehval batch` for many)")
    if "test" not in found:
        raise InputFileError(f"no validated test found in {', '.join(map(str, paths))}: expected "
                             f"{VALIDATED} (written by `vehval qa`) or a .parquet file")
    return found


def _existing(path: Path | None, what: str) -> Path | None:
    if path is not None and not path.is_file():
        raise InputFileError(f"{path}: {what} not found: check the path")
    return path


def _check_report_outputs(output: Path, excel: bool, inputs: list) -> None:
    """The report and, with ``--excel``, tables.xlsx beside it: the output policy."""
    from vehval.io.paths import check_outputs

    check_outputs(outfile=output, inputs=inputs)
    if excel:
        check_outputs(outfile=output.parent / "tables.xlsx", inputs=inputs)


@app.command("report")
def report_cmd(
    inputs: list[Path] = typer.Argument(..., help="Output directories of `vehval qa` (and `analyze`, "
                                                  "`validate`), or findings.json + validated.parquet "
                                                  "(+ control.json, validation.json)."),
    output: Path = typer.Option(None, "-o", "--output", callback=output_file, help="Report file (default OUTDIR/report.html)."),
    control: Path = typer.Option(None, "--control", help="control.json of `vehval analyze` "
                                                         "(default: found in the input directories)."),
    validation: Path = typer.Option(None, "--validation", help="validation.json of `vehval validate` "
                                                               "(default: found in the input directories)."),
    raw: Path = typer.Option(None, "--raw", help="The imported test (Parquet of `vehval import`): plots "
                                                 "the signals the QA selection dropped."),
    vehicle: str = typer.Option(None, "--vehicle", help="Vehicle name or file for the component maps "
                                                       "(default: the test's vehicle)."),
    title: str = typer.Option(None, "--title", help="Report title."),
    excel: bool = typer.Option(True, "--excel/--no-excel", help="Also write tables.xlsx beside the report."),
) -> None:
    """Write a self-contained report.html (and tables.xlsx): QA, control strategy and validation.

    Exit code 4: the results.json it shows has a figure withheld for QA errors (run
    `vehval results --force` or `vehval qa --force` to state them under a banner)."""
    from vehval.io.parquet import read_test
    from vehval.report import build_reports, load_json, write_report
    from vehval.report.inputs import checked_document, refuse_other_test

    found = collect_inputs(list(inputs))
    for kind, path in (("control", _existing(control, "control.json")),
                       ("validation", _existing(validation, "validation.json"))):
        if path is not None:
            found[kind] = path
    if output is None:
        base = inputs[0] if inputs[0].is_dir() else found["test"].parent
        output = base / "report.html"
    # every file read, not only the paths given: a directory's files are inputs too
    _check_report_outputs(output, excel, [*inputs, *found.values(), raw])
    test = read_test(found["test"])
    raw_test = read_test(raw) if _existing(raw, "imported test") is not None else None
    docs = {kind: checked_document(load_json(found[kind]), kind, found[kind])
            for kind in ("findings", "control", "validation", "results") if kind in found}
    refuse_other_test(test, found["test"], [(raw_test, raw)] + [
        (docs[k], found[k]) for k in ("findings", "results") if k in docs])
    qa, ctl, val, res = (docs.get(k) for k in ("findings", "control", "validation", "results"))
    kw: dict[str, Any] = {"vehicle": vehicle, "control": ctl, "validation": val, "title": title, "raw": raw_test,
          "results": res}
    if excel:
        paths = build_reports(output.parent, test, qa, html_name=output.name, **kw)
    else:
        paths = {"report": write_report(output, test=test, qa=qa, **kw)}
    for path in paths.values():
        size = path.stat().st_size / 1e6
        typer.echo(f"wrote {path} ({size:.1f} MB)")
    typer.echo("inputs: " + "; ".join(f"{k} {found[k]}" for k in ("test", "findings", "control", "validation")
                                      if k in found))
    if qa is None:
        typer.echo(f"note: no {FINDINGS} found: the report has no QA sections")
    if res is not None:
        from vehval.cli.commands_results import headline_lines, withheld_exit

        for line in headline_lines(res):
            typer.echo(line)
        withheld_exit(res)
