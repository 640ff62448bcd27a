"""Forward-looking vehicle simulation: cycles, components, controller, driver."""

from vehval.numba_cache import configure as _configure_numba_cache

_configure_numba_cache()  # before any compiled kernel of the package is decorated
