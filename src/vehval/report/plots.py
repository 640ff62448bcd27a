"""Engineering plots: operating points on component maps, histograms, Willans lines, Sankey.

Every function returns a :class:`plotly.graph_objects.Figure` built by the figure layer
(:mod:`vehval.figures.engineering`), or ``None`` together with a
note (via :class:`PlotSkipped`) when the data it needs is absent, so callers can say why a
plot is missing. Speeds are drawn in rpm and powers in kW for readability; the data stays SI.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from vehval.constants import RPM_RAD_PER_S
from vehval.display import as_unit
from vehval.equations.engine_state import engine_running
from vehval.figures.engineering import sankey_figure as _sankey
from vehval.figures.engineering import trace_figure
from vehval.fuels import resolve_fuel
from vehval.integrals import integral
from vehval.test import Test

RPM = RPM_RAD_PER_S  # [rad/s] per rpm
MAX_POINTS = 4000


class PlotSkipped(Exception):
    """Raised when a plot cannot be drawn; the message says why (shown in the report)."""


# ----------------------------------------------------------------------------- helpers

def _test_lhv(test: Test) -> float | None:
    """The LHV [J/kg] of the test's declared fuel (:func:`vehval.fuels.resolve_fuel`)."""
    fuel = resolve_fuel(test=test)
    return fuel.lhv_j_per_kg if fuel is not None else None


def pick(test: Test, base: str, origins: tuple[str, ...] = ("test", "calc", "simu")):
    """The signal of ``base`` to plot (:meth:`vehval.test.Test.best`), or None."""
    return test.best(base, origins)


def common(test: Test, bases: tuple[str, ...], origins: tuple[str, ...] = ("test", "calc", "simu"),
           ) -> tuple[np.ndarray, list[np.ndarray], list[str]]:
    """Signals of several bases on the time base of the first one.

    Returns
    -------
    time : numpy.ndarray
        [s]
    values : list of numpy.ndarray
        One array per base (SI), NaN outside each signal's span.
    names : list of str
        Signal used for each base.

    Raises
    ------
    PlotSkipped
        When a base has no signal.
    """
    sigs = []
    for b in bases:
        s = pick(test, b, origins)
        if s is None:
            raise PlotSkipped(f"no {b} signal")
        sigs.append(s)
    t = sigs[0].time
    return t, [s.values if s is sigs[0] else s.at(t) for s in sigs], [s.name for s in sigs]


def _thin(*arrays: np.ndarray, n: int = MAX_POINTS) -> list[np.ndarray]:
    size = arrays[0].size
    if size <= n:
        return list(arrays)
    idx = np.linspace(0, size - 1, n).astype(int)
    return [a[idx] for a in arrays]


def _component(vehicle: Any, *names: str) -> Any:
    for n in names:
        comp = getattr(vehicle, n, None)
        if comp is None and isinstance(vehicle, dict):
            comp = vehicle.get(n)
        if comp is not None:
            return comp
    return None


# ----------------------------------------------------------------------------- maps
def engine_map_figure(test: Test, vehicle: Any) -> Any:
    """Engine operating points on the fuel-map efficiency contours with the best-efficiency line.

    Parameters
    ----------
    test : Test
        Uses ``eng_spd_out`` [rad/s] and ``eng_trq_out`` [N·m] (test, else calc, else simu).
    vehicle : vehval.vehicle.Vehicle
        Its ``engine`` parameters give the fuel map (``speed_rpm``, ``torque_nm``,
        ``fuel_rate_g_per_s``), full-load curve and fuel heating value.
    """
    eng = _component(vehicle, "engine", "eng")
    if eng is None or not hasattr(eng, "fuel_rate_g_per_s"):
        raise PlotSkipped("no vehicle engine fuel map")
    spd = np.asarray(eng.speed_rpm, float)
    trq = np.asarray(eng.torque_nm, float)
    fuel = np.asarray(eng.fuel_rate_g_per_s, float) / as_unit(1.0, "g/s")  # [kg/s], rows = speed
    lhv = float(eng.fuel_lhv_j_per_kg)
    pw = (spd[:, None] * RPM) * trq[None, :]
    with np.errstate(divide="ignore", invalid="ignore"):
        eff = as_unit(np.where((fuel > 0) & (pw > 0), pw / (fuel * lhv), np.nan), "%")
    tmax = np.asarray(eng.max_torque_nm, float)
    eff = np.where(trq[None, :] <= np.interp(spd, spd, tmax)[:, None] * 1.02, eff, np.nan)
    traces: list[tuple[str, dict]] = [
        ("Contour", dict(x=spd, y=trq, z=eff.T, name="efficiency [%]", colorscale="Blues",
                         contours={"start": 10, "end": 40, "size": 2, "showlabels": True},
                         colorbar={"title": {"text": "eff. [%]"}}, opacity=0.75,
                         hovertemplate="%{x:.0f} rpm, %{y:.0f} N·m: %{z:.1f} %<extra></extra>")),
        ("Scatter", dict(x=spd, y=tmax, mode="lines", name="full load",
                         line={"color": "#212529", "width": 2}))]
    try:
        from vehval.vehicle.maps import best_efficiency_line
        _, w, t = best_efficiency_line(eng)
        traces.append(("Scatter", dict(x=w / RPM, y=t, mode="lines", name="best efficiency",
                                       line={"color": "#2b8a3e", "width": 3, "dash": "dash"})))
    except Exception:  # noqa: BLE001 - the line is optional decoration (older vehicle models)
        pass
    try:
        tt, (w, tq), names = common(test, ("eng_spd_out", "eng_trq_out"))
        on = np.isfinite(w) & np.isfinite(tq) & engine_running(tt, w)
        x, y = _thin(w[on] / RPM, tq[on])
        traces.append(("Scatter", dict(x=x, y=y, mode="markers",
                                       name=f"engine running ({names[0]})",
                                       marker={"size": 4, "color": "#d9480f", "opacity": 0.5})))
    except PlotSkipped:
        pass
    return trace_figure(traces, title="Engine operating points on the efficiency map",
                        xlabel="engine speed [rpm]", ylabel="engine torque [N·m]")


def machine_efficiency(speed_rpm: np.ndarray, torque_nm: np.ndarray, loss_w: np.ndarray) -> np.ndarray:
    """Efficiency [%] of an electric machine with inverter from its loss map.

    Motoring (``T·ω > 0``): ``P / (P + loss)``; generating: ``(|P| − loss) / |P|``, with
    ``P = T·ω`` the mechanical power [W]; NaN at zero power.
    """
    pm = (np.asarray(speed_rpm, float)[:, None] * RPM) * np.asarray(torque_nm, float)[None, :]
    loss = np.asarray(loss_w, float)
    a = np.abs(pm)
    with np.errstate(divide="ignore", invalid="ignore"):
        eff = np.where(pm > 0, pm / (pm + loss), (a - loss) / a)
    eff = np.where(a > 1.0, eff, np.nan)
    return as_unit(np.clip(eff, 0.0, 1.0), "%")


def machine_map_figure(test: Test, vehicle: Any, which: str) -> Any:
    """Motor (``mot``, MG2) or generator (``gen``, MG1) operating points on the efficiency map.

    The map is the vehicle's ``mg2``/``mg1`` loss map (``speed_rpm``, ``torque_nm``,
    ``loss_w``) turned into efficiency by :func:`machine_efficiency`, with the torque
    envelope ``min(max_torque_nm, max_power_w / |ω|)``. Operating points come from
    ``<mot|gen>_spd_out`` [rad/s] and ``<mot|gen>_trq_out`` [N·m].
    """
    base = {"mot": "mot", "gen": "gen"}[which]
    comp = _component(vehicle, *(("mg2", "motor", "mot") if which == "mot" else ("mg1", "generator", "gen")))
    title = "Motor (MG2)" if which == "mot" else "Generator (MG1)"
    traces: list[tuple[str, dict]] = []
    if comp is not None and hasattr(comp, "loss_w"):
        spd, trq = np.asarray(comp.speed_rpm, float), np.asarray(comp.torque_nm, float)
        traces.append(("Contour", dict(
            x=spd, y=trq, z=machine_efficiency(spd, trq, comp.loss_w).T,
            colorscale="Blues", opacity=0.75, name="efficiency [%]",
            contours={"start": 50, "end": 98, "size": 4, "showlabels": True},
            colorbar={"title": {"text": "eff. [%]"}},
            hovertemplate="%{x:.0f} rpm, %{y:.0f} N·m: %{z:.1f} %<extra></extra>")))
        w = np.linspace(spd.min(), spd.max(), 200)
        with np.errstate(divide="ignore"):
            env = np.minimum(comp.max_torque_nm, comp.max_power_w / np.abs(w * RPM))
        traces += [("Scatter", dict(x=w, y=env, mode="lines", name="torque limit",
                                    line={"color": "#212529"})),
                   ("Scatter", dict(x=w, y=-env, mode="lines", name="torque limit",
                                    showlegend=False, line={"color": "#212529"}))]
    try:
        _, (w, tq), names = common(test, (f"{base}_spd_out", f"{base}_trq_out"))
        ok = np.isfinite(w) & np.isfinite(tq)
        x, y = _thin(w[ok] / RPM, tq[ok])
        traces.append(("Scatter", dict(x=x, y=y, mode="markers",
                                       name=f"operating points ({names[0]})",
                                       marker={"size": 4, "color": "#d9480f", "opacity": 0.5})))
        subtitle = "operating points"
    except PlotSkipped as exc:
        if not traces:
            raise PlotSkipped(f"no {title} map and {exc}") from None
        subtitle = f"map only: {exc}"
    return trace_figure(traces, title=f"{title}: {subtitle}", xlabel="speed [rpm]",
                        ylabel="torque [N·m]")


# ----------------------------------------------------------------------------- histograms
def regen_current_histogram(test: Test) -> Any:
    """Battery current [A] while braking: vehicle moving and decelerating (dv/dt < −0.1 m/s²).

    The current is ``ess_curr``; without it, ``ess_pwr / ess_volt`` (current positive when
    discharging, like the power).
    """
    try:
        t, (i, v), names = common(test, ("ess_curr", "veh_spd"))
    except PlotSkipped:
        try:
            t, (p, u, v), names = common(test, ("ess_pwr", "ess_volt", "veh_spd"))
        except PlotSkipped:
            raise PlotSkipped("no ess_curr signal, nor ess_pwr and ess_volt") from None
        with np.errstate(divide="ignore", invalid="ignore"):
            i = np.where(u > 1.0, p / u, np.nan)
        names = [f"{names[0]} / {names[1]}", names[2]]
    acc = np.gradient(np.where(np.isfinite(v), v, 0.0), t) if t.size > 1 else np.zeros_like(t)
    mask = np.isfinite(i) & (v > 0.5) & (acc < -0.1)
    if not mask.any():
        raise PlotSkipped("no braking phase (deceleration below −0.1 m/s² while moving)")
    return trace_figure([("Histogram", dict(x=i[mask], nbinsx=60, name=names[0],
                                            marker={"color": "#1f5fa8"}))],
                        title=f"Battery current during braking ({mask.sum()} samples)",
                        xlabel=f"{names[0]} [A]", ylabel="samples", height=380, vline=0.0)


def engine_power_histogram(test: Test) -> Any:
    """Distribution of engine power [kW] while the engine runs (by its speed, the rule of
    :mod:`vehval.equations.engine_state`; every sample without a speed)."""
    p = pick(test, "eng_pwr_out")
    if p is not None:
        pw, name = p.values, p.name
        try:
            tt, (_, w), _ = common(test, ("eng_pwr_out", "eng_spd_out"))
            running = engine_running(tt, w) & np.isfinite(w)
        except PlotSkipped:
            running = np.ones(pw.shape, bool)
    else:
        tt, (w, tq), names = common(test, ("eng_spd_out", "eng_trq_out"))
        pw, name = w * tq, f"{names[0]} × {names[1]}"
        running = engine_running(tt, w) & np.isfinite(w)
    on = np.isfinite(pw) & running
    if not on.any():
        raise PlotSkipped("engine never on")
    return trace_figure([("Histogram", dict(x=as_unit(pw[on], "kW"), nbinsx=50, name=name,
                                            marker={"color": "#d9480f"}))],
                        title="Engine power while running", xlabel="engine power [kW]",
                        ylabel="samples", height=380)


# ----------------------------------------------------------------------------- Willans
def willans(test: Test, lhv_j_per_kg: float | None = None) -> dict:
    """Willans line: fuel power [W] = slope × engine power [W] + intercept, engine running.

    Returns
    -------
    dict
        ``eng_pwr`` and ``fuel_pwr`` arrays [W] of the running samples, ``slope`` [-]
        (inverse marginal efficiency), ``intercept`` [W] (fuel power at zero output),
        ``marginal_efficiency`` [-] and ``r2`` [-].
    """
    lhv = lhv_j_per_kg or _test_lhv(test)
    fp = pick(test, "fuel_pwr")
    if fp is not None:
        t, fuel = fp.time, fp.values
    else:
        fr = pick(test, "fuel_rate")
        if fr is None:
            raise PlotSkipped("no fuel_rate or fuel_pwr signal")
        if not lhv:
            raise PlotSkipped("no fuel declared (template 'fuel:'): fuel power unknown")
        t, fuel = fr.time, fr.values * lhv
    ep = pick(test, "eng_pwr_out")
    if ep is not None:
        pw = ep.at(t)
    else:
        w, tq = pick(test, "eng_spd_out"), pick(test, "eng_trq_out")
        if w is None or tq is None:
            raise PlotSkipped("no engine power (eng_pwr_out or eng_spd_out and eng_trq_out)")
        pw = w.at(t) * tq.at(t)
    on = np.isfinite(pw) & np.isfinite(fuel) & (fuel > 0) & (pw > 0)
    if on.sum() < 3 or np.ptp(pw[on]) <= 0:
        raise PlotSkipped("too few running samples for a Willans line")
    slope, icpt = np.polyfit(pw[on], fuel[on], 1)
    r2 = float(np.corrcoef(pw[on], fuel[on])[0, 1] ** 2)
    return {"eng_pwr": pw[on], "fuel_pwr": fuel[on], "slope": float(slope), "intercept": float(icpt),
            "marginal_efficiency": float(1.0 / slope) if slope else float("nan"), "r2": r2}


def willans_figure(test: Test, lhv_j_per_kg: float | None = None) -> Any:
    """Scatter of fuel power against engine power [kW] with the fitted Willans line."""
    w = willans(test, lhv_j_per_kg)
    x, y = _thin(as_unit(w["eng_pwr"], "kW"), as_unit(w["fuel_pwr"], "kW"))
    xs = np.array([0.0, float(np.max(w["eng_pwr"]))])
    return trace_figure([
        ("Scatter", dict(x=x, y=y, mode="markers", name="engine running",
                         marker={"size": 4, "opacity": 0.45})),
        ("Scatter", dict(x=as_unit(xs, "kW"), y=as_unit(w["slope"] * xs + w["intercept"], "kW"),
                         mode="lines",
                         name=(f"fuel = {w['slope']:.3f}·P + {as_unit(w['intercept'], 'kW'):.2f} kW "
                               f"(marginal eff. {as_unit(w['marginal_efficiency'], '%'):.1f} %, "
                               f"R² = {w['r2']:.3f})"),
                         line={"color": "#d9480f", "width": 2}))],
        title="Willans line", xlabel="engine power [kW]", ylabel="fuel power [kW]")


# ----------------------------------------------------------------------------- Sankey
def _energy(test: Test, base: str, origins: tuple[str, ...], sign: int = 0, scale: float = 1.0) -> float | None:
    s = pick(test, base, origins)
    if s is None or s.time.size < 2:
        return None
    v = np.asarray(s.values, float) * scale
    if sign > 0:
        v = np.maximum(v, 0.0)
    elif sign < 0:
        v = np.maximum(-v, 0.0)
    return _known(integral(s.time, v))


def _known(x: float) -> float | None:
    """``x``, or None when the integral could not be formed (fewer than two finite samples)."""
    return x if np.isfinite(x) else None


def energy_flows(test: Test, origin: str = "test", lhv_j_per_kg: float | None = None) -> dict[str, float]:
    """Energies [J] over the test from the power signals of one origin (``test`` → also ``calc``).

    Returns a dict with ``fuel`` (fuel chemical energy), ``engine`` (engine output),
    ``battery_out`` / ``battery_in`` (discharge and charge), ``wheel_out`` (positive
    tractive energy at the wheels), ``road_load`` (``veh_frc_loss`` × ``veh_spd``) and
    ``braking`` (negative wheel energy), each present only when its signals are.
    Battery power is positive when discharging.
    """
    origins = (origin, "calc") if origin == "test" else (origin,)
    lhv = lhv_j_per_kg or _test_lhv(test)
    out: dict[str, float] = {}
    fuel = _energy(test, "fuel_pwr", origins) or (
        _energy(test, "fuel_rate", origins, scale=lhv) if lhv else None)
    eng = _energy(test, "eng_pwr_out", origins, sign=+1)
    if eng is None:
        w, tq = pick(test, "eng_spd_out", origins), pick(test, "eng_trq_out", origins)
        if w is not None and tq is not None:
            eng = _known(integral(w.time, np.maximum(w.values * tq.at(w.time), 0.0)))
    for key, val in (("fuel", fuel), ("engine", eng),
                     ("battery_out", _energy(test, "ess_pwr", origins, sign=+1)),
                     ("battery_in", _energy(test, "ess_pwr", origins, sign=-1))):
        if val is not None:
            out[key] = val
    wheel = pick(test, "whl_pwr_out", origins)
    if wheel is None:
        f, v = pick(test, "veh_frc_in", origins), pick(test, "veh_spd", origins)
        if f is not None and v is not None:
            p, tw = f.values * v.at(f.time), f.time
        else:
            p = tw = None
    else:
        p, tw = np.asarray(wheel.values, float), wheel.time
    if p is not None and tw.size > 1:
        out["wheel_out"] = integral(tw, np.maximum(p, 0.0))
        out["braking"] = integral(tw, np.maximum(-p, 0.0))
    fl, v = pick(test, "veh_frc_loss", origins), pick(test, "veh_spd", origins)
    if fl is not None and v is not None and fl.time.size > 1:
        out["road_load"] = integral(fl.time, fl.values * v.at(fl.time))
    return {k: x for k, x in out.items() if np.isfinite(x)}


def sankey_figure(flows: dict[str, float], title: str = "Energy flow over the test") -> Any:
    """Sankey diagram [MJ] from fuel and battery to the wheels and the losses.

    Nodes: fuel → engine → powertrain (planetary, MG1, MG2, inverters) ← battery discharge;
    powertrain → wheels, battery charge and powertrain losses (the balance, clipped at 0);
    engine → engine losses. Missing quantities are left out.
    """
    if "fuel" not in flows and "battery_out" not in flows:
        raise PlotSkipped("no fuel or battery energy")
    nodes = ["Fuel", "Engine", "Engine losses", "Battery (discharge)", "Powertrain",
             "Wheels (traction)", "Battery (charge)", "Powertrain losses", "Road load",
             "Inertia and brakes"]
    links: list[tuple[int, int, float]] = []

    def link(a: str, b: str, v: float | None) -> None:
        if v is not None and v > 0:
            links.append((nodes.index(a), nodes.index(b), float(as_unit(v, "MJ"))))

    fuel, eng = flows.get("fuel"), flows.get("engine")
    if fuel is not None and eng is None:
        eng = 0.0
    link("Fuel", "Engine", fuel)
    if fuel is not None and eng is not None:
        link("Engine", "Engine losses", max(fuel - eng, 0.0))
        link("Engine", "Powertrain", eng)
    link("Battery (discharge)", "Powertrain", flows.get("battery_out"))
    inflow = (eng or 0.0) + flows.get("battery_out", 0.0)
    wheel, charge = flows.get("wheel_out"), flows.get("battery_in")
    link("Powertrain", "Wheels (traction)", wheel)
    link("Powertrain", "Battery (charge)", charge)
    if wheel is not None:
        link("Powertrain", "Powertrain losses", max(inflow - wheel - (charge or 0.0), 0.0))
        road = flows.get("road_load")
        if road is not None:
            link("Wheels (traction)", "Road load", min(road, wheel))
            link("Wheels (traction)", "Inertia and brakes", max(wheel - road, 0.0))
    return _sankey(nodes, links, title=title,
                   colors=["#e67700", "#d9480f", "#adb5bd", "#2b8a3e", "#1f5fa8", "#0b7285",
                           "#2b8a3e", "#adb5bd", "#868e96", "#868e96"])
