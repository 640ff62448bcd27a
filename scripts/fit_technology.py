"""Fit the generic technology coefficients on one Test Car List year, judge them on another.

The cars of the fit list (the fleet planner's runnable gasoline cars,
:func:`vehval.epa.fleet.plan_fleet`; every ``--every``-th car) are predicted on a grid of
friction scale x idle factor (:mod:`vehval.epa.technology`); the fuel of the model is
exactly inverse in the indicated efficiency, so the efficiency of each engine technology
is closed-form (the median log error set to zero), and each transmission family's gearbox
efficiency is the family's residual median (fuel about inverse in it). Per engine
technology the grid point of the least mean |log error| is kept. Intervals: 2.5-97.5 %
percentiles over ``--boot`` bootstrap resamples of the cars (the whole choice repeated).
Then every runnable row of the judge list is predicted with the fitted coefficients
(out-of-sample) and the figures of the acceptance are printed: median |error| per
procedure, the share within 5 %, the mean HWFET / FTP-75 bias across cars, the median bias
per technology group.

Usage::

    python scripts/fit_technology.py 16tstcar.csv 19tstcar.csv [--every 3] [--dt 0.5] \
        [--write-yaml src/vehval/data/epa/technology_coefficients.yaml] [--json out.json] \
        [--fuel diesel]

``--fuel diesel`` fits the compression-ignition engine alone on the list's diesel cars
(its efficiency, friction and idle; the gearbox families and the spark-ignition values are
kept as the coefficients file has them).
"""

from __future__ import annotations

import argparse
import dataclasses
import itertools
import json
import math
import re
import sys
import time
from collections import defaultdict

import numpy as np

from vehval.epa import technology as tech
from vehval.epa.fleet import plan_fleet, read_fleet
from vehval.epa.procedures import plan_for
from vehval.epa.specs import INDICATED_EFFICIENCY, vehicle_from_specs
from vehval.epa.validation import predict_test
from vehval.errors import VehvalError

KEYS = ("ftp75", "hwfet", "us06")
GRID_KEYS = ("friction_scale", "idle_factor", "pumping_bar", "accessory_power_w")
FRICTION_GRID = (0.4, 0.5, 0.75)
IDLE_GRID = (2.0, 2.5, 3.0)
PUMPING_GRID = (0.4, 0.8, 1.2)  # [bar]
ACCESSORY_GRID = (300.0, 600.0, 900.0, 1200.0)  # [W]
#: the diesel's grid: no throttle (pumping 0), friction around its starting 1.3, idle on
#: or above its Willans line; its gearbox efficiencies are the gasoline fit's (not refitted
#: on the few diesel cars) and its efficiency has no specific-power exponent
DIESEL_GRID = ((1.0, 1.3, 1.6), (1.0, 1.5, 2.0, 2.5), (0.0,), (300.0, 600.0))


def with_values(base: tech.Coefficients, engine: dict, trans: dict, note: str,
                scales: dict | None = None) -> tech.Coefficients:
    """A copy of ``base`` with engine {tech: {key: value}}, transmission {family: eff} and
    upshift scales {family: scale}."""
    eng = {t: dict(v) for t, v in base.engine.items()}
    for t, vals in engine.items():
        for k, x in vals.items():
            eng[t][k] = tech.Coefficient(float(x), (float(x), float(x)), note)
    tr = {f: dict(v) for f, v in base.transmission.items()}
    for f, x in trans.items():
        tr[f]["efficiency"] = tech.Coefficient(float(x), (float(x), float(x)), note)
    for f, x in (scales or {}).items():
        tr[f]["upshift_scale"] = tech.Coefficient(float(x), (float(x), float(x)), note)
    return dataclasses.replace(base, engine=eng, transmission=tr)


def judged_jobs(path: str, dt: float, every: int = 1, fuel: str = "gasoline") -> list:
    """The fleet planner's car jobs of one list on ``fuel`` (every ``every``-th)."""
    tests, _ = read_fleet([path])
    jobs = [j for j in plan_fleet(tests, dt).jobs if j.fuel == fuel]
    return jobs[::every]


def predict(jobs: list, coef: tech.Coefficients, dt: float) -> list[dict]:
    """One record per judged row: car, engine technology, family, procedure, error."""
    from vehval.epa.consistency import check_listed_figures

    out = []
    for j in jobs:
        try:
            veh = vehicle_from_specs(j.specs, coefficients=coef)
        except VehvalError:
            continue
        for t in j.tests:
            proc, _ = plan_for(t, j.fuel)
            if proc is None or proc.key not in KEYS or not check_listed_figures(t).ok:
                continue
            try:
                pred = predict_test(veh, t, proc, dt)
            except VehvalError:
                continue
            sp = j.specs
            out.append({"car": j.key, "tech": sp.engine_technology, "kw_per_l":
                        sp.rated_power_w / sp.displacement_l / 1e3, "litres": sp.displacement_l,
                        "kg": sp.mass_kg, "kw": sp.rated_power_w / 1e3, "nv": sp.n_v_ratio,
                        "gears": sp.gears, "bag_ratio": sp.cold_bag_ratio,
                        "family": j.specs.family, "procedure": proc.key,
                        "error": pred.overall_mpg / t.fe - 1.0, "row": t.source})
    return out


def fit_levels(recs: list[dict], eff0: dict[str, float], iters: int = 4,
               shared: bool = True) -> dict:
    """Closed-form levels: per engine technology the indicated efficiency at 60 kW/L and its
    specific-power exponent (a trimmed straight line of the log error against log specific
    power), per family the gearbox efficiency (median), alternated; mpg is proportional to
    both efficiencies (fuel inverse in them). ``shared`` False (the diesel): the engine's
    level only (median), no exponent, the family efficiencies kept. Returns the values and
    ``adjusted(record)``, the log error a record would have with them."""
    le = np.array([math.log1p(r["error"]) for r in recs])
    x = np.array([math.log(r["kw_per_l"] * 1e3 / tech.REFERENCE_SPECIFIC_POWER_W_PER_L)
                  for r in recs])
    techs = np.array([r["tech"] for r in recs])
    fams = np.array([r["family"] for r in recs])
    a = dict.fromkeys(set(techs), 0.0)
    g = dict.fromkeys(set(techs), 0.0)
    b = dict.fromkeys(set(fams), 0.0)
    for _ in range(iters):
        for t in a:
            m = techs == t
            y = -(le[m] + np.array([b[f] for f in fams[m]]))
            keep = np.abs(y - np.median(y)) < 0.25
            if shared and keep.sum() >= 10 and np.ptp(x[m][keep]) > 0.1:
                coef = np.polyfit(-x[m][keep], y[keep], 1)
                g[t], a[t] = float(coef[0]), float(coef[1])
            else:
                g[t], a[t] = 0.0, float(np.median(y))
            a[t] = float(np.median(y + g[t] * x[m]))  # the level robust: median
        for f in b if shared else ():
            m = fams == f
            b[f] = -float(np.median(le[m] + np.array([a[t] - g[t] * xx
                                                       for t, xx in zip(techs[m], x[m])])))
        shift = float(np.median(list(b.values())))  # the families' share: centred
        b = {f: v - shift for f, v in b.items()}
        a = {t: v + shift for t, v in a.items()}
    eta = {t: INDICATED_EFFICIENCY * math.exp(v) for t, v in a.items()}
    eff = {f: min(eff0[f] * math.exp(v), 0.99) for f, v in b.items()} if shared else {}

    def adjusted(r: dict) -> float:
        xx = math.log(r["kw_per_l"] * 1e3 / tech.REFERENCE_SPECIFIC_POWER_W_PER_L)
        return (math.log1p(r["error"]) + math.log(eta[r["tech"]] / INDICATED_EFFICIENCY)
                - g[r["tech"]] * xx
                + (math.log(eff[r["family"]] / eff0[r["family"]]) if shared else 0.0))

    return {"eta": eta, "gamma": g, "eff": eff, "adjusted": adjusted}


def choose(by_combo: dict, eff0: dict[str, float], shared: bool = True) -> dict:
    """Per engine technology the grid point of least mean |log error| after the levels."""
    best = {}
    techs = sorted({r["tech"] for rr in by_combo.values() for r in rr})
    for t in techs:
        scores = {}
        for combo, recs in by_combo.items():
            sel = [r for r in recs if r["tech"] == t]
            if not sel:
                continue
            lev = fit_levels(sel, eff0, shared=shared)
            scores[combo] = float(np.mean([abs(lev["adjusted"](r)) for r in sel]))
        best[t] = min(scores, key=scores.get)
    recs = [r for combo, rr in by_combo.items() for r in rr
            if r["tech"] in best and best[r["tech"]] == combo]
    lev = fit_levels(recs, eff0, shared=shared)
    return {"combo": best, "eta": lev["eta"], "gamma": lev["gamma"], "eff": lev["eff"]}


def _intervals(by: dict, n: int, seed: int, fit) -> dict:
    """2.5-97.5 % percentiles of every value ``fit(weight)`` returns (``weight``: car -> times
    drawn) over ``n`` resamples of the cars of ``by``, with their replacement."""
    cars = sorted({r["car"] for rr in by.values() for r in rr})
    rng = np.random.default_rng(seed)
    draws: dict[str, list[float]] = defaultdict(list)
    for _ in range(n):
        weight: dict = defaultdict(int)
        for k in rng.choice(len(cars), len(cars)):
            weight[cars[k]] += 1
        res = fit(weight)
        for key, v in _levels(res).items():
            draws[key].append(v)
        for t, combo in (res.get("combo") or {}).items():
            for k, v in zip(GRID_KEYS, combo):
                draws[f"engine.{t}.{k}"].append(v)
        for f, v in (res.get("scale") or {}).items():
            draws[f"transmission.{f}.upshift_scale"].append(v)
    return {k: (float(np.percentile(v, 2.5)), float(np.percentile(v, 97.5)))
            for k, v in draws.items()}


def _levels(res: dict) -> dict[str, float]:
    """The closed-form levels of a choice, by coefficient path."""
    out = {f"transmission.{f}.efficiency": v for f, v in res["eff"].items()}
    for t, v in res["eta"].items():
        out[f"engine.{t}.indicated_efficiency"] = v
        out[f"engine.{t}.efficiency_specific_power_exponent"] = res["gamma"][t]
    return out


def bootstrap(by_combo: dict, eff0: dict, n: int, seed: int = 1, shared: bool = True) -> dict:
    """2.5-97.5 % intervals of every fitted value over car resamples."""
    def fit(weight: dict) -> dict:
        sub = {c: [r for r in rr for _ in range(weight[r["car"]])] for c, rr in by_combo.items()}
        return choose(sub, eff0, shared)

    return _intervals(by_combo, n, seed, fit)


def choose_scales(by_scale: dict, eff0: dict[str, float], cars: dict | None = None) -> dict:
    """Per transmission family the upshift scale of least mean |log error| with the engine
    levels held at those of scale 1 (else the first) and the family's own gearbox
    efficiency (its median, at most 0.99); ``cars``: car -> weight of a resample. Then the
    levels of the records at the chosen scales."""
    def pick(recs: list[dict]) -> list[dict]:
        return recs if cars is None else [r for r in recs for _ in range(cars.get(r["car"], 0))]

    ref = by_scale.get(1.0) or next(iter(by_scale.values()))
    lev0 = fit_levels(pick(ref), eff0)

    def engine_only(r: dict) -> float:
        x = math.log(r["kw_per_l"] * 1e3 / tech.REFERENCE_SPECIFIC_POWER_W_PER_L)
        return (math.log1p(r["error"]) + math.log(lev0["eta"][r["tech"]] / INDICATED_EFFICIENCY)
                - lev0["gamma"][r["tech"]] * x)

    best = {}
    for f in sorted({r["family"] for rr in by_scale.values() for r in rr}):
        scores = {}
        for k, rr in by_scale.items():
            y = np.array([engine_only(r) for r in pick(rr) if r["family"] == f])
            if y.size:
                b = min(-float(np.median(y)), math.log(0.99 / eff0[f]))
                scores[k] = float(np.mean(np.abs(y + b)))
        best[f] = min(scores, key=scores.get)
    recs = [r for k, rr in by_scale.items() for r in pick(rr) if best[r["family"]] == k]
    lev = fit_levels(recs, eff0)
    return {"scale": best, "eta": lev["eta"], "gamma": lev["gamma"], "eff": lev["eff"]}


def scale_intervals(by_scale: dict, eff0: dict, n: int, seed: int = 2) -> dict:
    """2.5-97.5 % intervals of the chosen scales, and of the levels fitted with them, over
    car resamples (the engine grid point held)."""
    return _intervals(by_scale, n, seed, lambda weight: choose_scales(by_scale, eff0, weight))


def judge(recs: list[dict]) -> dict:
    """The acceptance figures of a set of predicted rows."""
    out: dict = {"n_rows": len(recs), "n_cars": len({r["car"] for r in recs})}
    err = np.array([r["error"] for r in recs])
    out["within_5"] = float(np.mean(np.abs(err) <= 0.05)) if len(err) else math.nan
    for k in KEYS:
        e = np.array([r["error"] for r in recs if r["procedure"] == k])
        out[k] = {"n": len(e), "median_abs": float(np.median(np.abs(e))) if len(e) else None,
                  "median": float(np.median(e)) if len(e) else None,
                  "within_5": float(np.mean(np.abs(e) <= 0.05)) if len(e) else None}
    per_car: dict[str, dict[str, list[float]]] = defaultdict(lambda: defaultdict(list))
    for r in recs:
        per_car[r["car"]][r["procedure"]].append(r["error"])
    ratios = [(1 + np.mean(p["hwfet"])) / (1 + np.mean(p["ftp75"])) - 1
              for p in per_car.values() if p.get("hwfet") and p.get("ftp75")]
    out["hwfet_ftp_bias"] = float(np.mean(ratios)) if ratios else None
    out["n_ratio_cars"] = len(ratios)
    groups: dict[str, list[float]] = defaultdict(list)
    for r in recs:
        groups[f"{r['tech']} / {r['family']}"].append(r["error"])
        groups[r["tech"]].append(r["error"])
        groups[r["family"]].append(r["error"])
    out["groups"] = {g: {"n": len(v), "median": float(np.median(v)),
                         "median_abs": float(np.median(np.abs(v)))}
                     for g, v in sorted(groups.items())}
    return out


def print_judge(title: str, j: dict) -> None:
    print(f"\n{title}: {j['n_rows']} rows, {j['n_cars']} cars; within 5 %: "
          f"{100 * j['within_5']:.1f} %; HWFET/FTP bias across {j['n_ratio_cars']} cars: "
          f"{100 * (j['hwfet_ftp_bias'] or math.nan):+.1f} %")
    for k in KEYS:
        p = j[k]
        if p["n"]:
            print(f"  {k}: n {p['n']}, median |error| {100 * p['median_abs']:.1f} %, median "
                  f"{100 * p['median']:+.1f} %, within 5 % {100 * p['within_5']:.0f} %")
    for g, v in j["groups"].items():
        print(f"  {g}: n {v['n']}, median bias {100 * v['median']:+.1f} %, median |error| "
              f"{100 * v['median_abs']:.1f} %")


def _line(k: str, v: float, lo: float, hi: float, source: str, fit: str) -> str:
    fit_text = f", fit: \"{fit}\"" if fit else ""
    return (f"    {k}: {{value: {v:.4g}, interval: [{min(lo, v):.4g}, {max(hi, v):.4g}], "
            f"source: \"{source}\"{fit_text}}}")


def yaml_text(fit_list: str, res: dict, iv: dict, base: tech.Coefficients, n_cars: int,
              every: int, fuel: str = "gasoline") -> str:
    """The coefficients file of a fit (values, intervals, provenance): the technologies
    fitted (those of ``res``) written anew, every other value kept as ``base`` has it."""
    which = "every" if every == 1 else f"every {every}th"
    fit = (f"fitted on {fit_list} ({n_cars} cars, {which} runnable {fuel} car; "
           "scripts/fit_technology.py)")
    header = fit if fuel == "gasoline" else base.header.get("fit", "")
    lines = ["# Generic technology coefficients of a car built from its EPA Test Car List row",
             "# (vehval.epa.technology; read by vehval.epa.specs.vehicle_from_specs).",
             "# Written by scripts/fit_technology.py: intervals are 2.5-97.5 % bootstrap",
             "# percentiles over the cars of the fit.",
             "provenance:", "  fitted: true", f"  fit: \"{header}\""]
    if fuel != "gasoline":
        lines.append(f"  fit_{fuel}: \"{fit}\"")
    elif base.header.get("fit_diesel"):
        lines.append(f"  fit_diesel: \"{base.header['fit_diesel']}\"")
    texts = [header, fit if fuel != "gasoline" else base.header.get("fit_diesel", "")]
    fit_lists = sorted({m.group(1) for m in (re.match(r"fitted on (\S+) \(", str(x))
                                              for x in texts) if m})
    lines.append("  fit_lists: [" + ", ".join(f'"{x}"' for x in fit_lists) + "]")
    lines += [f"turbo_min_specific_power_w_per_l: {base.turbo_min_specific_power_w_per_l:g}",
              "engine:"]
    src = {"indicated_efficiency": "slope of the Willans line (fuel inverse in it)",
           "friction_scale": "factor on Heywood (1988) eq. 13.13 friction MEP, with the "
                             "part-load pumping",
           "idle_factor": "warm idle fuel / the Willans map at idle and the accessory load "
                          "(idle control with retarded spark)",
           "pumping_bar": "part-load pumping MEP at zero load [bar], to 0 at full load",
           "accessory_power_w": "electrical and mechanical accessories on the engine during "
                                "the test [W]",
           "efficiency_specific_power_exponent": "indicated efficiency x (specific power / "
                                                 "60 kW/L)^-exponent"}
    for t in tech.ENGINE_TECHNOLOGIES:
        lines.append(f"  {t}:")
        old = base.engine.get(t, {})
        if t not in res["combo"]:
            lines += [_line(k, c.value, *c.interval, c.source, c.fit) for k, c in old.items()]
            continue
        vals = {"indicated_efficiency": res["eta"][t],
                "efficiency_specific_power_exponent": res["gamma"][t],
                **dict(zip(GRID_KEYS, res["combo"][t]))}
        for k, v in vals.items():
            lo, hi = iv.get(f"engine.{t}.{k}", (v, v))
            source = old[k].source if t == "diesel" and k in old else src[k]
            lines.append(_line(k, v, lo, hi, source, fit))
    lines.append("transmission:")
    for f in ("automatic", "cvt", "automated_manual", "manual"):
        lines.append(f"  {f}:")
        if f not in res["eff"]:
            lines += [_line(k, c.value, *c.interval, c.source, c.fit)
                      for k, c in base.transmission[f].items()]
            continue
        v = res["eff"][f]
        lo, hi = iv.get(f"transmission.{f}.efficiency", (v, v))
        lines.append(_line("efficiency", v, lo, hi, "gearbox efficiency with the family's "
                           "launch and shift losses", fit))
        k = (res.get("scale") or {}).get(f)
        old = base.transmission[f].get("upshift_scale")
        if k is not None:
            lo, hi = iv.get(f"transmission.{f}.upshift_scale", (k, k))
            lines.append(_line("upshift_scale", k, lo, hi, "factor on the family's upshift "
                               "engine speeds (shift strategy; vehval.epa.transmissions)", fit))
        elif old is not None:
            lines.append(_line("upshift_scale", old.value, *old.interval, old.source, old.fit))
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("fit_list")
    ap.add_argument("judge_list")
    ap.add_argument("--every", type=int, default=3)
    ap.add_argument("--judge-every", type=int, default=1)
    ap.add_argument("--dt", type=float, default=0.5)
    ap.add_argument("--boot", type=int, default=100)
    ap.add_argument("--write-yaml")
    ap.add_argument("--json")
    ap.add_argument("--base", help="coefficients file whose values not fitted are kept "
                    "(default: the package's)")
    ap.add_argument("--grid", nargs=4, metavar=("FRICTION", "IDLE", "PUMPING", "ACCESSORY"),
                    help="comma-separated grid values of friction scale, idle factor, "
                         "pumping MEP [bar] and accessory power [W] (default: the module's "
                         "grids)")
    ap.add_argument("--scales", default="0.85,1,1.2,1.45,1.7",
                    help="comma-separated upshift scales tried per transmission family after "
                         "the engine grid ('' : not fitted)")
    ap.add_argument("--fuel", choices=("gasoline", "diesel"), default="gasoline",
                    help="the cars fitted and judged: gasoline (both spark-ignition "
                         "technologies and the gearbox families) or diesel (the "
                         "compression-ignition engine alone)")
    a = ap.parse_args(argv)
    shared = a.fuel == "gasoline"
    grid = (FRICTION_GRID, IDLE_GRID, PUMPING_GRID, ACCESSORY_GRID) if shared else DIESEL_GRID
    if a.grid:
        grid = tuple(tuple(float(x) for x in g.split(",")) for g in a.grid)
    base = tech.load_coefficients(a.base)
    eff0 = {f: base.transmission[f]["efficiency"].value for f in base.transmission}
    start = time.time()
    jobs = judged_jobs(a.fit_list, a.dt, a.every, a.fuel)
    by_combo = {}
    for combo in itertools.product(*grid):
        vals = dict(zip(GRID_KEYS, combo))
        coef = with_values(base, {t: {"indicated_efficiency": INDICATED_EFFICIENCY,
                                      "efficiency_specific_power_exponent": 0.0, **vals}
                                  for t in tech.ENGINE_TECHNOLOGIES}, eff0, "grid")
        by_combo[combo] = predict(jobs, coef, a.dt)
        print(f"grid {vals}: {len(by_combo[combo])} rows, {time.time() - start:.0f} s",
              file=sys.stderr, flush=True)
    res = choose(by_combo, eff0, shared)
    iv = bootstrap(by_combo, eff0, a.boot, shared=shared)
    scales = [float(x) for x in a.scales.split(",") if x.strip()] if shared else []
    if scales:  # the shift strategy per family, at the engine grid point chosen
        grid_engine = {t: {"indicated_efficiency": INDICATED_EFFICIENCY,
                           "efficiency_specific_power_exponent": 0.0,
                           **dict(zip(GRID_KEYS, res["combo"][t]))} for t in res["combo"]}
        by_scale = {}
        for k in scales:
            c = with_values(base, grid_engine, eff0, "grid", {f: k for f in eff0})
            by_scale[k] = predict(jobs, c, a.dt)
            print(f"upshift scale {k:g}: {len(by_scale[k])} rows, {time.time() - start:.0f} s",
                  file=sys.stderr, flush=True)
        res.update(choose_scales(by_scale, eff0))
        iv.update(scale_intervals(by_scale, eff0, a.boot))
    engine = {t: {"indicated_efficiency": res["eta"][t],
                  "efficiency_specific_power_exponent": res["gamma"][t],
                  **dict(zip(GRID_KEYS, res["combo"][t]))} for t in res["combo"]}
    coef = with_values(base, engine, res["eff"], "fit", res.get("scale"))
    n_rows_fit = sum(len(r) for r in by_combo.values()) // len(by_combo)
    print(f"fit on {a.fit_list}: {len(jobs)} cars, {n_rows_fit} rows; {res}; intervals {iv}")
    t0 = time.time()
    fit_recs = predict(jobs, coef, a.dt)
    print_judge(f"IN-SAMPLE {a.fit_list} (the cars fitted on)", judge(fit_recs))
    judge_jobs = judged_jobs(a.judge_list, a.dt, a.judge_every, a.fuel)
    recs = predict(judge_jobs, coef, a.dt)
    rate = len(recs) / max(time.time() - t0, 1e-9)
    j = judge(recs)
    print_judge(f"OUT-OF-SAMPLE {a.judge_list} (every runnable {a.fuel} car)", j)
    print(f"rows per second (fit set and judge set, dt {a.dt:g} s, one process): {rate:.1f}")
    if a.write_yaml:
        with open(a.write_yaml, "w") as fh:
            fh.write(yaml_text(a.fit_list.rsplit("/", 1)[-1], res, iv, base, len(jobs), a.every,
                               a.fuel))
    if a.json:
        with open(a.json, "w") as fh:
            json.dump({"fit": {"combo": {k: list(v) for k, v in res["combo"].items()},
                               "scale": res.get("scale"),
                               "eta": res["eta"], "eff": res["eff"], "gamma": res["gamma"],
                               "intervals": {k: list(v) for k, v in iv.items()}},
                       "in_sample": judge(fit_recs), "out_of_sample": j, "rows": recs}, fh,
                      indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
