"""Fuel plausibility gates (vehval.qa.fuel_gates, the fuel-map unit hint, the density check).

Each mistake below gave a wrong headline with exit 0 before the gates: a fuel channel scaled
x2 or x0.5, a density in g/cm3 or missing a digit, the fuel reading zero, missing, stuck or
clipped while the engine delivers power, a volume rate declared as a mass rate. Now each is
refused at input or withholds the fuel figures with the reason and the fix.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from helpers.data import REAL
from vehval.errors import ConfigError
from vehval.qa.findings import Kind, Severity

HERE = Path(__file__).resolve().parent
CRUZE = REAL / "d3_2014_chevrolet_cruze_diesel" / "61410015 Test Data.txt"
FUEL_RAW = "Eng_FuelFlow_Direct"


@pytest.fixture(scope="module")
def virtual(tmp_path_factory) -> Path:
    """A virtual 2004 Prius on the UDDS (engine torque, force, fuel in ccps), one file."""
    from vehval.synth import make_virtual_test

    d = tmp_path_factory.mktemp("fuelgates") / "virtual"
    make_virtual_test("prius_2004", "udds", seed=3, faults="none", outdir=d)
    for extra in d.glob("*_obd.csv"):
        extra.unlink()
    tpl = yaml.safe_load((d / "template.yaml").read_text(encoding="utf-8"))
    tpl["files"] = [f for f in tpl["files"] if f["match"].endswith("_d3.txt")]
    (d / "template.yaml").write_text(yaml.safe_dump(tpl), encoding="utf-8")
    return d


def _copy(src: Path, dst: Path, *, channel: dict | None = None, constants: dict | None = None,
          fuel=None, header: tuple[str, str] | None = None) -> tuple[Path, Path]:
    """The virtual test in ``dst`` with the fuel channel's spec, constants, fuel values
    (``fuel(t, v) -> v``) or a header text changed."""
    dst.mkdir()
    data = next(src.glob("*_d3.txt"))
    lines = data.read_text(encoding="latin-1").splitlines()
    head = lines[0].split("\t")
    col = next(i for i, h in enumerate(head) if h.startswith(FUEL_RAW + "["))
    if header is not None:
        lines[0] = lines[0].replace(*header)
    if fuel is not None:
        out = [lines[0]]
        for ln in lines[1:]:
            p = ln.split("\t")
            p[col] = fuel(float(p[0]), p[col])
            out.append("\t".join(p))
        lines = out
    (dst / data.name).write_text("\n".join(lines) + "\n", encoding="latin-1")
    tpl = yaml.safe_load((src / "template.yaml").read_text(encoding="utf-8"))
    tpl["files"][0]["channels"][FUEL_RAW].update(channel or {})
    tpl["constants"].update(constants or {})
    (dst / "template.yaml").write_text(yaml.safe_dump(tpl), encoding="utf-8")
    return dst / data.name, dst / "template.yaml"


def _run(data: Path, tpl: Path):
    from vehval.workflow import TestRun

    run = TestRun.load([data], tpl)
    res = run.results().results
    return res, run.qa_outcome.result.findings


def _errors(findings, kind: Kind):
    return [f for f in findings if f.kind == kind and f.severity == Severity.ERROR]


def test_clean_virtual_test_has_no_fuel_gate_finding(virtual, tmp_path):
    res, found = _run(*_copy(virtual, tmp_path / "clean"))
    assert not [f for f in found if f.kind in (Kind.FUEL_EFFICIENCY, Kind.FUEL_RESPONSE)]
    assert res.headline()["withheld"] is None


@pytest.mark.parametrize("scale, word", [(2.0, "2x"), (0.5, "1/2")])
def test_fuel_scale_withholds_with_the_factor(virtual, tmp_path, scale, word):
    res, found = _run(*_copy(virtual, tmp_path / "s", channel={"scale": scale}))
    err = _errors(found, Kind.FUEL_EFFICIENCY)
    assert len(err) == 1, [f.message for f in found if f.severity == Severity.ERROR]
    assert "brake efficiency" in err[0].message and word in err[0].message
    assert err[0].numbers["factor"] == pytest.approx(scale)
    head = res.headline()
    assert head["fuel_economy_mpg"] is None and head["withheld"] is not None
    assert "fuel_efficiency" in head["withheld"]["reason"]


@pytest.mark.parametrize("density, guess", [(74.0, "a digit missing"), (0.74, "g/cm3")])
def test_density_out_of_liquid_range_refused_naming_key_and_unit(virtual, tmp_path, density,
                                                                   guess):
    from vehval.io.template import load_template

    _data, tpl = _copy(virtual, tmp_path / "d", constants={"fuel_density_kg_per_m3": density})
    with pytest.raises(ConfigError) as exc:
        load_template(tpl)
    text = str(exc.value)
    assert "constants.fuel_density_kg_per_m3" in text and guess in text and "740 kg/m3" in text


def test_fuel_spec_density_refused():
    from vehval.io.template import template_from_data

    data = {"files": [{"match": "*.csv", "source": "dyno", "time": {"column": "t"},
                       "channels": {"v": {"name": "veh_spd_test", "unit": "m/s"}}}],
            "fuel": {"name": "diesel", "density_kg_per_m3": 1500}}
    with pytest.raises(ConfigError, match="fuel.density_kg_per_m3: 1500 kg/m3 is no liquid"):
        template_from_data(data, "t.yaml")


def _firing_window(virtual: Path) -> tuple[float, float]:
    """A 200 s window holding the most engine-on time of the virtual test."""
    data = next(virtual.glob("*_d3.txt"))
    arr = np.genfromtxt(data, delimiter="\t", skip_header=1)
    head = data.read_text(encoding="latin-1").splitlines()[0].split("\t")
    t = arr[:, 0]
    fuel = arr[:, next(i for i, h in enumerate(head) if h.startswith(FUEL_RAW))]
    best = max(np.arange(0.0, t[-1] - 200.0, 20.0),
               key=lambda a: float(np.sum((t >= a) & (t < a + 200.0) & (fuel > 0.05))))
    return float(best), float(best) + 200.0


@pytest.mark.parametrize("mode", ["zero", "nan", "stuck", "clip"])
def test_fuel_not_following_power_withholds(virtual, tmp_path, mode):
    t0, t1 = _firing_window(virtual)

    def mutate(t: float, v: str) -> str:
        if mode == "clip":
            return f"{min(float(v), 0.3):.3f}"
        if not t0 <= t < t1:
            return v
        if mode == "stuck":
            return "0.400"                  # a plausible reading, frozen for 200 s
        return "0.000" if mode == "zero" else "NaN"
    res, found = _run(*_copy(virtual, tmp_path / mode, fuel=mutate))
    err = _errors(found, Kind.FUEL_RESPONSE)
    assert err, [f.message for f in found if f.signal.startswith("fuel")]
    assert "while the engine delivers power" in err[0].message and err[0].fix
    if mode == "clip":
        assert "clipped at its ceiling" in err[0].message
    head = res.headline()
    assert head["fuel_economy_mpg"] is None
    assert "fuel_response" in head["withheld"]["reason"]


def test_volume_rate_declared_as_mass_named_by_the_fuel_map(virtual, tmp_path):
    # the header agrees with the template (g/s), so only the physics can tell: the meter
    # reads 1/0.74 of the engine map, which ccps (the density) explains
    data, tpl = _copy(virtual, tmp_path / "v", channel={"unit": "g/s"},
                      header=(f"{FUEL_RAW}[ccps]", f"{FUEL_RAW}[g/s]"))
    res, found = _run(data, tpl)
    err = _errors(found, Kind.FUEL_MAP)
    assert len(err) == 1 and err[0].numbers["probable_unit"] == "ccps"
    assert "in ccps, not g/s (x0.74)" in err[0].fix
    assert res.headline()["withheld"] is not None


# ---------------------------------------------------------------- the real Cruze HWFET
def _cruze(tmp_path: Path, *, scale: float | None = None, fuel=None) -> tuple[Path, Path]:
    tpl = yaml.safe_load((HERE / "templates" / "cruze.yaml").read_text(encoding="utf-8"))
    spec = tpl["files"][0]["channels"]["Fuel_Flow_Bench_Modal"]
    if scale is not None:
        spec["scale"] = scale
    (tmp_path / "t.yaml").write_text(yaml.safe_dump(tpl), encoding="utf-8")
    data = CRUZE
    if fuel is not None:
        lines = CRUZE.read_text(encoding="latin-1").splitlines()
        col = lines[0].split("\t").index("Fuel_Flow_Bench_Modal[g/s]")
        out = [lines[0]]
        for ln in lines[1:]:
            p = ln.split("\t")
            p[col] = fuel(float(p[0]), p[col])
            out.append("\t".join(p))
        data = tmp_path / CRUZE.name
        data.write_text("\n".join(out) + "\n", encoding="latin-1")
    return data, tmp_path / "t.yaml"


@pytest.mark.realdata
@pytest.mark.skipif(not CRUZE.is_file(), reason="real data not available")
def test_cruze_hwfet_gates(tmp_path):
    res, found = _run(*_cruze(tmp_path))
    assert res.headline()["fuel_economy_mpg"] == pytest.approx(54.80, abs=0.01)
    assert not [f for f in found if f.kind in (Kind.FUEL_EFFICIENCY, Kind.FUEL_RESPONSE)]
    for scale in (2.0, 0.5):
        d = tmp_path / str(scale)
        d.mkdir()
        res, found = _run(*_cruze(d, scale=scale))
        err = _errors(found, Kind.FUEL_EFFICIENCY)
        assert err and "tank-to-wheel" in err[0].message
        assert err[0].numbers["factor"] == pytest.approx(scale)
        assert res.headline()["fuel_economy_mpg"] is None
    d = tmp_path / "zero"
    d.mkdir()
    res, found = _run(*_cruze(d, fuel=lambda t, v: "0.000" if 1000 <= t < 1200 else v))
    assert _errors(found, Kind.FUEL_RESPONSE)
    assert res.headline()["fuel_economy_mpg"] is None
