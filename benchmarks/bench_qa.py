"""The whole QA chain on one 10 Hz, 1,500 s, 60-channel test, against reading the file.

Baseline: ``vehval.io.readers.read_raw`` of the same D3 file (parse only), measured in the
same run. Measured: ``run_qa`` (alignment, QA levels 1-3, calculations, selection) on the
imported test; the target is that the analysis adds less than 2 s. The QA gate of the results
(:func:`vehval.results.gate.apply_gate`) is measured on and off: ``run_qa`` + results with
it against without, target under 10 % more. The CAN-logger-like second
source needed by alignment and QA2 is made from three of the file's channels (1 Hz with
jitter and a known 2.3 s clock offset), so every stage does real work.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np

from benchmarks.common import best_of, make_d3_file, row


def _test_and_template(path: Path):
    from vehval.io.importer import import_test
    from vehval.io.propose import propose_template
    from vehval.io.readers import read_raw
    from vehval.io.template import ChannelSpec
    from vehval.test import Signal

    tpl, _ = propose_template([path])
    raw = read_raw(path)
    units = dict(zip(raw.names, raw.units))
    k = 0
    for spec in tpl.files:
        for key, ch in list(spec.channels.items()):
            if ch.delete or (ch.unit is None and units.get(key) is None):
                # generic DAQ channels: keep them under a numbered qualifier
                base = {"V": "aux_volt", "C": "amb_temp", "A": "ess_curr"}.get(units.get(key) or "")
                if base is None:
                    continue
                k += 1
                spec.channels[key] = ChannelSpec(name=f"{base}_d{k}_test", unit=units[key])
    tpl.constants.fuel_density_kg_per_m3 = 745.0
    tpl.constants.test_mass_kg = 1295.0
    tpl.constants.road_load_a_n = 88.6
    tpl.constants.road_load_b_n_per_mps = 0.14
    tpl.constants.road_load_c_n_per_mps2 = 0.36
    test = import_test([path], tpl, repair_time=True)
    rng = np.random.default_rng(0)
    t0, t1 = test.span()
    t_obd = t0 + 2 + np.cumsum(1.0 + rng.normal(0, 0.04, int(t1 - t0)))
    t_obd = t_obd[t_obd < t1 - 3]
    for base in ("veh_spd", "eng_spd_out"):
        sigs = test.by_base(base)
        if sigs:
            s = sigs[0]
            test.add(Signal.standard(f"{base}_can_test", t_obd, s.at(t_obd + 2.3), source="can"))
    return test, tpl


def run() -> list[dict]:
    from vehval.io.readers import read_raw
    from vehval.qa.pipeline import run_qa

    with tempfile.TemporaryDirectory() as d:
        path = make_d3_file(Path(d) / "bench_d3.txt", duration_s=1500, rate_hz=10, n_channels=60)
        t_read = best_of(lambda: read_raw(path), n=3)
        test, tpl = _test_and_template(path)
        n_sig, n_samp = len(test), max(s.time.size for s in test)
        result = {}

        def qa():
            result["r"] = run_qa(test, None, tpl)

        t_qa = best_of(qa, n=3)
        r = result["r"]
        t_qa_bare = _without_crosschecks(qa)
        t_cc = _crosschecks_alone(r, tpl)
        off = r.alignment[0].offset_s if r.alignment else float("nan")
        t_res, t_gate, n_err = _results_and_gate(r, tpl)
    note = (f"{n_sig} signals x {n_samp} samples; {len(r.findings)} findings, "
            f"{len(r.calculations.computed)} calc signals; CAN offset found {off:+.3f} s (true +2.300 s)")
    return [
        row("qa_chain_1500s_60ch", t_qa, "s", target=2.0,
            note="align + QA1 + QA2 + calc + QA3 + select (run_qa); target: under 2 s; " + note),
        row("qa_chain_vs_read", t_qa, "s", baseline=t_read,
            note="ratio of the analysis time to read_raw of the same file (parse only)"),
        row("qa_results_gate_on_vs_off", t_qa + t_res + t_gate, "s", baseline=t_qa + t_res,
            target=1.10,
            note=(f"`vehval qa` work (run_qa + results) with the QA gate of the results "
                  f"(apply_gate, {len(r.findings)} findings, {n_err} errors) against without; "
                  f"target: under 10 % more; gate alone {1e3 * t_gate:.2f} ms")),
        row("qa_crosschecks_and_gate_on_vs_off", t_qa + t_res + t_gate, "s",
            baseline=t_qa_bare + t_res, target=1.10,
            note=("`vehval qa` work (run_qa + results) with the physical cross-checks "
                  "(qa.crosscheck, qa.obd_checks) and the QA gate, against both left out; "
                  f"target: under 10 % more; the cross-checks alone {1e3 * t_cc:.1f} ms")),
    ]


def _crosschecks_alone(r, tpl) -> float:
    """Best time [s] of the physical cross-checks on the validated test."""
    from vehval.qa.plausibility import run_plausibility

    return best_of(lambda: run_plausibility(r.validated, None, tpl), n=3)


def _without_crosschecks(qa) -> float:
    """Best time [s] of ``qa`` with the physical cross-checks replaced by nothing."""
    from vehval.qa import plausibility

    keep = plausibility.run_crosschecks
    plausibility.run_crosschecks = lambda *a, **k: []
    try:
        return best_of(qa, n=3)
    finally:
        plausibility.run_crosschecks = keep


def _results_and_gate(r, tpl) -> tuple[float, float, int]:
    """Best times [s] of the results stage and of its QA gate (on a fresh copy each time),
    and the number of error findings the gate sees. An error finding on the fuel channel
    is added so the gate withholds figures (its worst case: every scope checked)."""
    import copy
    import time

    from vehval.qa.findings import Finding, Kind, Severity
    from vehval.results import results_from_template
    from vehval.results.gate import apply_gate

    test = r.validated
    t_res = best_of(lambda: results_from_template(test, tpl), n=3)
    res = results_from_template(test, tpl)
    fuel = (res.inputs.get("fuel") or res.inputs.get("speed") or ["veh_spd_test"])[0]
    findings = list(r.findings) + [Finding(fuel, Kind.UNIT_SUSPECT, float("nan"), float("nan"),
                                           Severity.ERROR, "benchmark: unit suspect")]
    best = float("inf")
    for _ in range(5):
        work = copy.deepcopy(res)
        t0 = time.perf_counter()
        apply_gate(work, findings)
        best = min(best, time.perf_counter() - t0)
    return t_res, best, sum(f.severity == Severity.ERROR for f in findings)


if __name__ == "__main__":  # pragma: no cover
    for x in run():
        print(x)
