"""The figure of one finding, made for its kind (the report's figure layer).

Every figure is stacked panels on one linked time axis (:func:`time_traces_figure`), one
unit per panel, in display units (:mod:`vehval.display`: rpm not rad/s, SOC in %, mph or
km/h), the finding's samples shaded:

- ``drive_quality``: the measured speed against the cycle's target on one axis, over the
  phase the finding names;
- ``fuel_map``: the measured fuel rate against the engine fuel map at the measured speed
  and torque (fuel on its own axis), engine speed and torque below;
- a balance check (``sign_flip``, ``calc_mismatch`` of a check of the calculation file:
  the power balance of battery and machines): its two sides on one axis;
- every other kind: the signal and its related signals, grouped by display unit.

:func:`finding_figure` returns the plotly figure dict and the display unit of each panel
(``meta.units``), which the tests walk to hold "one unit per axis".
"""

from __future__ import annotations

from typing import Any

import numpy as np

from vehval.report.figures import PALETTE, time_traces_figure

__all__ = ["finding_figure", "finding_span", "panel_units"]

#: Seconds shown either side of a finding's span (at least), and the share of the span.
PAD_S, PAD_SHARE = 5.0, 0.2
#: Most signals drawn for one finding.
MAX_SIGNALS = 8


def _display(values: np.ndarray, unit: str, name: str) -> tuple[np.ndarray, str]:
    from vehval.display import to_display

    return to_display(np.asarray(values, float), unit or "dimensionless", signal=name)


def _num(x: Any) -> float | None:
    try:
        v = float(x)
    except (TypeError, ValueError):
        return None
    return v if np.isfinite(v) else None


def finding_span(finding: dict) -> tuple[float, float] | None:
    """The finding's flagged span [s] (None: the whole test)."""
    a, b = _num(finding.get("start_s")), _num(finding.get("end_s"))
    return (a, b) if a is not None and b is not None else None


def _window(t: np.ndarray, span: tuple[float, float] | None) -> np.ndarray:
    if span is None:
        return np.ones(t.size, bool)
    pad = max(PAD_S, PAD_SHARE * (span[1] - span[0]))
    return (t >= span[0] - pad) & (t <= span[1] + pad)


def _panel(label: str, unit: str, traces: list[dict], spans: list) -> dict:
    for tr in traces:
        tr.setdefault("unit", unit)
    return {"ylabel": f"{label} [{unit}]" if unit else label, "unit": unit,
            "traces": traces, "spans": spans}


def _trace(name: str, t: np.ndarray, y: np.ndarray, i: int, **kw: Any) -> dict:
    return {"name": name, "t": t, "y": y, "color": PALETTE[i % len(PALETTE)], **kw}


def _by_unit(tests: list[Any], names: list[str],
             span: tuple[float, float] | None) -> list[dict]:
    """The signals in display units, one panel per unit (first-seen order); each taken from
    the first test holding it (the validated test, then the imported one: a dropped signal)."""
    panels: dict[str, dict] = {}
    for i, name in enumerate(names[:MAX_SIGNALS]):
        sig = next((t[name] for t in tests if t is not None and name in t), None)
        if sig is None:
            continue
        t = np.asarray(sig.time, float)
        keep = _window(t, span)
        y, unit = _display(sig.values[keep], sig.unit, name)
        p = panels.setdefault(unit, _panel(name if not panels.get(unit) else "", unit, [],
                                           [span] if span else []))
        p["traces"].append(_trace(name, t[keep], y, i, unit=unit))
    for unit, p in panels.items():
        names_in = ", ".join(tr["name"] for tr in p["traces"])
        p["ylabel"] = f"{names_in} [{unit}]" if unit else names_in
    return list(panels.values())


def _drive_quality(test: Any, finding: dict, results: dict | None) -> list[dict] | None:
    from vehval.results.phases import match_cycle, reference_speed

    speed = test.best("veh_spd", ("test",))
    if speed is None:
        return None
    match = match_cycle(speed, test.meta.cycle, getattr(test.meta, "cycle_match", None),
                        test.meta.offsets_s)
    if match is None:
        return None
    phase = (finding.get("numbers") or {}).get("phase")
    segs = [s for p in (results or {}).get("phases") or [] if p.get("name") == phase
            for s in p.get("segments_s") or []]
    t = np.asarray(speed.time, float)
    keep = np.zeros(t.size, bool) if segs else np.ones(t.size, bool)
    for a, b in segs:
        keep |= (t >= a) & (t <= b)
    ref = reference_speed(t[keep], match)
    y, unit = _display(speed.values[keep], speed.unit, speed.name)
    r, _ = _display(ref, "m/s", "veh_spd")
    return [_panel("vehicle speed", unit, [
        _trace(f"{speed.name} (measured)", t[keep], y, 0),
        _trace(f"{match.cycle} target", t[keep], r, 1, dash="dot")],
        [(float(a), float(b)) for a, b in segs])]


def _fuel_map(test: Any, finding: dict, vehicle: Any) -> list[dict] | None:
    from vehval.qa.fuelmap import engine_map, map_fuel_rate

    fmap = engine_map(vehicle) if vehicle is not None else None
    name = finding.get("signal") or ""
    spd = test.best("eng_spd_out", ("test", "calc"))
    trq = test.best("eng_trq_out", ("test", "calc"))
    if fmap is None or name not in test or spd is None or trq is None:
        return None
    fuel = test[name]
    t = np.asarray(fuel.time, float)
    span = finding_span(finding)
    keep = _window(t, span)
    w, q = spd.at(t[keep]), trq.at(t[keep])
    mapped = map_fuel_rate(fmap, np.nan_to_num(w), np.nan_to_num(q))
    mapped = np.where(np.isfinite(w) & np.isfinite(q), mapped, np.nan)
    y, unit = _display(fuel.values[keep], fuel.unit, name)
    m, _ = _display(mapped, fuel.unit, name)
    spans = [span] if span else []
    ws, wu = _display(w, spd.unit, spd.name)
    qs, qu = _display(q, trq.unit, trq.name)
    return [_panel("fuel rate", unit, [_trace(f"{name} (measured)", t[keep], y, 0),
                                       _trace("engine fuel map", t[keep], m, 1, dash="dot")], spans),
            _panel(spd.name, wu, [_trace(spd.name, t[keep], ws, 2)], spans),
            _panel(trq.name, qu, [_trace(trq.name, t[keep], qs, 3)], spans)]


#: SI units a balance check's side may come out in (its display unit follows).
_SIDE_UNITS = ("W", "J", "N*m", "N", "m/s", "rad/s", "kg/s", "A", "V", "m/s**2")


def side_unit(text: str) -> str:
    """The SI unit of one side of a calculation-file check (``ess_volt * ess_curr`` -> ``W``),
    from the nomenclature units of its signals; ``dimensionless`` when not one of
    :data:`_SIDE_UNITS`."""
    from vehval.equations.expr import parse_expression
    from vehval.nomenclature import registry as names
    from vehval.units import registry as units

    try:
        ex = parse_expression(text, "check")
        u = units()
        var = {n: 1.0 * u(names()[n].unit.replace("dimensionless", "")
                          or "dimensionless") for n in ex.names}
        q = ex._eval(ex.tree, var, np.zeros(1))
        dim = getattr(q, "dimensionality", None)
    except Exception:  # noqa: BLE001 - an expression pint cannot carry: no unit
        return "dimensionless"
    return next((c for c in _SIDE_UNITS if dim == u(c).dimensionality), "dimensionless")


def _check(finding: dict, calc: Any) -> list[dict] | None:
    """The two sides of the calculation file's check the finding names."""
    checks = getattr(calc, "checks", None) or {}
    msg = str(finding.get("message") or "")
    name = next((n for n in checks if msg.startswith(f"{n}:")), None)
    if name is None:
        return None
    chk = checks[name]
    t = np.asarray(calc.grid, float)
    blame = str(chk.get("blame") or "")
    left, _, right = str(chk.get("text") or "left ≈ right").partition("≈")
    unit = side_unit(left.strip())
    lhs, label = _display(chk["lhs"], unit, blame)
    rhs, _ = _display(chk["rhs"], unit, blame)
    span = finding_span(finding)
    return [_panel(name, label, [_trace(left.strip() or "left side", t, lhs, 0),
                                 _trace(right.strip() or "right side", t, rhs, 1, dash="dot")],
                   [span] if span else [])]


def finding_figure(test: Any, finding: dict, *, results: dict | None = None,
                   calc: Any = None, vehicle: Any = None, imported: Any = None) -> dict:
    """The figure of one finding (a plotly figure dict), made for its kind.

    Parameters
    ----------
    test : Test
        The test QA ran on (SI signals).
    finding : dict
        The finding as ``findings.json`` / ``results.json`` write it.
    results : dict, optional
        The ``results.json`` document (phase segments of a drive-quality finding).
    calc : CalcResult, optional
        QA's calculations (the two sides of a balance check).
    vehicle : Vehicle, optional
        The template's vehicle (the engine fuel map).
    imported : Test, optional
        The test as imported: a signal QA dropped from ``test`` is drawn from it.

    Returns
    -------
    dict
        ``data`` and ``layout``; ``layout.meta.units`` lists the display unit of each panel
        (one per y axis).
    """
    kind = finding.get("kind")
    panels = None
    if kind == "drive_quality":
        panels = _drive_quality(test, finding, results)
    elif kind == "fuel_map":
        panels = _fuel_map(test, finding, vehicle)
    elif kind in ("sign_flip", "calc_mismatch"):
        panels = _check(finding, calc)
    if not panels:
        names = [finding.get("signal") or "", *(finding.get("related") or [])]
        names = [n for i, n in enumerate(names) if n and n not in names[:i]]
        panels = _by_unit([test, imported], names, finding_span(finding))
    fig = time_traces_figure(panels, row_height=150)
    title = f"{kind}: {finding.get('signal') or ''}"
    if not fig["data"]:
        title += " (no samples of its signals in the test to draw)"
    fig["layout"]["title"] = {"text": title, "font": {"size": 13}, "x": 0.01}
    fig["layout"]["margin"]["t"] = 40
    fig["layout"]["meta"] = {"units": [p["unit"] for p in panels], "kind": kind,
                             "points": int(sum(np.size(tr["x"]) for tr in fig["data"]))}
    return fig


def panel_units(fig: dict) -> dict[str, set[str]]:
    """y axis -> the display units of the traces drawn on it (each trace's ``meta.unit``;
    the axis title's ``[unit]`` for a trace without one), for the check that no axis
    carries two units."""
    out: dict[str, set[str]] = {}
    layout = fig.get("layout") or {}
    for tr in fig.get("data") or []:
        axis = "yaxis" + str(tr.get("yaxis", "y"))[1:]
        unit = (tr.get("meta") or {}).get("unit") if isinstance(tr.get("meta"), dict) else None
        if unit is None:
            title = ((layout.get(axis) or {}).get("title") or {}).get("text", "")
            unit = title.rsplit("[", 1)[1].rstrip("]") if title.endswith("]") and "[" in title \
                else ""
        out.setdefault(axis, set()).add(unit)
    return out
