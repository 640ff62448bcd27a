"""Attack campaign III, silent figures: mistakes that move a stated figure, on the Cruze HWFET.

Each mutation runs on a virtual dyno test of the packaged Cruze (``vehval synth``, so the class
runs without the real data) and, when ``../shared/data/real`` holds it, on the real Cruze
HWFET 61410015 (UDDS 61410013 for the phase channel). A case is *silently wrong* when the
command exits 0 (or 4) and no finding, warning or refusal line names the problem; *handled*
when one does (on screen: a warning only in findings.json does not count); *clean error* for a
refusal naming it.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Callable, Iterator

import numpy as np
import yaml
from attack3_common import Case, named
from attack3_inputs import CRUZE_REAL, CRUZE_TEMPLATE, d3_of, prius_list, sedan_tests, synth

#: What a finding naming each problem says (every pattern on one problem line).
FUEL_FACTOR = named(r"fuel|densit", r"efficien|scale|densit|plausib|unit|factor|twice|half|"
                    r"too (high|low)|expected")
FUEL_DROPOUT = {
    "zero": named(r"fuel", r"zero|missing|gap|no reading|dropout|while the engine|delivers"),
    "NaN gap": named(r"fuel", r"gap|missing|nan|no reading|dropout|not a number"),
    "clipped": named(r"fuel", r"clip|saturat|ceiling|capped|limit|maximum"),
    "stuck": named(r"fuel", r"stuck|constant|frozen|flat|unchanged|repeat"),
}
SPEED_SCALE = named(r"speed|distance|cycle", r"scale|distance|longer|shorter|factor|unit")
PHASE_LATE = named(r"bag|phase", r"distance|duration|\blate\b|shift|offset|misalign",
                   exclude=r"drive quality")
ROAD_LOAD = named(r"road.?load|coef|road_load", r"negative|zero|sign|lbf|magnitude|plausib|"
                  r"unit|must be|positive|below|above|outside")
MONTE_CARLO = named(r"monte|draws", r"few|at least|minimum|not enough|too|unreliable|"
                    r"instead|only")
VOLUME_FUEL = named(r"fuel", r"cm3|cm³|ccps|cc/s|volume|densit|probably")
MASS_LB = named(r"mass", r"template|test_mass|\blb\b|pound|differ|identified")
START_BOUNDS = named(r"start|engine_on_power_w", r"bound|outside|range|clip|ignored|finite|"
                     r"nan|refus")


def _base(root: Path, kind: str) -> tuple[Path, Path] | None:
    """(data file, template) of a base test: virtual/real HWFET or UDDS; None if absent."""
    if kind.startswith("virtual"):
        d = synth(root, "cruze_diesel_2014", kind.split()[1])
        return d3_of(d), d / "template.yaml"
    num = {"real hwfet": "61410015", "real udds": "61410013"}[kind]
    f = CRUZE_REAL / f"{num} Test Data.txt"
    return (f, CRUZE_TEMPLATE) if f.is_file() else None


def _load_tpl(p: Path) -> dict:
    return yaml.safe_load(p.read_text(encoding="utf-8"))


def _channel(tpl: dict, std: str) -> dict:
    for f in tpl["files"]:
        for ch in f["channels"].values():
            if isinstance(ch, dict) and ch.get("name") == std:
                return ch
    raise KeyError(std)


def _d3_table(path: Path) -> tuple[list[str], list[list[str]]]:
    lines = path.read_text(encoding="utf-8", errors="replace").splitlines()
    head = lines[0]
    rows = [ln.split("\t") for ln in lines[1:] if ln.strip()]
    return [head], rows


def _col(head: str, prefix: str) -> int:
    cols = head.split("\t")
    return next(i for i, c in enumerate(cols) if c.startswith(prefix))


def _window(rows: list[list[str]], head: str, rng: np.random.Generator,
            seconds: float = 200.0) -> tuple[int, int]:
    """Rows of a stretch of ``seconds`` where the car drives above 40 mph with the engine
    above 1100 rpm (the engine delivers), chosen with ``rng``."""
    t = np.array([float(r[0]) for r in rows])
    v = np.array([float(r[_col(head, "Dyno_Speed")]) for r in rows])
    e = np.array([float(r[_col(head, "Engine_Speed")]) for r in rows])
    n = int(round(seconds / np.median(np.diff(t))))
    ok = ((v > 40) & (e > 1100)).astype(int)
    run = np.convolve(ok, np.ones(n, int), mode="valid")
    starts = np.flatnonzero(run == n)
    if starts.size == 0:  # the longest stretch above 40 mph
        starts = np.array([int(np.argmax(run))])
    i = int(rng.choice(starts))
    return i, i + n


def _fuel_edit(how: str, rng: np.random.Generator) -> Callable[[Path, Path], None]:
    """Edit of the fuel column of a D3 file: zero / NaN / stuck for 200 s, clipped at 1 g/s,
    or g/s turned into cm³/s (diesel 0.851 g/cm³) with the header's unit (a file whose header
    says g/s over cm³/s values reads 17.5 % high: a meter gain error that no check can tell
    from a less efficient engine without an engine map or a carbon balance)."""
    def edit(src: Path, dst: Path) -> None:
        (head,), rows = _d3_table(src)
        j = _col(head, "Fuel_Flow_Bench_Modal")
        if how == "clipped":
            for r in rows:
                r[j] = f"{min(float(r[j]), 1.0):.4f}"
        elif how == "cc/s":  # as a lab's file in cm³/s says it: its header names the unit
            for r in rows:
                r[j] = f"{float(r[j]) / 0.851:.5f}"
            cols = head.split("\t")
            cols[j] = cols[j].split("[")[0] + "[cc/s]"
            head = "\t".join(cols)
        else:
            a, b = _window(rows, head, rng)
            held = rows[a][j]
            for r in rows[a:b]:
                r[j] = {"zero": "0.000", "NaN gap": "nan", "stuck": held}[how]
        dst.write_text("\n".join([head] + ["\t".join(r) for r in rows]) + "\n", encoding="utf-8")
    return edit


def _phase_late(seconds: float) -> Callable[[Path, Path], None]:
    """The phase channel ``seconds`` late (its values moved down the rows)."""
    def edit(src: Path, dst: Path) -> None:
        (head,), rows = _d3_table(src)
        j = _col(head, "Phase_#")
        t = np.array([float(r[0]) for r in rows])
        k = int(round(seconds / np.median(np.diff(t))))
        vals = [r[j] for r in rows]
        for i, r in enumerate(rows):
            r[j] = vals[max(i - k, 0)]
        dst.write_text("\n".join([head] + ["\t".join(r) for r in rows]) + "\n", encoding="utf-8")
    return edit


def _tpl_edit(fn: Callable[[dict], None]) -> Callable[[Path, Path], None]:
    def edit(src: Path, dst: Path) -> None:
        tpl = _load_tpl(src)
        fn(tpl)
        dst.write_text(yaml.safe_dump(tpl, sort_keys=False), encoding="utf-8")
    return edit


def _set(**kv) -> Callable[[dict], None]:
    return lambda tpl: tpl["constants"].update(kv)


def _scale(std: str, factor: float) -> Callable[[dict], None]:
    return lambda tpl: _channel(tpl, std).update(scale=factor)


def _mutations(rng: np.random.Generator) -> list[tuple]:
    """(name, base kind, data edit or None, template edit or None, extra args, must)."""
    rl = {"road_load_a_n": 100.69, "road_load_b_n_per_mps": 12.334,
          "road_load_c_n_per_mps2": 0.04294}
    # the summary sheet's numbers in lbf, lbf/mph and lbf/mph² written into the N fields
    lbf = {"road_load_a_n": 22.636, "road_load_b_n_per_mps": 1.23944,
           "road_load_c_n_per_mps2": 0.001929}
    hw = "hwfet"
    out = [
        ("fuel channel scale 2", hw, None, _scale("fuel_rate_test", 2.0), [], FUEL_FACTOR),
        ("fuel channel scale 0.5", hw, None, _scale("fuel_rate_test", 0.5), [], FUEL_FACTOR),
        ("fuel_density_kg_per_m3 85.1", hw, None, _set(fuel_density_kg_per_m3=85.1), [],
         FUEL_FACTOR),
        ("fuel_density_kg_per_m3 0.851", hw, None, _set(fuel_density_kg_per_m3=0.851), [],
         FUEL_FACTOR),
        ("fuel zero for 200 s at speed", hw, _fuel_edit("zero", rng), None, [],
         FUEL_DROPOUT["zero"]),
        ("fuel NaN gap of 200 s", hw, _fuel_edit("NaN gap", rng), None, [],
         FUEL_DROPOUT["NaN gap"]),
        ("fuel clipped at 1 g/s", hw, _fuel_edit("clipped", rng), None, [],
         FUEL_DROPOUT["clipped"]),
        ("fuel stuck for 200 s", hw, _fuel_edit("stuck", rng), None, [],
         FUEL_DROPOUT["stuck"]),
        ("fuel in cm³/s declared g/s", hw, _fuel_edit("cc/s", rng), None, [], VOLUME_FUEL),
        ("speed channel scale 1.1", hw, None, _scale("veh_spd_test", 1.1), [], SPEED_SCALE),
        ("UDDS phase channel 60 s late", "udds", _phase_late(60.0), None, [], PHASE_LATE),
        ("road load A negative", hw, None, _set(**{**rl, "road_load_a_n": -100.69}), [],
         ROAD_LOAD),
        ("road load B negative", hw, None, _set(**{**rl, "road_load_b_n_per_mps": -12.334}),
         [], ROAD_LOAD),
        ("road load C negative", hw, None, _set(**{**rl, "road_load_c_n_per_mps2": -0.04294}),
         [], ROAD_LOAD),
        ("road load all zero", hw, None, _set(road_load_a_n=0.0, road_load_b_n_per_mps=0.0,
                                              road_load_c_n_per_mps2=0.0), [], ROAD_LOAD),
        ("road load in lbf, lbf/mph, lbf/mph² given as N", hw, None,
         _set(**lbf), [], ROAD_LOAD),
        ("--monte-carlo 1", hw, None, None, ["--monte-carlo", "1"], MONTE_CARLO),
        ("--monte-carlo 2", hw, None, None, ["--monte-carlo", "2"], MONTE_CARLO),
    ]
    return out


def silent_figures(root: Path, rng: np.random.Generator) -> Iterator[Case]:
    """The mutations above on the virtual and (when present) the real Cruze, then the
    model commands: in-sample predictions, cm³/s fuel, duplicate grids, a mass in pounds,
    calibration starts out of bounds."""
    d = root / "figures"
    real = CRUZE_REAL.is_dir()
    for k, (what, cyc, data_edit, tpl_edit, extra, must) in enumerate(_mutations(rng)):
        for origin in ("virtual", "real") if real else ("virtual",):
            kind = f"{origin} {cyc}"
            if origin == "real" and _base(root, kind) is None:
                continue
            folder = d / f"m{k}_{origin}"
            case = Case("silent figures", f"{what} ({origin} Cruze {cyc.upper()})", [],
                        expect="ok", must=must, refusal_must=must, ok_codes=(0, 4))

            def prep(case=case, folder=folder, kind=kind, data_edit=data_edit,
                     tpl_edit=tpl_edit, extra=extra):
                base = _base(root, kind)
                assert base is not None
                data, tpl = base
                folder.mkdir(parents=True, exist_ok=True)
                if data_edit is not None:
                    new = folder / data.name
                    data_edit(data, new)
                    data = new
                if tpl_edit is not None:
                    new = folder / "template.yaml"
                    _tpl_edit(tpl_edit)(tpl, new)
                    tpl = new
                case.args = ["results", data, "-t", tpl, "-o", folder / "out", *extra]
            case.prepare = prep
            yield case
    yield from _model_commands(root, d, rng)


def _model_commands(root: Path, d: Path, rng: np.random.Generator) -> Iterator[Case]:
    sed = root / "_sedan"
    lst = sed / "19tstcar.csv"
    evh = ["epa", "vehicle", lst, "--make", "MAKER", "--model", "SEDAN XLE", "--year", "2019",
           "--dt", "1", "--json"]

    def held_out_same(text: str) -> bool:
        """No test both calibrated on and counted held-out (the summary line 'held-out: N
        tests' with N > 0 when every test is a calibration test), or a line naming it."""
        claimed = re.search(r"held.out:\s*[1-9]", text, re.I) is not None
        return not claimed or named(r"--predict|in.sample|held.out", r"also|both|same")(text)
    for k, f in enumerate(["t1", "t3"]):
        yield Case("silent figures", f"epa vehicle --predict equal to --calibrate ({f})",
                   [*evh[:-1], "--calibrate", sed / f"{f} Test Data.txt", "--calibrate",
                    sed / "t2 Test Data.txt", "--predict", sed / f"{f} Test Data.txt",
                    "-t", sed / "t.yaml", "-o", d / f"same{k}.yaml"], expect="ok",
                   must=held_out_same, refusal_must=r"--predict|--calibrate|in.sample|both",
                   prepare=lambda: sedan_tests(root))
    yield Case("silent figures", "epa vehicle: fuel in cm³/s declared g/s", [
        *evh, "--calibrate", sed / "t1 Test Data.txt", "--calibrate", sed / "t2 Test Data.txt",
        "-t", sed / "t_gps.yaml", "-o", d / "gps.yaml"], expect="ok",
        must=lambda text: re.search(r"cm3|cm³|ccps|cc/s|volume", text, re.I) is not None,
        refusal_must=r"cm3|cm³|ccps|cc/s|volume|unit", prepare=lambda: sedan_tests(root))
    # epa calibrate with two grids of one parameter
    pl = root / "_lists" / "prius.csv"
    for k, (a, b) in enumerate([("soc_gain_w=20000,30000", "soc_gain_w=40000"),
                                ("engine_min_power_w=9000", "controller.engine_min_power_w="
                                 "10000,11000")]):
        yield Case("silent figures", f"epa calibrate --param {a} --param {b}", [
            "epa", "calibrate", pl, "--vehicle", "prius_2016", "--tests",
            "model=PRIUS,procedure=hwfet", "--param", a, "--param", b, "--refine", "0",
            "--workers", "1", "--dt", "1", "-o", d / f"grid{k}.yaml"],
            refusal_must=named(r"soc_gain_w|engine_min_power_w",
                               r"twice|duplicat|more than once|again|repeated|both|two grids"),
            prepare=lambda: prius_list(root))
    # identify with the template's test mass in pounds
    for origin in ("virtual", "real") if CRUZE_REAL.is_dir() else ("virtual",):
        folder = d / f"w_{origin}"  # no pattern word in the path
        case = Case("silent figures", f"identify, template test_mass_kg in pounds ({origin})",
                    [], expect="ok", must=MASS_LB, refusal_must=r"mass")

        def prep(case=case, folder=folder, origin=origin):
            base = _base(root, f"{origin} hwfet")
            assert base is not None
            data, tpl = base
            folder.mkdir(parents=True, exist_ok=True)
            t = _load_tpl(tpl)
            t["constants"]["test_mass_kg"] = round(t["constants"]["test_mass_kg"] / 0.45359237)
            (folder / "template.yaml").write_text(yaml.safe_dump(t, sort_keys=False))
            case.args = ["identify", data, "-t", folder / "template.yaml", "-o",
                         folder / "veh.yaml"]
        case.prepare = prep
        yield case
    # calibrate --start outside the parameter's bounds
    for k, value in enumerate(["1e300", "NaN", "-1e300", "Infinity"]):
        folder = d / f"s{k}"
        case = Case("silent figures", f"calibrate --start engine_on_power_w = {value}", [],
                    expect="ok", must=START_BOUNDS, refusal_must=r"engine_on_power_w|start",
                    forbidden=lambda folder=folder, value=value: _written(folder, value))

        def prep(case=case, folder=folder, value=value):
            p = synth(root, "prius_2004", "udds", seed=7)
            folder.mkdir(parents=True, exist_ok=True)
            (folder / "s.json").write_text(
                '{"controller": {"engine_on_power_w": %s}}' % value)
            case.args = ["calibrate", "--test", f"{d3_of(p)},{next(p.glob('*_obd.csv'))}",
                         "-t", p / "template.yaml", "-o", folder / "out", "--start",
                         folder / "s.json", "--params", "controller.engine_on_power_w",
                         "--maxiter", "1", "--popsize", "1"]
        case.prepare = prep
        yield case


def _written(folder: Path, value: str) -> bool:
    """The absurd start value written into the calibrated vehicle."""
    p = folder / "out" / "vehicle_calibrated.yaml"
    if not p.is_file():
        return False
    m = re.search(r"^\s*engine_on_power_w:\s*(\S+)\s*$", p.read_text(), re.M)
    if not m:
        return False
    try:
        v = float(m.group(1))
    except ValueError:
        return True
    return not np.isfinite(v) or abs(v) > 1e7
