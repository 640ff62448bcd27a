"""The real EPA Test Car Lists (2016, 2017, 2019): every file reads; values match the raw text.

Skips cleanly when the shared data directory is absent (env VEHVAL_SHARED_DATA, the shared
``data`` directory, or ``<repo>/../shared/data``; its ``real/`` folder holds the files).
"""

from __future__ import annotations

from pathlib import Path

import pytest

from helpers.data import REAL
from vehval.constants import LBF_N
from vehval.epa import apply_selector, plan_for, read_lists, read_test_car_list

pytestmark = pytest.mark.realdata

REPO = Path(__file__).resolve().parents[2]
EPA = REAL / "epa_test_car_list"

if not EPA.is_dir():
    pytest.skip(f"EPA Test Car List not found at {EPA}", allow_module_level=True)


def test_every_year_reads():
    n = {f.name: len(read_test_car_list(f)) for f in sorted(EPA.glob("*tstcar.csv"))}
    assert set(n) == {"16tstcar.csv", "17tstcar.csv", "19tstcar.csv"}
    assert all(v > 1000 for v in n.values())


def test_prius_2016_epa_tests():
    tests = apply_selector(read_lists([EPA]), "model=PRIUS,year=2016,originator=EPA")
    assert len(tests) == 6
    ftp = next(t for t in tests if t.test_number == "GTYX91002968")
    # raw text: 18.272 lbf, bags 50.7069485 / 126.2907815 / 62.7224963 / 114.3515914 mpg
    assert ftp.target_a_n == pytest.approx(18.272 * LBF_N, rel=1e-12)
    assert ftp.bags[1] == pytest.approx(126.2907815, rel=1e-12)
    assert all(plan_for(t)[0] is not None for t in tests)


def _bag_distance(cycle: str, windows) -> float:
    import numpy as np

    from vehval.cycles import load_cycle

    c = load_cycle(cycle)
    t = np.arange(0.0, c.time_s[-1] + 1.0)
    v = np.interp(t, c.time_s, c.speed_mps)
    return float(sum(v[(t >= a) & (t < (b if b is not None else np.inf))].sum()
                     for a, b in windows))


def test_bag_definitions_reproduce_the_listed_whole_test_result():
    """The bag windows and the FTP weighting are the lab's: recombining the listed bag
    figures by our bag distances gives the listed whole-test figure (rtol 0.5 %: the list
    rounds RND_ADJ_FE to 0.1 mpg and the lab uses its measured distances)."""
    from vehval.epa.procedures import FTP75, US06

    dc, dh = (_bag_distance("us06", b.windows) for b in US06.bags)
    d1, d2 = (_bag_distance("udds", b.windows) for b in FTP75.bags[:2])
    tests = apply_selector(read_lists([EPA]), "model=PRIUS,year=2016")
    n = 0
    for t in tests:
        b = t.bags
        if t.procedure_code == 90:
            assert (dc + dh) / (dc / b[0] + dh / b[1]) == pytest.approx(t.fe, rel=0.005)
            n += 1
        elif t.procedure_code == 21:
            cold = (d1 + d2) / (d1 / b[0] + d2 / b[1])
            hot = (d1 + d2) / (d1 / b[2] + d2 / b[3])
            assert 1 / (0.43 / cold + 0.57 / hot) == pytest.approx(t.fe, rel=0.005)
            n += 1
    assert n == 8  # 4 FTP-75 and 4 US06 tests of the 2016 Prius


def test_list_consistency_on_the_real_lists():
    """Every 2016 PRIUS test is consistent within 0.5 %; over the three lists, the checks find
    the placeholders (10000 mpg) and the rows whose bags contradict the whole-test figure."""
    from vehval.epa.consistency import check_listed_figures

    tests = read_lists([EPA])
    checks = {t.label: check_listed_figures(t) for t in tests}
    prius = apply_selector(tests, "model=PRIUS,year=2016")
    assert all(checks[t.label].ok for t in prius)
    assert all(abs(checks[t.label].rel_diff) < 0.005 for t in prius
               if checks[t.label].rel_diff is not None)
    bad = {k: c for k, c in checks.items() if not c.ok}
    assert 10 <= len(bad) <= 0.02 * len(tests)  # a few dozen rows of about 11000
    assert any("10000 mpg" in c.note for c in bad.values())
    assert any(c.rel_diff is not None and c.rel_diff > 0.4 for c in bad.values())


def test_prius_2016_against_its_epa_run_tests():
    """HWFET, US06 (whole and both parts) and FTP bags 2-3 of the EPA-run tests: all 12
    within 5 % (the controller is calibrated on the MFR tests only; the cold-start model on
    the four FTP-75s, each of them predicted within 4 % when held out: docs/validation.md);
    the prediction spread follows the measured one over all originators."""
    from vehval.epa.validation import validate_tests

    tests = apply_selector(read_lists([EPA]), "model=PRIUS,year=2016")
    val = validate_tests("prius_2016", tests)
    acc = [c for c in val.comparisons if c.originator == "EPA" and c.judged
           and (c.procedure, c.item) in {("hwfet", "overall"), ("us06", "overall"),
                                         ("us06", "bag 1"),
                                         ("us06", "bag 2"), ("ftp75", "bag 2"),
                                         ("ftp75", "bag 3")}]
    err = sorted(abs(c.error) for c in acc)
    assert len(err) == 12 and err[-1] <= 0.05
    assert sum(e <= 0.03 for e in err) >= 8  # the goal of 3 % for most
    # the cold start: bag 1, cold UDDS and composite
    cold = [c for c in val.comparisons if c.originator == "EPA" and c.cold_start]
    assert len(cold) == 6 and all(c.judged and abs(c.error) <= 0.05 for c in cold)
    # bag 2 is fed by the battery (J1711 balances the test, not each bag), the UDDS pairs
    # are near balanced; the lower road load of the EPA-run configuration stores more charge
    # in the loaded cold-start engine: a larger battery share in its bag 2
    pairs = [c for c in val.comparisons if c.originator == "EPA" and c.item.startswith("bags")]
    assert len(pairs) == 4 and all(abs(c.error) <= 0.03 for c in pairs)
    assert all(abs(c.battery_share) < 0.01 for c in pairs)
    bag2 = {c.originator: c.battery_share for c in val.comparisons
            if (c.procedure, c.item) == ("ftp75", "bag 2")}
    assert bag2["EPA"] > bag2["MFR"] > 0.05
    assert val.stats()["spread_correlation"]["pooled"] >= 0.95
    assert all(p.trace_n_miss == 0 and abs(p.energy_balance_rel) < 1e-9
               for p in val.predictions)
    # in-sample honesty: the six MFR tests (controller) and the four FTP-75s (cold start)
    # are calibration tests of the file; the headline counts the held-out figures only
    ins = {c.test for c in val.comparisons if c.in_sample}
    assert len(ins) == 8 and all(c.originator == "MFR" or c.procedure == "ftp75"
                                 for c in val.comparisons if c.in_sample)
    held, fit = val.stats(), val.stats(in_sample=True)
    assert held["n_judged"] == 8 and held["n_within_tolerance"] == 8
    assert fit["n_judged"] == 36 and held["n_judged_in_sample"] == 36


CAMRY = REAL / "d3_2018_toyota_camry_1hz_subset"


@pytest.mark.skipif(not CAMRY.is_dir(), reason="Camry D3 subset not found")
def test_camry_from_specs_all_splits(tmp_path):
    """2018 Camry (speed and fuel only, 1 Hz) from the 2019 list's CAMRY XLE/XSE row, fuel
    model calibrated on every two (and every three) of the four tests: docs/validation.md
    gives the tables. Acceptance of issue 27: every 2 + 2 split predicts both held-out tests
    within 5 % (measured: largest 3.9 %, US06 from FTP + HWFET); leave-one-out within 3.6 %."""
    from vehval.epa.specs import specs_from_tests
    from vehval.epa.specs_fit import all_splits, dyno_run
    from vehval.workflow import TestRun

    tmpl = tmp_path / "camry.yaml"
    tmpl.write_text("template_version: 1\nfuel: gasoline_e0\nfiles:\n- source: dyno\n"
                    "  format: d3\n  time: {column: Time}\n  channels:\n"
                    "    Eng_FuelFlow_Direct_DI: {name: fuel_rate_test, unit: ccps}\n"
                    "    Dyno_Spd: {name: veh_spd_test, unit: mph}\n", encoding="utf-8")
    runs = [dyno_run(TestRun.load([f], tmpl, use_qa=False).test)
            for f in sorted(CAMRY.glob("*Test Data.txt"))]
    assert [r.cold for r in runs] == [True, False, False, False]  # 61811011: FTP-75 type
    specs = specs_from_tests(apply_selector(read_lists([EPA / "19tstcar.csv"]),
                                            {"make": "TOYOTA", "model": "CAMRY XLE/XSE",
                                             "year": "2019"}))
    assert specs.gears == 8 and specs.n_v_ratio == pytest.approx(24.7)
    rows = all_splits(specs, runs, 2, dt=0.5)
    assert len(rows) == 6
    assert all(abs(e) < 0.02 for r in rows for e in r["calibration_errors"].values())
    assert max(r["max_abs_held_out"] for r in rows) < 0.05
    # the calibrated parameters stay physical: indicated efficiency, friction near Heywood's
    assert all(0.40 < r["indicated_efficiency"] < 0.52 and 0.6 <= r["friction_scale"] <= 1.2
               for r in rows)
    loo = all_splits(specs, runs, 3, dt=0.5)
    assert len(loo) == 4 and max(r["max_abs_held_out"] for r in loo) < 0.05


def test_every_test_number_kept_and_a_byte_order_mark_read(tmp_path):
    """Every distinct test number of the 2016 and 2019 lists is a test (the 2019 Pacifica
    HCRX10045415 repeats HCRX10045413's values and was dropped: 5 of its 6 rows); a test
    listed again is named; the list saved with a UTF-8 byte-order mark reads the same."""
    import csv

    for name in ("16tstcar.csv", "19tstcar.csv"):
        with (EPA / name).open(encoding="latin-1", newline="") as fh:
            rows = list(csv.reader(fh))
        numbers = {r[rows[0].index("Test Number")] for r in rows[1:]}
        tests = read_test_car_list(EPA / name)
        assert {t.test_number for t in tests} == numbers
        assert len(read_lists([EPA / name])) == len(tests) == len(numbers)
        assert sum(len(t.duplicate_rows) for t in tests) == len(rows) - 1 - len(numbers)
        derived = sum(r[rows[0].index("Analytically Derived FE?")] == "Yes" for r in rows[1:])
        assert 0 < sum(bool(t.analytically_derived) for t in tests) <= derived
    pacifica = apply_selector(read_lists([EPA]), "make=CHRYSLER,model=PACIFICA,year=2019,"
                                                 "vehicle=L7RUC2302")
    assert sorted(t.test_number for t in pacifica) == [f"HCRX1004541{k}" for k in (2, 3, 4, 5)]
    bom = tmp_path / "19tstcar.csv"
    bom.write_bytes(b"\xef\xbb\xbf" + (EPA / "19tstcar.csv").read_bytes().decode("latin-1")
                    .encode("utf-8"))
    assert [t.to_dict() | {"source": ""} for t in read_test_car_list(bom)] == \
        [t.to_dict() | {"source": ""} for t in read_test_car_list(EPA / "19tstcar.csv")]
