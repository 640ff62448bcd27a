"""Fixtures for the import tests: small synthetic raw files written in tmp_path."""

from __future__ import annotations

from pathlib import Path

import pytest
from iohelpers import D3_TEMPLATE, write_d3

from vehval.cli import main


@pytest.fixture
def d3_file(tmp_path) -> Path:
    return write_d3(tmp_path / "run_d3.txt")


@pytest.fixture
def d3_template(tmp_path) -> Path:
    p = tmp_path / "T.yaml"
    p.write_text(D3_TEMPLATE, encoding="utf-8")
    return p


@pytest.fixture
def cli(capsys):
    """Run ``vehval`` in-process; return (exit code, stdout, stderr)."""
    def run(*args: str):
        code = main([str(a) for a in args])
        out = capsys.readouterr()
        return code, out.out, out.err
    return run


