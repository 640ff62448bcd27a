"""`vehval report`: the HTML report and Excel tables from the output of `vehval qa`."""

from __future__ import annotations

import json
from pathlib import Path

import typer

from vehval.cli import app
from vehval.errors import InputFileError

FINDINGS = "findings.json"
VALIDATED = "validated.parquet"


def _load_json(path: Path) -> dict:
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError) as exc:
        raise InputFileError(f"{path}: cannot be read ({exc})") from None
    except json.JSONDecodeError as exc:
        raise InputFileError(f"{path}: line {exc.lineno}: not valid JSON ({exc.msg}): "
                             "re-run `vehval qa` to rewrite it") from None


def collect_inputs(paths: list[Path]) -> dict[str, Path]:
    """Find findings.json, the validated Parquet test and optional control/validation JSON.

    ``paths`` are QA output directories and/or files; files are recognised by name
    (``findings.json``, ``control.json``, ``validation.json``) or extension (``.parquet``).
    """
    found: dict[str, Path] = {}
    for p in paths:
        if not p.exists():
            raise InputFileError(f"{p}: not found: give the output directory of `vehval qa` "
                                 f"(with {FINDINGS} and {VALIDATED}) or those files")
        files = sorted(p.iterdir()) if p.is_dir() else [p]
        for f in files:
            name = f.name.lower()
            if name == FINDINGS or (p == f and name.endswith(".json") and "findings" in name):
                found["findings"] = f
            elif name in ("control.json", "validation.json"):
                found[name[:-5]] = f
            elif name.endswith(".parquet"):
                # validated.parquet wins over any other Parquet file of a directory
                if "test" not in found or name == VALIDATED or p == f:
                    found["test"] = f
    if "test" not in found:
        raise InputFileError(f"no validated test found in {', '.join(map(str, paths))}: expected "
                             f"{VALIDATED} (written by `vehval qa`) or a .parquet file")
    return found


@app.command("report")
def report_cmd(
    inputs: list[Path] = typer.Argument(..., help="QA output directory, or findings.json + validated.parquet "
                                                  "(+ control.json, validation.json)."),
    output: Path = typer.Option(None, "-o", "--output", help="Report file (default OUTDIR/report.html)."),
    vehicle: str = typer.Option(None, "--vehicle", help="Vehicle name or file for the component maps "
                                                       "(default: the test's vehicle)."),
    title: str = typer.Option(None, "--title", help="Report title."),
    excel: bool = typer.Option(True, "--excel/--no-excel", help="Also write tables.xlsx beside the report."),
) -> None:
    """Write a self-contained report.html (and tables.xlsx) for a QA'd test."""
    from vehval.io.parquet import read_test
    from vehval.report import build_reports, write_report

    found = collect_inputs(list(inputs))
    test = read_test(found["test"])
    qa = _load_json(found["findings"]) if "findings" in found else None
    control = _load_json(found["control"]) if "control" in found else None
    validation = _load_json(found["validation"]) if "validation" in found else None
    if output is None:
        base = inputs[0] if inputs[0].is_dir() else found["test"].parent
        output = base / "report.html"
    if excel:
        paths = build_reports(output.parent, test, qa, vehicle=vehicle, control=control,
                              validation=validation, title=title, html_name=output.name)
    else:
        paths = {"report": write_report(output, test=test, qa=qa, vehicle=vehicle, control=control,
                                        validation=validation, title=title)}
    for kind, path in paths.items():
        size = path.stat().st_size / 1e6
        typer.echo(f"wrote {path} ({size:.1f} MB)")
    if qa is None:
        typer.echo(f"note: no {FINDINGS} found: the report has no QA sections")
