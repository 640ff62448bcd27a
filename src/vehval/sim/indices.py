"""Index constants of the compiled loops, generated from :mod:`vehval.sim.layout`.

``P_<NAME>`` indexes the parameter vector (:data:`~vehval.sim.layout.PARAMS`), ``S_<NAME>``
the recorded signals (:data:`~vehval.sim.layout.SIGNALS`), ``Y_<NAME>`` the summary
(:data:`~vehval.sim.layout.SUMMARY`), ``X_<NAME>`` the loop state
(:data:`~vehval.sim.layout.STATE`); ``N_P``, ``N_S``, ``N_Y``, ``N_X`` are their lengths. numba reads
module globals as compile-time constants, so the kernels index with literals; the compiled
cache follows a change here through :mod:`vehval.numba_cache`.
"""

from __future__ import annotations

from vehval.sim.layout import PARAMS, SIGNALS, STATE, SUMMARY


def constants(prefix: str, names: tuple[str, ...]) -> dict[str, int]:
    """``{PREFIX_NAME: position}`` for a layout tuple."""
    return {f"{prefix}_{n.upper()}": i for i, n in enumerate(names)}


_ALL = {**constants("P", PARAMS), **constants("S", SIGNALS), **constants("Y", SUMMARY),
        **constants("X", STATE),
        "N_P": len(PARAMS), "N_S": len(SIGNALS), "N_Y": len(SUMMARY), "N_X": len(STATE)}
globals().update(_ALL)
__all__ = sorted(_ALL)
