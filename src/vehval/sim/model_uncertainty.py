"""Model uncertainty: the vehicle file's sourced parameter ranges propagated to a figure.

Each parameter with an ``uncertainty`` in the vehicle file (:func:`vehval.sim.sensitivity.
uncertain_parameters`) is a source of model uncertainty. Its effect on the SOC-corrected
fuel economy of a cycle (the simulator's energy-balance correction, from the initial SOC of the charge-balanced
base run, as in :func:`vehval.sim.sensitivity.sensitivity`) is propagated in one of two ways;
the result is the expanded uncertainty ``U`` (k = 2) of the predicted figure.

**Linearisation** (``method="linear"``, the default): each parameter at its two ends, one at
a time; its half-swing ``h_i = (f(high) - f(low)) / 2`` is turned into a standard uncertainty
as the sheet states the range:

* ``range: [low, high]`` and ``scale: [low, high]`` (curves, maps): a limit with no stated
  confidence, taken as uniform (GUM 4.3.7): ``u_i = h_i / sqrt(3)``;
* ``rel_sd: x``: the ends are nominal x (1 -+ 2 x), so ``u_i = h_i / 2``.

``u = sqrt(sum u_i^2)`` (parameters uncorrelated), ``U = 2 u``. Cost: two runs per parameter.

**Monte Carlo** (``method="monte_carlo"``): ``draws`` sets of every scalar parameter at once
(uniform over a range, normal for rel_sd), ``U = 2 s`` with ``s`` the standard deviation of
the figures. At least :data:`MIN_DRAWS` draws (fewer are refused with the count); the
figure states its own sampling error, the relative standard error of a standard deviation
from n draws ``1 / sqrt(2 (n - 1))`` (7 % at 100 draws, 5 % at 200). Curves and maps are not
drawn (each would need its own run); their linearised contribution (two runs each) is added
in quadrature and counted in ``n_linearised``.

A vehicle without parameter ranges gets ``U = 0`` with method ``none`` and a note. Models
identified from tests (``vehval identify``) carry a prediction interval instead
(:mod:`vehval.identify.uncertainty`, given by ``vehval predict``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np

from vehval.constants import MIN_MC_DRAWS
from vehval.cycles import Cycle
from vehval.errors import ConfigError
from vehval.sim.batch import simulate_batch
from vehval.sim.sensitivity import MPG, Uncertain, _draw, _run_variants, uncertain_parameters
from vehval.sim.simulate import simulate
from vehval.vehicle import Vehicle, load_vehicle

#: Coverage factor of U.
K = 2.0
#: Fewest Monte Carlo draws accepted (the one floor of every draw).
MIN_DRAWS = MIN_MC_DRAWS
METHODS = ("linear", "monte_carlo")


@dataclass
class FigureUncertainty:
    """Model uncertainty of one predicted figure (a cycle's SOC-corrected fuel economy).

    Attributes
    ----------
    figure : str
        The cycle.
    nominal_mpg : float
        The model's figure with the nominal parameters [mpg].
    u_mpg : float
        Expanded uncertainty U (k = 2) [mpg].
    u_rel : float
        U / nominal [-].
    method : str
        ``linear``, ``monte_carlo`` or ``none``.
    n_draws : int or None
        Monte Carlo draws that gave a figure.
    sampling_error_rel : float or None
        Relative standard error of U from the finite draws [-] (Monte Carlo).
    n_linearised : int
        Parameters entering by their linearised contribution.
    contributors : list of dict
        ``{key, u_rel, share}``: each parameter's relative standard uncertainty and share of
        the linearised variance, largest first (linear; the curves' part of a Monte Carlo).
    notes : list of str
    """

    figure: str
    nominal_mpg: float
    u_mpg: float
    u_rel: float
    method: str
    n_draws: int | None = None
    sampling_error_rel: float | None = None
    n_linearised: int = 0
    contributors: list[dict[str, Any]] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        return {"figure": self.figure, "nominal_mpg": self.nominal_mpg, "U_mpg": self.u_mpg,
                "U_rel": self.u_rel, "k": K, "method": self.method, "n_draws": self.n_draws,
                "sampling_error_rel": self.sampling_error_rel,
                "n_linearised": self.n_linearised, "contributors": list(self.contributors),
                "notes": list(self.notes)}


def standard_uncertainty(u: Uncertain, half_swing: float) -> float:
    """Standard uncertainty of a figure from one parameter's half-swing (see the module
    docstring: uniform for a range or scale, ends at 2 sd for rel_sd)."""
    return abs(half_swing) / (2.0 if "rel_sd" in u.spec else math.sqrt(3.0))


def _figures(veh: Vehicle, cyc: Any, variants: list[dict], dt: float, soc0: float,
             workers: int) -> list[float]:
    """Fuel economy [mpg] of each variant (:func:`vehval.sim.sensitivity.figure_key`:
    SOC-corrected from ``soc0`` for a hybrid, plain for a car without a battery, ``soc0``
    NaN); nan where a variant is not a valid vehicle. A power-split car's scalar variants
    share one compiled call; every other case runs as the sensitivity runs it."""
    if isinstance(veh, Vehicle) and math.isfinite(soc0) and not any(
            isinstance(x, list) for var in variants for x in var.values()):
        try:   # one validation per variant; the filtering path below validates twice
            return [float(r[MPG]) for r in simulate_batch(
                veh, cyc, variants, dt=dt, workers=workers, soc_initial=soc0)]
        except ConfigError:
            pass   # a variant that is not a valid vehicle: run them apart (nan for it)
    return [float(x) for x in _run_variants(veh, cyc, variants, dt, soc0, workers)]


def _linear(veh: Vehicle, unc: list[Uncertain], cyc: Any, dt: float, soc0: float,
            base: float, workers: int) -> tuple[float, list[dict[str, Any]], list[str]]:
    """Sum of squares of the parameters' standard uncertainties [mpg^2], contributors, notes."""
    variants = [{u.key: u.low} for u in unc] + [{u.key: u.high} for u in unc]
    res = _figures(veh, cyc, variants, dt, soc0, workers) if unc else []
    n = len(unc)
    rows: list[dict[str, Any]] = []
    notes: list[str] = []
    var = 0.0
    for j, u in enumerate(unc):
        lo, hi = res[j], res[n + j]
        if not (math.isfinite(lo) and math.isfinite(hi)):
            notes.append(f"{u.key}: an end of its range is not a valid vehicle; left out")
            continue
        s = standard_uncertainty(u, 0.5 * (hi - lo))
        var += s * s
        rows.append({"key": u.key, "u_rel": s / base})
    for r in rows:
        r["share"] = (float(r["u_rel"]) * base) ** 2 / var if var > 0 else 0.0
    rows.sort(key=lambda r: -float(r["share"]))
    return var, rows, notes


def _monte_carlo(veh: Vehicle, unc: list[Uncertain], cyc: Any, dt: float, soc0: float,
                 draws: int, seed: int, workers: int) -> np.ndarray:
    """Figures [mpg] of ``draws`` joint draws of the scalar parameters (finite ones)."""
    rng = np.random.default_rng(seed)
    variants = [{u.key: _draw(u, rng) for u in unc} for _ in range(draws)]
    out = np.asarray(_figures(veh, cyc, variants, dt, soc0, workers), float)
    return out[np.isfinite(out)]


def check_method(method: str, draws: int) -> None:
    """Refuse an unknown method or a Monte Carlo of fewer than :data:`MIN_DRAWS` draws
    (ConfigError naming the count and the sampling error it would have)."""
    if method not in METHODS:
        raise ConfigError(f"model uncertainty: unknown method '{method}' (use "
                          f"{', '.join(METHODS)})")
    if method == "monte_carlo" and draws < MIN_DRAWS:
        raise ConfigError(f"model uncertainty: a Monte Carlo of {draws} draws is refused: at "
                          f"least {MIN_DRAWS} are needed (the relative sampling error of U "
                          f"would be {100 / math.sqrt(2 * max(draws - 1, 1)):.0f} %)")


def figure_uncertainty(vehicle: Vehicle | str, cycle: str | Cycle, *, method: str = "linear",
                       draws: int = 200, dt: float = 1.0, seed: int = 0, workers: int = 2,
                       params: Sequence[str] | None = None) -> FigureUncertainty:
    """U (k = 2) of the SOC-corrected fuel economy of ``vehicle`` on ``cycle``.

    Parameters
    ----------
    vehicle : Vehicle or name/path
    cycle : str or Cycle
    method : str
        ``linear`` or ``monte_carlo`` (see the module docstring).
    draws : int
        Monte Carlo draws, at least :data:`MIN_DRAWS`.
    dt : float
        Simulation step [s].
    seed : int
        Seed of the draws.
    workers : int
        Threads of the parallel compiled runs.
    params : sequence of str, optional
        Only these uncertain parameters (default: all).

    Raises
    ------
    ConfigError
        An unknown method, fewer than :data:`MIN_DRAWS` draws, or a parameter named in
        ``params`` without an uncertainty.
    """
    check_method(method, draws)
    veh = load_vehicle(vehicle)
    name = cycle if isinstance(cycle, str) else cycle.name
    unc = uncertain_parameters(veh, params)
    r = simulate(veh, cycle, dt=dt, charge_balance=True)
    base = float(r.summary.get(MPG, r.summary["fuel_economy_mpg"]))
    soc0 = float(r.summary.get("soc_initial", math.nan))
    if not unc:
        return FigureUncertainty(name, base, 0.0, 0.0, "none", notes=[
            f"{veh.name}: no parameter carries an uncertainty; U_model = 0"])
    if method == "linear":
        var, rows, notes = _linear(veh, unc, cycle, dt, soc0, base, workers)
        u = K * math.sqrt(var)
        return FigureUncertainty(name, base, u, u / base, "linear", n_linearised=len(rows),
                                 contributors=rows, notes=notes)
    maps = [u for u in unc if "scale" in u.spec]
    scalars = [u for u in unc if "scale" not in u.spec]
    figs = _monte_carlo(veh, scalars, cycle, dt, soc0, draws, seed, workers)
    if figs.size < MIN_DRAWS:
        raise ConfigError(f"model uncertainty of {veh.name} on {name}: only {figs.size} of "
                          f"{draws} draws gave a valid vehicle; at least {MIN_DRAWS} are needed")
    var_maps, rows, notes = _linear(veh, maps, cycle, dt, soc0, base, workers)
    var = float(np.var(figs, ddof=1)) + var_maps
    u = K * math.sqrt(var)
    if figs.size < draws:
        notes.append(f"{draws - figs.size} of {draws} draws were not a valid vehicle; left out")
    return FigureUncertainty(name, base, u, u / base, "monte_carlo", n_draws=int(figs.size),
                             sampling_error_rel=1.0 / math.sqrt(2.0 * (figs.size - 1)),
                             n_linearised=len(rows), contributors=rows, notes=notes)


def model_uncertainty(vehicle: Vehicle | str, cycles: Sequence[str | Cycle], **kw: Any
                      ) -> dict[str, FigureUncertainty]:
    """U (k = 2) per cycle (:func:`figure_uncertainty` with the same keywords)."""
    veh = load_vehicle(vehicle)
    out = {}
    for cyc in cycles:
        fu = figure_uncertainty(veh, cyc, **kw)
        out[fu.figure] = fu
    return out
