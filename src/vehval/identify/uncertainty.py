"""Coverage of a prediction by the identification data, and its 95 % prediction interval.

**Coverage.** The identification's fired operating points (engine speed x engine power) are
binned on a grid of ``SPEED_BIN_RPM`` x ``POWER_BIN_W``; a cell is covered when it holds at
least ``MIN_CELL_S`` of samples, or borders such a cell (one cell of tolerance). A
prediction's *uncovered share* is the share of its predicted fuel burnt, fired, in cells not
covered: fuel the model extrapolates. Idle and overrun fuel count as covered (their rates
are identified as such). The grid is stored with the vehicle (``identification.coverage``),
so ``vehval predict`` needs only the vehicle file.

**Prediction interval** of the fuel of a test or phase (half-width, relative), from three
independent parts and the coverage:

- residual noise: the fuel model's residual summed over ``block_s`` blocks has variance
  ``block_var_kg2``; a prediction spanning n blocks gets ``n · block_var_kg2``;
- parameter uncertainty: ``g' C g`` with C the coefficients' covariance (sandwich over blocks)
  and g the sum of the model's regressors over the predicted operating points;
- model error from test to test: the RMS of the fuel model's relative error per phase of the
  identification tests, on their own measured operating points (the first bag of a test
  burns more than later ones, which the model has no term for); a whole test of K phases
  with fuel shares w_k gets ``rms · sqrt(sum w_k²)``;
- coverage: ``EXTRAP_REL`` x the uncovered share, added to the half-width (the model's
  error on fuel it extrapolates is taken as up to 25 % of that fuel).

``half = 1.96 · sqrt(residual + parameters + model) / predicted + EXTRAP_REL · uncovered``.
"""

from __future__ import annotations

import numpy as np

from vehval.constants import RPM_RAD_PER_S
from vehval.integrals import held_sum

SPEED_BIN_RPM = 100.0
POWER_BIN_W = 2000.0
MIN_CELL_S = 1.0
EXTRAP_REL = 0.25
POOR_COVERAGE = 0.2   # uncovered share above which predict warns
Z95 = 1.96
RPM = RPM_RAD_PER_S  # [rad/s] per [rpm]


def coverage_grid(w: np.ndarray, p: np.ndarray, dt: float) -> dict:
    """Covered cells of the fired operating points (``w`` [rad/s], ``p`` [W], step ``dt``)."""
    iw = np.floor(w / (SPEED_BIN_RPM * RPM)).astype(int)
    ip = np.floor(p / POWER_BIN_W).astype(int)
    cells, counts = np.unique(np.column_stack([iw, ip]), axis=0, return_counts=True)
    core = {(int(a), int(b)) for (a, b), c in zip(cells, counts) if c * dt >= MIN_CELL_S}
    near = {(a + da, b + db) for a, b in core for da in (-1, 0, 1) for db in (-1, 0, 1)}
    return {"speed_bin_rpm": SPEED_BIN_RPM, "power_bin_w": POWER_BIN_W,
            "min_cell_s": MIN_CELL_S, "cells": sorted([list(c) for c in near])}


def _covered(grid: dict, w: np.ndarray, p: np.ndarray) -> np.ndarray:
    cells = {tuple(c) for c in grid["cells"]}
    iw = np.floor(w / (grid["speed_bin_rpm"] * RPM)).astype(int)
    ip = np.floor(p / grid["power_bin_w"]).astype(int)
    return np.array([(a, b) in cells for a, b in zip(iw, ip)], dtype=bool)


def _regressors(w, p, standing, overrun, fired, w_scale, p_scale) -> np.ndarray:
    """The fuel model's columns (scaled as in :mod:`vehval.identify.fuelmap`)."""
    ws, ps, f = w / w_scale, np.maximum(p, 0.0) / p_scale, fired.astype(float)
    return np.column_stack([f, f * ws, f * ws * ws, f * ps, f * ps * ws,
                            overrun.astype(float), standing.astype(float)])


def interval_parts(identification: dict, sim, dt: float, selections: dict) -> dict:
    """Per selection (name -> boolean mask over the simulated samples): the uncovered share
    and the relative 95 % half-width (see the module docstring); {} when the vehicle's
    identification carries no uncertainty (a vehicle not identified by vehval)."""
    fm = (identification or {}).get("fuel_map") or {}
    unc, grid = fm.get("uncertainty"), (identification or {}).get("coverage")
    if not unc or not grid:
        return {}
    w = np.asarray(sim["eng_spd_out_simu"].values, float)
    p = np.asarray(sim["eng_pwr_out_simu"].values, float)
    fuel = np.asarray(sim["fuel_rate_simu"].values, float)
    v = np.asarray(sim["veh_spd_simu"].values, float)
    cut = np.asarray(sim["eng_fuel_cut_simu"].values, float) > 0.5
    standing = v < 0.05
    overrun = ~standing & cut
    fired = ~standing & ~overrun
    x = _regressors(w, p, standing, overrun, fired, unc["w_scale"], unc["p_scale"])
    cov = np.asarray(unc["theta_cov_scaled"], float)
    uncovered = fired & ~_covered(grid, w, p)
    n_block = unc["block_s"] / dt
    out = {}
    for name, (sel, weights) in selections.items():
        total = held_sum(fuel, dt, sel)
        if total <= 0:
            continue
        g = x[sel].sum(axis=0) * dt
        var = (float(np.count_nonzero(sel)) / n_block * unc["block_var_kg2"]
               + float(g @ cov @ g)
               + (unc["phase_error_rms"] * total) ** 2 * float(np.sum(np.square(weights))))
        share = held_sum(fuel, dt, sel & uncovered) / total
        out[name] = {"uncovered_share": share,
                     "pi95_rel": float(Z95 * np.sqrt(var) / total + EXTRAP_REL * share)}
    return out
