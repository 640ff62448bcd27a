"""Sensitivity of charge-balanced fuel economy to the uncertain parameters of a vehicle.

Each parameter with an ``uncertainty`` in the vehicle file (see
:class:`vehval.vehicle.base.Block`) is set to the low and the high end of its range, one at
a time, on every cycle. Per cycle the initial SOC of the charge-balanced base run is used
for every variant and the result is the SOC-corrected fuel economy (SAE J1711 energy
method, see :func:`vehval.sim.simulate.summarise`): the variants then differ from the
base only by the parameter, not by a re-balanced SOC. Variants of scalar parameters run
in one parallel compiled call per cycle; curves and maps run one by one.

An optional Monte Carlo draws every parameter at once (uniform over a range or scale,
normal for a relative standard deviation) and reports the 5/50/95 % fuel economy per cycle.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np

from vehval import progress
from vehval.errors import ConfigError
from vehval.sim.batch import simulate_batch
from vehval.sim.simulate import simulate
from vehval.vehicle import BLOCKS, Vehicle, load_vehicle
from vehval.vehicle.base import uncertainty_bounds

DEFAULT_CYCLES = ("udds", "hwfet", "us06", "japan1015", "nedc")
MPG = "fuel_economy_soc_corrected_mpg"


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
    for blk in BLOCKS:
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
    for key in params:
        if key not in found:
            raise ConfigError(f"--params: '{key}' has no uncertainty in {where} (parameters "
                              f"with one: {', '.join(sorted(found)) or 'none'})")
        out.append(found[key])
    return out


def _is_map(u: Uncertain) -> bool:
    return "scale" in u.spec


def _run_variants(veh: Vehicle, cycle: str, variants: list[dict], dt: float, soc0: float,
                  workers: int) -> list[float]:
    """SOC-corrected mpg of each variant (nan where the variant is not a valid vehicle)."""
    out = [float("nan")] * len(variants)
    scalar_idx, scalar_rows = [], []
    for k, var in enumerate(variants):
        try:
            v = veh.with_overrides(var)
        except ConfigError:
            continue  # e.g. an end that breaks a consistency rule: reported as nan
        if any(isinstance(x, list) for x in var.values()):
            out[k] = simulate(v, cycle, dt=dt, soc_initial=soc0).summary[MPG]
        else:
            scalar_idx.append(k)
            scalar_rows.append(var)
    if scalar_rows:
        res = simulate_batch(veh, cycle, scalar_rows, dt=dt, workers=workers, soc_initial=soc0)
        for k, r in zip(scalar_idx, res):
            out[k] = r[MPG]
    return out


def sensitivity(vehicle: Vehicle | str, cycles: Sequence[str] = DEFAULT_CYCLES,
                params: Sequence[str] | None = None, dt: float = 1.0, workers: int = 2,
                monte_carlo: int = 0, seed: int = 0) -> dict[str, Any]:
    """One-at-a-time sensitivity (and optional Monte Carlo) of charge-balanced fuel economy.

    Returns
    -------
    dict
        ``vehicle``, ``cycles``, ``dt_s``, ``base`` ({cycle: {``mpg``, ``soc_initial``}}),
        ``parameters``: list ranked by ``swing_pct`` (largest first) of {``key``,
        ``nominal``, ``low``, ``high`` (scalars; curves give their scale factors),
        ``uncertainty``, ``source``, ``cycles``: {cycle: {``low_mpg``, ``high_mpg``,
        ``low_pct``, ``high_pct``}}, ``swing_pct`` (largest |high - low| over the cycles, %
        of the base)}, and ``monte_carlo`` ({cycle: {``p5``, ``p50``, ``p95``, ``n``}}) when
        asked.
    """
    veh = load_vehicle(vehicle)
    unc = uncertain_parameters(veh, params)
    base = {}
    progress.add((3 if monte_carlo else 2) * len(cycles))  # base, variants (, draws) per cycle
    for cyc in cycles:
        r = simulate(veh, cyc, dt=dt, charge_balance=True)
        base[cyc] = {"mpg": r.summary[MPG], "soc_initial": r.summary["soc_initial"]}
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
            res[cyc] = {"low_mpg": lo, "high_mpg": hi, "low_pct": 100 * (lo / b - 1),
                        "high_pct": 100 * (hi / b - 1)}
        swings = [abs(r["high_pct"] - r["low_pct"]) for r in res.values()
                  if np.isfinite(r["high_pct"] - r["low_pct"])]
        scale = u.spec.get("scale")
        rows.append({"key": u.key,
                     "nominal": 1.0 if scale else u.nominal,
                     "low": scale[0] if scale else u.low,
                     "high": scale[1] if scale else u.high,
                     "uncertainty": u.spec, "source": u.source, "cycles": res,
                     "swing_pct": max(swings) if swings else float("nan")})
    rows.sort(key=lambda r: -r["swing_pct"] if np.isfinite(r["swing_pct"]) else 0.0)
    out = {"vehicle": veh.name, "cycles": list(cycles), "dt_s": dt, "base": base,
           "parameters": rows}
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
    return {"data": [{"type": "bar", "orientation": "h", "y": names, "x": lo, "name": "low end",
                      "marker": {"color": "#1f5fa8"}},
                     {"type": "bar", "orientation": "h", "y": names, "x": hi,
                      "name": "high end", "marker": {"color": "#d9480f"}}],
            "layout": {"barmode": "overlay", "height": 120 + 22 * len(rows),
                       "title": {"text": f"{cycle}: fuel economy change [%] "
                                         f"(base {result['base'][cycle]['mpg']:.1f} mpg)"},
                       "xaxis": {"title": {"text": "change of SOC-corrected mpg [%]"}},
                       "margin": {"l": 260, "r": 20, "t": 40, "b": 50}}}
