"""Figures of the report's engineering and energy pages: plotly figure objects laid out here.

The pages compute the data (operating points, maps, histograms, Willans fits, energy flows)
and describe each trace as ``(kind, properties)``, a plotly trace class name (``Scatter``,
``Contour``, ``Histogram``) and its properties; this module builds the figure, its title,
axes, size and margins (:func:`trace_figure`) and the energy-flow diagram
(:func:`sankey_figure`). Values arrive in their display units (rpm, kW, MJ, %).
"""

from __future__ import annotations

from typing import Any, Sequence

import plotly.graph_objects as go

#: Colour of the links of an energy-flow diagram.
LINK_COLOR = "rgba(31,95,168,0.25)"

__all__ = ["LINK_COLOR", "sankey_figure", "trace_figure"]


def trace_figure(traces: Sequence[tuple[str, dict[str, Any]]], *, title: str, xlabel: str,
                 ylabel: str, height: int = 460, vline: float | None = None) -> go.Figure:
    """One pair of axes holding ``traces`` (``(kind, properties)``: ``("Scatter", {...})``),
    titled ``title``, ``height`` [px] tall, with a dotted vertical line at ``vline``."""
    fig = go.Figure()
    for kind, props in traces:
        fig.add_trace(getattr(go, kind)(**props))
    if vline is not None:
        fig.add_vline(x=vline, line={"color": "#868e96", "dash": "dot"})
    fig.update_layout(title={"text": title, "font": {"size": 14}}, height=height, bargap=0.04,
                      margin={"l": 70, "r": 30, "t": 50, "b": 50},
                      xaxis_title=xlabel, yaxis_title=ylabel, legend={"x": 0.01, "y": 0.99})
    return fig


def sankey_figure(nodes: Sequence[str], links: Sequence[tuple[int, int, float]], *,
                  colors: Sequence[str], title: str, unit: str = "MJ") -> go.Figure:
    """An energy-flow (Sankey) diagram: ``nodes`` (labels, one colour each) and ``links``
    ``(source, target, value)`` by node index, values in ``unit``."""
    fig = go.Figure(go.Sankey(
        valueformat=".2f", valuesuffix=f" {unit}",
        node={"label": list(nodes), "pad": 18, "thickness": 16, "color": list(colors)},
        link={"source": [a for a, _, _ in links], "target": [b for _, b, _ in links],
              "value": [v for _, _, v in links], "color": LINK_COLOR}))
    fig.update_layout(title={"text": title, "font": {"size": 14}}, height=420,
                      margin={"l": 20, "r": 20, "t": 50, "b": 20})
    return fig
