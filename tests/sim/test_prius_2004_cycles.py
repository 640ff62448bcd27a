"""scripts/prius_2004_cycles.py and scripts/epa_lab_pairs.py: the change-by-change replay of the
2004 vehicle file's history and the one-model window of a pair of lab rows."""

from __future__ import annotations

import importlib.util
import shutil
import subprocess
from pathlib import Path

import pytest

from vehval.vehicle import load_vehicle

ROOT = Path(__file__).resolve().parents[2]


def _script(name: str):
    spec = importlib.util.spec_from_file_location(f"vehval_{name}", ROOT / "scripts" / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _has_history() -> bool:
    if shutil.which("git") is None:
        return False
    out = subprocess.run(["git", "log", "-1", "--format=%h", "--", "src/vehval/data/vehicles/"
                          "prius_2004.yaml"], cwd=ROOT, capture_output=True, text=True)
    return out.returncode == 0 and bool(out.stdout.strip())


@pytest.mark.skipif(not _has_history(), reason="needs a git checkout with the file's history")
def test_changes_applied_in_turn_end_at_the_packaged_file(tmp_path):
    """Applying every recorded value change, component by component, from the first loadable
    version reproduces every parameter of the packaged file (no change lost or doubled)."""
    mod = _script("prius_2004_cycles")
    rows, skipped = mod.steps(tmp_path)
    assert rows[0]["vehicle"] is not None
    last = [r["vehicle"] for r in rows if r["vehicle"] is not None][-1]
    packaged = load_vehicle(ROOT / mod.VEHICLE)
    assert mod.flat(last) == mod.flat(packaged)
    # a step names exactly the keys it changed, each within its one component
    for r in rows[1:]:
        assert len({k.split(".")[0] for k in r["changed"]}) <= 1
        if r["vehicle"] is None:
            assert r["changed"] == []
    for note in skipped:
        assert "not loadable by the present schema" in note


def test_flat_ignores_sources_and_sees_values():
    mod = _script("prius_2004_cycles")
    veh = load_vehicle("prius_2004")
    base = mod.flat(veh)
    assert not any(".sources" in k or ".uncertainty" in k for k in base)
    other = veh.with_overrides({"controller.regen_fraction_max": 0.9})
    diff = {k for k in base if base[k] != mod.flat(other)[k]}
    assert diff == {"controller.regen_fraction_max"}


def test_one_model_window():
    """A figure P within tol of every m (error P / m - 1, as epa validate states it)."""
    mod = _script("epa_lab_pairs")
    lo, hi = mod.one_model_window([65.9, 71.4], 0.05)
    assert lo == pytest.approx(71.4 * 0.95) and hi == pytest.approx(65.9 * 1.05)
    for p in (lo, hi):
        assert all(abs(p / m - 1) <= 0.05 + 1e-12 for m in (65.9, 71.4))
    # 47.6 / 42.6 = 1.117 > 1.05 / 0.95: no figure is within 5 % of both
    assert mod.one_model_window([42.6, 47.6], 0.05) is None
    assert mod.one_model_window([50.0], 0.05) == pytest.approx((47.5, 52.5))


def test_lab_summary_ratios_by_class_and_procedure():
    """EPA-run figure over the manufacturer's mean of the same setting, per class and procedure."""
    from types import SimpleNamespace as Row

    mod = _script("epa_lab_pairs")
    groups = {
        ("car A", "ftp75"): [Row(model="CIVIC", originator="MFR", fe=40.0),
                             Row(model="CIVIC", originator="MFR", fe=42.0),
                             Row(model="CIVIC", originator="EPA", fe=39.0)],
        ("car B", "ftp75"): [Row(model="PRIUS c", originator="MFR", fe=75.0),
                             Row(model="PRIUS c", originator="EPA", fe=69.0)],
        ("car C", "us06"): [Row(model="CAMRY HYBRID", originator="EPA", fe=40.0)],  # no MFR row
    }
    lines = mod.lab_summary(groups)
    assert lines[2] == "| hybrid | ftp75 | 1 | -8.0 % | -8.0 % | -8.0 % |"
    assert lines[3] == "| other | ftp75 | 1 | -4.9 % | -4.9 % | -4.9 % |"  # 39 / 41 - 1
    assert len(lines) == 4
