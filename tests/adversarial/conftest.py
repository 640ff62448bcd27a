"""Small generated inputs for the adversarial suite (a 60 s D3-like test and its template)."""

from __future__ import annotations

import pytest

from helpers.cli import TEMPLATE, write_d3


@pytest.fixture
def small_test(tmp_path):
    """``(data_file, template_file)`` of a small valid test in ``tmp_path/in``."""
    d = tmp_path / "in"
    d.mkdir()
    f = d / "run1_d3.txt"
    write_d3(f)
    t = d / "T.yaml"
    t.write_text(TEMPLATE)
    return f, t
