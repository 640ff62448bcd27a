"""Attack campaign III (scripts/attack_campaign3.py): a fixed-seed case of each class, each a
real ``python -m vehval`` process, HTTP request against ``vehval serve`` or Chromium page
load, ends in a clean error or a handled answer.

The whole campaign runs in the ``slow`` test when ``VEHVAL_CAMPAIGN=1`` and as
``python scripts/attack_campaign3.py``; its totals are in docs/robustness.md.
"""

from __future__ import annotations

import importlib.util
import json
import os
import stat
import subprocess
import sys
from pathlib import Path

import pytest

SCRIPTS = Path(__file__).resolve().parents[2] / "scripts"
SCRIPT = SCRIPTS / "attack_campaign3.py"

pytestmark = pytest.mark.xdist_group("campaign3")  # one vehval serve and its port at a time


def _campaign():
    spec = importlib.util.spec_from_file_location("attack_campaign3", SCRIPT)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod  # dataclasses look their module up here
    sys.path.insert(0, str(SCRIPTS))
    try:
        spec.loader.exec_module(mod)
    finally:
        sys.path.remove(str(SCRIPTS))
    return mod


CAMPAIGN = _campaign()
COMMON = sys.modules["attack3_common"]
CLASSES = list(CAMPAIGN.CLASSES)

#: The fixed case of each class (by name: a new variant does not move it); each its class's
#: representative of issue 37.
SAMPLE = {
    "outputs": "import -o a device",
    "workbench": "symlinked data file: GET /api/channel",
    "silent figures": "fuel channel scale 2 (virtual Cruze HWFET)",
    "hangs": "epa calibrate 5,000-value grid (--refine 0, --workers 1)",
    "internal": "identify --tyre '999/99 R99'",
    "EPA reader": "list: UTF-8 BOM, CR LF line ends",
    "exit crash": "template check over the 10 Cruze files x40",
}


def _case(tmp_path: Path, cls: str):
    cases = {c.name: c for c in CAMPAIGN.cases(tmp_path, [cls])}
    name = SAMPLE[cls]
    if cls == "outputs" and not CAMPAIGN.can_mknod():
        name = "import -o a FIFO"  # no device nodes without CAP_MKNOD
    if cls == "exit crash":
        # the crash (exit 134) was seen only on the real files, in about 1 run of 20 to 50:
        # 10 runs here (about 35 s); without the real files, virtual ones stand in
        if name not in cases:
            name = "template check over 3 virtual files x10"
        cases[name].repeat = 10
    return cases[name]


@pytest.mark.parametrize("cls", CLASSES)
def test_sample_of_class(cls, tmp_path):
    try:
        row = CAMPAIGN.run_all([_case(tmp_path, cls)], jobs=1)[0]
    finally:
        CAMPAIGN.stop_servers()
    assert row["outcome"] in ("clean error", "handled"), row


def test_every_class_has_its_sample(tmp_path):
    assert set(SAMPLE) == set(CLASSES)
    for cls in CLASSES:
        assert _case(tmp_path, cls).cls == cls


def test_classification(tmp_path):
    """A breach beats everything; a signal (134 = SIGABRT), a 5xx or a traceback is
    internal; an answer without its finding is silently wrong; a refusal must say what it
    must; an estimate printed before the timeout makes a long run handled."""
    k = COMMON.classify3
    c = COMMON.Case("x", "y", [], expect="ok", must=COMMON.named("fuel", "scale"),
                    refusal_must="fuel", ok_codes=(0, 4), breach=lambda text: "SECRET" in text)
    assert k(c, 0, "SECRET") == "breach"
    assert k(c, "hang", "") == "hang"
    assert k(c, -6, "terminate called without an active exception") == "internal error"
    assert k(c, 134, "") == "internal error"
    assert k(c, 3, "HTTP 500") == "internal error"
    assert k(c, 0, "ok", "Exception ignored in: <x>") == "internal error"
    assert k(c, 0, "headline hwfet: 27.40 mpg") == "silently wrong"
    # the pattern on the figure's own line is not a finding
    assert k(c, 0, "fuel scale 2: headline 27.40 mpg") == "silently wrong"
    assert k(c, 0, "  warning fuel_plausible  fuel channel scale 2 gives 18 %") == "handled"
    assert k(c, 4, "  error fuel_plausible  fuel channel scale 2: headline withheld") == \
        "handled"
    assert k(c, 2, "vehval: error: bad file") == "silently wrong"
    assert k(c, 2, "vehval: error: fuel channel: implausible") == "clean error"
    refusal = COMMON.Case("x", "y", [])
    assert k(refusal, 0, "done") == "silently wrong"
    assert k(refusal, 2, "vehval: error: no") == "clean error"
    est = COMMON.Case("x", "y", [], expect="ok", must=CAMPAIGN.states_estimate,
                      estimate_ok=True)
    assert k(est, "hang", "vehval: compiling the kernel (about 20 s; cached)") == "hang"
    assert k(est, "hang", "5000 settings x 1 test: estimated 2.1 h; running") == "handled"
    valid = COMMON.Case("x", "y", [], expect="ok", must="PRIUS", refusal_must=COMMON.never)
    assert k(valid, 2, "vehval: error: missing column(s) 'Model Year'") == "silently wrong"


def test_node_checks(tmp_path):
    """The breach check of the outputs class: a node replaced by a regular file."""
    kinds = ["FIFO", "socket"] + (["device"] if CAMPAIGN.can_mknod() else [])
    for kind in kinds:
        p = tmp_path / kind / "out.yaml"
        CAMPAIGN.make_node(p, kind)
        assert not CAMPAIGN.replaced(p, kind)
        p.unlink()
        p.write_text("x")
        assert CAMPAIGN.replaced(p, kind) and stat.S_ISREG(p.stat().st_mode)


def test_campaign_has_every_class_and_unique_names(tmp_path):
    cases = list(CAMPAIGN.cases(tmp_path))
    assert {c.cls for c in cases} == set(CLASSES)
    assert len({(c.cls, c.name) for c in cases}) == len(cases)
    assert len(cases) >= 150


@pytest.mark.slow
@pytest.mark.skipif(os.environ.get("VEHVAL_CAMPAIGN") != "1",
                    reason="the whole campaign takes about 15 min on 2 cores: VEHVAL_CAMPAIGN=1")
def test_whole_campaign(tmp_path):
    out = tmp_path / "campaign3.json"
    subprocess.run([sys.executable, str(SCRIPT), "--json", str(out), "--jobs", "2"],
                   capture_output=True, text=True, timeout=7200)
    rows = json.loads(out.read_text())
    bad = [r for r in rows if r["outcome"] not in ("clean error", "handled")]
    assert not bad, bad[:5]
