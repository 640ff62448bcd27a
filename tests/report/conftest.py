"""Fixtures of the report tests: a small multi-source Test and a QA dict shaped like findings.json."""

from __future__ import annotations

import pytest

from vehval.test import Test

from .helpers import make_qa, make_test


@pytest.fixture
def small_test() -> Test:
    return make_test()


@pytest.fixture
def qa_dict() -> dict:
    return make_qa()
