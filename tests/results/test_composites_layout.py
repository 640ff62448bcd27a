"""FTP composites from any layout (one record with the hot soak, a substitute bag 3) and the
caveats a composite carries when the test conditions are not the procedure's."""

from pathlib import Path

import numpy as np
import pytest

from helpers.data import CRUZE, REAL
from vehval.results import compute_results
from vehval.results.composites import SOAK_S

from .helpers import make_test, true_signals

EXPLICIT = {"density_kg_per_m3": 800.0, "lhv_j_per_kg": 42e6, "carbon_mass_fraction": 0.86}
HERE = Path(__file__).resolve().parent
CAMRY = REAL / "d3_2018_toyota_camry_1hz_subset"


def _two_runs(pause_s: float, *, cold_extra: float = 0.3e-3, with_temps: bool = False,
              cell_c: float = 23.0):
    """Cold UDDS, a pause standing with the engine off, hot UDDS, on one 1 Hz record.

    The cold run burns ``cold_extra`` [kg/s] more in its first 200 s (warm-up).
    """
    t1, s = true_signals(dt=1.0)
    v, f = s["veh_spd"], s["fuel_rate"].copy()
    cold = f.copy()
    cold[t1 < 200.0] += cold_extra
    gap = np.arange(1.0, pause_s, 1.0)
    t = np.concatenate([t1, t1[-1] + gap, t1[-1] + pause_s + t1])
    vel = np.concatenate([v, np.zeros(gap.size), v])
    fuel = np.concatenate([cold, np.zeros(gap.size), f])
    test = make_test(t, {"veh_spd": vel, "fuel_rate": fuel, "test_phase": np.zeros_like(t)},
                     phase=False)
    test.meta.cycle = "udds_x2"
    if with_temps:
        from vehval.test import Signal
        test.add(Signal.standard("amb_temp_test", t, np.full(t.size, cell_c), source="dyno"))
        test.add(Signal.standard("eng_temp_coolant_test", t,
                                 np.where(t < 60.0, cell_c + 1.0, 90.0), source="dyno"))
    return test, t, vel, fuel


def _fpd(t, v, f, segs):
    d = sum(np.trapezoid(v[(t >= a) & (t <= b)], t[(t >= a) & (t <= b)]) for a, b in segs)
    m = sum(np.trapezoid(f[(t >= a) & (t <= b)], t[(t >= a) & (t <= b)]) for a, b in segs)
    return m / d


def test_cold_and_hot_udds_in_one_record_give_the_ftp75_from_its_own_bags():
    test, t, v, f = _two_runs(SOAK_S[0])
    res = compute_results(test, fuel=EXPLICIT)
    names = {c.name: c for c in res.composites}
    assert {"udds", "udds_hot", "ftp75", "ftp75_4bag"} <= set(names)
    assert "ftp75_from_udds" not in names
    seg = {p.name: p.segments for p in res.phases}
    b1, b2, b3, b4 = (seg["run 1 bag1"], seg["run 1 bag2"], seg["run 2 bag1"], seg["run 2 bag2"])
    hand = 0.43 * _fpd(t, v, f, b1 + b2) + 0.57 * _fpd(t, v, f, b3 + b2)
    # rtol 2e-3: the hand integral cuts at sample times, vehval at the exact bag bounds
    assert res.value("ftp75", "fuel_per_distance_kg_per_m") == pytest.approx(hand, rel=2e-3)
    four = 0.43 * _fpd(t, v, f, b1 + b2) + 0.57 * _fpd(t, v, f, b3 + b4)
    assert res.value("ftp75_4bag", "fuel_per_distance_kg_per_m") == pytest.approx(four, rel=2e-3)
    # the UDDS figure is the cold run (FTP-72), not the hot one
    assert names["udds"].groups == [(1.0, ["run 1 bag1", "run 1 bag2"])]
    assert res.value("udds", "fuel_economy_mpg") < res.value("udds_hot", "fuel_economy_mpg")
    # no temperatures: the cold start is assumed from the layout, said as a caveat
    assert any("40 CFR 86.132" in c and "layout" in c for c in names["ftp75"].caveats)
    assert "hot soak" in names["ftp75"].rule


def test_the_headline_of_a_cold_soak_hot_record_is_the_ftp75_with_its_caveats():
    from vehval.report.results_view import results_section
    from vehval.report.sections import headline_banner

    test, *_ = _two_runs(SOAK_S[0])
    res = compute_results(test, fuel=EXPLICIT)
    h = res.headline()
    assert h["name"] == "ftp75" and h["kind"] == "composite"
    assert h["fuel_economy_mpg"] == res.value("ftp75", "fuel_economy_mpg")
    assert h["caveats"] and any("40 CFR 86.132" in c for c in h["caveats"])
    doc = res.to_dict()
    banner = headline_banner(doc)
    assert banner["title"].startswith("ftp75:")
    assert any(line.startswith("Caveat: ") and "86.132" in line for line in banner["lines"])
    table = next(t for t in results_section(doc).tables if t.key == "results-composites")
    col = table.columns.index("caveats")
    rows = {r[0]: r for r in table.rows}
    assert "86.132" in rows["ftp75"][col]


def test_a_short_pause_is_not_the_hot_soak_and_gives_no_ftp75():
    test, *_ = _two_runs(120.0)
    res = compute_results(test, fuel=EXPLICIT)
    names = [c.name for c in res.composites]
    assert "ftp75" not in names and "ftp75_4bag" not in names
    assert any("not the 40 CFR 86.137" in n and "2.0 min pause" in n for n in res.notes)
    ftp = next(c for c in res.composites if c.name == "ftp75_from_udds")
    assert any(c.startswith("substitute:") for c in ftp.caveats)


def test_a_record_that_starts_hot_gives_no_ftp75():
    test, *_ = _two_runs(SOAK_S[0], with_temps=True)
    test.signals["eng_temp_coolant_test"].values[:] = 90.0
    res = compute_results(test, fuel=EXPLICIT)
    assert "ftp75" not in [c.name for c in res.composites]
    assert any("starts hot" in n for n in res.notes)


def test_measured_cold_start_in_the_cell_range_leaves_the_ftp75_unqualified():
    test, *_ = _two_runs(SOAK_S[0], with_temps=True)
    res = compute_results(test, fuel=EXPLICIT)
    assert res.conditions["start"] == "cold"
    ftp = next(c for c in res.composites if c.name == "ftp75")
    assert ftp.caveats == []


@pytest.mark.parametrize("cell, word", [(-6.7, "cold-temperature"), (35.0, "hot-cell")])
def test_cold_and_hot_cell_tests_give_no_unqualified_ftp_figure(cell, word):
    test, *_ = _two_runs(SOAK_S[0], with_temps=True, cell_c=cell)
    res = compute_results(test, fuel=EXPLICIT)
    for c in res.composites:
        assert any("40 CFR 86.130" in cav and word in cav for cav in c.caveats), c.name
    # one run only: the bag-3 substitute composite is caveated too
    t, s = true_signals()
    one = make_test(t, s)
    from vehval.test import Signal
    one.add(Signal.standard("amb_temp_test", t, np.full(t.size, cell), source="dyno"))
    one.add(Signal.standard("eng_temp_coolant_test", t, np.full(t.size, cell + 1.0),
                            source="dyno"))
    res = compute_results(one, fuel=EXPLICIT)
    ftp = next(c for c in res.composites if c.name == "ftp75_from_udds")
    assert any(word in cav for cav in ftp.caveats) and any("substitute" in c for c in ftp.caveats)


def test_unknown_start_caveats_the_substitute_ftp():
    t, s = true_signals()
    res = compute_results(make_test(t, s), fuel=EXPLICIT)
    ftp = next(c for c in res.composites if c.name == "ftp75_from_udds")
    assert any("start temperature not measured" in c and "86.132" in c for c in ftp.caveats)
    assert ftp.to_dict()["caveats"] == ftp.caveats


def test_cli_prints_the_caveats(tmp_path, cli):
    from .helpers import cli_files
    raw, tpl = cli_files(tmp_path)
    code, out, err = cli("results", raw, "-t", tpl, "-o", tmp_path / "o")
    assert code == 0, err
    assert "! substitute: no hot-start run given" in out
    assert "! start temperature not measured" in out


@pytest.mark.realdata
@pytest.mark.skipif(not CAMRY.is_dir(), reason="real data not available")
def test_camry_61811011_ftp75_from_its_own_bags(tmp_path, cli):
    """Cold UDDS, soak, hot UDDS in one file: the FTP-75 within 0.1 % of a hand computation."""
    import json

    import yaml
    f = CAMRY / "61811011 Test Data.txt"
    tpl = tmp_path / "camry.yaml"
    tpl.write_text(yaml.safe_dump({"template_version": 1, "fuel": "gasoline_e10", "files": [{
        "source": "dyno", "format": "d3", "time": {"column": "Time"}, "channels": {
            "Eng_FuelFlow_Direct_DI": {"name": "fuel_rate_test", "unit": "ccps"},
            "Dyno_Spd": {"name": "veh_spd_test", "unit": "mph"}}}]}))
    code, out, err = cli("results", f, "-t", tpl, "-o", tmp_path / "o")
    assert code == 0, err
    doc = json.loads((tmp_path / "o" / "results.json").read_text())
    comp = {c["name"]: c for c in doc["composites"]}
    assert "ftp75_from_udds" not in comp and "no hot-start run given" not in out
    seg = {p["name"]: p["segments_s"] for p in doc["phases"]}
    raw = np.genfromtxt(f, delimiter=",", skip_header=1)
    t, cc, mph = raw[:, 0], raw[:, 1], raw[:, 2]

    def half(bags):   # miles per gallon of a group of bags, by hand from the file's columns
        miles = gal = 0.0
        for name in bags:
            (a, b), = seg[name]
            m = (t >= round(a)) & (t <= round(b))    # 1 Hz record: bounds to whole seconds
            miles += np.trapezoid(mph[m], t[m]) / 3600.0
            gal += np.trapezoid(cc[m], t[m]) / 3785.411784
        return miles / gal

    hand = 1.0 / (0.43 / half(["run 1 bag1", "run 1 bag2"]) + 0.57 / half(["run 2 bag1", "run 1 bag2"]))
    ours = comp["ftp75"]["values"]["fuel_economy_mpg"]
    print(f"\nCamry 61811011 FTP-75 {ours:.3f} mpg, by hand {hand:.3f} mpg "
          f"({100 * (ours / hand - 1):+.3f} %); UDDS (cold) "
          f"{comp['udds']['values']['fuel_economy_mpg']:.2f}, hot "
          f"{comp['udds_hot']['values']['fuel_economy_mpg']:.2f}")
    assert ours == pytest.approx(hand, rel=1e-3)
    assert comp["udds"]["groups"][0]["phases"] == ["run 1 bag1", "run 1 bag2"]
    assert "= ftp75" in out and "hot soak 10.1 min pause" in comp["ftp75"]["rule"]


CRUZE_TEMPLATE = HERE.parents[0] / "qa" / "templates" / "cruze.yaml"


@pytest.mark.realdata
@pytest.mark.skipif(not CRUZE.is_dir(), reason="real data not available")
@pytest.mark.parametrize("tid, word", [("61410028", "cold-temperature"), ("61410021", "hot-cell")])
def test_cruze_cold_and_ac_tests_give_no_unqualified_ftp_figure(tid, word, tmp_path, cli):
    import json
    code, out, err = cli("results", CRUZE / f"{tid} Test Data.txt", "-t", CRUZE_TEMPLATE,
                         "-o", tmp_path / "o")
    assert code == 0, err
    doc = json.loads((tmp_path / "o" / "results.json").read_text())
    assert doc["composites"]
    for c in doc["composites"]:
        assert any("40 CFR 86.130" in cav and word in cav for cav in c["caveats"]), c["name"]
    assert out.count("! cell") == len(doc["composites"])       # said on screen, each one
