"""Index constants of the compiled loops, generated from :mod:`vehval.sim.layout`.

``P_<NAME>`` indexes the parameter vector (:data:`~vehval.sim.layout.PARAMS`), ``S_<NAME>``
the recorded signals (:data:`~vehval.sim.layout.SIGNALS`), ``Y_<NAME>`` the summary
(:data:`~vehval.sim.layout.SUMMARY`), ``X_<NAME>`` the loop state
(:data:`~vehval.sim.layout.STATE`); ``N_P``, ``N_S``, ``N_Y``, ``N_X`` are their lengths.
``CP_``, ``CS_``, ``CY_`` (and ``N_CP``, ``N_CS``, ``N_CY``) are the same for the
conventional loop (``CONV_PARAMS``, ``CONV_SIGNALS``, ``CONV_SUMMARY``). numba reads
module globals as compile-time constants, so the kernels index with literals; the compiled
cache follows a change here through :mod:`vehval.numba_cache`.
"""

from __future__ import annotations

from vehval.sim.layout import (
    CONV_PARAMS,
    CONV_SIGNALS,
    CONV_SUMMARY,
    PARAMS,
    SIGNALS,
    STATE,
    SUMMARY,
)


def constants(prefix: str, names: tuple[str, ...]) -> dict[str, int]:
    """``{PREFIX_NAME: position}`` for a layout tuple."""
    return {f"{prefix}_{n.upper()}": i for i, n in enumerate(names)}


_ALL = {**constants("P", PARAMS), **constants("S", SIGNALS), **constants("Y", SUMMARY),
        **constants("X", STATE), **constants("CP", CONV_PARAMS),
        **constants("CS", CONV_SIGNALS), **constants("CY", CONV_SUMMARY),
        "N_CP": len(CONV_PARAMS), "N_CS": len(CONV_SIGNALS), "N_CY": len(CONV_SUMMARY),
        "N_P": len(PARAMS), "N_S": len(SIGNALS), "N_Y": len(SUMMARY), "N_X": len(STATE)}
globals().update(_ALL)
__all__ = sorted(_ALL)
