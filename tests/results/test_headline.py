"""The one headline (vehval.results.headline): figure with U, rule, every caveat (start
condition, cell, SAE J1711, substitutes), the model's verdict, the user's unit system; and the
two caveats that were wrong (a hot-start UDDS read as the FTP-72; the bag 2 stand-in for bag 3
said to overstate whatever the data)."""

import numpy as np
import pytest

from vehval.results import compute_results
from vehval.results.headline import headline_of

from .helpers import make_test, true_signals

EXPLICIT = {"density_kg_per_m3": 800.0, "lhv_j_per_kg": 42e6, "carbon_mass_fraction": 0.86}


def _with_temps(coolant_c: float, cell_c: float = 23.0):
    from vehval.test import Signal

    t, s = true_signals()
    test = make_test(t, s)
    test.add(Signal.standard("amb_temp_test", t, np.full(t.size, cell_c), source="dyno"))
    test.add(Signal.standard("eng_temp_coolant_test", t, np.full(t.size, coolant_c),
                             source="dyno"))
    return test


def test_a_hot_start_udds_is_not_the_ftp72_and_says_why():
    res = compute_results(_with_temps(91.0), fuel=EXPLICIT)
    assert res.conditions["start"] == "hot"
    doc = res.to_dict()
    h = headline_of(doc, system_name="us")
    assert h is not None and h.scope == "udds"
    assert any(c.startswith("hot start (coolant 91") and "86.132" in c for c in h.caveats), h.caveats
    assert "hot-start run" in h.rule and "(FTP-72) result over bags 1+2" not in h.rule
    lines = h.lines()
    assert any("! caveat: hot start" in ln for ln in lines), lines
    # a cold start keeps the FTP-72 rule and no start caveat
    cold = headline_of(compute_results(_with_temps(24.0), fuel=EXPLICIT).to_dict())
    assert cold is not None and "FTP-72" in cold.rule
    assert not any("hot start" in c for c in cold.caveats)


def test_the_bag2_stand_in_never_claims_a_direction_the_data_does_not_give():
    res = compute_results(_with_temps(24.0), fuel=EXPLICIT)
    ftp = next(c for c in res.composites if c.name == "ftp75_from_udds")
    assert "overstates" not in ftp.substitute and "--hot-start" in ftp.substitute


@pytest.mark.parametrize("hot_fuel, word", [(0.30, "overstates"), (0.15, "understates")])
def test_with_a_hot_bag1_the_stand_in_direction_comes_from_the_data(hot_fuel, word):
    t, s = true_signals()
    hot = {"fuel_mass_kg": hot_fuel, "distance_m": 5800.0}
    res = compute_results(make_test(t, s, constants={}), fuel=EXPLICIT, hot_start_bag1=hot)
    v = res.values
    fb2, db2 = v["bag2"]["fuel_mass_kg"], v["bag2"]["distance_m"]
    f12 = (v["bag1"]["fuel_mass_kg"] + fb2) / (v["bag1"]["distance_m"] + db2)
    stand_in = 0.43 * f12 + 0.57 * fb2 / db2
    measured = v["ftp75_from_udds"]["fuel_per_distance_kg_per_m"]
    note = next(n for n in res.notes if n.startswith("FTP-75: bag 2 standing for bag 3"))
    assert word in note and f"by {100 * abs(measured / stand_in - 1):.1f} %" in note, note
    mpg = v["ftp75_from_udds"]["fuel_economy_mpg"]
    assert f"against {mpg:.2f} mpg)" in note, note
    # the direction follows the hot bag against bag 2 per distance
    assert (hot_fuel / 5800.0 > fb2 / db2) == (word == "overstates")


def _doc(**over):
    doc = {"headline": {"name": "udds", "kind": "composite", "rule": "40 CFR 86.144: UDDS",
                        "fuel_economy_mpg": 62.2, "fuel_economy_u_mpg": 0.8,
                        "fuel_consumption_l_per_100km": 3.78, "withheld": None, "forced": False,
                        "caveats": []},
           "composites": [{"name": "udds", "uncertainty": {
               "fuel_consumption_l_per_100km": {"U": 0.05}}}],
           "soc_correction": {"status": "not_applicable"}, "withheld_count": 0}
    doc.update(over)
    return doc


def test_j1711_status_metric_order_and_model_verdict():
    soc = {"status": "beyond_tolerance_uncorrected",
           "message": "battery net energy change +2.03 % of the fuel energy, beyond ..."}
    h = headline_of(_doc(soc_correction=soc), system_name="metric",
                    model={"verdict": "consistent", "en": 0.42, "error_pct": 1.3})
    assert h is not None and h.j1711 == "beyond_tolerance_uncorrected"
    assert any("SAE J1711 beyond tolerance uncorrected" in c and "+2.03 %" in c
               for c in h.caveats)
    assert h.figure().startswith("3.78 ± 0.05 L/100 km (62.20 ± 0.80 mpg)")
    assert headline_of(_doc(), system_name="us").figure().startswith("62.20 ± 0.80 mpg")
    assert "En = +0.42" in (h.verdict_text() or "")
    d = h.to_dict()
    assert d["figure"] == h.figure() and d["caveats"] == h.caveats and "En" in d["verdict"]
    assert any("Caveat: SAE J1711" in ln for ln in d["banner"]["lines"])
    within = headline_of(_doc(soc_correction={"status": "within_tolerance", "message": "x"}))
    assert within is not None and within.j1711 == "within_tolerance" and not within.caveats


def test_withheld_and_forced_headlines():
    held = {"signals": ["fuel_rate_test"], "reason": "QA error", "fix": "check it"}
    doc = _doc(withheld_count=2)
    doc["headline"].update(fuel_economy_mpg=None, withheld=held)
    h = headline_of(doc)
    assert h is not None and h.kind == "withheld"
    assert h.lines()[0].startswith("headline udds: WITHHELD (fuel_rate_test)")
    assert h.banner()["kind"] == "withheld"
    doc["headline"].update(fuel_economy_mpg=60.0, forced=True)
    h = headline_of(doc)
    assert h is not None and h.kind == "forced" and h.lines()[0].startswith("STATED DESPITE")


def _bev_doc(u_rel=0.01):
    """A battery-electric results document: no fuel economy, SAE J1634 figures per scope."""
    doc = _doc(soc_correction={"status": "undetermined", "message": "no fuel energy"})
    doc["headline"].update(fuel_economy_mpg=None, fuel_economy_u_mpg=None,
                           fuel_consumption_l_per_100km=None)
    scope = {"mpge": 183.3, "ac_kwh_per_100mi": 18.39, "ac_kwh_per_100km": 11.43,
             "ac_basis": "DC / charger efficiency 0.88"}
    if u_rel is not None:
        scope["U_rel_dc_energy"] = u_rel
    doc["j1634"] = {"standard": "SAE J1634", "charger_efficiency": 0.88,
                    "scopes": {"bag1": dict(scope, mpge=160.0), "test": scope}}
    return doc


def test_a_battery_electric_headline_is_in_j1634_terms():
    """MPGe and kWh per distance with U in the user's system, the J1634 rule, no fuel
    economy and no SAE J1711 caveat (a fuel-energy ratio a BEV has not)."""
    h = headline_of(_bev_doc(), system_name="us",
                    model={"verdict": "consistent", "en": 0.2, "error_pct": 0.4,
                           "quantity": "DC energy"})
    assert h is not None and h.kind == "headline" and h.scope == "test"
    assert h.figure() == "183.3 ± 1.8 MPGe (18.39 ± 0.18 kWh/100 mi)"
    assert "SAE J1634" in h.rule and "0.88" in h.rule
    assert h.j1711 is None and not any("J1711" in c for c in h.caveats)
    assert h.lines()[0] == "headline test: 183.3 +- 1.8 MPGe (18.39 +- 0.18 kWh/100 mi)"
    assert "DC energy +0.4 % against the test" in (h.verdict_text() or "")
    assert h.to_dict()["electric"]["u_mpge"] == pytest.approx(1.833)
    metric = headline_of(_bev_doc(), system_name="metric")
    assert metric is not None
    assert metric.figure() == "11.43 ± 0.11 kWh/100 km (183.3 ± 1.8 MPGe)"
    no_u = headline_of(_bev_doc(u_rel=None), system_name="us")
    assert no_u is not None and no_u.figure() == "183.3 MPGe (18.39 kWh/100 mi)"
    # a car burning fuel keeps its fuel economy even beside J1634 figures
    both = _bev_doc()
    both["headline"]["fuel_economy_mpg"] = 50.0
    assert headline_of(both, system_name="us").figure().startswith("50.00")


def _idle(seconds: float = 9.8, creep_mps: float = 0.0005):
    """An idle record: standing, the speed sensor's offset only, the engine idling."""
    t = np.arange(0.0, seconds, 0.1)
    sig = {"veh_spd": np.full(t.size, creep_mps), "fuel_rate": np.full(t.size, 0.12e-3),
           "test_phase": np.ones(t.size)}
    return compute_results(make_test(t, sig, cycle="", phase=False), fuel=EXPLICIT)


def test_an_idle_record_has_no_fuel_economy_headline():
    """A 9.8 s idle record computes a fuel economy of a few millimetres driven: no headline,
    the reason stated; the whole test keeps its figure under its own name."""
    from vehval.results.gate import headline
    from vehval.results.headline import NOT_A_HEADLINE

    res = _idle()
    assert 0 < res.value("test", "distance_m") < 0.01
    assert res.value("test", "fuel_economy_mpg") is not None       # the scope keeps it
    h = headline(res)
    assert h["fuel_economy_mpg"] is None and h["fuel_economy_u_mpg"] is None
    assert h["withheld"]["rule"] == NOT_A_HEADLINE and not h["forced"]
    assert h["withheld"]["reason"].startswith("distance 0.0 m: no fuel-economy headline")
    doc = res.to_dict()
    assert doc["headline"]["withheld"]["reason"] == h["withheld"]["reason"]
    assert doc["withheld_count"] == 0                 # no QA error: no figure withheld
    hl = headline_of(doc)
    assert hl is not None and hl.kind == "withheld"
    assert hl.lines()[0] == f"headline test: {h['withheld']['reason']}"
    assert "--force" not in " ".join(hl.lines()) and hl.banner()["title"].endswith("none")


def test_a_headline_whose_u_exceeds_its_value_is_no_headline():
    from vehval.results.headline import MIN_HEADLINE_DISTANCE_M, not_a_headline

    w = not_a_headline(0.0067, 0.607, 2 * MIN_HEADLINE_DISTANCE_M)
    assert w is not None and w["reason"].startswith("U 0.607 mpg exceeds the value 0.0067 mpg")
    assert not_a_headline(0.0067, 0.607, None) is not None        # a composite: U alone
    assert not_a_headline(24.6, 0.3, 12000.0) is None
    assert not_a_headline(None, None, 0.0) is None                 # nothing stated
    # a cycle's own headline is untouched
    t, s = true_signals()
    from vehval.results.gate import headline
    assert headline(compute_results(make_test(t, s), fuel=EXPLICIT))["withheld"] is None
