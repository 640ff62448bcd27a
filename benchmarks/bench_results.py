"""The results stage on one 10 Hz, 1,500 s, 60-channel test, against the QA chain.

Baseline: ``run_qa`` on the same imported test (the ``vehval qa`` analysis), measured in the
same run. Measured: the results stage on QA's validated test (phases, composites, drive
quality, SOC correction) with first-order uncertainty, and with Monte Carlo (1,000 draws).
Targets: first order adds under 0.5 s to ``vehval qa``, Monte Carlo under 3 s.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

from benchmarks.bench_qa import _test_and_template
from benchmarks.common import best_of, make_d3_file, row


def run() -> list[dict]:
    from vehval.qa.pipeline import run_qa
    from vehval.results import compute_results

    with tempfile.TemporaryDirectory() as d:
        path = make_d3_file(Path(d) / "bench_d3.txt", duration_s=1500, rate_hz=10, n_channels=60)
        test, tpl = _test_and_template(path)
        keep = {}

        def qa():
            keep["qa"] = run_qa(test, None, tpl)

        t_qa = best_of(qa, n=3)
        validated = keep["qa"].validated
        fuel = {"density_kg_per_m3": 745.0, "lhv_j_per_kg": 42.6e6, "carbon_mass_fraction": 0.866}

        def first_order():
            keep["fo"] = compute_results(validated, fuel=fuel)

        def monte_carlo():
            keep["mc"] = compute_results(validated, fuel=fuel, method="monte_carlo", draws=1000)

        t_fo = best_of(first_order, n=5)
        t_mc = best_of(monte_carlo, n=3)
    fo = keep["fo"]
    note = (f"{len(validated)} signals, cycle {validated.meta.cycle or '-'}, {len(fo.phases)} phases, "
            f"{len(fo.composites)} composites, {len(fo.parameters)} uncertain inputs")
    return [
        row("results_first_order_1500s_60ch", t_fo, "s", target=0.5,
            note="results stage, first-order uncertainty: target under 0.5 s; " + note),
        row("results_monte_carlo_1000_1500s_60ch", t_mc, "s", target=3.0,
            note="results stage, Monte Carlo 1,000 draws: target under 3 s"),
        row("results_first_order_vs_qa", t_fo, "s", baseline=t_qa,
            note="ratio of the results stage (first order) to run_qa on the same test"),
        row("results_monte_carlo_vs_qa", t_mc, "s", baseline=t_qa,
            note="ratio of the results stage (Monte Carlo, 1,000 draws) to run_qa"),
    ]
