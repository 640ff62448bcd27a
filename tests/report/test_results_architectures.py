"""The results section names each architecture's own quantities: a battery-electric test
shows its SAE J1634 figures (no fuel columns, composites or SAE J1711 row), a conventional
car no battery column."""

from __future__ import annotations

from vehval.report.results_view import results_section


def _block(name: str | None, fuel: bool, battery: bool) -> dict:
    v = {"duration_s": 500.0, "distance_m": 5800.0, "mean_speed_mps": 11.6,
         "max_speed_mps": 25.4, "fuel_mass_kg": 0.34 if fuel else None,
         "fuel_economy_mpg": 33.7 if fuel else None,
         "fuel_consumption_l_per_100km": 6.98 if fuel else None, "co2_g_per_km": None,
         "ess_energy_net_j": 2.4e6 if battery else None}
    u = {"fuel_economy_mpg": {"U": 0.41}, "fuel_consumption_l_per_100km": {"U": 0.08}} if fuel else {}
    out = {"values": v, "uncertainty": u, "drive_quality": {"iwr_pct": 1.0, "rmsse_mph": 0.1}}
    return dict(out, name=name) if name else out


def _doc(fuel: bool, battery: bool, j1634: bool) -> dict:
    doc = {"test": {"id": "t", "cycle": "udds"}, "phases": [_block("bag1", fuel, battery)],
           "test_total": _block(None, fuel, battery),
           "composites": [dict(_block("udds", fuel, battery), rule="40 CFR 86.144", caveats=[])],
           "headline": {"name": "udds", "kind": "composite"},
           "soc_correction": {"status": "undetermined" if battery else "not_applicable",
                              "message": "battery net energy change +2400.0 kJ but no fuel energy"}}
    if j1634:
        scope = {"distance_m": 5800.0, "dc_energy_kwh": 0.66, "ac_energy_kwh": 0.75,
                 "ac_basis": "DC / charger efficiency 0.88", "ac_kwh_per_100mi": 20.73,
                 "ac_kwh_per_100km": 12.88, "mpge": 162.6, "U_rel_dc_energy": 0.01}
        doc["j1634"] = {"standard": "SAE J1634", "charger_efficiency": 0.88,
                        "scopes": {"bag1": scope, "test": scope}}
    return doc


def test_battery_electric_results_show_j1634_not_fuel():
    sec = results_section(_doc(fuel=False, battery=True, j1634=True))
    facts = dict(sec.facts)
    assert facts["Headline (SAE J1634)"] == "whole test: 162.6 ± 1.6 MPGe (20.73 ± 0.21 kWh/100 mi)"
    assert "Fuel" not in facts and "SOC correction (SAE J1711)" not in facts
    phases = sec.tables[0]
    assert not [c for c in phases.columns if "fuel" in c or "mpg]" in c or "L/100" in c
                or "CO2" in c]
    assert phases.columns[5:8] == ["MPGe", "AC energy [kWh/100 mi]", "battery net [kWh]"]
    assert phases.rows[0][5:8] == ["162.6 ± 1.6", "20.73 ± 0.21", 0.6667]
    assert phases.rows[-1][0] == "whole test" and phases.rows[-1][5] == "162.6 ± 1.6"
    assert "Regulatory composites" not in [t.title for t in sec.tables]


def test_conventional_results_have_no_battery_column():
    sec = results_section(_doc(fuel=True, battery=False, j1634=False))
    phases = sec.tables[0]
    assert "battery net [kWh]" not in phases.columns
    assert phases.columns[5:8] == ["fuel [g]", "fuel economy [mpg]", "consumption [L/100 km]"]
    assert phases.rows[0][6] == "33.70 ± 0.41"
    assert "Regulatory composites" in [t.title for t in sec.tables]
    # a hybrid keeps both
    hyb = results_section(_doc(fuel=True, battery=True, j1634=False)).tables[0]
    assert "battery net [kWh]" in hyb.columns and "fuel [g]" in hyb.columns


def test_workbook_results_are_numbers_with_their_u(tmp_path):
    """The Results sheet stores a page's "33.70 ± 0.41" as two numbers (value, U) under
    headers naming the unit, and "—" as an empty cell, not as text."""
    import openpyxl

    from vehval.report.excel import write_tables

    for fuel, battery, j1634, head, value, u in (
            (True, False, False, "fuel economy [mpg]", 33.7, 0.41),
            (False, True, True, "MPGe", 162.6, 1.6)):
        path = write_tables(tmp_path / f"t{int(fuel)}.xlsx", None,
                            results=_doc(fuel=fuel, battery=battery, j1634=j1634))
        ws = openpyxl.load_workbook(path, read_only=True)["Results"]
        rows = [r for r in ws.iter_rows(values_only=True)]
        at = next(i for i, r in enumerate(rows) if r[0] == "Results per phase")
        cols, bag1 = list(rows[at + 1]), rows[at + 2]
        j = cols.index(head)
        assert cols[j + 1] == f"U (k = 2) {head}"
        assert (bag1[j], bag1[j + 1]) == (value, u)
        assert not [v for v in bag1 if v in ("—", "") or (isinstance(v, str) and "±" in v)]
