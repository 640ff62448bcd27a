"""The import template of a virtual test, and the vehicle constants it declares.

The template maps each channel with the unit written in its header, the way an engineer
would write it from the file: a ``wrong_unit`` fault therefore reaches the imported data
(which is the point: QA has to catch it).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from vehval.io.template import Constants, Template


def vehicle_name(vehicle: Any, vehicle_arg: str | Path) -> str:
    """Short vehicle name: the model's ``name`` or the file stem of the argument."""
    name = getattr(vehicle, "name", None)
    return str(name) if name else Path(str(vehicle_arg)).stem


def vehicle_line(vehicle_ref: str | Path | None) -> str:
    """The template's ``vehicle:`` line naming the vehicle a virtual test was made from (a
    name, or the resolved path of a file), so that ``vehval validate`` without ``--vehicle``
    validates that car; '' without a reference."""
    import json

    if vehicle_ref is None:
        return ""
    ref = str(Path(vehicle_ref).resolve()) if Path(vehicle_ref).is_file() else str(vehicle_ref)
    return f"vehicle: {json.dumps(ref)}\n"


def vehicle_constants(vehicle: Any) -> dict[str, float]:
    """Template constants (SI, unit in the key) from the vehicle parameters.

    Returns
    -------
    dict
        ``test_mass_kg``, ``road_load_a_n``, ``road_load_b_n_per_mps``,
        ``road_load_c_n_per_mps2``, ``fuel_density_kg_per_m3``, ``fuel_lhv_j_per_kg``,
        ``wheel_radius_m``, ``final_drive_ratio``.
    """
    body, eng, dl = vehicle.body, vehicle.engine, vehicle.driveline
    return {
        "test_mass_kg": float(body.mass_kg),
        "road_load_a_n": float(body.road_load_a_n),
        "road_load_b_n_per_mps": float(body.road_load_b_n_per_mps),
        "road_load_c_n_per_mps2": float(body.road_load_c_n_per_mps2),
        "fuel_density_kg_per_m3": float(eng.fuel_density_kg_per_m3),
        "fuel_lhv_j_per_kg": float(eng.fuel_lhv_j_per_kg),
        "wheel_radius_m": float(dl.wheel_radius_m),
        "final_drive_ratio": float(dl.final_drive_ratio),
    }


def template_for(table: dict, datas: dict, consts: dict[str, float], vehicle: Any,
                 vehicle_arg: str | Path, cycle_name: str, seed: int, faults_label: str,
                 suffix: dict[str, str]) -> Template:
    """Build the (validated) import template of a virtual test.

    The template declares ``synthetic: true`` and ``cycle: <cycle_name>``, so the imported
    test carries the virtual-test flag and its generating cycle.

    Parameters
    ----------
    table : dict
        Sensor table (file label -> FileSpec).
    datas : dict
        Built files (file label -> FileData), for the header units actually written.
    consts : dict
        Template constants (see :func:`vehicle_constants`).
    vehicle, vehicle_arg
        Vehicle model and the name/path it was loaded from.
    cycle_name, seed, faults_label
        For the description.
    suffix : dict
        File label -> file name suffix (the template's ``match`` glob is ``*<suffix>``).
    """
    files = []
    for label, fs in table.items():
        d = datas[label]
        channels = {}
        for ch, s in fs.channels.items():
            entry: dict[str, Any] = {"name": s.name}
            if d.header_units[ch] is not None:
                entry["unit"] = d.header_units[ch]
            channels[ch] = entry
        time_col = "Time" if fs.format == "d3" else "Timestamp"
        files.append({"match": f"*{suffix[label]}", "source": fs.source, "format": fs.format,
                      "time": {"column": time_col, "unit": "s"}, "channels": channels})
    known = set(Constants.model_fields)
    data = {
        "template_version": 1,
        "vehicle": vehicle_name(vehicle, vehicle_arg),
        "cycle": cycle_name,
        "synthetic": True,
        "description": (f"VIRTUAL TEST (synthetic data from vehval synth, not a measurement): "
                        f"{vehicle_name(vehicle, vehicle_arg)} on {cycle_name}, seed {seed}, "
                        f"faults '{faults_label}'. Facility D3 file + OBD logger file."),
        "constants": {k: v for k, v in consts.items() if k in known},
        "files": files,
    }
    return Template.model_validate(data)
