"""`vehval signals` (the nomenclature registry) and the import commands:
`vehval template init|check`, `vehval import`, `vehval info`."""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING, Any

import typer

from vehval.cli.app import app
from vehval.cli.options import output_file
from vehval.errors import InputFileError

if TYPE_CHECKING:
    import numpy as np


@app.command("signals")
def signals_cmd(as_json: bool = typer.Option(False, "--json", help="Print JSON.")) -> None:
    """List the standard base names with unit, category and plausible range."""
    from vehval.nomenclature import registry

    reg = registry()
    if as_json:
        typer.echo(json.dumps({b: {"unit": s.unit, "category": s.category, "range": s.range,
                                   "description": s.description} for b, s in reg.specs.items()}))
        return
    for b, s in reg.specs.items():
        typer.echo(f"{b:22s} {s.unit:10s} {s.category:12s} {s.description}")


# --------------------------------------------------------------------------- import commands

template_app = typer.Typer(help="Create and check import templates.", no_args_is_help=True)
app.add_typer(template_app, name="template")


@template_app.command("init")
def template_init_cmd(
    files: list[Path] = typer.Argument(..., help="Raw files of one test."),
    output: Path = typer.Option(..., "-o", "--output", callback=output_file,
                                help="Template YAML to write."),
    force: bool = typer.Option(False, "--force", help="Overwrite an existing template."),
) -> None:
    """Propose a template: standard names, units and source tags for every channel."""
    from vehval.io.paths import check_input_file, check_outputs
    from vehval.io.propose import propose_template

    check_outputs(outfile=output, inputs=files)
    if output.exists() and not force:
        raise InputFileError(f"{output}: already exists: choose another name or pass --force")
    for f in files:
        check_input_file(f)
    template, unmatched = propose_template(files)
    template.save(output, placeholders=True)
    n = sum(len(f.channels) for f in template.files)
    typer.echo(f"wrote {output}: {len(template.files)} file entr{'y' if len(template.files) == 1 else 'ies'}, "
               f"{n} channels, {len(unmatched)} unmatched")
    for u in unmatched:
        typer.echo(f"  unmatched (delete: true, edit if needed): {u}")
    for item in template.todo:
        typer.echo(f"  to do: {item}")


@template_app.command("check")
def template_check_cmd(
    template: Path = typer.Argument(..., help="Template YAML."),
    files: list[Path] = typer.Argument(..., help="Raw files to check against it."),
) -> None:
    """Compare a template with raw files: missing/extra channels, unit problems."""
    from vehval.io.propose import check_template

    report = check_template(template, files)
    typer.echo(report.format())
    if not report.ok:
        raise typer.Exit(1)


@app.command("import")
def import_cmd(
    files: list[Path] = typer.Argument(..., help="Raw files of one test."),
    template: Path = typer.Option(..., "-t", "--template", help="Template YAML."),
    output: Path = typer.Option(..., "-o", "--output", callback=output_file,
                                help="Test Parquet file to write."),
    repair_time: bool = typer.Option(False, "--repair-time",
                                     help="Sort decreasing and drop repeated timestamps."),
) -> None:
    """Import raw files with a template into one Test Parquet file (SI units, provenance)."""
    from vehval.io.importer import import_test
    from vehval.io.parquet import write_test
    from vehval.io.paths import check_outputs

    check_outputs(outfile=output, inputs=[*files, template])
    test = import_test(files, template, repair_time=repair_time)
    write_test(test, output)
    typer.echo(f"wrote {output}: {len(test)} signals from {len(files)} file(s), "
               f"{len(test.meta.deleted)} channel(s) deleted")
    typer.echo(f"  cycle: {test.meta.cycle or '(not identified)'}"
               + ("  [VIRTUAL TEST: synthetic data]" if test.meta.synthetic else ""))
    for note in test.meta.notes:
        typer.echo(f"  {_shown_note(note, test.meta)}", err=note.startswith("warning"))


def _shown_note(note: str, meta: Any) -> str:
    """A stored note as a person reads it: the cycle identification's speeds in the
    display units (``--units``); the note itself stays SI (data)."""
    from vehval.cycles_text import cycle_note
    from vehval.display import system

    match = meta.cycle_match or {}
    if match.get("signal") and note == cycle_note(match):
        return cycle_note(match, system())
    return note


def _channel_stats(name: str, unit: str | None, t: np.ndarray | None, v: np.ndarray) -> dict:
    import numpy as np

    out: dict[str, Any] = {"name": name, "unit": unit, "samples": int(v.size), "nan": int(np.isnan(v).sum()),
           "rate_hz": None, "duration_s": None, "t0_s": None}
    if t is not None and t.size >= 2:
        dt = np.diff(t[np.isfinite(t)])
        med = float(np.median(dt)) if dt.size else float("nan")
        out["rate_hz"] = round(1.0 / med, 6) if med > 0 else None
        out["duration_s"] = float(np.nanmax(t) - np.nanmin(t))
        out["t0_s"] = float(np.nanmin(t))
    return out


def _raw_cycle(raw) -> dict:
    """Cycle of a raw file, identified from its vehicle-speed channel (matched like
    ``template init`` does), as ``{cycle, cycle_found}``; empty when the file has none."""
    from vehval.cycles_match import describe, identify_cycle
    from vehval.display import system
    from vehval.io.propose import match_channel, unit_known
    from vehval.units import to_si

    if raw.time_name is None and not raw.times:
        return {}
    for name, unit in zip(raw.names, raw.units):
        if name == raw.time_name or unit is None or not unit_known(unit):
            continue
        if match_channel(name, unit) != "veh_spd":
            continue
        t = raw.time_of(name)
        if t is None:
            continue
        if raw.time_unit:
            t = to_si(t, raw.time_unit, "s")
        cyc, _, details = identify_cycle(t, to_si(raw.data[name], unit, "m/s"))
        return {"cycle": cyc, "cycle_found": f"{describe(cyc, details)} from '{name}'",
                "cycle_shown": f"{describe(cyc, details, system())} from '{name}'"}
    return {}


@app.command("info")
def info_cmd(
    file: Path = typer.Argument(..., help="Raw file or Test Parquet."),
    as_json: bool = typer.Option(False, "--json", help="Print JSON."),
) -> None:
    """Channels, units, rates, duration, samples and NaN counts of a file."""
    from vehval.io.parquet import read_test
    from vehval.io.readers import read_raw

    info: dict = {"file": str(file)}
    try:
        test = read_test(file) if file.suffix.lower() in (".parquet", ".pq") else None
    except InputFileError:
        test = None
    if test is not None:
        info.update(kind="test", test_id=test.meta.test_id, cycle=test.meta.cycle or None,
                    cycle_found=next((n for n in test.meta.notes if n.startswith("cycle ")), None),
                    synthetic=bool(test.meta.synthetic), notes=test.meta.notes,
                    channels=[dict(_channel_stats(s.name, s.unit, s.time, s.values),
                                   source=s.source, raw_name=s.raw_name, raw_unit=s.raw_unit)
                              for s in test])
    else:
        raw = read_raw(file)
        tu = raw.time_unit
        info.update(kind="raw", format=raw.fmt, time_column=raw.time_name, time_unit=tu,
                    notes=raw.notes, channels=[])
        for name, unit in zip(raw.names, raw.units):
            if name == raw.time_name:
                continue
            t = raw.time_of(name)
            if t is not None and tu:
                from vehval.units import to_si
                t = to_si(t, tu, "s")
            info["channels"].append(_channel_stats(name, unit, t, raw.data[name]))
        info.update(_raw_cycle(raw))
    cycle_text = info.pop("cycle_shown", None)       # the screen's text (JSON stays SI)
    if test is not None and info.get("cycle_found"):
        cycle_text = _shown_note(info["cycle_found"], test.meta)
    if as_json:
        typer.echo(json.dumps(info, indent=1))
        return
    typer.echo(f"{file}: {info['kind']}" + (f" ({info['format']})" if "format" in info else ""))
    if info.get("synthetic"):
        typer.echo("  VIRTUAL TEST: synthetic data, not a measurement")
    if "cycle" in info:
        typer.echo(f"  cycle: {info['cycle'] or '(not identified)'}"
                   + (f"  [{cycle_text}]" if cycle_text else ""))
    for n in info["notes"]:
        if n != info.get("cycle_found"):     # already on the cycle line
            typer.echo(f"  note: {n}")
    # a test stores SI units: a person reads them in the display units (--units), as the
    # other commands print them, next to the unit the file or template declared and the
    # stored one
    shown = info["kind"] == "test"
    typer.echo(f"  {'channel':28s} "
               + (f"{'declared':9s} {'unit (SI)':13s} {'shown as':9s} " if shown
                  else f"{'unit':13s} ")
               + f"{'samples':>8s} {'rate[Hz]':>9s} {'dur[s]':>9s} {'NaN':>6s}")
    for c in info["channels"]:
        rate = f"{c['rate_hz']:.3g}" if c["rate_hz"] else "-"
        dur = f"{c['duration_s']:.1f}" if c["duration_s"] is not None else "-"
        typer.echo(f"  {c['name']:28s} "
                   + (f"{str(c.get('raw_unit') or '-'):9s} {str(c['unit'] or '-'):13s} "
                      f"{_display_label(c):9s} " if shown else f"{str(c['unit'] or '-'):13s} ")
                   + f"{c['samples']:8d} {rate:>9s} {dur:>9s} {c['nan']:6d}")


def _display_label(channel: dict) -> str:
    """The display unit (``--units``) a stored SI channel is shown in by the other commands."""
    from vehval.display import unit_for

    if not channel["unit"]:
        return "-"
    return unit_for(channel["unit"], signal=channel["name"]).label or "-"
