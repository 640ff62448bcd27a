"""Inputs of the workbench tests: the virtual test's fuel column, its expected mpg, tree copies.

Imported by the tests of this folder (and its conftest); fixtures stay in conftest.py.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

#: Density of the virtual test's fuel (vehval synth's gasoline) [g/cm³].
SYNTH_DENSITY_G_PER_CC = 0.74


FUEL_COLUMN = "Eng_FuelFlow_Direct"


def _relabel_fuel(src: Path, dst: Path) -> None:
    lines = src.read_text(encoding="utf-8").splitlines()
    head = lines[0].split("\t")
    i = head.index(f"{FUEL_COLUMN}[ccps]")
    head[i] = f"{FUEL_COLUMN}[mg/s]"
    out = ["\t".join(head)]
    for line in lines[1:]:
        cells = line.split("\t")
        if len(cells) > i and cells[i].strip():
            cells[i] = f"{float(cells[i]) * SYNTH_DENSITY_G_PER_CC:.5f}"  # cm³/s -> g/s
        out.append("\t".join(cells))
    dst.write_text("\n".join(out) + "\n", encoding="utf-8")


def expected_mpg(synth_dir: Path, density_kg_per_m3: float) -> float:
    """Fuel economy of the simulation behind the virtual test [mpg] at the given density."""
    truth = json.loads((synth_dir / "truth.json").read_text(encoding="utf-8"))
    s = truth["simulation"]["summary"]
    litres = s["fuel_mass_kg"] / density_kg_per_m3 * 1000.0
    return (s["distance_m"] / 1609.344) / (litres / 3.785411784)


def copy_tree(src: Path, dst: Path) -> Path:
    shutil.copytree(src, dst)
    return dst


def client(ws: Path, csrf: bool = True):
    """A test client of the workbench on workspace ``ws``, with its token (and its CSRF
    token, as the pages send it, unless ``csrf`` is false)."""
    from starlette.testclient import TestClient

    from vehval.serve.app import create_app

    app = create_app(ws)
    wb = app.state.workbench
    headers = {"X-Vehval-Token": wb.token, **({"X-CSRF-Token": wb.csrf} if csrf else {})}
    return TestClient(app, base_url="http://127.0.0.1", headers=headers)
