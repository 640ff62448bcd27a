"""A workspace with one virtual test for the workbench tests.

The virtual dyno (``vehval synth``, no injected fault) writes a D3 facility file; its fuel
flow column is rewritten in g/s but labelled ``[mg/s]`` (a unit error of the kind a facility
file carries), so ``vehval template init`` declares it mg/s. Only the D3 file is kept.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from vehval.cli import main

from .helpers import _relabel_fuel


@pytest.fixture(scope="session")
def synth_dir(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("synth") / "udds"
    assert main(["synth", "--vehicle", "prius_2004", "--cycle", "udds", "--seed", "3",
                 "--faults", "none", "-o", str(d)]) == 0
    return d


@pytest.fixture()
def workspace(synth_dir, tmp_path) -> Path:
    """``WS/virtual/``: the relabelled D3 file, and ``template.yaml`` from `template init`."""
    ws = tmp_path / "ws"
    test = ws / "virtual"
    test.mkdir(parents=True)
    d3 = next(synth_dir.glob("*_d3.txt"))
    _relabel_fuel(d3, test / "run_d3.txt")
    assert main(["template", "init", str(test / "run_d3.txt"), "-o", str(test / "template.yaml")]) == 0
    return ws



@pytest.fixture(scope="session")
def batch_ws(synth_dir, tmp_path_factory) -> Path:
    """``WS/in/{udds,japan1015}/`` (virtual tests), ``WS/template.yaml`` (no ``cycle:``: each
    test's cycle is identified) and ``WS/out/`` from ``vehval batch`` (QA, reports)."""
    from vehval.batch import run_batch

    ws = tmp_path_factory.mktemp("batchws")
    hw = tmp_path_factory.mktemp("synth_jp") / "japan1015"
    assert main(["synth", "--vehicle", "prius_2004", "--cycle", "japan1015", "--seed", "4",
                 "--faults", "none", "-o", str(hw)]) == 0
    for name, src in (("udds", synth_dir), ("japan1015", hw)):
        d = ws / "in" / name
        d.mkdir(parents=True)
        for f in (*src.glob("*_d3.txt"), *src.glob("*_obd.csv")):
            shutil.copy(f, d / f.name)
    text = (synth_dir / "template.yaml").read_text(encoding="utf-8")
    (ws / "template.yaml").write_text(
        "\n".join(ln for ln in text.splitlines() if not ln.startswith("cycle:")) + "\n",
        encoding="utf-8")
    run_batch(ws / "in", ws / "template.yaml", ws / "out", steps=["qa"], workers=0, progress=False)
    return ws


@pytest.fixture()
def browser():
    """Headless Debian Chromium through playwright (skips when either is missing)."""
    from helpers.browser import ARGS, CHROMIUM

    if not Path(CHROMIUM).exists():
        pytest.skip("chromium not installed (run `make browser`)")
    sync_api = pytest.importorskip("playwright.sync_api")
    pytest.importorskip("uvicorn")
    with sync_api.sync_playwright() as p:
        try:
            b = p.chromium.launch(executable_path=CHROMIUM, args=ARGS)
        except Exception as exc:  # noqa: BLE001 - a broken browser install is a skip
            pytest.skip(f"chromium does not start: {exc}")
        yield b
        b.close()


@pytest.fixture(scope="session")
def bev_ws(tmp_path_factory) -> Path:
    """``WS/bev/``: a virtual UDDS test of the test BEV (``vehval.synth.bev``, an answer key
    of SAE J1634 figures) under its template (``architecture: battery_electric``) naming the
    vehicle file ``test_bev.yaml`` as the command line names one run from ``WS`` (a test
    using it works from there: ``monkeypatch.chdir``). Returns the workspace;
    ``WS/truth.json`` is the key."""
    import json

    import yaml

    from helpers.bev import bev_data
    from vehval.cycles import load_cycle
    from vehval.synth.bev import make_bev_test
    from vehval.vehicle import load_vehicle

    ws = tmp_path_factory.mktemp("bevws")
    vfile = ws / "test_bev.yaml"
    vfile.write_text(yaml.safe_dump(bev_data(), sort_keys=False), encoding="utf-8")
    truth = make_bev_test(load_vehicle(vfile), load_cycle("udds"), 5, ws / "bev")
    for name in ("README.txt", "truth.json"):
        (ws / "bev" / name).unlink()
    data = yaml.safe_load((ws / "bev" / "template.yaml").read_text(encoding="utf-8"))
    data["vehicle"] = vfile.name
    (ws / "bev" / "template.yaml").write_text(yaml.safe_dump(data, sort_keys=False),
                                              encoding="utf-8")
    (ws / "truth.json").write_text(json.dumps(truth["j1634"]), encoding="utf-8")
    return ws
