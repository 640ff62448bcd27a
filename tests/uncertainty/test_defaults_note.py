"""The note of a borrowed packaged precision names the cycle, or says none was found."""

from __future__ import annotations

from vehval.uncertainty.defaults import cycle_precision


def test_the_borrowed_precision_note_reads_without_a_cycle():
    assert cycle_precision("udds")[1] == ""
    assert cycle_precision("nedc")[1] == ("no packaged precision for the cycle 'nedc': the "
                                          "ftp75 figure is used")
    assert cycle_precision(None)[1] == ("no packaged precision for a test whose cycle was not "
                                        "identified: the ftp75 figure is used")
