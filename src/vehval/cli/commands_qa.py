"""`vehval qa`: import a test, run the data-quality analysis, write the results atomically."""

from __future__ import annotations

import json
from collections import Counter
from pathlib import Path

import typer

from vehval.cli.app import app
from vehval.cli.options import bounded, output_dir


def _count(n: int, noun: str) -> str:
    """``"1 finding"``, ``"0 errors"``, ``"3 warnings"``."""
    return f"{n} {noun}" + ("" if n == 1 else "s")


def _when(f: dict) -> str:
    """`` (at 186.0 s)`` or `` (404.0-998.0 s)``: the time window of a finding, or ''."""
    t0, t1 = f.get("start_s"), f.get("end_s")
    if t0 is None:
        return ""
    if t1 is None or t1 == t0:
        return f" (at {t0:.1f} s)"
    return f" ({t0:.1f}-{t1:.1f} s)"


def _summary(d: dict, outdir: Path) -> dict:
    return {"test": d["test"], "outdir": str(outdir), "summary": d["summary"],
            "alignment": [{k: a[k] for k in ("source", "reference", "offset_s", "confidence",
                                             "applied")} for a in d["alignment"]],
            "files": ["findings.json", "results.json", "validated.parquet", "template_final.yaml"]}


@app.command("qa")
def qa_cmd(
    files: list[Path] = typer.Argument(..., help="Raw files of one test."),
    template: Path = typer.Option(..., "-t", "--template", help="Import template YAML."),
    vehicle: str = typer.Option(None, "--vehicle",
                                help="Vehicle file name or path (default: the template's)."),
    outdir: Path = typer.Option(..., "-o", "--outdir", callback=output_dir, help="Output directory."),
    as_json: bool = typer.Option(False, "--json", help="Print findings.json (plus outdir and files) on stdout."),
    report: bool = typer.Option(False, "--report", help="Also write the HTML QA report."),
    max_offset: float = typer.Option(30.0, "--max-offset", callback=bounded("max_offset"), help="Alignment search range ±[s]."),
    force: bool = typer.Option(False, "--force", help="State result figures QA errors would "
                               "withhold, under a banner (exit 0 instead of 4)."),
) -> None:
    """Import, align, check (QA levels 1-3), calculate and select signals.

    Writes findings.json, validated.parquet and template_final.yaml into OUTDIR (atomically);
    with --report also report.html and tables.xlsx. Exit code 4: a result figure was
    withheld for a QA error on its signals.
    """
    from vehval.cli.commands_results import echo_results, withheld_exit
    from vehval.io.atomic import atomic_dir, write_text_atomic
    from vehval.io.parquet import write_test
    from vehval.io.paths import check_outputs, vehicle_path
    from vehval.qa.select import save_final_template
    from vehval.workflow import TestRun

    check_outputs(outdir=outdir, inputs=[*files, template, vehicle_path(vehicle)],
                  writes=["findings.json", "validated.parquet", "template_final.yaml",
                          "report.html", "tables.xlsx"])
    run = TestRun.load(files, template, vehicle)
    qa = run.qa(max_offset_s=max_offset)
    result, doc = qa.result, qa.document  # doc: findings.json
    results = run.results(force=force).results
    with atomic_dir(outdir) as stage:
        write_text_atomic(stage / "findings.json", json.dumps(doc, indent=1))
        write_text_atomic(stage / "results.json", json.dumps(results.to_dict(), indent=1))
        write_test(result.validated, stage / "validated.parquet")
        save_final_template(run.template, result.selection, stage / "template_final.yaml")
        if report:
            run.report(stage, raw=run.test)
    summ = _summary(doc, outdir)
    if report:
        summ["files"] += ["report.html", "tables.xlsx"]
    if as_json:
        # the public contract: findings.json's keys, plus where the files went
        full = dict(doc, outdir=summ["outdir"], files=summ["files"])
        typer.echo(json.dumps(full, indent=1))
        withheld_exit(results.to_dict())
        return
    s = summ["summary"]
    echo_results(results)
    for f in results.findings:
        typer.echo(f"  {f.severity.value:7s} {f.kind.value:14s} {f.message}")
    # the counts cover every finding printed: QA's and the results stage's
    sev = dict(s["by_severity"])
    for f in results.findings:
        sev[f.severity.value] = sev.get(f.severity.value, 0) + 1
    n_res = len(results.findings)
    extra = (f", {n_res} of them from the results stage" if n_res > 1 else
             ", 1 from the results stage" if n_res else "")
    typer.echo(f"{result.test_id}: {_count(s['total'] + n_res, 'finding')} "
               f"({_count(sev.get('error', 0), 'error')}, "
               f"{_count(sev.get('warning', 0), 'warning')}, {sev.get('info', 0)} info{extra}); "
               f"kept {s['kept']}, dropped {s['dropped']}, computed {s['computed']}")
    for a in summ["alignment"]:
        off = "n/a" if a["offset_s"] is None else f"{a['offset_s']:+.3f} s"
        typer.echo(f"  align {a['source']} -> {a['reference']}: {off} "
                   f"(confidence {a['confidence']:.2f}{'' if a['applied'] else ', not applied'})")
    shown = [f for f in doc["findings"] if f["severity"] != "info"]
    same = Counter((f["kind"], f["message"]) for f in shown)
    for f in shown:
        # the same sentence twice (two stretches out of range...): say when each one is
        where = _when(f) if same[(f["kind"], f["message"])] > 1 else ""
        typer.echo(f"  {f['severity']:7s} {f['kind']:14s} {f['message']}{where}")
    from vehval.qa.uncertainty import comparison_lines

    for line in comparison_lines(doc):   # Tables 2 and 3: differences and En (k = 2)
        typer.echo(line)
    for note in doc.get("notes") or []:  # repairs made at import (a stray timestamp dropped...)
        if str(note).startswith("warning"):
            typer.echo(f"  {note}", err=True)
    typer.echo(f"wrote {outdir}/: {', '.join(summ['files'])}")
    withheld_exit(results.to_dict())
