"""Identification of a vehicle model from its own dyno tests (conventional powertrain).

traces -> road load (:mod:`.roadload`) -> gears, converter, shift lines (:mod:`.gears`) ->
fuel map (:mod:`.fuelmap`) -> vehicle file (:mod:`.build`); :mod:`.predict` drives held-out
tests with the model; :mod:`.report` shows the fits. Above the simulator in the data flow.
"""

from vehval.identify.build import Identification, identify_conventional, write_vehicle
from vehval.identify.loading import load_traces
from vehval.identify.predict import predict_trace
from vehval.identify.traces import (
           IdentificationError,
           Trace,
           trace_from_test,
)

__all__ = ["Identification", "IdentificationError", "Trace", "identify_conventional",
           "load_traces", "predict_trace", "trace_from_test", "write_vehicle"]
