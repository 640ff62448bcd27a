"""Cross-car survey of the spec-built conventional car, uncalibrated (generic values only).

For every automatic gasoline configuration of the EPA Test Car Lists given that has an
FTP-75, an HWFET and a US06 test, build the car with ``vehval epa vehicle``'s generic values
(:func:`vehval.epa.specs.vehicle_from_specs`), simulate the three tests as ``vehval epa
validate`` does and print the fuel-economy errors (model / list - 1) with HWFET diagnostics:
mean engine speed and gear of the model against the top-gear engine speed N/V x mean speed,
share of time in top gear and locked, share of the fuel burnt at low load (brake MEP below
2 bar) and the friction share of the fuel (friction MEP / (BMEP + FMEP) on the Willans line).

The cars are the ``CARS`` list (the first configuration of each; ``--all``: every
configuration in list order, at most ``--per-make`` per make and year); ``half`` A / B
alternates along that order (A chooses a change, B checks it). What-if options change one
generic value for the run only (``--set NAME=VALUE`` for a constant of
``vehval.epa.specs`` / ``engine_model``, ``--eta``, ``--friction-scale``, ``--idle-factor``,
``--pumping-bar``, ``--high-load-from-bar``); docs/validation.md gives the results.

Usage::

    python scripts/epa_survey.py 16tstcar.csv 19tstcar.csv [--dt 0.5] [--json out.json] \
        [--set UPSHIFT_RPM=1100] [--idle-factor 1.73] [--pumping-bar 0.5]
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections import defaultdict

import numpy as np

from vehval.constants import MPH_M_PER_S as MPH
from vehval.constants import RPM_RAD_PER_S as RPM
from vehval.epa import engine_model as em
from vehval.epa import specs as sp
from vehval.epa import transmissions as tr
from vehval.epa.procedures import is_gasoline, plan_for, procedure_key
from vehval.epa.reader import read_test_car_list
from vehval.epa.specs import RATIO_SPREAD, specs_from_tests, vehicle_from_specs
from vehval.epa.validation import _grids, predict_test, vehicle_for_test
from vehval.errors import VehvalError
from vehval.sim.simulate import architecture, balanced_plan

KEYS = ("ftp75", "hwfet", "us06")
#: the survey's cars (year, make, model as the lists spell them): the first configuration
#: of each; mainstream makes, 4-10 gears, 1.4-6.2 L, naturally aspirated and turbo
CARS = (
    (2016, "FORD", "F150 4X2"), (2019, "FORD", "F150 SUPER CAB 4X4"), (2019, "BMW", "540I"),
    (2016, "HYUNDAI", "ELANTRA"), (2019, "MAZDA", "CX-5"),
    (2016, "CHEVROLET", "C15 SILVERADO 2WD"), (2019, "MERCEDES-BENZ", "C 300"),
    (2019, "JEEP", "WRANGLER 4X4"), (2019, "KIA", "SOUL"), (2016, "TOYOTA", "TUNDRA 2WD"),
    (2019, "FORD", "MUSTANG"), (2016, "DODGE", "CHARGER AWD"), (2019, "HONDA", "ACCORD"),
    (2019, "TOYOTA", "CAMRY XLE/XSE"), (2016, "TOYOTA", "COROLLA"), (2016, "TOYOTA", "RAV4"),
    (2016, "HONDA", "PILOT 2WD 9AT"), (2016, "FORD", "EXPLORER FWD"),
    (2016, "CHEVROLET", "MALIBU"), (2016, "BMW", "535I"), (2019, "HYUNDAI", "SANTA FE"),
    (2019, "CHEVROLET", "EQUINOX FWD"), (2019, "CADILLAC", "CT6"),
    (2019, "TOYOTA", "HIGHLANDER"), (2019, "ACURA", "RDX FWD A-SPEC"),
    (2019, "VOLKSWAGEN", "JETTA"), (2019, "NISSAN", "ARMADA 2WD"), (2019, "RAM", "1500 4X2"),
    (2016, "DODGE", "CHARGER"), (2016, "KIA", "SORENTO"), (2019, "GMC", "K10 SIERRA 4WD"),
    (2016, "MERCEDES-BENZ", "GLC 300"),
)


def candidates(paths: list[str], per_make: int, cars=CARS) -> list[list]:
    """Row groups of one configuration each (automatic, gasoline, FTP and HWFET): the
    first of each of ``cars`` in that order, or (``cars`` empty) every one in list order,
    at most ``per_make`` per make and year."""
    groups: dict[tuple, list] = defaultdict(list)
    for p in paths:
        for t in read_test_car_list(p):
            groups[(t.year, t.make, t.model, t.vehicle_id, t.config)].append(t)
    out: list[list] = []
    per: dict[tuple, int] = defaultdict(int)
    for key in sorted(groups):
        rows = groups[key]
        t0 = rows[0]
        if t0.transmission not in ("A", "SA") or t0.gears not in RATIO_SPREAD:
            continue
        if "HYBRID" in t0.model.upper():
            continue
        have = {procedure_key(t) for t in rows if is_gasoline(t.fuel) and t.fe > 0}
        if not {"ftp75", "hwfet"} <= have or per[(t0.year, t0.make)] >= per_make:
            continue
        try:
            specs_from_tests(rows)
        except VehvalError:
            continue
        per[(t0.year, t0.make)] += 1
        out.append(rows)
    if not cars:
        return out
    first: dict[tuple, list] = {}
    for rows in out:
        first.setdefault((rows[0].year, rows[0].make.upper(), rows[0].model.upper()), rows)
    return [first[c] for c in cars if c in first]


def hwfet_diagnostics(veh, test, specs, dt: float) -> dict:
    """Engine speed, gear, lock-up and fuel shares of the model over one HWFET."""
    proc, _ = plan_for(test)
    v = vehicle_for_test(veh, test, tuple(dict.fromkeys(proc.runs)))
    grids = _grids(v, proc, dt)
    _, runs, _ = balanced_plan(v, grids)
    col = architecture(v).column
    out = runs[0][0]
    spd = out[:, col["veh_spd"]]
    moving = spd > 1.0
    we = out[moving, col["eng_spd_out"]] / RPM
    gear = out[moving, col["gb_gear"]]
    trq = out[moving, col["eng_trq_out"]]
    fuel = out[moving, col["fuel_rate"]]
    vd = specs.displacement_l
    bmep = em.mep_pa(np.maximum(trq, 0.0), vd)
    fmep = em.fmep_pa(we)
    low = bmep < 2e5
    nv_rpm = specs.n_v_ratio * float(np.mean(spd[moving])) / MPH
    firing = fuel > 0
    return {
        "eng_rpm": float(np.mean(we)), "gear": float(np.mean(gear)),
        "top_share": float(np.mean(gear == specs.gears)),
        "nv_rpm": nv_rpm,
        "low_load_fuel_share": float(fuel[low].sum() / max(fuel.sum(), 1e-12)),
        "friction_share": float(np.sum((fmep / (bmep + fmep) * fuel)[firing])
                                / max(fuel[firing].sum(), 1e-12)),
        "bmep_bar": float(np.mean(bmep) / 1e5),
    }


def with_part_load_pumping(zero_load_bar: float) -> None:
    """What-if: add a throttling pumping MEP to the generic map, ``zero_load_bar`` [bar] at
    zero brake load falling linearly to 0 at full load (the throttled intake pressure rises
    about in proportion to the load; Heywood's eq. 13.13 holds the pumping at wide-open
    throttle only)."""
    base = em.fuel_rate_g_per_s

    def fuel(speed_rpm, torque, full_load_nm, displacement_l, eta_i, friction_scale, lhv,
             high_load=(em.HIGH_LOAD_FUEL, em.HIGH_LOAD_FROM)):
        spd = np.asarray(speed_rpm, float)[:, None]
        trq = np.maximum(np.asarray(torque, float)[None, :], 0.0)
        bmep = em.mep_pa(trq, displacement_l)
        full = em.mep_pa(np.asarray(full_load_nm, float)[:, None], displacement_l)
        pmep = zero_load_bar * 1e5 * np.clip(1.0 - bmep / full, 0.0, 1.0)
        tmax = np.asarray(full_load_nm, float)[:, None]
        power = (pmep / eta_i * em.high_load_factor(trq / tmax, *high_load)
                 * displacement_l * 1e-3 * spd * RPM / (4.0 * math.pi))  # [W]
        extra = power / lhv * 1e3
        return base(speed_rpm, torque, full_load_nm, displacement_l, eta_i, friction_scale,
                    lhv, high_load) + extra

    em.fuel_rate_g_per_s = fuel


def with_high_load_from_bmep(from_bar: float) -> None:
    """What-if: the high-load fuel (knock-limited spark, enrichment) rises from an absolute
    brake MEP ``from_bar`` [bar] to full load, instead of from a share of the full-load
    torque (the same for a 12 bar naturally aspirated engine at 6 bar)."""
    base = em.fuel_rate_g_per_s

    def fuel(speed_rpm, torque, full_load_nm, displacement_l, eta_i, friction_scale, lhv,
             high_load=(em.HIGH_LOAD_FUEL, em.HIGH_LOAD_FROM)):
        tmax = np.asarray(full_load_nm, float)
        start = np.clip(from_bar * 1e5 / em.mep_pa(tmax, displacement_l), 0.0, 0.95)
        rows = [base(np.asarray(speed_rpm, float)[i:i + 1], torque, tmax[i:i + 1],
                     displacement_l, eta_i, friction_scale, lhv,
                     (high_load[0], float(start[i]))) for i in range(len(tmax))]
        return np.vstack(rows)

    em.fuel_rate_g_per_s = fuel


def ftp_idle_share(veh, test, dt: float) -> float:
    """Share of the model's FTP-75 fuel burnt standing (engine idling) [-]."""
    proc, _ = plan_for(test)
    v = vehicle_for_test(veh, test, tuple(dict.fromkeys(proc.runs)))
    _, runs, _ = balanced_plan(v, _grids(v, proc, dt))
    col = architecture(v).column
    fuel = np.concatenate([r[0][:, col["fuel_rate"]] for r in runs])
    spd = np.concatenate([r[0][:, col["veh_spd"]] for r in runs])
    return float(fuel[spd < 0.05].sum() / max(fuel.sum(), 1e-12))


def survey(paths: list[str], n_max: int, dt: float, per_make: int, cars=CARS,
           idle_factor: float = 1.0, technology: bool = False, **model_kw) -> list[dict]:
    rows_out = []
    for k, rows in enumerate(candidates(paths, 999 if cars else per_make, cars)[:n_max]):
        specs = specs_from_tests(rows)
        veh = (vehicle_from_specs(specs) if technology
               else vehicle_from_specs(specs, technology=False, **model_kw))
        if idle_factor != 1.0:
            idle = veh.engine_control.idle_fuel_rate_g_per_s * idle_factor
            veh = vehicle_from_specs(specs, idle_fuel_g_per_s=idle, technology=False,
                                     idle_source=f"{idle_factor:g} x the map", **model_kw)
        rec = {"car": f"{specs.make} {specs.model} {specs.year}", "half": "AB"[k % 2],
               "gears": specs.gears, "litres": specs.displacement_l,
               "kw": specs.rated_power_w / 1e3, "nv": specs.n_v_ratio}
        bag_errs: dict[int, list[float]] = {}
        for key in KEYS:
            errs = []
            for t in rows:
                if procedure_key(t) != key or not is_gasoline(t.fuel) or not t.fe > 0:
                    continue
                proc, why = plan_for(t)
                if proc is None:
                    continue
                pred = predict_test(veh, t, proc, dt)
                errs.append(pred.overall_mpg / t.fe - 1.0)
                if key == "ftp75":
                    for b in (2, 3):
                        if math.isfinite(t.bags[b - 1]):
                            bag_errs.setdefault(b, []).append(
                                pred.bags_mpg[b] / t.bags[b - 1] - 1.0)
                if key == "ftp75" and "ftp_idle_share" not in rec:
                    rec["ftp_idle_share"] = ftp_idle_share(veh, t, dt)
                if key == "hwfet" and "eng_rpm" not in rec:
                    rec.update(hwfet_diagnostics(veh, t, specs, dt))
            rec[key] = float(np.mean(errs)) if errs else math.nan
        rec["ratio"] = (1 + rec["hwfet"]) / (1 + rec["ftp75"]) - 1
        for b in (2, 3):
            rec[f"bag{b}"] = float(np.mean(bag_errs[b])) if b in bag_errs else math.nan
        # HWFET against the hot bags (no cold start, no hot soak): bag 2 stabilised, bag 3 hot
        rec["ratio_hot"] = (1 + rec["hwfet"]) / (1 + 0.5 * (rec["bag2"] + rec["bag3"])) - 1
        rows_out.append(rec)
        print(_line(rec), flush=True)
    return rows_out


HEAD = ("| car | half | gears | L | kW | FTP | HWFET | US06 | HWFET/FTP | HWFET/hot bags | "
        "HWFET rpm model / "
        "N/V | gear (top share) | fuel at BMEP < 2 bar | friction share | FTP-75 fuel standing |")


def _pc(x: float) -> str:
    return f"{100 * x:+.1f}" if math.isfinite(x) else "-"


def _line(r: dict) -> str:
    return (f"| {r['car']} | {r['half']} | {r['gears']} | {r['litres']:.1f} | {r['kw']:.0f} | "
            f"{_pc(r['ftp75'])} | {_pc(r['hwfet'])} | {_pc(r['us06'])} | "
            f"{_pc(r['ratio'])} | {_pc(r['ratio_hot'])} | "
            f"{r['eng_rpm']:.0f} / {r['nv_rpm']:.0f} | "
            f"{r['gear']:.2f} ({100 * r['top_share']:.0f} %) | "
            f"{100 * r['low_load_fuel_share']:.0f} % | {100 * r['friction_share']:.0f} % | "
            f"{100 * r['ftp_idle_share']:.1f} % |")


def summary(rows: list[dict]) -> str:
    out = []
    for half in ("A", "B", "AB"):
        sel = [r for r in rows if r["half"] in half]
        if not sel:
            continue
        parts = []
        for key in (*KEYS, "ratio", "ratio_hot"):
            e = np.array([r[key] for r in sel if math.isfinite(r[key])]) * 100
            parts.append(f"{key} mean {e.mean():+.1f} mean|e| {np.abs(e).mean():.1f} "
                         f"({e.min():+.1f}..{e.max():+.1f})")
        out.append(f"half {half} ({len(sel)} cars): " + "; ".join(parts))
    return "\n".join(out)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("lists", nargs="+")
    ap.add_argument("--max", type=int, default=200)
    ap.add_argument("--per-make", type=int, default=2)
    ap.add_argument("--all", action="store_true",
                    help="every configuration in list order instead of the survey's cars")
    ap.add_argument("--dt", type=float, default=0.5)
    ap.add_argument("--json")
    ap.add_argument("--eta", type=float, default=sp.INDICATED_EFFICIENCY,
                    help="indicated efficiency [-]")
    ap.add_argument("--friction-scale", type=float, default=1.0, help="x Heywood [-]")
    ap.add_argument("--idle-factor", type=float, default=1.0,
                    help="warm idle fuel = this x the map at idle [-]")
    ap.add_argument("--technology", action="store_true",
                    help="the generic technology coefficients (vehval.epa.technology) instead "
                         "of the generic constants")
    ap.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                    help="override a generic constant of vehval.epa.specs or "
                         "vehval.epa.engine_model for a what-if run (e.g. UPSHIFT_RPM=1100)")
    ap.add_argument("--pumping-bar", type=float, default=0.0,
                    help="what-if: part-load pumping MEP at zero load [bar]")
    ap.add_argument("--high-load-from-bar", type=float, default=0.0,
                    help="what-if: high-load fuel from this brake MEP [bar]")
    a = ap.parse_args(argv)
    if a.high_load_from_bar:
        with_high_load_from_bmep(a.high_load_from_bar)
    if a.pumping_bar:
        with_part_load_pumping(a.pumping_bar)
    for item in a.set:
        name, value = item.split("=", 1)
        mods = [m for m in (sp, em, tr) if hasattr(m, name)]
        if not mods:
            ap.error(f"--set {item}: no constant {name} in vehval.epa.specs or engine_model")
        for m in mods:
            setattr(m, name, type(getattr(m, name))(float(value)))
    print(HEAD)
    print("|---" * (HEAD.count("|") - 1) + "|")
    rows = survey(a.lists, a.max, a.dt, a.per_make, () if a.all else CARS,
                  idle_factor=a.idle_factor, technology=a.technology,
                  indicated_efficiency=a.eta,
                  friction_scale=a.friction_scale)
    print(summary(rows))
    if a.json:
        with open(a.json, "w") as fh:
            json.dump(rows, fh, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
