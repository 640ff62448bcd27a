"""The attack campaign (scripts/attack_campaign.py) ends with no internal error, no hang and
no silently wrong answer; its totals table is the one in docs/robustness.md."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

SCRIPT = Path(__file__).resolve().parents[2] / "scripts" / "attack_campaign.py"


@pytest.mark.slow
def test_campaign_is_clean(tmp_path):
    out = tmp_path / "campaign.json"
    proc = subprocess.run([sys.executable, str(SCRIPT), "--json", str(out)], capture_output=True,
                          text=True, timeout=600, env={**os.environ, "PYTHONUNBUFFERED": "1"})
    rows = json.loads(out.read_text())
    bad = [r for r in rows if r["outcome"] not in ("clean error", "handled")]
    assert not bad, bad[:5]
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert len(rows) >= 150 and "| **total** |" in proc.stdout
