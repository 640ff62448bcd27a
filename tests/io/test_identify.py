"""Drive-cycle identification from the measured speed, and how import/CLI report it.

Traces are built from the package cycles (exact by construction), then disturbed the way a
dyno file is: pre-test padding, a start offset, 10 Hz sampling, driver/sensor noise, repeats
with pauses, a soak, logging gaps. Tolerances are stated where figures are compared.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from iohelpers import write_d3

from vehval.cycles import list_cycles, load_cycle, steady_cycle
from vehval.cycles_match import describe, identify_cycle
from vehval.errors import ConfigError, VehvalError
from vehval.io.importer import import_test, set_cycle
from vehval.io.parquet import read_test
from vehval.io.template import Template, load_template

MPH = 0.44704


def _dyno(speed_1hz: np.ndarray, *, start_s: float = 0.0, pad_s: float = 10.0, rate: float = 10.0,
          noise: float = 0.0, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """A dyno record of a 1 Hz speed trace: ``pad_s`` of idle before t = 0, the trace started
    at ``start_s``, sampled at ``rate`` with Gaussian noise ``noise`` [m/s]."""
    t = np.arange(-pad_s, start_s + speed_1hz.size + 2.0, 1.0 / rate)
    v = np.interp(t - start_s, np.arange(speed_1hz.size, dtype=float), speed_1hz, left=0.0, right=0.0)
    v = v + np.random.default_rng(seed).normal(0.0, noise, t.size)
    return t, v


def _v(name: str) -> np.ndarray:
    c = load_cycle(name)
    return np.interp(np.arange(int(c.duration_s) + 1.0), c.time_s, c.speed_mps)


@pytest.mark.parametrize("name", list_cycles())
def test_every_package_cycle_identifies_itself(name):
    """An exact trace gives its own name, offset 0 and RMS ~0 (1e-6 m/s: float round-off)."""
    c = load_cycle(name)
    got, score, d = identify_cycle(c.time_s, c.speed_mps)
    assert got == name, d
    assert d["rms_mps"] < 1e-6 and d["offset_s"] == 0.0 and score == pytest.approx(1.0, abs=1e-3)


def test_padding_offset_noise_at_10hz():
    """-10 s padding, cycle started 3.4 s late, 0.25 m/s noise: found with the offset within
    0.15 s (1 s bins + sub-second search) and an RMS near the noise averaged over 10 samples
    (0.25/sqrt(10) = 0.08 m/s; 0.15 allows for the bin/ramp smoothing)."""
    t, v = _dyno(_v("udds"), start_s=3.4, noise=0.25, seed=1)
    name, score, d = identify_cycle(t, v)
    assert name == "udds"
    assert d["offset_s"] == pytest.approx(3.4, abs=0.15)
    assert d["rms_mps"] < 0.15 and d["coverage"] == 1.0 and d["explained"] == 1.0
    assert 0.8 < score <= 1.0
    assert describe(name, d).startswith("cycle identified as udds (rms 0.")


def test_repeats_with_pause_and_soak():
    hw = _v("hwfet")
    t, v = _dyno(np.r_[hw, np.zeros(15), hw])
    name, _, d = identify_cycle(t, v)
    assert name == "hwfet_x2" and d["cycle"] == "hwfet" and d["repeats"] == 2
    assert d["offsets_s"] == pytest.approx([0.0, hw.size + 15.0], abs=0.1)
    assert "hwfet x2" in describe(name, d)
    ud = _v("udds")  # FTP-type: UDDS, 10 min soak, UDDS
    name, _, d = identify_cycle(*_dyno(np.r_[ud, np.zeros(600), ud]))
    assert name == "udds_x2"


def test_ftp75_split_by_its_hot_soak():
    """Bags 1-2, a 10 min soak, bag 3: the FTP-75, not one UDDS (which explains ~70 %)."""
    f = _v("ftp75")
    trace = np.r_[f[:1370], np.zeros(600), f[1370:]]
    name, _, d = identify_cycle(*_dyno(trace, noise=0.2, seed=2))
    assert name == "ftp75" and d["split_by_soak"] is True
    assert "split by a soak" in describe(name, d)


def test_nedc_is_not_four_ece15():
    name, _, d = identify_cycle(*_dyno(_v("nedc"), noise=0.2))
    assert name == "nedc"
    ece = next(c for c in d["candidates"] if c["cycle"] == "ece15")
    assert ece["repeats"] == 4 and ece["explained"] < 0.9  # found, but explains too little


def test_steady_speed_runs():
    s = steady_cycle(60 / 3.6, 300.0)
    name, score, d = identify_cycle(s.time_s, s.speed_mps + np.random.default_rng(3).normal(0, 0.1, s.time_s.size))
    assert name == "steady_60kph" and d["method"] == "steady" and score > 0.85
    assert len(d["plateaus"]) == 1 and d["plateaus"][0][2] == pytest.approx(60 / 3.6, abs=0.1)
    # a 0-80-0 km/h sweep in 20 km/h steps held 2 min each, 15 s ramps
    steps = np.repeat(np.array([20, 40, 60, 80, 60, 40, 20]) / 3.6, 120)
    sweep = np.convolve(np.r_[np.zeros(20), steps, np.zeros(20)], np.ones(15) / 15, "same")
    name, _, d = identify_cycle(np.arange(sweep.size, dtype=float), sweep)
    assert name == "steady" and len(d["plateaus"]) == 7


@pytest.mark.parametrize("case", ["partial", "extra_driving", "too_fast", "gap", "idle", "short", "wot"])
def test_no_match(case):
    ud = _v("udds")
    rng = np.random.default_rng(4)
    if case == "partial":          # 60 % of the UDDS: coverage below 90 %
        trace = ud[:820]
    elif case == "extra_driving":  # a UDDS then 20 min of other driving: explains < 90 %
        other = np.abs(np.cumsum(rng.normal(0, 0.6, 1200)))
        trace = np.r_[ud, np.zeros(30), np.clip(other, 0, 30)]
    elif case == "too_fast":       # driven 12 % too fast: RMS error above 1 m/s
        trace = ud * 1.12
    elif case == "gap":            # 200 s logging gap: the data covers < 90 % of the cycle
        t, v = _dyno(ud)
        keep = (t < 400) | (t > 600)
        name, _, d = identify_cycle(t[keep], v[keep])
        assert name is None and "udds" not in [c["cycle"] for c in d["candidates"]]
        return
    elif case == "idle":
        trace = np.zeros(1500)
    elif case == "short":
        name, _, d = identify_cycle([0.0, 1.0, 2.0], [0.0, 1.0, 2.0])
        assert name is None and "10 s" in d["reason"]
        return
    else:                          # wide-open-throttle runs: 0 -> 35 m/s, brake, three times
        run = np.r_[np.zeros(20), np.minimum(np.arange(60) * 1.2, 35.0), np.linspace(35, 0, 15)]
        trace = np.tile(run, 3)
    name, score, d = identify_cycle(*_dyno(trace))
    assert name is None and score == 0.0 and d["reason"]
    assert describe(name, d).startswith("cycle not identified: ")


def test_rms_threshold_is_a_parameter():
    t, v = _dyno(_v("us06") * 1.03)  # 3 % fast: RMS ~0.6 m/s (3 % of a 20 m/s RMS speed)
    assert identify_cycle(t, v)[0] == "us06"
    assert identify_cycle(t, v, max_rms_mps=0.3)[0] is None
    assert identify_cycle(t, v, cycles=["udds", "hwfet"])[0] is None


def test_bad_input():
    with pytest.raises(VehvalError, match="same length"):
        identify_cycle([0.0, 1.0], [0.0])
    t, v = _dyno(_v("sc03"))
    v[::7] = np.nan  # NaN samples are ignored
    assert identify_cycle(t, v)[0] == "sc03"


# ------------------------------------------------------------------ template and importer
def _d3(path, name: str, *, start_s: float = 0.0):
    t, v = _dyno(_v(name), start_s=start_s)
    rows = [[round(float(a), 3), round(float(b) / MPH, 3), 1500.0, 77.0, 1.0] for a, b in zip(t, v)]
    return write_d3(path, rows)


def test_importer_identifies_and_notes(tmp_path, d3_template):
    f = _d3(tmp_path / "r_d3.txt", "hwfet", start_s=1.0)
    test = import_test([f], d3_template)
    assert test.meta.cycle == "hwfet" and test.meta.synthetic is False
    note = next(n for n in test.meta.notes if n.startswith("cycle "))
    assert note.startswith("cycle identified as hwfet (rms 0.0") and "offset 1.0 s" in note
    assert note.endswith("from veh_spd_test")
    assert import_test([f], d3_template, identify=False).meta.cycle == ""


def test_template_cycle_and_synthetic_keys(tmp_path, d3_template):
    f = _d3(tmp_path / "r_d3.txt", "hwfet")
    text = d3_template.read_text(encoding="utf-8")
    p = tmp_path / "T2.yaml"
    p.write_text("cycle: us06\nsynthetic: true\n" + text, encoding="utf-8")
    t = load_template(p)
    assert t.cycle == "us06" and t.synthetic is True
    test = import_test([f], t)  # the template wins over identification (it says us06)
    assert test.meta.cycle == "us06" and test.meta.synthetic is True
    assert "cycle from the template: us06" in test.meta.notes
    again = load_template(t.save(tmp_path / "T3.yaml"))
    assert again.cycle == "us06" and again.synthetic is True
    assert t.to_yaml().index("cycle:") < t.to_yaml().index("description:")
    set_cycle(test, None)  # identification alone still finds the trace
    assert test.meta.cycle == "hwfet"
    # unknown keys are still rejected, with a suggestion
    p.write_text("cycles: us06\n" + text, encoding="utf-8")
    with pytest.raises(ConfigError, match=r"cycles: unknown key \(did you mean 'cycle'\?\)"):
        load_template(p)
    p.write_text("cycle: 'us 06'\n" + text, encoding="utf-8")
    with pytest.raises(ConfigError, match="cycle: "):
        load_template(p)
    p.write_text("synthetic: maybe\n" + text, encoding="utf-8")
    with pytest.raises(ConfigError, match="synthetic: "):
        load_template(p)
    assert Template.model_validate({"files": [{"source": "dyno"}]}).synthetic is False


def test_import_without_speed_notes_why(tmp_path, d3_template):
    f = write_d3(tmp_path / "r_d3.txt", header=["Time[sec]", "X[mph]", "Engine_Speed[rpm]",
                                                 "Cell_Temp[F]", "Phase_#"])
    p = tmp_path / "T.yaml"
    p.write_text(d3_template.read_text(encoding="utf-8").replace(
        "Dyno_Speed: {name: veh_spd_test, unit: mph}", "X: {delete: true}"), encoding="utf-8")
    test = import_test([f], p)
    assert test.meta.cycle == ""
    assert any(n.startswith("cycle not identified: no measured vehicle speed") for n in test.meta.notes)


def test_cli_import_and_info_print_the_cycle(tmp_path, cli, d3_template):
    f = _d3(tmp_path / "r_d3.txt", "sc03")
    code, out, err = cli("info", f)
    assert code == 0, err
    assert "cycle: sc03  [cycle identified as sc03 (rms 0.1" in out and " mph, offset" in out and "from 'Dyno_Speed'" in out
    o = tmp_path / "o.parquet"
    code, out, err = cli("import", f, "-t", d3_template, "-o", o)
    assert code == 0, err
    assert "  cycle: sc03\n" in out and "VIRTUAL" not in out
    assert read_test(o).meta.cycle == "sc03"
    code, out, err = cli("info", o, "--json")
    assert code == 0, err
    info = json.loads(out)
    assert info["cycle"] == "sc03" and info["synthetic"] is False
    assert info["cycle_found"].startswith("cycle identified as sc03")


def test_propose_unknown_header_unit_goes_to_todo(tmp_path):
    from vehval.io.propose import propose_template, source_tag, unit_from_name
    from vehval.io.readers import read_raw

    p = tmp_path / "run_daq.csv"
    p.write_text("Time[s],Engine_Speed[blips],Vehicle_Speed_Target[km/h]\n0,1,2\n1,2,3\n",
                 encoding="utf-8")
    t, _ = propose_template([p])
    ch = t.files[0].channels
    assert t.files[0].source == "daq"  # a registry source named in the file name
    assert ch["Engine_Speed"].delete and ch["Engine_Speed"].name == "eng_spd_out_test"
    assert "blips" in ch["Engine_Speed"].reason
    assert any("unit 'blips' is unknown" in x for x in t.todo)
    assert ch["Vehicle_Speed_Target"].name == "veh_spd_target_test"
    saved = load_template(t.save(tmp_path / "T.yaml"))  # the proposal loads as it is
    assert saved.files[0].channels["Engine_Speed"].delete
    assert unit_from_name("MG2_RPM", "rad/s") == "rpm" and unit_from_name("MG2_RPM", "m/s") is None
    q = tmp_path / "log.csv"  # OBD-like names without units: an OBD logger
    q.write_text("Timestamp,ENGINE_RPM,MAF,VEHICLE_SPEED\n0,1,2,3\n1,2,3,4\n", encoding="utf-8")
    assert source_tag(read_raw(q)) == "obd"
    q.write_text("Timestamp,Pressure,Flow\n0,1,2\n1,2,3\n", encoding="utf-8")
    assert source_tag(read_raw(q)) == "log"  # nothing OBD-like: the file stem


def test_a_damaged_timestamp_far_out_gives_no_match_not_a_huge_grid():
    """One timestamp at 4e300 s (a damaged file) must not ask for a 1 s grid over it."""
    c = load_cycle("udds")
    t = np.append(c.time_s, 4e300)
    v = np.append(c.speed_mps, 0.0)
    got, score, _ = identify_cycle(t, v)
    assert got is None and score == 0.0


def test_the_cycle_line_speaks_the_display_units(tmp_path, cli, d3_template, monkeypatch):
    """`info` and `import` print the identification's speeds in the display units; the
    test's note and the JSON stay SI (data)."""
    monkeypatch.setenv("VEHVAL_UNITS", "us")     # `--units` sets it: restored after the test
    f = _d3(tmp_path / "r_d3.txt", "sc03")
    lines = {}
    for system, unit in (("us", "mph"), ("metric", "km/h")):
        code, out, err = cli("--units", system, "info", f)
        assert code == 0, err
        lines[system] = next(x for x in out.splitlines() if "cycle identified" in x)
        assert f" {unit}, offset" in lines[system] and "m/s" not in lines[system]
        o = tmp_path / f"{system}.parquet"
        code, out, err = cli("--units", system, "import", f, "-t", d3_template, "-o", o)
        assert code == 0, err
        assert f" {unit}, offset" in out and "m/s" not in out
        assert any("m/s, offset" in n for n in read_test(o).meta.notes)   # stored SI
        code, out, err = cli("--units", system, "info", o)
        assert code == 0 and f" {unit}, offset" in out, out
        code, out, err = cli("--units", system, "info", o, "--json")
        assert "m/s, offset" in json.loads(out)["cycle_found"]


def test_describe_in_display_units():
    from vehval.cycles_text import describe, no_match_reason

    steady = {"method": "steady", "plateaus": [[0.0, 100.0, 25.0]], "steady_fraction": 0.9}
    assert "at 90 km/h" in describe("steady_90kph", steady)                  # the note: SI
    assert "at 55.9 mph" in describe("steady_90kph", steady, "us")
    assert "at 90 km/h" in describe("steady_90kph", steady, "metric")
    miss = {"limits": {"max_rms_mps": 2.0, "min_coverage": 0.5, "min_explained": 0.6},
            "best": {"name": "udds", "explained": 0.4, "rms_mps": 1.0}, "steady_fraction": 0.1}
    assert "(rms 1.00 m/s)" in no_match_reason(miss)
    assert "(rms 2.24 mph)" in no_match_reason(miss, "us")
    assert "within 7.2 km/h RMS" in no_match_reason({**miss, "best": None}, "metric")
