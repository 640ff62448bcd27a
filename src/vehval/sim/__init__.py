"""Forward-looking vehicle simulation: cycles, components, controller, driver.

The compiled kernels are decorated with :func:`vehval.numba_cache.njit` (the cache directory
of this source version); numba loads with the first module that holds one.
"""
