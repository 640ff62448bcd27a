"""Report sections of the later stages: control-strategy analysis and model validation.

Both stages hand the report a *section payload*::

    {"title": str, "intro": str, "tables": [{"title", "columns", "rows", "note"}],
     "figures": [plotly figure dict | {"title", "figure", "linked", "note"}], "notes": [str]}

* ``vehval analyze`` writes ``control.json`` (:meth:`vehval.analysis.AnalysisResult.to_dict`):
  the payload is its ``report`` entry. The report adds facts and figures drawn from the rest
  of the document (engine operating points on the best-efficiency line, mode timeline, SOC
  regulation, regenerative share of braking); the raw arrays are not dumped as tables.
* ``vehval validate`` writes ``validation.json``, which *is* a payload.

Any other dict is shown as a payload; when it has no tables or figures, its keys are shown
as generic tables.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from vehval.display import as_unit
from vehval.figures import layout_figure
from vehval.report.figures import PALETTE, FigSpec
from vehval.report.safety import GL_TO_SVG
from vehval.report.sections import Section
from vehval.report.tables import table_from_spec, to_tables

PAYLOAD_KEYS = ("tables", "figures", "notes", "intro", "title")


# ----------------------------------------------------------------------------- figures
def _title_text(layout: dict) -> str:
    t = layout.get("title")
    if isinstance(t, dict):
        t = t.get("text")
    return str(t) if t else ""


def _object_titles(obj: Any) -> Any:
    """Copy of a figure part with every ``title: "text"`` as ``title: {"text": "text"}``.

    plotly.js 3 dropped the string shorthand (axis titles given as strings vanish).
    """
    if isinstance(obj, dict):
        return {k: ({"text": v} if k == "title" and isinstance(v, str) else _object_titles(v))
                for k, v in obj.items()}
    if isinstance(obj, list) and obj and isinstance(obj[0], dict):
        return [_object_titles(v) for v in obj]
    return obj


def normalise_figure(fig: Any, caption: str = "") -> tuple[dict, str]:
    """A plotly figure as a JSON dict ready for the page, and its caption.

    The caption is the given one, else the layout title; a layout title equal to the
    caption is removed (the page shows the caption). String titles become ``{"text": ...}``
    objects. WebGL traces are drawn as SVG on the page (see
    :func:`vehval.report.safety.safe_figure`).
    """
    if hasattr(fig, "to_plotly_json"):
        fig = fig.to_plotly_json()
    fig = dict(fig or {})
    layout = _object_titles(dict(fig.get("layout") or {}))
    data = [_object_titles(dict(t)) for t in fig.get("data") or []]
    ltitle = _title_text(layout)
    caption = caption or ltitle
    if ltitle and ltitle == caption:
        layout.pop("title", None)
        m = dict(layout.get("margin") or {})
        if m.get("t", 0) > 40:
            m["t"] = 30
            layout["margin"] = m
    for t in data:
        t["type"] = GL_TO_SVG.get(t.get("type", "scatter"), t.get("type", "scatter"))
    fig["data"], fig["layout"] = data, layout
    return fig, caption


def is_time_figure(fig: dict) -> bool:
    """True when the figure's x axes are time [s]: the lowest titled one says ``time``."""
    layout = fig.get("layout") or {}
    titles = [_title_text(v) for k, v in layout.items() if k.startswith("xaxis") and isinstance(v, dict)]
    titles = [t for t in titles if t]
    return bool(titles) and all(t.lower().startswith("time") for t in titles)


def payload_figures(figures: list, default: str) -> list[FigSpec]:
    """FigSpecs of a payload's ``figures`` list (plain figures or ``{title, figure}`` wrappers).

    A figure is *linked* (its time axis follows the other time plots of the page) when the
    wrapper says so, else when its x axes are time (:func:`is_time_figure`).
    """
    out = []
    for i, f in enumerate(figures or []):
        wrapped = isinstance(f, dict) and "figure" in f
        fig, caption = normalise_figure(f["figure"] if wrapped else f,
                                        str(f.get("title") or "") if wrapped else "")
        if not fig.get("data"):
            continue
        linked = f.get("linked") if wrapped else None
        out.append(FigSpec(caption or f"{default} figure {i + 1}", fig,
                           linked=bool(linked) if linked is not None else is_time_figure(fig),
                           note=str(f.get("note") or "") if wrapped else ""))
    return out


def payload_section(key: str, title: str, payload: dict, *, rest: bool | None = None) -> Section:
    """A section from a payload dict.

    With ``rest`` its other keys become generic tables; by default (None) only when the
    payload has neither tables nor figures (a payload's tables are the curated view of the
    rest, e.g. ``Validation.to_dict()`` carries both).
    """
    if rest is None:
        rest = not (payload.get("tables") or payload.get("figures"))
    sec = Section(key, str(payload.get("title") or title), intro=str(payload.get("intro") or ""))
    for i, spec in enumerate(payload.get("tables") or []):
        t = table_from_spec(spec, f"{title} table {i + 1}")
        t.key = f"{key}-{t.key}"
        sec.tables.append(t)
    sec.figures += payload_figures(payload.get("figures") or [], title)
    sec.notes += [str(n) for n in payload.get("notes") or []]
    if rest:
        for k, v in payload.items():
            if k not in PAYLOAD_KEYS:
                sec.tables += to_tables(v, f"{title}: {k}", key=f"{key}-{k}")
    return sec


# ----------------------------------------------------------------------------- control
def is_control_doc(doc: Any) -> bool:
    """True for a ``control.json`` document (analysis result with its ``report`` entry)."""
    return isinstance(doc, dict) and ("control_version" in doc or isinstance(doc.get("report"), dict))


def _fmt(v: Any, spec: str = ".4g") -> str:
    return format(v, spec) if isinstance(v, (int, float)) and not isinstance(v, bool) else "—"


#: Margins [px] and legend place of the control section's figures.
_MARGIN = {"l": 70, "r": 20, "t": 30, "b": 50}
_LEGEND = {"x": 0.01, "y": 0.99}


def operating_points_figure(op: dict) -> dict | None:
    """Engine operating points [rpm, N·m] with the fuel map's best-efficiency line."""
    pts, best = op.get("points") or {}, op.get("best_line") or {}
    if not pts.get("speed_rpm") and not best.get("speed_rpm"):
        return None
    data = []
    if pts.get("speed_rpm"):
        data.append({"type": "scatter", "mode": "markers", "name": "engine running",
                     "x": pts["speed_rpm"], "y": pts["torque_nm"],
                     "marker": {"size": 4, "color": PALETTE[1], "opacity": 0.45}})
    if best.get("speed_rpm"):
        band = op.get("band_nm")
        data.append({"type": "scatter", "mode": "lines", "name": "best-efficiency line",
                     "x": best["speed_rpm"], "y": best["torque_nm"],
                     "line": {"color": PALETTE[2], "width": 3, "dash": "dash"}})
        if isinstance(band, (int, float)):
            for sign in (1, -1):
                data.append({"type": "scatter", "mode": "lines", "showlegend": sign > 0,
                             "name": f"±{band:g} N·m band", "x": best["speed_rpm"],
                             "y": [t + sign * band for t in best["torque_nm"]],
                             "line": {"color": PALETTE[2], "width": 1, "dash": "dot"}})
    return layout_figure(data, height=420, margin=_MARGIN, xlabel="engine speed [rpm]",
                         ylabel="engine torque [N·m]", legend=_LEGEND)


def mode_timeline_figure(modes: dict) -> dict | None:
    """Operating mode over time: one horizontal bar per mode segment [s]."""
    segs = [s for s in modes.get("timeline") or [] if isinstance(s, dict)]
    if not segs:
        return None
    order = [m for m in modes.get("codes") or [] if any(s.get("mode") == m for s in segs)]
    order += sorted({s.get("mode") for s in segs} - set(order))
    data = []
    for i, m in enumerate(order):
        mine = [s for s in segs if s.get("mode") == m]
        data.append({"type": "bar", "orientation": "h", "name": m, "y": [m] * len(mine),
                     "base": [s["start_s"] for s in mine], "x": [s["duration_s"] for s in mine],
                     "marker": {"color": PALETTE[i % len(PALETTE)]}, "showlegend": False,
                     "hovertemplate": "%{y}: %{base:.1f} s + %{x:.1f} s<extra></extra>"})
    return layout_figure(data, height=90 + 26 * len(order), barmode="overlay",
                         margin={"l": 130, "r": 20, "t": 20, "b": 45}, xlabel="time [s]",
                         categories=order[::-1])


def soc_regulation_figure(soc: dict) -> dict | None:
    """Median battery power [kW] by SOC bin during engine-on propulsion, with the fit."""
    bins = [b for b in soc.get("bins") or [] if isinstance(b, dict)
            and isinstance(b.get("soc"), (int, float)) and isinstance(b.get("ess_pwr_median_w"), (int, float))]
    if not bins:
        return None
    x = [b["soc"] for b in bins]
    data = [{"type": "scatter", "mode": "markers", "name": "median per SOC bin",
             "x": x, "y": [as_unit(b["ess_pwr_median_w"], "kW") for b in bins],
             "text": [f"n = {b.get('n')}" for b in bins],
             "marker": {"size": 8, "color": PALETTE[0]}}]
    slope, icpt = soc.get("slope_w"), soc.get("intercept_w")
    if isinstance(slope, (int, float)) and isinstance(icpt, (int, float)):
        xs = [min(x), max(x)]
        r2 = soc.get("r2")
        data.append({"type": "scatter", "mode": "lines", "x": xs, "y": [as_unit(slope * s + icpt, "kW") for s in xs],
                     "name": f"fit: {as_unit(slope, 'kW'):.4g} kW per unit SOC" + (f" (R² = {r2:.3f})" if isinstance(r2, (int, float)) else ""),
                     "line": {"color": PALETTE[1], "width": 2}})
    return layout_figure(data, height=360, margin=_MARGIN, xlabel="state of charge [-]",
                         ylabel="battery power [kW] (+ discharge)", legend=_LEGEND)


def regen_share_figure(brk: dict) -> dict | None:
    """Regenerative share of braking energy by deceleration [m/s²] and speed [m/s] bins."""
    cells = [c for c in brk.get("by_decel_speed") or [] if isinstance(c, dict)
             and isinstance(c.get("regen_share"), (int, float))
             and isinstance(c.get("decel_mps2"), list) and isinstance(c.get("speed_mps"), list)]
    if not cells:
        return None
    n = np.array([c.get("n") or 0 for c in cells], float)
    size = 6 + 18 * np.sqrt(n / max(n.max(), 1.0))
    return layout_figure([{"type": "scatter", "mode": "markers", "name": "regen share",
                      "x": [0.5 * sum(c["speed_mps"]) for c in cells],
                      "y": [0.5 * sum(c["decel_mps2"]) for c in cells],
                      "text": [f"{as_unit(c['regen_share'], '%'):.0f} % of {c.get('n')} steps" for c in cells],
                      "marker": {"size": size.tolist(), "color": [c["regen_share"] for c in cells],
                                 "cmin": 0, "cmax": 1, "colorscale": "Viridis",
                                 "colorbar": {"title": {"text": "regen share"}}},
                      "hovertemplate": "%{x:.1f} m/s, %{y:.2f} m/s²: %{text}<extra></extra>"}],
                         height=380, margin=_MARGIN, xlabel="vehicle speed [m/s] (bin centre)",
                         ylabel="deceleration [m/s²] (bin centre)")


#: Tables and facts of the control section about a hybrid's controller only.
HYBRID_ONLY_TABLES = ("Estimated controller parameters",)


def control_section(doc: dict, hybrid: bool = True) -> Section:
    """The control-strategy section from ``control.json`` (or a plain payload).

    ``hybrid=False`` (a conventional car) leaves out the hybrid controller's content: the
    SOC window and regulation, the power thresholds of the engine on/off rule.
    """
    if not is_control_doc(doc):
        return payload_section("control", "Control strategy", doc)
    payload = doc["report"] if isinstance(doc.get("report"), dict) else {}
    sec = payload_section("control", "Control strategy", payload, rest=False)
    if not hybrid:
        sec.tables = [t for t in sec.tables if t.title not in HYBRID_ONLY_TABLES]
    sec.intro = sec.intro or ("Control strategy estimated from the test data (vehval analyze): "
                              "engine on/off rule, operating modes, engine operating points, SOC "
                              "regulation and braking split.")
    eng, op, soc = doc.get("engine") or {}, doc.get("operating_points") or {}, doc.get("soc_regulation") or {}
    share = eng.get("on_share")
    sec.facts = [("Test", str(doc.get("test_id") or "—")),
                 ("Rule agreement", f"{as_unit(doc['rule_agreement'], '%'):.1f} % of steps"
                  if isinstance(doc.get("rule_agreement"), (int, float)) else "not estimated"),
                 ("Engine on", f"{as_unit(share, '%'):.1f} % of the time, {eng.get('starts', '—')} starts"
                  if isinstance(share, (int, float)) else "—"),
                 ("Engine state from", str(eng.get("method") or "—")),
                 ("On the best line", f"{as_unit(op['share_within_band'], '%'):.1f} % within ±{_fmt(op.get('band_nm'), 'g')} N·m"
                  if isinstance(op.get("share_within_band"), (int, float)) else "—"),
                 ("SOC window", (f"{_fmt(soc.get('soc_min'), '.3f')} – {_fmt(soc.get('soc_max'), '.3f')}"
                                 f" (mean {_fmt(soc.get('soc_mean'), '.3f')})"))]
    if not hybrid:
        sec.facts = sec.facts[:-1]   # no SOC window
        soc = {}
    if soc.get("why"):
        sec.notes.append(f"SOC regulation: {soc['why']}")
    if (doc.get("braking") or {}).get("basis"):
        sec.notes.append(f"Braking split: {doc['braking']['basis']}")
    for cap, make, arg, linked in (
            ("Engine operating points and the best-efficiency line", operating_points_figure, op, False),
            ("Operating modes over time", mode_timeline_figure, doc.get("modes") or {}, True),
            ("SOC regulation: battery power against SOC", soc_regulation_figure, soc, False),
            ("Regenerative share of braking energy", regen_share_figure, doc.get("braking") or {}, False)):
        fig = make(arg)
        if fig is not None:
            sec.figures.append(FigSpec(cap, fig, linked=linked))
    if not sec.tables and not sec.figures:
        sec.notes.append("control.json has no report entry: re-run `vehval analyze`.")
    return sec


# ----------------------------------------------------------------------------- validation
def validation_section(doc: dict) -> Section:
    """The validation section from ``validation.json`` (a payload, see the module doc)."""
    sec = payload_section("validation", "Validation", doc)
    sec.intro = sec.intro or "The model simulated on the test's own conditions, against the test."
    return sec
