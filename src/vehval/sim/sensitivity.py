"""Sensitivity of charge-balanced fuel economy to the uncertain parameters of a vehicle.

Each parameter with an ``uncertainty`` in the vehicle file (see
:class:`vehval.vehicle.base.Block`) is set to the low and the high end of its range, one at
a time, on every cycle. The figure is the fuel economy (:func:`figure_key`): for a hybrid
(power-split or parallel) the initial SOC of the charge-balanced base run is used for every
variant and the result is the SOC-corrected fuel economy (the simulator's energy-balance
correction, :func:`vehval.sim.simulate.energy_balance_fuel_kg`): the variants then differ
from the base only by the parameter, not by a re-balanced SOC; a conventional car has no
battery and its plain fuel economy is the figure. A battery-electric car burns no fuel and
is refused. Variants of scalar parameters of a power-split car run in one parallel compiled
call per cycle (:func:`vehval.sim.batch.simulate_batch`); curves, maps and the other
architectures run one by one.

An optional Monte Carlo draws every parameter at once (uniform over a range or scale,
normal for a relative standard deviation) and reports the 5/50/95 % fuel economy per cycle.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np

from vehval import progress
from vehval.constants import LB_KG
from vehval.display import as_unit
from vehval.errors import ConfigError
from vehval.sim.batch import simulate_batch
from vehval.sim.simulate import architecture, simulate
from vehval.vehicle import BLOCKS, Vehicle, load_vehicle
from vehval.vehicle.base import uncertainty_bounds
from vehval.vehicle.definition import absent_categories

DEFAULT_CYCLES = ("udds", "hwfet", "us06", "japan1015", "nedc")
#: the figure of a hybrid: SOC-corrected fuel economy [mpg]
MPG = "fuel_economy_soc_corrected_mpg"
#: the figure of a car without a traction battery: its fuel economy [mpg]
PLAIN_MPG = "fuel_economy_mpg"


def figure_key(veh: Any) -> str:
    """Summary key of the fuel economy the sensitivity reads for ``veh``'s architecture.

    :data:`MPG` (SOC-corrected, from a charge-balanced base run) for a car with a traction
    battery, :data:`PLAIN_MPG` for one without.

    Raises
    ------
    ConfigError
        A car that burns no fuel (battery-electric): it has no fuel economy.
    """
    arch = architecture(veh)
    if "fuel" in absent_categories(arch.name):
        raise ConfigError(f"{veh.file or veh.name} is a '{arch.name}' vehicle: it burns no "
                          "fuel and vehval sensitivity ranks effects on fuel economy; its "
                          "energy consumption is simulated by vehval simulate and stated by "
                          "vehval results (SAE J1634 kWh/100 mi and MPGe)")
    return MPG if arch.has_battery else PLAIN_MPG


def _base_run(veh: Any, cycle: Any, dt: float) -> tuple[float, float, str]:
    """Base figure [mpg], the initial SOC its variants start from (NaN without a battery)
    and the summary key of the figure: charge-balanced for a hybrid, one plain run else."""
    key = figure_key(veh)
    r = simulate(veh, cycle, dt=dt, charge_balance=architecture(veh).has_battery)
    return float(r.summary[key]), float(r.summary.get("soc_initial", float("nan"))), key


@dataclass
class Uncertain:
    """One uncertain parameter: dotted key, nominal, low and high ends, spec and source."""

    key: str
    nominal: Any
    low: Any
    high: Any
    spec: dict
    source: str


def uncertain_parameters(veh: Vehicle, params: Sequence[str] | None = None) -> list[Uncertain]:
    """The parameters of ``veh`` that carry an uncertainty (all, or those named in ``params``).

    Raises
    ------
    ConfigError
        A name in ``params`` that is not a parameter with an uncertainty (names the key and
        the vehicle file).
    """
    found: dict[str, Uncertain] = {}
    blocks = veh._blocks() if hasattr(veh, "_blocks") else BLOCKS  # every architecture's
    for blk in blocks:
        b = getattr(veh, blk, None)
        if b is None or not getattr(b, "uncertainty", None):
            continue
        for name, spec in b.uncertainty.items():
            nominal = getattr(b, name)
            lo, hi = uncertainty_bounds(nominal, spec)
            found[f"{blk}.{name}"] = Uncertain(f"{blk}.{name}", nominal, lo, hi, dict(spec),
                                               b.sources.get(name, ""))
    if params is None:
        return list(found.values())
    where = veh.file or veh.name
    out = []
    for key in dict.fromkeys(params):  # a name given twice is ranked once
        if key not in found:
            raise ConfigError(f"--params: '{key}' has no uncertainty in {where} (parameters "
                              f"with one: {', '.join(sorted(found)) or 'none'})")
        out.append(found[key])
    return out


def _is_map(u: Uncertain) -> bool:
    return "scale" in u.spec


def _run_variants(veh: Vehicle, cycle: str, variants: list[dict], dt: float, soc0: float,
                  workers: int) -> list[float]:
    """Fuel economy [mpg] of each variant (:func:`figure_key`) from SOC ``soc0`` (NaN: a car
    without a battery); nan where the variant is not a valid vehicle. Scalar variants of a
    power-split car share one compiled call (:func:`simulate_batch` packs that kernel)."""
    key = figure_key(veh)
    start = soc0 if np.isfinite(soc0) else None
    out = [float("nan")] * len(variants)
    scalar_idx, scalar_rows = [], []
    for k, var in enumerate(variants):
        try:
            v = veh.with_overrides(var)
        except ConfigError:
            continue  # e.g. an end that breaks a consistency rule: reported as nan
        if isinstance(veh, Vehicle) and not any(isinstance(x, list) for x in var.values()):
            scalar_idx.append(k)
            scalar_rows.append(var)
        else:
            out[k] = simulate(v, cycle, dt=dt, soc_initial=start).summary[key]
    if scalar_rows:
        res = simulate_batch(veh, cycle, scalar_rows, dt=dt, workers=workers, soc_initial=start)
        for k, r in zip(scalar_idx, res):
            out[k] = r[key]
    return out


def swing_pct(per_cycle: dict[str, dict[str, float]]) -> float:
    """A parameter's rank: the largest change of the figure from the base at either end over
    the cycles, ``max |low_pct|, |high_pct|`` [%] (both ends may move it the same way); nan
    when no end gave a figure."""
    ends = [abs(r[k]) for r in per_cycle.values() for k in ("low_pct", "high_pct")
            if np.isfinite(r[k])]
    return max(ends) if ends else float("nan")


def sensitivity(vehicle: Vehicle | str, cycles: Sequence[str] = DEFAULT_CYCLES,
                params: Sequence[str] | None = None, dt: float = 1.0, workers: int = 2,
                monte_carlo: int = 0, seed: int = 0) -> dict[str, Any]:
    """One-at-a-time sensitivity (and optional Monte Carlo) of the fuel economy
    (:func:`figure_key`: charge-balanced SOC-corrected for a hybrid, plain for a
    conventional car). A cycle named twice runs once.

    Returns
    -------
    dict
        ``vehicle``, ``figure`` (the summary key read, :func:`figure_key`), ``cycles``,
        ``dt_s``, ``base`` ({cycle: {``mpg``, ``soc_initial`` (None without a battery)}}), ``parameters``: list ranked by ``swing_pct`` (largest
        first) of {``key``, ``nominal``, ``low``, ``high`` (scalars; curves give their scale
        factors), ``uncertainty``, ``source``, ``cycles``: {cycle: {``low_mpg``,
        ``high_mpg``, ``low_pct``, ``high_pct`` (signed change from the base, %)}},
        ``swing_pct`` (:func:`swing_pct`: the largest |change from the base| of either end
        over the cycles, %)}, and ``monte_carlo`` ({cycle: {``p5``, ``p50``, ``p95``,
        ``n``}}) when asked.

    Raises
    ------
    ConfigError
        A car that burns no fuel, or no parameter with an uncertainty (nothing to rank).
    """
    veh = load_vehicle(vehicle)
    key = figure_key(veh)  # a battery-electric car is refused before anything runs
    cycles = list(dict.fromkeys(cycles))
    unc = uncertain_parameters(veh, params)
    if not unc:
        raise ConfigError(f"{veh.file or veh.name}: no parameter carries an uncertainty, "
                          "nothing to rank: give ranges under a block's 'uncertainty:' in "
                          "the vehicle file (docs/simulation.md), or use --road-load")
    base = {}
    progress.add((3 if monte_carlo else 2) * len(cycles))  # base, variants (, draws) per cycle
    for cyc in cycles:
        mpg, soc0, _ = _base_run(veh, cyc, dt)
        base[cyc] = {"mpg": mpg, "soc_initial": soc0}
        progress.advance()
    rows = []
    variants = [{u.key: u.low} for u in unc] + [{u.key: u.high} for u in unc]
    per_cycle = {}
    for cyc in cycles:
        per_cycle[cyc] = _run_variants(veh, cyc, variants, dt, base[cyc]["soc_initial"], workers)
        progress.advance()
    n = len(unc)
    for j, u in enumerate(unc):
        res = {}
        for cyc in cycles:
            b = base[cyc]["mpg"]
            lo, hi = per_cycle[cyc][j], per_cycle[cyc][n + j]
            res[cyc] = {"low_mpg": lo, "high_mpg": hi, "low_pct": as_unit(lo / b - 1, "%"),
                        "high_pct": as_unit(hi / b - 1, "%")}
        scale = u.spec.get("scale")
        rows.append({"key": u.key,
                     "nominal": 1.0 if scale else u.nominal,
                     "low": scale[0] if scale else u.low,
                     "high": scale[1] if scale else u.high,
                     "uncertainty": u.spec, "source": u.source, "cycles": res,
                     "swing_pct": swing_pct(res)})
    rows.sort(key=lambda r: -r["swing_pct"] if np.isfinite(r["swing_pct"]) else 0.0)
    out = {"vehicle": veh.name, "figure": key, "cycles": cycles, "dt_s": dt,
           "base": base, "parameters": rows}
    if monte_carlo > 0:
        out["monte_carlo"] = _monte_carlo(veh, unc, cycles, dt, base, workers, monte_carlo,
                                          seed)
    return out


def _draw(u: Uncertain, rng: np.random.Generator) -> Any:
    if "rel_sd" in u.spec:
        return u.nominal * (1 + u.spec["rel_sd"] * rng.standard_normal())
    if "range" in u.spec:
        return rng.uniform(*u.spec["range"])
    return (np.asarray(u.nominal, float) * rng.uniform(*u.spec["scale"])).tolist()


def _monte_carlo(veh, unc, cycles, dt, base, workers, n, seed) -> dict[str, Any]:
    rng = np.random.default_rng(seed)
    scalars = [u for u in unc if not _is_map(u)]  # curves stay nominal (one run each)
    variants = [{u.key: _draw(u, rng) for u in scalars} for _ in range(n)]
    out = {}
    for cyc in cycles:
        mpg = np.asarray(_run_variants(veh, cyc, variants, dt, base[cyc]["soc_initial"],
                                       workers))
        ok = mpg[np.isfinite(mpg)]
        p5, p50, p95 = (np.percentile(ok, [5, 50, 95]).tolist() if ok.size
                        else [float("nan")] * 3)
        out[cyc] = {"p5": p5, "p50": p50, "p95": p95, "n": int(ok.size)}
        progress.advance()
    return out


def tornado_figure(result: dict[str, Any], cycle: str, top: int = 20) -> dict:
    """plotly figure JSON: change of fuel economy [%] at the low and high end, ranked."""
    rows = [r for r in result["parameters"] if np.isfinite(r["swing_pct"])][:top][::-1]
    names = [r["key"] for r in rows]
    lo = [r["cycles"][cycle]["low_pct"] for r in rows]
    hi = [r["cycles"][cycle]["high_pct"] for r in rows]
    from vehval.figures import bar_figure

    return bar_figure([{"name": "low end", "x": lo, "y": names, "color": "#1f5fa8"},
                       {"name": "high end", "x": hi, "y": names, "color": "#d9480f"}],
                      horizontal=True, overlay=True, height=120 + 22 * len(rows),
                      title=f"{cycle}: fuel economy change [%] "
                            f"(base {result['base'][cycle]['mpg']:.1f} mpg)",
                      xlabel="change of SOC-corrected mpg [%]"
                      if result.get("figure", MPG) == MPG else "change of mpg [%]",
                      margin={"l": 260, "r": 20, "t": 40, "b": 50})


# --- fuel economy against road load and test weight -------------------------------------

#: body parameters of the road-load derivative (test weight and the coast-down A, B, C)
LOAD_KEYS = ("body.mass_kg", "body.road_load_a_n", "body.road_load_b_n_per_mps",
             "body.road_load_c_n_per_mps2")


def tractive_energy_j(cycle: Any, mass_kg: float, a_n: float, b_n_per_mps: float,
                      c_n_per_mps2: float) -> float:
    """Positive work at the wheels [J] to drive ``cycle`` at a test weight and road load.

    ``∫ max(F v, 0) dt`` with ``F = m dv/dt + A + B v + C v²`` on the cycle's own trace
    (no powertrain, no rotating inertia): the road-load measure the list's figures scale with.
    """
    from vehval.cycles import load_cycle

    cyc = load_cycle(cycle)
    t = np.asarray(cyc.time_s, float)
    v = np.asarray(cyc.speed_mps, float)
    dt = np.diff(t)
    vm = 0.5 * (v[1:] + v[:-1])
    acc = np.diff(v) / dt
    f = mass_kg * acc + a_n * (vm > 0) + b_n_per_mps * vm + c_n_per_mps2 * vm * vm
    return float(np.sum(np.maximum(f * vm, 0.0) * dt))


def load_derivatives(vehicle: Vehicle | str, cycles: Sequence[str] = ("udds", "hwfet", "us06"),
                     dt: float = 0.2, rel_step: float = 0.05,
                     workers: int = 1) -> dict[str, Any]:
    """Elasticities of the fuel economy (:func:`figure_key`) to test weight and road load.

    Each of :data:`LOAD_KEYS` is moved by ``-+rel_step`` (central difference) from the
    vehicle's value, for a hybrid from the initial SOC of the charge-balanced base run; and
    all four together (the road load scaled as a whole, which scales the tractive energy by
    the same factor).

    Returns
    -------
    dict
        {cycle: {``mpg`` (base: SOC-corrected for a hybrid, plain for a conventional car),
        ``soc_initial`` (NaN without a battery), ``tractive_energy_j``, ``elasticity``
        ({key: d ln mpg / d ln x}, plus ``all`` for the four together),
        ``per_100_lb_pct`` and ``per_100_kg_pct`` (mpg change [%] per 100 lb and per 100 kg
        of test weight)}}.
    """
    veh = load_vehicle(vehicle)
    figure_key(veh)  # a battery-electric car is refused before anything runs
    b = veh.body
    out: dict[str, Any] = {}
    base_vals = {k: float(getattr(b, k.split(".", 1)[1])) for k in LOAD_KEYS}
    variants: list[dict[str, float]] = []
    for k in LOAD_KEYS:
        variants += [{k: base_vals[k] * (1 - rel_step)}, {k: base_vals[k] * (1 + rel_step)}]
    variants += [{k: v * (1 - rel_step) for k, v in base_vals.items()},
                 {k: v * (1 + rel_step) for k, v in base_vals.items()}]
    step = np.log((1 + rel_step) / (1 - rel_step))
    mass = base_vals["body.mass_kg"]
    for cyc in dict.fromkeys(cycles):
        base, soc0, _ = _base_run(veh, cyc, dt)
        mpg = _run_variants(veh, cyc, variants, dt, soc0, workers)
        el = {}
        for j, k in enumerate([*LOAD_KEYS, "all"]):
            el[k] = float(np.log(mpg[2 * j + 1] / mpg[2 * j]) / step)
        # 100 lb and 100 kg of test weight [kg]: steps of weight, not unit conversions
        steps = {"per_100_lb_pct": 100.0 * LB_KG, "per_100_kg_pct": 100.0}  # not a unit conversion
        out[cyc] = {"mpg": base, "soc_initial": soc0,
                    "tractive_energy_j": tractive_energy_j(cyc, *base_vals.values()),
                    "elasticity": el,
                    **{name: as_unit(el["body.mass_kg"] * kg / mass, "%")
                       for name, kg in steps.items()}}
    return {"vehicle": veh.name, "dt_s": dt, "rel_step": rel_step, "cycles": out}


#: the cycle whose trace measures a procedure's road load (an FTP-75 drives the UDDS)
PROCEDURE_CYCLE = {"ftp75": "udds", "hwfet": "hwfet", "us06": "us06"}


def _side(prefix: str, cfg: tuple, labels: set[str]) -> dict[str, Any]:
    """One configuration of a pair: its label (weight and A in SI), selections, weight, A."""
    sel = "/".join(sorted(labels))
    return {prefix: f"{sel} ({cfg[0]:.0f} kg, A {cfg[1]:.1f} N)", f"{prefix}_selection": sel,
            f"{prefix}_mass_kg": cfg[0], f"{prefix}_road_load_a_n": cfg[1]}


def configuration_pairs(rows: Sequence[dict[str, Any]]) -> list[dict[str, Any]]:
    """Fuel economy between test configurations, measured (list) against predicted (model).

    Parameters
    ----------
    rows : sequence of dict
        One whole-test figure each: ``procedure`` (``ftp75``, ``hwfet``, ``us06``),
        ``mass_kg``, ``road_load_a_n``, ``road_load_b_n_per_mps``,
        ``road_load_c_n_per_mps2``, ``measured_mpg``, ``predicted_mpg``, ``label`` (the
        selection it came from).

    Returns
    -------
    list of dict
        Per procedure, every configuration (weight and road load) against the one with the
        largest tractive energy: ``procedure``, ``reference``, ``config`` (labels with the
        test weight and A), ``n_ref``, ``n``, ``tractive_change_pct`` (tractive energy over
        the procedure's cycle), ``measured_change_pct`` and ``predicted_change_pct`` (mean
        mpg), ``measured_elasticity`` and ``predicted_elasticity`` (-d ln mpg / d ln
        tractive energy). A car without regenerative braking whose losses all scale with the
        road load at a constant efficiency has 1; fixed losses make it smaller; a hybrid
        recovers part of the inertial work, and less road load leaves more of it to recover,
        which can make it larger (on a UDDS). The labels state the weight and A in SI
        (kg, N); ``reference_mass_kg``, ``reference_road_load_a_n``, ``config_mass_kg``,
        ``config_road_load_a_n`` and ``reference_selection``, ``config_selection`` (the
        selections' labels) give them apart for display in any unit system.
    """
    groups: dict[tuple, dict[str, Any]] = {}
    for r in rows:
        if r["procedure"] not in PROCEDURE_CYCLE or r.get("measured_mpg") is None:
            continue
        cfg = tuple(round(float(r[k]), 4) for k in
                    ("mass_kg", "road_load_a_n", "road_load_b_n_per_mps",
                     "road_load_c_n_per_mps2"))
        g = groups.setdefault((r["procedure"], cfg), {"meas": [], "pred": [], "labels": set()})
        g["meas"].append(float(r["measured_mpg"]))
        g["pred"].append(float(r["predicted_mpg"]))
        g["labels"].add(str(r.get("label", "")))
    out = []
    for proc in PROCEDURE_CYCLE:
        cfgs = [(cfg, g) for (p, cfg), g in groups.items() if p == proc]
        if len(cfgs) < 2:
            continue
        energy = {cfg: tractive_energy_j(PROCEDURE_CYCLE[proc], *cfg) for cfg, _ in cfgs}
        ref_cfg, ref = max(cfgs, key=lambda c: energy[c[0]])
        m0, p0 = float(np.mean(ref["meas"])), float(np.mean(ref["pred"]))
        for cfg, g in cfgs:
            if cfg == ref_cfg:
                continue
            de = np.log(energy[cfg] / energy[ref_cfg])
            dm = np.log(float(np.mean(g["meas"])) / m0)
            dp = np.log(float(np.mean(g["pred"])) / p0)
            out.append({"procedure": proc, **_side("reference", ref_cfg, ref["labels"]),
                        **_side("config", cfg, g["labels"]), "n_ref": len(ref["meas"]),
                        "n": len(g["meas"]), "tractive_change_pct": as_unit(float(np.expm1(de)), "%"),
                        "measured_change_pct": as_unit(float(np.expm1(dm)), "%"),
                        "predicted_change_pct": as_unit(float(np.expm1(dp)), "%"),
                        "measured_elasticity": float(-dm / de) if de else float("nan"),
                        "predicted_elasticity": float(-dp / de) if de else float("nan")})
    return out
