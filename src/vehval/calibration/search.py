"""Searches over bounded vehicle parameters (derivative-free: the fuel and engine state of a
hybrid move in steps with its thresholds, so gradients are useless).

* :func:`de_polish`: differential evolution (scipy, a whole generation evaluated as one
  batch, Latin-hypercube start plus the start point), then a bounded Nelder-Mead polish in
  normalised coordinates that can step across the plateaus the evolution leaves;
* :func:`powell`: bounded Powell from the start point, kept only when it improves on it;
* :func:`grid_refine`: every point of a grid, then coordinate refinement (midpoints towards
  each neighbour, the step halving each round), each setting scored once.

Each is deterministic for a given objective (and seed).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field
from typing import Any, Callable, Iterable, Sequence

import numpy as np
from scipy.optimize import differential_evolution, minimize


@dataclass
class PointSearch:
    """Outcome of a search over a parameter vector.

    Attributes
    ----------
    x : numpy.ndarray
        Best parameter vector found (the start when nothing beat it).
    value, start_value : float
        Objective at ``x`` and at the start.
    method : str
        What ran, for the result and the provenance.
    n_evaluations : int
        Objective evaluations (the start included).
    """

    x: np.ndarray
    value: float
    start_value: float
    method: str
    n_evaluations: int = 0


def de_polish(f_batch: Callable[[np.ndarray], np.ndarray], f_point: Callable[[np.ndarray], float],  # noqa: PLR0913 - the search options of `vehval calibrate`, passed through
              best: Callable[[], tuple[float, np.ndarray]], lo: np.ndarray, hi: np.ndarray,
              x0: np.ndarray, *, popsize: int, maxiter: int, seed: int, polish: bool = True,
              polish_evals: int | None = None, label: str = "",
              callback: Callable[[], None] | None = None) -> str:
    """Differential evolution, then a bounded Nelder-Mead polish around the best point.

    Parameters
    ----------
    f_batch : callable
        Objective of candidates ``xs`` of shape (n_params, n_candidates) -> (n_candidates,).
    f_point : callable
        Objective of one vector (the polish).
    best : callable
        The best (objective, vector) evaluated so far: the objective keeps it (a batch may
        hold invalid candidates it scores with a penalty and never counts as best).
    lo, hi : numpy.ndarray
        Bounds of each parameter.
    x0 : numpy.ndarray
        Start point (in the first population).
    popsize, maxiter, seed : int
        Population multiplier, generations (at most) and seed of the evolution.
    polish : bool
        Run the polish (budget ``polish_evals`` evaluations per parameter, default 30).
    label : str
        Objective named in the method text (``traces objective``).
    callback : callable, optional
        Called after each generation.

    Returns
    -------
    str
        The method text (``differential evolution (..., N generations) + Nelder-Mead polish``).
    """
    def cb(*_a: Any, **_k: Any) -> None:
        if callback is not None:
            callback()

    de = differential_evolution(f_batch, list(zip(lo, hi)), vectorized=True, updating="deferred",
                                popsize=popsize, maxiter=maxiter, init="latinhypercube",
                                x0=x0, polish=False, seed=seed, tol=1e-3, atol=1e-4,
                                mutation=(0.5, 1.0), recombination=0.7, callback=cb)
    method = f"differential evolution ({label}, popsize {popsize}, {de.nit} generations)"
    if polish:
        n = len(x0)
        span = hi - lo

        def f_norm(u: np.ndarray) -> float:
            return f_point(lo + np.clip(u, 0.0, 1.0) * span)

        u0 = (best()[1] - lo) / span
        simplex = [u0] + [np.clip(u0 + np.eye(n)[i] * 0.05 * (1 if u0[i] < 0.95 else -1), 0, 1)
                          for i in range(n)]
        minimize(f_norm, u0, method="Nelder-Mead", bounds=[(0.0, 1.0)] * n,
                 options={"initial_simplex": np.array(simplex),
                          "maxfev": (polish_evals or 30) * n, "xatol": 1e-4, "fatol": 1e-5})
        method += " + Nelder-Mead polish"
    return method


def powell(f: Callable[[np.ndarray], float], x0: np.ndarray,
           bounds: Sequence[tuple[float, float]], maxfev: int) -> PointSearch:
    """Bounded Powell from ``x0`` (xtol 1e-3, ftol 1e-6); the start stays when it is better."""
    count = [0]

    def counted(x: np.ndarray) -> float:
        count[0] += 1
        return f(x)

    f0 = counted(x0)
    res = minimize(counted, x0, method="Powell", bounds=bounds,
                   options={"maxfev": maxfev, "xtol": 1e-3, "ftol": 1e-6})
    x = res.x if res.fun <= f0 else x0
    return PointSearch(x=np.asarray(x, float), value=float(min(res.fun, f0)), start_value=f0,
                       method="bounded Powell", n_evaluations=count[0])


def _key(values: Iterable[float]) -> tuple[float, ...]:
    return tuple(round(float(v), 9) for v in values)


@dataclass
class GridSearch:
    """Outcome of :func:`grid_refine`: the best setting, every setting scored in order."""

    best: tuple[float, ...]
    score: Any
    evaluations: list[tuple[tuple[float, ...], Any]] = field(default_factory=list)
    method: str = ""


def grid_method(refine_rounds: int) -> str:
    """The method text of :func:`grid_refine` with ``refine_rounds`` rounds."""
    if refine_rounds <= 0:
        return "grid"
    return (f"grid, then {refine_rounds} round{'s' if refine_rounds != 1 else ''} of "
            "coordinate refinement")


def grid_refine(grid: dict[str, list[float]],
                evaluate: Callable[[list[tuple[float, ...]]], Iterable[Any]],
                refine_rounds: int) -> GridSearch:
    """Every setting of ``grid``, then ``refine_rounds`` rounds of coordinate refinement.

    Parameters
    ----------
    grid : dict
        Parameter name -> sorted candidate values.
    evaluate : callable
        Scores of a list of settings (tuples in the order of ``grid``), in order; scores
        compare with ``<`` (lower is better; tuples compare element by element).
    refine_rounds : int
        Rounds after the grid: each parameter in turn, a step of half the last one (first:
        half the smallest grid spacing) below and above the best, the lower kept.

    Returns
    -------
    GridSearch
        Each setting is scored once (settings equal to 1e-9 count as one).
    """
    cache: dict[tuple[float, ...], Any] = {}
    evals: list[tuple[tuple[float, ...], Any]] = []
    names = list(grid)

    def score_all(settings: list[tuple[float, ...]]) -> None:
        todo = list(dict.fromkeys(_key(v) for v in settings if _key(v) not in cache))
        for v, sc in zip(todo, evaluate(todo)):
            cache[v] = sc
            evals.append((v, sc))

    def score(values: Iterable[float]) -> Any:
        return cache[_key(values)]

    combos: list[tuple[float, ...]] = list(itertools.product(*grid.values()))
    score_all(combos)
    best = min(combos, key=score)
    steps = {n: float(min(np.diff(v)) if len(v) > 1 else abs(v[0]) * 0.1 or 1.0)
             for n, v in grid.items()}
    for _ in range(refine_rounds):
        for i, n in enumerate(names):
            steps[n] /= 2.0
            cands: list[tuple[float, ...]] = []
            for sign in (-1.0, 1.0):
                moved = list(best)
                moved[i] = best[i] + sign * steps[n]
                cands.append(tuple(moved))
            score_all(cands)
            for cand in cands:  # minus first, then plus against the updated best
                if score(cand) < score(best):
                    best = cand
    return GridSearch(best=tuple(best), score=score(best), evaluations=evals,
                      method=grid_method(refine_rounds))
