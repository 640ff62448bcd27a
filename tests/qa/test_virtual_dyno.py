"""QA on virtual dyno tests with injected faults (vehval.synth): recall and false alarms.

Each virtual test is a short UDDS piece (340 s, ending at rest) so that the whole module stays fast. A fault
counts as found when a warning- or error-level finding names its signal with a span that
overlaps the fault span (on the true clock, ±1 s). A false alarm is a warning/error on a
signal that carries no injected fault. Figures are printed (run with -s to see them).
"""

import json

import numpy as np
import pytest

synth = pytest.importorskip("vehval.synth")
pytest.importorskip("vehval.sim.simulate")

from vehval.io.importer import import_test  # noqa: E402
from vehval.qa.findings import Severity  # noqa: E402
from vehval.qa.pipeline import run_qa  # noqa: E402
from vehval.sim.cycles import Cycle, load_cycle  # noqa: E402
from vehval.sim.vehicle import load_vehicle  # noqa: E402

MIX_B = [
    {"kind": "clock_offset", "file": "obd", "magnitude": -5.1, "delay_s": 0.2},
    {"kind": "spikes", "channel": "Dyno_Tractive_Effort", "start_frac": 0.1, "end_frac": 0.9,
     "magnitude": 3000.0, "count": 4},
    {"kind": "stuck", "channel": "MG2_RPM", "start_frac": 0.3, "end_frac": 0.45},
    {"kind": "dropout", "channel": "Hioki_Batt_Voltage", "start_frac": 0.6, "end_frac": 0.65},
    {"kind": "sign_flip", "channel": "MG2_TORQUE"},
    {"kind": "out_of_range", "channel": "Engine_Coolant_Temp", "start_frac": 0.5, "end_frac": 0.55,
     "magnitude": 200.0},
    {"kind": "zero", "channel": "Hioki_Boost_Voltage"},
]
CASES = [("default", 1), ("default", 2), ("default", 5), (MIX_B, 3), (MIX_B, 4), ("none", 6)]


@pytest.fixture(scope="module")
def cycle():
    c = load_cycle("udds")
    keep = c.time_s <= 340.0          # UDDS is at rest at 340 s: no artificial end step
    return Cycle.from_trace(c.time_s[keep], c.speed_mps[keep], "udds340")


@pytest.fixture(scope="module")
def results(cycle, tmp_path_factory):
    veh = load_vehicle("prius_2004")
    out = []
    for faults, seed in CASES:
        d = tmp_path_factory.mktemp(f"vt{seed}")
        so = synth.make_virtual_test(cycle=cycle, seed=seed, faults=faults, outdir=d)
        test = import_test(so.files, so.template_path)
        res = run_qa(test, veh)
        truth = json.loads(so.truth_path.read_text())
        out.append((faults if isinstance(faults, str) else "mix_b", seed, truth, res))
    return out


def _score(truth, res):
    faulty = {f["signal"] for f in truth["faults"] if f.get("signal")}
    found, missed = [], []
    for f in truth["faults"]:
        if not f.get("signal"):
            continue
        t0, t1 = f["true_start_s"] - 1.0, f["true_end_s"] + 1.0
        hit = [g for g in res.findings if g.signal == f["signal"] and g.severity != Severity.INFO
               and g.overlaps(t0, t1)]
        (found if hit else missed).append((f["kind"], f["signal"], sorted({g.kind.value for g in hit})))
    measured = {s.name for s in res.validated} | set(res.selection.dropped) | set(res.selection.kept)
    measured = {n for n in measured if not n.endswith("_calc")}
    clean = measured - faulty
    alarms = sorted({(g.signal, g.kind.value) for g in res.findings
                     if g.severity != Severity.INFO and g.signal in clean})
    return found, missed, clean, alarms


def test_clock_offsets_recovered(results):
    for mix, seed, truth, res in results:
        for a in res.alignment:
            true = truth["offsets_s"][a.source]
            # one sample of the faster source (0.1 s), plus the difference of the sensors'
            # first-order lags (a lag tau delays a signal by ~tau, indistinguishable from a
            # clock offset by correlation): the truth's offset is the clock's alone
            lags = {c["name"]: c["lag_s"] for c in truth["channels"].values()}
            lag_diff = max(abs(lags.get(p.ref, 0) - lags.get(p.other, 0)) for p in a.pairs)
            assert a.applied, (mix, seed, a.message)
            assert abs(a.offset_s - true) <= 0.1 + lag_diff, (mix, seed, a.offset_s, true, lag_diff)


def test_clean_virtual_test_has_no_warning(results):
    for mix, seed, truth, res in results:
        if mix == "none":
            bad = [(f.signal, f.kind.value, f.message) for f in res.findings if f.severity != Severity.INFO]
            assert bad == []


def test_recall_and_false_alarm_rate(results):
    n_found = n_faults = n_alarm = n_clean = 0
    lines = []
    for mix, seed, truth, res in results:
        found, missed, clean, alarms = _score(truth, res)
        n_found += len(found)
        n_faults += len(found) + len(missed)
        n_alarm += len({s for s, _ in alarms})
        n_clean += len(clean)
        lines.append(f"{mix:8s} seed {seed}: found {len(found)}/{len(found) + len(missed)}; "
                     f"missed {[(k, s) for k, s, _ in missed]}; false alarms {alarms}")
    recall = n_found / max(n_faults, 1)
    far = n_alarm / max(n_clean, 1)
    print("\n" + "\n".join(lines))
    print(f"RECALL {recall:.3f} ({n_found}/{n_faults} channel faults); FALSE-ALARM RATE {far:.3f} "
          f"({n_alarm} of {n_clean} clean signal-instances with a warning/error)")
    # the single-source 8 % fuel-meter gain error is undetectable without a model (it is
    # found by validation against the simulation, not by QA); everything else should be
    assert recall >= 0.85
    assert far <= 0.05
