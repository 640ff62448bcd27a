"""Hand-constructed Prius-like tests for the QA library (no simulator needed).

The drive is a sequence of smooth accelerations, cruises and decelerations; every other
signal follows from the powertrain equations with the Table-1 parameters, so the clean
test satisfies them exactly (up to the stated sensor noise).
"""

from __future__ import annotations

import pytest

from vehval.test import Test

from .helpers import make_test


@pytest.fixture
def clean_test() -> Test:
    return make_test(seed=1)
