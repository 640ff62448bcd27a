"""Mutation campaign (scripts/mutation_campaign.py), fast subset on a virtual dyno test.

Unit and mapping mistakes in the virtual test's template: each must be withheld with a hint
naming the signal and the probable unit (the declared one and the factor), or leave every
stated figure within its expanded uncertainty. The whole campaign over the real Cruze, Camry,
Prius c and Insight files runs as ``python scripts/mutation_campaign.py --all`` and in the
``slow`` test below when ``VEHVAL_CAMPAIGN=1``; its table is in docs/robustness.md.
"""

from __future__ import annotations

import importlib.util
import os
import sys
from pathlib import Path

import pytest
import yaml

SCRIPT = Path(__file__).resolve().parents[2] / "scripts" / "mutation_campaign.py"


def _campaign():
    spec = importlib.util.spec_from_file_location("mutation_campaign", SCRIPT)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod  # dataclasses look their module up here
    spec.loader.exec_module(mod)
    return mod


CAMPAIGN = _campaign()
#: mutation -> outcomes accepted on the virtual Prius (a dyno file with force, fuel, cycle)
EXPECTED = {
    "fuel mg/s": {"withheld+hint"},
    "fuel kg/h": {"withheld+hint"},
    "fuel L/h": {"withheld+hint"},
    "fuel volume/mass (ccps as g/s)": {"withheld+hint"},
    "speed km/h vs mph": {"withheld+hint"},
    "speed m/s": {"withheld+hint"},
    "test mass in lb": {"unaffected+hint"},
    "force lbf": {"unaffected+hint"},
    "engine rpm as rad/s": {"unaffected+hint"},
    "swapped channels": {"withheld+hint"},
    "wrong phase channel": {"withheld+hint"},  # phase figures withheld until the mapping is fixed
    "shifted time base (+7.3 s)": {"unaffected"},
    "misspelled raw channel": {"withheld+hint"},
}


@pytest.fixture(scope="module")
def outcomes(tmp_path_factory):
    from vehval.synth import make_virtual_test

    root = tmp_path_factory.mktemp("mut")
    d = root / "virtual"
    make_virtual_test("prius_2004", "udds", seed=3, faults="none", outdir=d)
    for extra in d.glob("*_obd.csv"):
        extra.unlink()                                   # one file per case, as the campaign
    tpl = yaml.safe_load((d / "template.yaml").read_text(encoding="utf-8"))
    tpl["files"] = [f for f in tpl["files"] if f["match"].endswith("_d3.txt")]
    (d / "template.yaml").unlink()
    ds = CAMPAIGN.Dataset(
        "virtual", "virtual", "*_d3.txt", lambda: yaml.safe_load(yaml.safe_dump(tpl)),
        {"fuel": "Eng_FuelFlow_Direct", "speed": "Dyno_Speed", "force": "Dyno_Tractive_Effort",
         "engine": "Engine_Speed", "phase": "Phase_#", "other": "Test_Cell_RH",
         "mass": "test_mass_kg"})
    found = CAMPAIGN.campaign(root, datasets=[ds], mutations=list(EXPECTED), log=lambda s: None)
    return {o.mutation: o for o in found}


@pytest.mark.slow
@pytest.mark.parametrize("mutation", list(EXPECTED))
def test_mutation_outcome(outcomes, mutation):
    o = outcomes[mutation]
    assert o.outcome in EXPECTED[mutation], (o.outcome, o.detail, o.breaches)


@pytest.mark.slow
def test_no_breach(outcomes):
    assert [o for o in outcomes.values() if o.outcome == "BREACH"] == []


@pytest.mark.slow
def test_fuel_hint_names_declared_and_probable_unit(outcomes):
    """Virtual fuel flow is in cm³/s: declared mg/s, the hint is ccps, x740 (the density)."""
    assert "in ccps, not mg/s (x740)" in outcomes["fuel mg/s"].detail


#: Cells where nothing in the data can tell (docs/robustness.md, note d): the wrong fuel
#: declared. (The on-road Prius c speed units are caught by the OBD PID's whole km/h.)
KNOWN_BREACHES = {("cruze", "wrong fuel"), ("camry", "wrong fuel")}


@pytest.mark.slow
@pytest.mark.realdata
@pytest.mark.skipif(os.environ.get("VEHVAL_CAMPAIGN") != "1",
                    reason="the whole campaign on the real files is opt-in (VEHVAL_CAMPAIGN=1)")
def test_whole_campaign_on_real_files():
    if not CAMPAIGN.DEFAULT_DATA.is_dir():
        pytest.skip("real data not available")
    found = CAMPAIGN.campaign(CAMPAIGN.DEFAULT_DATA, every=True, log=lambda s: None)
    assert found
    assert [o.outcome for o in found if o.outcome == "withheld, no hint"] == []
    breaches = [(o.dataset, o.file, o.mutation) for o in found if o.outcome == "BREACH"
                and (o.dataset, o.mutation) not in KNOWN_BREACHES]
    assert breaches == []
