"""The page of ``vehval sensitivity``: base figures, a tornado per cycle, the ranked table.

plotly.js is read from the local copy written beside the page
(:func:`vehval.report.page.write_plotly_asset`).
"""

from __future__ import annotations

import json

from vehval.report.document import bullets, figure, h1, h2, para, render_document, table
from vehval.report.figures import FigSpec
from vehval.report.plugins import normalise_figure


def render_sensitivity_page(result: dict, plotly_src: str) -> str:
    """HTML of the page of a ``sensitivity`` result (``sensitivity.json``).

    Parameters
    ----------
    result : dict
        ``vehicle``, ``dt_s`` [s], ``cycles``, ``base`` (``mpg`` per cycle), ``parameters``
        (``key``, ``swing_pct``, ``cycles`` (``low_pct``, ``high_pct`` per cycle),
        ``uncertainty``, ``source``), optional ``monte_carlo`` (``p5``, ``p50``, ``p95``
        [mpg], ``n`` per cycle).
    plotly_src : str
        Relative path of plotly.js from the page.
    """
    from vehval.sim.sensitivity import tornado_figure

    cycles = result["cycles"]
    base = ", ".join(f"{c} {b['mpg']:.1f}" for c, b in result["base"].items())
    from vehval.sim.sensitivity import MPG

    hybrid = result.get("figure", MPG) == MPG
    what = ("SOC-corrected fuel economy from the initial SOC of the charge-balanced base run"
            if hybrid else "Fuel economy (a car without a traction battery: no SOC correction)")
    blocks = [h1(f"Sensitivity of fuel economy: {result['vehicle']}"),
              para(f"{what}, dt = {result['dt_s']:g} s. Base: {base} mpg.")]
    if "monte_carlo" in result:
        blocks += [h2("Monte Carlo (all parameters at once)"),
                   bullets([f"{c}: {m['p5']:.1f} / {m['p50']:.1f} / {m['p95']:.1f} mpg "
                            f"(5/50/95 %, n = {m['n']})" for c, m in result["monte_carlo"].items()])]
    for c in cycles:
        fig, caption = normalise_figure(tornado_figure(result, c))
        blocks.append(figure(FigSpec(caption, fig)))
    rows = [[r["key"], f"{r['swing_pct']:.2f}"]
            + [f"{r['cycles'][c]['low_pct']:+.2f} / {r['cycles'][c]['high_pct']:+.2f}" for c in cycles]
            + [json.dumps(r["uncertainty"]), r["source"]] for r in result["parameters"]]
    blocks += [h2("Ranked parameters"),
               table(["parameter", "swing [%]"] + [f"{c} low / high [%]" for c in cycles]
                     + ["uncertainty", "source"], rows)]
    return render_document(blocks, title=f"Sensitivity {result['vehicle']}", css="sensitivity.css",
                           plotly_js=plotly_src)
