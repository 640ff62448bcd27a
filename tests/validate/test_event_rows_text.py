"""The engine start/stop rows of a validation read "mean lag n/a" when no event matched;
they said "mean lag nan s" on the report page (0 test starts against 38 simulated)."""

from __future__ import annotations

from types import SimpleNamespace

from vehval.validate.compare import Comparison
from vehval.validate.metrics import match_events


def test_no_matched_event_gives_no_nan_text():
    none = match_events([], [10.0, 50.0])
    some = match_events([10.0], [10.5])
    fake = SimpleNamespace(on_agreement=0.42, starts=none, stops=some)
    rows = Comparison.event_rows(fake)
    assert rows[1][-1] == "0.0 % matched within ±2 s, mean lag n/a (none matched)"
    assert rows[2][-1] == "100.0 % matched within ±2 s, mean lag 0.50 s"
    assert not [c for r in rows for c in r if "nan" in str(c).lower()]
