"""Attack campaign II (scripts/attack_campaign2.py): a fixed-seed sample of each class, each
case a real ``python -m vehval`` process, ends in a clean error or a handled answer.

The whole campaign (267 cases, about 15 min on 2 cores) runs in the ``slow`` test when
``VEHVAL_CAMPAIGN=1`` and as
``python scripts/attack_campaign2.py``; its totals are in docs/robustness.md.
"""

from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

SCRIPT = Path(__file__).resolve().parents[2] / "scripts" / "attack_campaign2.py"

def _campaign():
    spec = importlib.util.spec_from_file_location("attack_campaign2", SCRIPT)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod  # dataclasses look their module up here
    sys.path.insert(0, str(SCRIPT.parent))
    try:
        spec.loader.exec_module(mod)
    finally:
        sys.path.remove(str(SCRIPT.parent))
    return mod


CAMPAIGN = _campaign()
CLASSES = list(CAMPAIGN.CLASSES)


@pytest.mark.parametrize("cls", CLASSES)
def test_sample_of_class(cls, tmp_path):
    cases = list(CAMPAIGN.cases(tmp_path, [cls]))
    case = cases[int(np.random.default_rng(31).integers(len(cases)))]
    row = CAMPAIGN.run_case(case)
    assert row["outcome"] in ("clean error", "handled"), row


def test_every_case_is_classified_strictly(tmp_path):
    """The classification itself: a breach beats everything, a traceback is internal, an exit
    0 without the expected text is silently wrong, a refusal must say what it must."""
    c = CAMPAIGN.Case("x", "y", [], expect="ok", must="rate_irregular", refusal_must="memory",
                      breach=lambda text: "SECRET" in text)
    k = CAMPAIGN.classify2
    assert k(c, 0, "SECRET", "") == "breach"
    assert k(c, "hang", "", "") == "hang"
    assert k(c, 2, "Traceback (most recent call last)", "") == "internal error"
    assert k(c, 0, "ok", "Exception ignored in: <x>") == "internal error"
    assert k(c, -9, "", "") == "internal error"
    assert k(c, 0, "findings: none", "") == "silently wrong"
    assert k(c, 0, '{"kind": "rate_irregular"}', "") == "handled"
    assert k(c, 2, "vehval: error: bad file", "") == "silently wrong"
    assert k(c, 2, "vehval: error: would need 3 GiB of memory", "") == "clean error"
    refusal = CAMPAIGN.Case("x", "y", [])
    assert k(refusal, 0, "done", "") == "silently wrong"
    assert k(refusal, 2, "vehval: error: no", "") == "clean error"


def test_campaign_has_every_class_and_size(tmp_path):
    cases = list(CAMPAIGN.cases(tmp_path))
    assert {c.cls for c in cases} == set(CLASSES)
    assert len(cases) == 267
    assert len({(c.cls, c.name) for c in cases}) == len(cases)


@pytest.mark.slow
@pytest.mark.skipif(os.environ.get("VEHVAL_CAMPAIGN") != "1",
                    reason="the whole campaign takes about 15 min on 2 cores: VEHVAL_CAMPAIGN=1")
def test_whole_campaign(tmp_path):
    out = tmp_path / "campaign2.json"
    subprocess.run([sys.executable, str(SCRIPT), "--json", str(out), "--jobs", "2"],
                   capture_output=True, text=True, timeout=5400)
    rows = json.loads(out.read_text())
    bad = [r for r in rows if r["outcome"] not in ("clean error", "handled")]
    assert len(rows) == 267 and not bad, bad[:5]


def test_page_breach_check(tmp_path):
    """A payload raw in a page, or a script-src allowing inline or eval, is a breach; an
    escaped payload under a strict script-src is not."""
    page = tmp_path / "r.html"
    check = CAMPAIGN._html_breach([tmp_path])
    meta = '<meta http-equiv="Content-Security-Policy" content="default-src \'none\'; {}">'
    page.write_text(meta.format("script-src 'sha256-abc'; style-src 'unsafe-inline'")
                    + "&lt;svg onload=alert('X5S')&gt;")
    assert not check("")
    page.write_text(meta.format("script-src 'unsafe-inline' file:"))
    assert check("")
    page.write_text(meta.format("script-src 'sha256-abc'") + "<SVG onload=alert('X5S')>")
    assert check("")


def test_a_larger_address_space_never_refuses_what_a_smaller_one_runs(tmp_path):
    """A 10 h test that QA runs under 1 GB of address space runs under 1.5 GB too, with two
    runs at once. Arrow's allocator reserved a 1 GiB arena when the limit left room for it
    (the 1.5 GB run was refused for memory, the 1 GB one ran), and its CSV reader's worker
    threads failed to start beside another run (an internal error, or a hang)."""
    from concurrent.futures import ThreadPoolExecutor
    from dataclasses import replace

    cases = {c.name: c for c in CAMPAIGN.cases(tmp_path, ["memory"])}
    pick = [cases[f"10 h at 10 Hz, qa under {gb} GB of address space"] for gb in ("1", "1.5")]
    pick[0].prepare()  # both read one file: written once, before they start
    twins = [replace(pick[1], args=[*pick[1].args[:-1], tmp_path / f"twin{k}"]) for k in (0, 1)]
    with ThreadPoolExecutor(2) as pool:
        rows = list(pool.map(CAMPAIGN.run_case, twins))
    rows.append(CAMPAIGN.run_case(pick[0]))
    assert [r["outcome"] for r in rows] == ["handled"] * 3, rows
