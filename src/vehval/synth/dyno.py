"""The virtual dyno: a simulated run written as realistic test files with known faults.

:func:`make_virtual_test` simulates a vehicle on a cycle (``vehval.sim.simulate``, dt 0.1 s),
then "measures" the run as a test facility would:

* ``<id>_d3.txt``  facility file in Argonne D3 style (10 Hz, TAB, CRLF, ``Name[unit]``);
* ``<id>_obd.csv`` OBD/CAN logger file (~1 Hz polling, own clock, transport delay, coarse);
* ``template.yaml`` import template mapping both to the standard nomenclature;
* ``truth.json``  everything injected: offsets, faults, sensor models, settings, controller;
* ``clean.parquet`` the clean SI signals each channel was derived from;
* ``README.txt``  says, in plain words, that this is a virtual test.

Sensor models are in ``data/faults/sensors.yaml``, the default fault mix in
``data/faults/default.yaml``. The same seed gives byte-identical files.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from vehval.errors import VehvalError
from vehval.io.atomic import atomic_dir, atomic_path, write_text_atomic
from vehval.synth.clean import SYNTHESISED, build_clean
from vehval.synth.faults import load_fault_specs, resolve_faults
from vehval.synth.files import FileData, build_file
from vehval.synth.sensors import load_sensor_table
from vehval.synth.template import template_for, vehicle_constants, vehicle_name
from vehval.synth.writers import write_table

TRUTH_FORMAT = "vehval-virtual-test-truth"
TIME_CONVENTION = (
    "true_time = file_time + offset_s, offset_s = -(clock_offset_s + delay_s): a sample stamped "
    "file_time holds the value of the true (simulation) instant file_time + offset_s; "
    "Test.shift_source(source, offset_s) puts an imported source on the true clock. Fault "
    "start_s/end_s are on the file's clock, true_start_s/true_end_s on the true clock.")
FILE_SUFFIX = {"facility": "_d3.txt", "obd": "_obd.csv"}


@dataclass(frozen=True)
class SynthOutput:
    """Paths of a virtual test.

    Attributes
    ----------
    files : list of pathlib.Path
        The raw test files (facility D3 file first, then the OBD file).
    template_path : pathlib.Path
        The import template.
    truth_path : pathlib.Path
        ``truth.json`` (offsets, faults, sensor models, settings).
    clean_path : pathlib.Path
        ``clean.parquet`` with the clean SI signals.
    """

    files: list[Path]
    template_path: Path
    truth_path: Path
    clean_path: Path


def is_virtual_test_dir(path: str | Path) -> bool:
    """True when ``path`` holds a ``truth.json`` written by the virtual dyno."""
    return bool(_previous_truth(Path(path)))


def _previous_truth(outdir: Path) -> dict:
    p = outdir / "truth.json"
    try:
        data = json.loads(p.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}
    return data if isinstance(data, dict) and data.get("format") == TRUTH_FORMAT else {}


def _json_default(obj: Any) -> Any:
    if isinstance(obj, (np.floating, np.integer)):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"not JSON serialisable: {type(obj).__name__}")


def _plain(value: Any) -> Any:
    """JSON-safe copy of a value (pydantic models dumped, numpy turned into lists)."""
    if hasattr(value, "model_dump"):
        value = value.model_dump(mode="json")
    return json.loads(json.dumps(value, default=_json_default))


def _faults_origin(faults: str | Path | list) -> str:
    if isinstance(faults, list):
        return "faults"
    return "data/faults/default.yaml" if str(faults) == "default" else str(faults)


def _faults_label(faults: str | Path | list) -> str:
    if isinstance(faults, list):
        return "custom list"
    if str(faults) in ("default", "none"):
        return str(faults)
    return Path(faults).name


def _load_inputs(vehicle: str | Path, cycle: Any, controller_overrides: dict | None,
                 vehicle_overrides: dict | None) -> tuple[Any, Any]:
    """Load the vehicle (with overrides) and the cycle; raises VehvalError when unknown."""
    from vehval.cycles import Cycle, load_cycle
    from vehval.vehicle import load_vehicle

    cyc = cycle if isinstance(cycle, Cycle) else load_cycle(cycle)
    veh = load_vehicle(vehicle)
    if vehicle_overrides or controller_overrides:
        veh = apply_overrides(veh, vehicle_overrides or {}, controller_overrides or {})
    return veh, cyc


def _simulate(veh: Any, cyc: Any) -> Any:
    """Run the simulation at dt = 0.1 s."""
    from vehval.sim.simulate import simulate

    return simulate(veh, cyc, dt=0.1)


def apply_overrides(vehicle: Any, vehicle_overrides: dict, controller_overrides: dict) -> Any:
    """A validated copy of ``vehicle`` with parameter overrides.

    Parameters
    ----------
    vehicle : Vehicle
        Loaded vehicle.
    vehicle_overrides : dict
        ``{"body.mass_kg": 1350, ...}``: ``<block>.<parameter>`` keys.
    controller_overrides : dict
        Keys of the ``controller`` block (``{"soc_target": 0.55}``).

    Raises
    ------
    ConfigError
        When a key is not a parameter of the vehicle (from ``Vehicle.with_overrides``).
    """
    merged = dict(vehicle_overrides)
    merged.update({f"controller.{k}": v for k, v in controller_overrides.items()})
    return vehicle.with_overrides(merged)


def make_virtual_test(vehicle: str | Path = "prius_2004", cycle: Any = "udds", seed: int = 7,
                      faults: str | Path | list = "default", outdir: str | Path = "virtual_test",
                      controller_overrides: dict | None = None,
                      vehicle_overrides: dict | None = None) -> SynthOutput:
    """Simulate a run and write it as a virtual test with known sensor errors and faults.

    Parameters
    ----------
    vehicle : str or path
        Vehicle file name (``prius_2004``) or path.
    cycle : str, path or Cycle
        Drive cycle name, CSV path or :class:`vehval.cycles.Cycle`.
    seed : int
        Seed of every random draw (noise, jitter, spike positions...).
    faults : {'default', 'none'}, path or list
        Fault mix: the package default, nothing, a fault YAML file or a list of fault dicts.
    outdir : path
        Output directory, written atomically (files appear complete or not at all).
    controller_overrides : dict, optional
        Controller parameters to replace (``{"soc_target": 0.55}``); the controller actually
        used is recorded in the truth.
    vehicle_overrides : dict, optional
        Vehicle parameters to replace by ``<block>.<parameter>`` (``{"body.mass_kg": 1350}``).

    Returns
    -------
    SynthOutput
        Paths of the files, template, truth and clean signals.

    Raises
    ------
    VehvalError
        Unknown vehicle or cycle, invalid fault file or override.
    """
    seed = int(seed)
    table = load_sensor_table()
    specs = load_fault_specs(faults)
    veh, cyc = _load_inputs(vehicle, cycle, controller_overrides, vehicle_overrides)
    consts = vehicle_constants(veh)
    duration = float(cyc.duration_s)
    spans = {}  # first and last time of each file, on the file's own clock [s]
    for label, fs in table.items():
        if fs.format == "d3":  # fixed stamps: -pre_padding .. end + post_padding
            spans[label] = (-fs.setting("pre_padding_s", 10.0),
                            duration + fs.setting("post_padding_s", 3.0))
        else:  # the logger polls on the true clock and stamps with its offset clock
            c = sum(float(f.magnitude or 0.0) for f in specs
                    if f.kind == "clock_offset" and f.file == label)
            spans[label] = (fs.setting("start_s", -4.0) + c,
                            duration + fs.setting("post_padding_s", 2.0) + c)
    # fail fast on a bad fault file, before the simulation
    resolved = resolve_faults(specs, table, duration, spans, origin=_faults_origin(faults))
    result = _simulate(veh, cyc)

    sim_signals = {}
    for sig in result.test:
        if sig.name.endswith("_simu"):
            sim_signals[sig.name[: -len("_simu")]] = (sig.time, sig.values)
    needed = {ch.clean for fs in table.values() for ch in fs.channels.values()} - set(SYNTHESISED)
    missing = sorted(needed - set(sim_signals))
    if missing:
        raise VehvalError(f"the simulation result lacks signals the virtual dyno needs: "
                          f"{', '.join(b + '_simu' for b in missing)}")
    shift = max([abs(f.params["clock_offset_s"]) + abs(f.params["delay_s"])
                 for f in resolved if f.kind == "clock_offset"] + [0.0])
    grid, clean = build_clean(sim_signals, cyc.name, duration, seed, consts["fuel_lhv_j_per_kg"],
                              pad_s=15.0 + float(np.ceil(shift)))

    test_id = re.sub(r"[^A-Za-z0-9_.-]+", "_", f"virtual_{vehicle_name(veh, vehicle)}_{cyc.name}_seed{seed}")
    datas: dict[str, FileData] = {}
    for label, fs in table.items():
        datas[label] = build_file(fs, grid, clean, duration, seed,
                                  [f for f in resolved if f.file == label],
                                  consts["fuel_density_kg_per_m3"])

    outdir = Path(outdir)
    previous = _previous_truth(outdir)
    with atomic_dir(outdir) as stage:
        written = {}
        for label, d in datas.items():
            name = test_id + FILE_SUFFIX[label]
            info = write_table(stage / name, d.headers, d.columns, style=d.spec.format,
                               decimals=d.spec.decimals, truncate_rows=d.truncate_rows,
                               nul_padding=64 if (d.truncate_rows is not None and label == "obd") else 0)
            written[label] = (name, info)
        template = template_for(table, datas, consts, veh, vehicle, cyc.name, seed,
                                _faults_label(faults), FILE_SUFFIX)
        template.save(stage / "template.yaml")
        import pandas as pd

        frame = pd.DataFrame({"time": grid, **{b: clean[b] for b in sorted(clean)}})
        with atomic_path(stage / "clean.parquet") as tmp:
            frame.to_parquet(tmp, index=False)
        truth = _truth(test_id, veh, vehicle, cyc, seed, faults, table, datas, written, resolved,
                       consts, result, grid, clean, controller_overrides, vehicle_overrides)
        write_text_atomic(stage / "truth.json", json.dumps(truth, indent=2, default=_json_default) + "\n")
        write_text_atomic(stage / "README.txt", _readme(test_id, truth))
    # a previous virtual test in the same directory must not leave its data files behind:
    # the template's globs would match them too
    new_names = {w[0] for w in written.values()}
    for f in (previous.get("files") or {}).values():
        old = f.get("file") if isinstance(f, dict) else None
        if old and old not in new_names and Path(old).name == old:
            (outdir / old).unlink(missing_ok=True)
    return SynthOutput(files=[outdir / written[k][0] for k in datas],
                       template_path=outdir / "template.yaml", truth_path=outdir / "truth.json",
                       clean_path=outdir / "clean.parquet")


def _truth(test_id, veh, vehicle_arg, cyc, seed, faults, table, datas, written, resolved, consts,  # noqa: PLR0913 - every input of the virtual test, recorded in truth.json
           result, grid, clean, controller_overrides, vehicle_overrides) -> dict:
    files, channels, offsets = {}, {}, {}
    for label, d in datas.items():
        name, info = written[label]
        files[label] = {
            "file": name, "format": d.spec.format, "source": d.spec.source,
            "offset_s": round(d.offset_s, 9) + 0.0, "clock_offset_s": d.clock_offset_s,
            "delay_s": d.delay_s, "rate_hz": d.spec.rate_hz, "decimals": d.spec.decimals,
            "rows_written": info["rows_written"], "truncated": d.truncate_rows is not None,
            "partial_last_line": info["partial_line"], "bytes": info["bytes"],
            "first_time_s": round(float(d.file_time[0]), 3),
            "settings": dict(d.spec.settings)}
        offsets[d.spec.source] = round(d.offset_s, 9) + 0.0
        for ch, s in d.spec.channels.items():
            entry = s.to_dict(consts["fuel_density_kg_per_m3"])
            entry.update({"file": label, "header": d.headers[1 + list(d.spec.channels).index(ch)],
                          "header_unit": d.header_units[ch], "true_raw_unit": s.unit,
                          "faults": [f.index for f in resolved if f.channel == ch]})
            channels[ch] = entry
    control = getattr(veh, "controller", None)
    summary = getattr(result, "summary", {}) or {}
    return {
        "format": TRUTH_FORMAT, "version": 1, "synthetic": True,
        "note": "VIRTUAL TEST: synthetic data from a simulation, not a measurement",
        "test_id": test_id, "vehicle": vehicle_name(veh, vehicle_arg), "cycle": cyc.name,
        "cycle_duration_s": float(cyc.duration_s), "seed": seed,
        "faults_setting": _faults_label(faults),
        "time_convention": TIME_CONVENTION,
        "offsets_s": offsets,
        "files": files,
        "channels": channels,
        "faults": [f.to_dict(datas[f.file].offset_s) for f in resolved],
        "clean": {"path": "clean.parquet", "time_column": "time",
                  "grid_dt_s": round(float(grid[1] - grid[0]), 9),
                  "grid_start_s": float(grid[0]), "grid_end_s": float(grid[-1]),
                  "units": {b: _unit_of(b) for b in sorted(clean)},
                  "synthesised": {b: "vehval.synth.clean (not simulated)" for b in sorted(SYNTHESISED)},
                  "note": "simulation signals are held (and motion quantities zeroed) outside "
                          "the simulated span"},
        "constants": consts,
        "controller": ({k: v for k, v in _plain(control).items() if k != "sources"}
                       if control is not None else None),
        "controller_overrides": _plain(controller_overrides or {}),
        "vehicle_overrides": _plain(vehicle_overrides or {}),
        "simulation": {"dt_s": 0.1, "summary": _plain(summary)},
        "settings": {"sensor_table": "vehval/data/faults/sensors.yaml",
                     "fault_kinds_applied": sorted({f.kind for f in resolved})},
    }


def _unit_of(base: str) -> str:
    from vehval.nomenclature import registry

    return registry()[base].unit


def _readme(test_id: str, truth: dict) -> str:
    lines = [
        "VIRTUAL TEST - synthetic data, not a measurement",
        "=" * 48,
        "",
        f"Generated by `vehval synth` (vehval.synth.make_virtual_test): vehicle {truth['vehicle']},",
        f"cycle {truth['cycle']} ({truth['cycle_duration_s']:g} s), seed {truth['seed']}, "
        f"faults '{truth['faults_setting']}'.",
        "A forward-looking simulation was 'measured' by virtual sensors (noise, gain and offset",
        "errors, quantisation, lag, sample jitter) and known faults were injected.",
        "",
        "Files:",
    ]
    for label, f in truth["files"].items():
        lines.append(f"  {f['file']:44s} {label} file ({f['format']}, source '{f['source']}', "
                     f"{f['rows_written']} rows)")
    lines += [
        "  template.yaml                                import template (vehval import)",
        "  truth.json                                   the answers: offsets, faults, sensor models",
        "  clean.parquet                                clean SI signals the channels came from",
        "",
        f"Injected faults: {len(truth['faults'])}",
    ]
    for f in truth["faults"]:
        where = f["channel"] or f["file"]
        lines.append(f"  - {f['kind']:13s} {where:22s} {f['start_s']:9.2f} .. {f['end_s']:9.2f} s  "
                     f"{f['description']}")
    lines += ["", "Time convention: " + truth["time_convention"], ""]
    return "\n".join(lines)
