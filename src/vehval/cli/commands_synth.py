"""`vehval synth`: write a virtual test (simulated run + virtual sensors + known faults)."""

from __future__ import annotations

import json
from pathlib import Path

import typer

from vehval.cli.app import app
from vehval.cli.options import bounded, output_dir
from vehval.errors import ConfigError, VehvalError


def _pairs(items: list[str], option: str) -> dict:
    from vehval.cli.options import parse_assignments

    return parse_assignments(items, option, "soc_target=0.6")


@app.command("synth")
def synth_cmd(
    vehicle: str = typer.Option("prius_2004", "--vehicle", help="Vehicle name or YAML path."),
    cycle: str = typer.Option("udds", "--cycle", help="Cycle name, 'steady:60kph:300s' or CSV path."),
    seed: int = typer.Option(7, "--seed", callback=bounded("seed"), help="Seed of every random draw (same seed, same bytes)."),
    faults: str = typer.Option("default", "--faults",
                               help="'default' (a representative mix), 'none', or a fault YAML file."),
    out: Path = typer.Option(..., "-o", "--out", callback=output_dir, help="Output directory (written atomically)."),
    control: list[str] = typer.Option([], "--control", metavar="KEY=VALUE",
                                      help="Controller parameter override (repeatable)."),
    param: list[str] = typer.Option([], "--param", metavar="KEY=VALUE",
                                    help="Vehicle parameter override, dotted key (repeatable)."),
    force: bool = typer.Option(False, "--force", help="Write into a non-empty directory that "
                                                      "is not a previous virtual test."),
    as_json: bool = typer.Option(False, "--json", help="Print the output paths as JSON."),
) -> None:
    """Simulate VEHICLE on CYCLE and write it as a virtual dyno test: a D3 facility file, an
    OBD logger file, an import template and truth.json (every injected offset and fault)."""
    from vehval.io.paths import check_outputs, vehicle_path
    from vehval.synth import make_virtual_test
    from vehval.synth.dyno import is_virtual_test_dir
    from vehval.vehicle import load_vehicle

    check_outputs(outdir=out, inputs=[vehicle_path(vehicle), vehicle_path(cycle),
                                      vehicle_path(faults)])
    veh = load_vehicle(vehicle)
    if veh.architecture == "conventional":
        _synth_conventional(veh, cycle, seed, faults, out, control, param, as_json)
        return
    if veh.architecture == "parallel_hybrid":
        _synth_parallel(veh, vehicle, cycle, seed, faults, out, control, param, as_json)
        return

    if out.is_dir() and any(out.iterdir()) and not is_virtual_test_dir(out) and not force:
        raise VehvalError(f"output directory '{out}' is not empty and holds no virtual test: "
                          "choose an empty directory or pass --force")
    if faults not in ("default", "none") and not Path(faults).is_file():
        raise ConfigError(f"fault file '{faults}' does not exist: use --faults default, "
                          "--faults none or the path of a fault YAML file")
    res = make_virtual_test(vehicle=vehicle, cycle=cycle, seed=seed, faults=faults, outdir=out,
                            controller_overrides=_pairs(control, "--control") or None,
                            vehicle_overrides=_pairs(param, "--param") or None)
    truth = json.loads(res.truth_path.read_text(encoding="utf-8"))
    if as_json:
        typer.echo(json.dumps({"files": [str(p) for p in res.files],
                               "template": str(res.template_path), "truth": str(res.truth_path),
                               "clean": str(res.clean_path), "faults": len(truth["faults"]),
                               "offsets_s": truth["offsets_s"]}, indent=1))
        return
    typer.echo(f"virtual test '{truth['test_id']}' (VIRTUAL: synthetic, not a measurement) in {out}")
    for p in res.files:
        typer.echo(f"  data      {p.name}")
    typer.echo(f"  template  {res.template_path.name}")
    typer.echo(f"  truth     {res.truth_path.name}: {len(truth['faults'])} injected faults, "
               f"offsets {truth['offsets_s']}")
    typer.echo(f"import it with: vehval import {' '.join(str(p) for p in res.files)} "
               f"-t {res.template_path}")


def _synth_parallel(veh, vehicle, cycle, seed, faults, out, control, param, as_json) -> None:
    """Parallel hybrid: the 10 Hz log channels with noise and the controller's rules as the
    answer key (no fault mix)."""
    from vehval.cycles import load_cycle
    from vehval.synth.parallel import make_parallel_test

    if faults not in ("default", "none"):
        raise ConfigError("--faults: fault files apply to power-split virtual tests only")
    over = {**{f"controller.{k}": v for k, v in (_pairs(control, "--control") or {}).items()},
            **(_pairs(param, "--param") or {})}
    veh = veh.with_overrides(over or None)
    truth = make_parallel_test(veh, load_cycle(cycle), seed, out, vehicle_ref=str(vehicle))
    if as_json:
        typer.echo(json.dumps({"files": truth["files"], "template": truth["template"],
                               "truth": str(out / "truth.json")}, indent=1))
        return
    typer.echo(f"virtual parallel-hybrid test '{truth['test_id']}' (VIRTUAL: synthetic, not a "
               f"measurement) in {out}")
    typer.echo(f"analyze it with: vehval analyze {' '.join(truth['files'])} -t "
               f"{truth['template']} -o OUTDIR")


def _synth_conventional(veh, cycle, seed, faults, out, control, param, as_json) -> None:
    """Conventional car: dyno channels with a slow fuel bench and noise (no fault mix)."""
    from vehval.cycles import load_cycle
    from vehval.synth.conventional import make_conventional_test

    if control:
        raise ConfigError("--control: a conventional vehicle has no supervisory controller")
    if faults not in ("default", "none"):
        raise ConfigError("--faults: fault files apply to power-split virtual tests only")
    veh = veh.with_overrides(_pairs(param, "--param") or None)
    truth = make_conventional_test(veh, load_cycle(cycle), seed, out)
    if as_json:
        typer.echo(json.dumps({"files": truth["files"], "template": truth["template"],
                               "truth": str(out / "truth.json")}, indent=1))
        return
    typer.echo(f"virtual conventional test '{truth['test_id']}' (VIRTUAL: synthetic, not a "
               f"measurement) in {out}")
    typer.echo(f"identify it with: vehval identify {' '.join(truth['files'])} -t "
               f"{truth['template']} --architecture conventional -o VEHICLE.yaml")
