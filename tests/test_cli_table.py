"""80-column terminal output (reported: `cycles list` wrapped one word per line, `catalog
summary` truncated names)."""

from __future__ import annotations

from vehval.cli import main
from vehval.cli.table import render


def test_cycles_list_fits_80_columns(capsys, monkeypatch):
    monkeypatch.setenv("COLUMNS", "80")
    assert main(["cycles", "list"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert max(len(ln) for ln in lines) <= 80
    rows = [ln for ln in lines[3:] if ln.strip()]
    assert len(rows) >= 10 and all(len(ln.split()) >= 6 for ln in rows)   # one row per cycle
    assert any(ln.startswith("udds ") for ln in rows)


def test_catalog_summary_layout_keeps_names_whole():
    cols = ["vehicle", "cycle", "metric", "n", "mean", "std", "cv [%]", "min", "max"]
    rows = [["prius_2004_perturbed", "udds", m, "5", "1234.6", "12.35", "1.00",
             "1200.1", "1251"] for m in ("fuel_economy_mpg", "fuel_consumption_l_per_100km",
                                                "engine_on_fraction")]
    text = render(cols, rows, width=80, group_by=("vehicle", "cycle"))
    lines = text.splitlines()
    assert max(len(ln) for ln in lines) <= 80, text
    assert "prius_2004_perturbed / udds" in lines
    assert any("fuel_consumption_l_per_100km" in ln for ln in lines)   # not truncated
    assert "…" not in text


def test_narrow_table_is_left_as_is():
    text = render(["a", "b"], [["x", "1"]], width=80)
    assert text.splitlines() == ["a  b", "----", "x  1"]
