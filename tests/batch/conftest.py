"""Fixtures for the batch tests: small D3-style tests written in tmp_path.

The generator is deliberately simple and self-contained (a 1 Hz D3 text file and a
one-entry template), so the batch machinery is tested independently of the simulator;
the virtual-dyno tests in test_batch_cluster.py use vehval.synth.make_virtual_test.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from .helpers import TEMPLATE


@pytest.fixture
def template_path(tmp_path) -> Path:
    p = tmp_path / "d3_template.yaml"
    p.write_text(TEMPLATE, encoding="utf-8")
    return p
