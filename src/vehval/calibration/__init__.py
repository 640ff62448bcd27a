"""The calibration engine: one search, hold-out evaluation and provenance for every calibrator.

Three commands tune vehicle parameters: ``vehval calibrate`` (a power-split model on dyno
tests, :mod:`vehval.validate.calibration`), ``vehval calibrate`` on a conventional car
(identification's calibration step, :mod:`vehval.identify.calibrate`) and ``vehval epa
calibrate`` (:mod:`vehval.epa.calibrate`). Each states its objective (what a setting of the
parameters scores on its tests); everything else is here, once:

* :mod:`~vehval.calibration.search`: the searches over bounded parameters (differential
  evolution with a Nelder-Mead polish, bounded Powell, a grid with coordinate refinement);
* :mod:`~vehval.calibration.holdout`: errors before and after on the tuning and held-out
  tests, and the over-fitting guard;
* :mod:`~vehval.calibration.provenance`: the one provenance text of a calibrated value and
  the one way it is written into the vehicle file.
"""

from vehval.calibration.holdout import HOLDOUT_TOL_POINTS, before_after, holdout_worse
from vehval.calibration.provenance import (
    Provenance,
    vehicle_with_values,
    write_vehicle_yaml,
)
from vehval.calibration.search import (
    GridSearch,
    PointSearch,
    de_polish,
    grid_refine,
    powell,
)

__all__ = ["HOLDOUT_TOL_POINTS", "GridSearch", "PointSearch", "Provenance", "before_after",
           "de_polish", "grid_refine", "holdout_worse", "powell", "vehicle_with_values",
           "write_vehicle_yaml"]
