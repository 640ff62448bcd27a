"""The virtual test of each architecture as one stage (``vehval synth``): the files written,
the document of ``--json`` and the lines on screen.

:func:`power_split_test` writes the facility and OBD files of a power-split hybrid with the
fault mix; :func:`conventional_test` the dyno channels of a conventional car (slow fuel
bench, noise, no fault mix). The stage registry (:mod:`vehval.architectures`) picks one by
the vehicle file's architecture.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from vehval.errors import ConfigError, VehvalError


@dataclass
class VirtualTest:
    """A written virtual test: ``document`` (``vehval synth --json``) and ``lines`` (its
    text on screen)."""

    document: dict[str, Any]
    lines: list[str] = field(default_factory=list)


def power_split_test(veh: Any, vehicle: str, cycle: str, seed: int, faults: str, out: Path,
                     control: dict, param: dict, force: bool) -> VirtualTest:
    """A power-split hybrid on ``cycle`` with the fault mix ``faults`` (``default``,
    ``none`` or a fault YAML file), controller and vehicle overrides, written into ``out``
    (a non-empty directory that holds no virtual test only with ``force``)."""
    from vehval.synth import make_virtual_test
    from vehval.synth.dyno import is_virtual_test_dir

    if out.is_dir() and any(out.iterdir()) and not is_virtual_test_dir(out) and not force:
        raise VehvalError(f"output directory '{out}' is not empty and holds no virtual test: "
                          "choose an empty directory or pass --force")
    if faults not in ("default", "none") and not Path(faults).is_file():
        raise ConfigError(f"fault file '{faults}' does not exist: use --faults default, "
                          "--faults none or the path of a fault YAML file")
    res = make_virtual_test(vehicle=vehicle, cycle=cycle, seed=seed, faults=faults, outdir=out,
                            controller_overrides=control or None,
                            vehicle_overrides=param or None)
    truth = json.loads(res.truth_path.read_text(encoding="utf-8"))
    doc = {"files": [str(p) for p in res.files], "template": str(res.template_path),
           "truth": str(res.truth_path), "clean": str(res.clean_path),
           "faults": len(truth["faults"]), "offsets_s": truth["offsets_s"]}
    lines = [f"virtual test '{truth['test_id']}' (VIRTUAL: synthetic, not a measurement) in {out}"]
    lines += [f"  data      {p.name}" for p in res.files]
    lines += [f"  template  {res.template_path.name}",
              f"  truth     {res.truth_path.name}: {len(truth['faults'])} injected faults, "
              f"offsets {_offsets_text(truth['offsets_s'])}",
              f"import it with: vehval import {' '.join(str(p) for p in res.files)} "
              f"-t {res.template_path}"]
    return VirtualTest(doc, lines)


def _offsets_text(offsets_s: dict[str, float]) -> str:
    """The injected clock offsets as a person reads them: ``dyno 0 s, obd -2.7 s``."""
    from vehval.display import format_value

    return ", ".join(f"{source} {format_value(value, 's')}" for source, value in offsets_s.items())


def _written(kind: str, truth: dict, out: Path, next_step: str) -> VirtualTest:
    """The document and lines of a virtual test written by a maker that returns its truth."""
    doc = {"files": truth["files"], "template": truth["template"],
           "truth": str(out / "truth.json")}
    return VirtualTest(doc, [
        f"virtual {kind} test '{truth['test_id']}' (VIRTUAL: synthetic, not a measurement) "
        f"in {out}", next_step.format(files=" ".join(truth["files"]), template=truth["template"])])


def _without_faults(faults: str, control: dict, kind: str | None) -> None:
    """Refuse a fault mix (power-split tests only) and, for a car without a supervisory
    controller (``kind``), controller overrides."""
    if kind is not None and control:
        raise ConfigError(f"--control: a {kind} vehicle has no supervisory controller")
    if faults not in ("default", "none"):
        raise ConfigError("--faults: fault files apply to power-split virtual tests only")


def conventional_test(veh: Any, vehicle: str, cycle: str, seed: int, faults: str, out: Path,
                      control: dict, param: dict, force: bool) -> VirtualTest:
    """A conventional car on ``cycle``: dyno channels with a slow fuel bench and noise (no
    fault mix, no controller), vehicle overrides ``param``, written into ``out``."""
    from vehval.cycles import load_cycle
    from vehval.synth.conventional import make_conventional_test

    _without_faults(faults, control, "conventional")
    truth = make_conventional_test(veh.with_overrides(param or None), load_cycle(cycle), seed,
                                   out, vehicle_ref=vehicle)
    return _written("conventional", truth, out, "identify it with: vehval identify {files} -t "
                    "{template} --architecture conventional -o VEHICLE.yaml")


def battery_electric_test(veh: Any, vehicle: str, cycle: str, seed: int, faults: str,
                          out: Path, control: dict, param: dict, force: bool) -> VirtualTest:
    """A battery-electric car on ``cycle``: dyno speed and force, battery volts and amps with
    noise, and the SAE J1634 answer key, written into ``out`` (no fault mix, no controller),
    vehicle overrides ``param``."""
    from vehval.cycles import load_cycle
    from vehval.synth.bev import make_bev_test

    _without_faults(faults, control, "battery-electric")
    truth = make_bev_test(veh.with_overrides(param or None), load_cycle(cycle), seed, out,
                          vehicle_ref=vehicle)
    return _written("battery-electric", truth, out,
                    "its SAE J1634 figures: vehval results {files} -t {template}")


def parallel_hybrid_test(veh: Any, vehicle: str, cycle: str, seed: int, faults: str,
                         out: Path, control: dict, param: dict, force: bool) -> VirtualTest:
    """A parallel hybrid on ``cycle``: the 10 Hz log channels with noise and the controller's
    rules as the answer key (no fault mix), controller overrides ``control`` and vehicle
    overrides ``param``, written into ``out``."""
    from vehval.cycles import load_cycle
    from vehval.synth.parallel import make_parallel_test

    _without_faults(faults, control, None)
    over = {**{f"controller.{k}": v for k, v in (control or {}).items()}, **(param or {})}
    truth = make_parallel_test(veh.with_overrides(over or None), load_cycle(cycle), seed, out,
                               vehicle_ref=str(vehicle))
    return _written("parallel-hybrid", truth, out, "analyze it with: vehval analyze {files} -t "
                    "{template} -o OUTDIR")
