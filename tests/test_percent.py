"""display.percent: a share never reads 0 % or 100 % when it is neither."""

from __future__ import annotations

import math

import pytest

from vehval.display import percent


@pytest.mark.parametrize("fraction, decimals, expected", [
    (0.1234, 1, "12.3 %"),            # 1-99 %: the decimals asked
    (0.1234, 0, "12 %"),
    (0.01, 1, "1.0 %"),
    (1.0, 1, "100.0 %"),
    (1.2, 0, "120 %"),
    (0.0, 1, "0.0 %"),                # exactly zero stays zero
    (-0.0, 0, "0 %"),
    (0.00014, 1, "0.014 %"),          # below 1 %: two significant digits
    (0.00014, 0, "0.014 %"),
    (0.005, 0, "0.50 %"),
    (0.0001, 1, "0.010 %"),
    (-0.00014, 1, "-0.014 %"),
    (0.99986, 1, "99.986 %"),         # just short of the whole: its distance to 100 %
    (0.996, 0, "99.60 %"),
    (7.14e-5, 1, "0.0071 %"),         # one sample in 14 000
    (2e-6, 1, "0.0002 %"),
    (1e-7, 1, "< 0.0001 %"),          # beyond four decimals: a bound
    (-1e-7, 1, "> -0.0001 %"),
    (0.9999999, 1, "> 99.9999 %"),
    (math.nan, 1, "n/a"),
    (None, 1, "n/a"),
])
def test_percent_hand_cases(fraction, decimals, expected):
    assert percent(fraction, decimals) == expected


@pytest.mark.parametrize("decimals", [0, 1, 2])
def test_no_non_zero_share_reads_zero_or_whole(decimals):
    for k in range(1, 200):
        x = 10.0 ** (-k / 20)                    # 0.89 down to 1e-10
        for share in (x, 1 - x):
            text = percent(share, decimals)
            number = text.split()[-2] if text[0] in "<>" else text.split()[0]
            assert float(number) not in (0.0, 100.0), (share, text)
