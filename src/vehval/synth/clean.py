"""The clean SI signals a virtual test is measured from.

Most come from the simulation (``<base>_simu`` signals); the few quantities the simulator does
not model (test cell temperature and humidity, engine coolant temperature, test phase) are
synthesised here from simple, documented models driven by the simulation. All are put on one
uniform grid that extends the simulation grid by padding on both sides (the vehicle is at rest
and the values are held there), so that every file's sample instants fall inside it.
"""

from __future__ import annotations

import numpy as np

from vehval.cycles import cycle_parts
from vehval.synth.sensors import rng_for

#: Clean signals synthesised by the virtual dyno (not simulated), with their SI unit.
SYNTHESISED = {"amb_temp": "degC", "amb_rh": "dimensionless", "eng_temp_coolant": "degC",
               "test_phase": "dimensionless"}


PAD_S = 15.0  # clean-grid padding on each side of the simulation [s]


def extended_grid(sim_time: np.ndarray, pad_s: float = PAD_S) -> np.ndarray:
    """Uniform grid [s] covering the simulation grid plus ``pad_s`` on each side.

    The step is the simulation's; grid points coincide with the simulation's samples.
    """
    dt = float(np.median(np.diff(sim_time)))
    n_pad = int(round(pad_s / dt))
    k = np.arange(-n_pad, sim_time.size + n_pad)
    return np.round(sim_time[0] + k * dt, 9)


def hold_extend(sim_time: np.ndarray, values: np.ndarray, grid: np.ndarray) -> np.ndarray:
    """Values on ``grid``: interpolated inside the simulation, first/last value held outside."""
    v = np.asarray(values, dtype=float)
    v = np.where(np.isfinite(v), v, 0.0)
    return np.interp(grid, sim_time, v)


def test_phase(grid: np.ndarray, cycle_name: str, duration_s: float) -> np.ndarray:
    """Phase number: 0 in the padding, 1, 2... over the cycle's regulatory parts.

    The parts are those of the one table (:func:`vehval.cycles.cycle_parts`); a part met
    twice keeps its number (the US06 city part is phase 1 before and after the highway
    part, as a lab's bag 1); a cycle without standard parts is phase 1 throughout.
    """
    parts = cycle_parts(cycle_name)
    numbers = {p: i for i, p in enumerate(dict.fromkeys(p for p, _, _ in parts), start=1)}
    phase = np.ones(np.shape(grid))
    for part, start, _ in parts:
        if start < duration_s:
            phase[grid >= start] = numbers[part]
    return np.where((grid < 0.0) | (grid > duration_s), 0.0, phase).astype(float)


def cell_conditions(grid: np.ndarray, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Test cell temperature [°C] and relative humidity [-]: set point plus HVAC cycling."""
    rng = rng_for(seed, "clean", "cell")
    t0 = rng.uniform(22.0, 25.0)
    rh0 = rng.uniform(0.40, 0.50)
    period = rng.uniform(500.0, 700.0)
    phase = rng.uniform(0, 2 * np.pi)
    temp = t0 + 0.3 * np.sin(2 * np.pi * grid / period + phase) + 2.0e-4 * (grid - grid[0])
    rh = rh0 - 0.01 * np.sin(2 * np.pi * grid / period + phase)
    return temp, rh


def coolant_temperature(grid: np.ndarray, fuel_rate_kg_s: np.ndarray, amb_c: np.ndarray,
                        fuel_lhv_j_per_kg: float) -> np.ndarray:
    """Engine coolant temperature [°C] from a lumped thermal model (cold start).

    ``C dT/dt = eta_c * P_fuel - h (T - T_amb) - q_thermostat`` with ``C = 40 kJ/K``,
    ``eta_c = 0.30`` of the fuel power to the coolant, ``h = 15 W/K`` and a thermostat that
    removes the surplus above 88 °C (proportional, 2 kW/K). Starts at the cell temperature.
    """
    dt = float(grid[1] - grid[0])
    p_fuel = np.clip(np.asarray(fuel_rate_kg_s, float), 0.0, None) * fuel_lhv_j_per_kg
    cap, eta, h, t_open, k_rad = 40.0e3, 0.30, 15.0, 88.0, 2.0e3
    out = np.empty_like(grid)
    temp = float(amb_c[0])
    for i in range(grid.size):
        out[i] = temp
        q = eta * p_fuel[i] - h * (temp - amb_c[i]) - k_rad * max(temp - t_open, 0.0)
        temp += dt * q / cap
    return out


def build_clean(sim_signals: dict[str, tuple[np.ndarray, np.ndarray]], cycle_name: str,
                duration_s: float, seed: int, fuel_lhv_j_per_kg: float, pad_s: float = PAD_S,
                ) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """All clean signals on the extended grid.

    Parameters
    ----------
    sim_signals : dict
        ``base -> (time [s], values [SI])`` of the simulation's ``_simu`` signals.
    cycle_name : str
        Cycle name (for the phase numbers).
    duration_s : float
        Cycle duration [s].
    seed : int
        Test seed.
    fuel_lhv_j_per_kg : float
        Fuel lower heating value [J/kg] for the coolant model.
    pad_s : float
        Padding on each side of the simulated span [s]; must cover every file's sample
        instants on the true clock.

    Returns
    -------
    grid : numpy.ndarray
        Extended uniform grid [s].
    clean : dict
        ``base -> values [SI]`` on ``grid``.
    """
    t_ref = sim_signals["veh_spd"][0]
    grid = extended_grid(t_ref, pad_s)
    clean = {b: hold_extend(t, v, grid) for b, (t, v) in sim_signals.items()}
    # at rest in the padding: speeds, forces, torques and flows are those of a parked car
    outside = (grid < t_ref[0]) | (grid > t_ref[-1])
    for b in ("veh_spd", "veh_acc", "veh_frc_in", "veh_frc_loss", "whl_trq_out", "whl_spd",
              "mot_spd_out", "mot_trq_out", "brk_frc", "drv_pwr_demand"):
        if b in clean:
            clean[b] = np.where(outside, 0.0, clean[b])
    temp, rh = cell_conditions(grid, seed)
    clean["amb_temp"] = temp
    clean["amb_rh"] = rh
    fuel = clean.get("fuel_rate", np.zeros_like(grid))
    clean["eng_temp_coolant"] = coolant_temperature(grid, fuel, temp, fuel_lhv_j_per_kg)
    clean["test_phase"] = test_phase(grid, cycle_name, duration_s)
    return grid, clean
