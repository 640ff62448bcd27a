"""The vehicle definition: parameter blocks, maps and loading of vehicle files.

A vehicle file is data that QA, analysis, identification, the report and the simulator all
read; this package sits below all of them (it imports only units, errors and numpy/pydantic).
The ``architecture:`` key of the file selects the model: ``power_split`` (default),
``conventional``, ``parallel_hybrid`` or ``battery_electric``.
"""

from vehval.vehicle.bev import BEV_BLOCKS, BatteryElectricVehicle
from vehval.vehicle.conventional import CONVENTIONAL_BLOCKS, ConventionalVehicle
from vehval.vehicle.definition import ARCHITECTURES, BLOCKS, Vehicle, list_vehicles, load_vehicle
from vehval.vehicle.parallel import PARALLEL_BLOCKS, ParallelHybridVehicle

__all__ = ["ARCHITECTURES", "BEV_BLOCKS", "BLOCKS", "BatteryElectricVehicle", "CONVENTIONAL_BLOCKS",
           "ConventionalVehicle", "PARALLEL_BLOCKS", "ParallelHybridVehicle", "Vehicle",
           "list_vehicles", "load_vehicle"]
