"""Traces for the page: min/max-decimated for the whole test, exact when zoomed in."""

from __future__ import annotations

import numpy as np

from vehval.report.decimate import decimate_minmax

#: Most points sent for one trace (about two per pixel of a wide plot).
MAX_POINTS = 4000


def _finite_or_none(a: np.ndarray) -> list:
    return [None if not np.isfinite(x) else float(x) for x in a]


def series(time: np.ndarray, values: np.ndarray, t0: float | None = None,
           t1: float | None = None, n: int = MAX_POINTS) -> dict:
    """A trace for a plot, within ``[t0, t1]`` [s] (the whole trace when not given).

    Parameters
    ----------
    time, values : numpy.ndarray
        Samples (time [s] non-decreasing; values in the unit shown).
    t0, t1 : float, optional
        Window of the plot [s].
    n : int
        Most points returned: a window holding more samples is min/max decimated
        (:func:`vehval.report.decimate.decimate_minmax`, every extreme kept), a smaller one is
        returned exactly.

    Returns
    -------
    dict
        ``t``, ``y`` (lists, ``None`` for NaN), ``exact`` (True when every sample of the
        window is there), ``n_window`` (samples in the window), ``span`` ([first, last] [s]).
    """
    t = np.asarray(time, float)
    y = np.asarray(values, float)
    n = int(min(max(n, 10), 20_000))
    span = [float(t[0]), float(t[-1])] if t.size else [0.0, 0.0]
    if t0 is not None or t1 is not None:
        lo = int(np.searchsorted(t, -np.inf if t0 is None else t0, side="left"))
        hi = int(np.searchsorted(t, np.inf if t1 is None else t1, side="right"))
        lo, hi = max(lo - 1, 0), min(hi + 1, t.size)  # one sample beyond each edge
        t, y = t[lo:hi], y[lo:hi]
    m = t.size
    exact = m <= n
    if not exact:
        td, yd = decimate_minmax(t, y, max((n - 2) // 2, 1))
        if td.size > n:  # gaps keep a third point per bucket
            td, yd = decimate_minmax(t, y, max((n - 2) // 3, 1))
        t, y = td, yd
    return {"t": _finite_or_none(t), "y": _finite_or_none(y), "exact": bool(exact),
            "n_window": int(m), "span": span}


def series_figure(s: dict, name: str, unit: str, title: str) -> dict:
    """The figure of one trace of :func:`series` (already windowed and decimated) on one
    axis in ``unit`` (the report's figure layer), as plotly JSON the page draws."""
    import json

    from vehval.report.figures import figure_json, one_axis_figure

    t = np.array([np.nan if v is None else v for v in s["t"]], float)
    y = np.array([np.nan if v is None else v for v in s["y"]], float)
    fig = one_axis_figure([{"name": name, "t": t, "y": y}], unit=unit or "", ylabel=name,
                          n_buckets=0)
    fig["layout"]["title"] = {"text": title, "font": {"size": 13}, "x": 0.01}
    fig["layout"]["meta"].update(exact=bool(s["exact"]), points=int(t.size))
    return json.loads(figure_json(fig))
