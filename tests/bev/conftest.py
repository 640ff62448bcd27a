"""Fixtures of the battery-electric tests."""

from __future__ import annotations

import pytest
import yaml

from helpers.bev import bev_data


@pytest.fixture()
def bev_file(tmp_path):
    path = tmp_path / "test_bev.yaml"
    path.write_text(yaml.safe_dump(bev_data(), sort_keys=False), encoding="utf-8")
    return path
