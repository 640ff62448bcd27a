"""Min/max decimation of time traces: the figure layer's (:mod:`vehval.figures.decimate`),
named here for the report's and the workbench's callers."""

from vehval.figures.decimate import *  # noqa: F403
from vehval.figures.decimate import DEFAULT_BUCKETS, bucket_index, decimate_minmax, minmax_indices

__all__ = ["DEFAULT_BUCKETS", "bucket_index", "decimate_minmax", "minmax_indices"]
