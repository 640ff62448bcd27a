"""The vehicle definition: parameter blocks, maps and loading of vehicle files.

A vehicle file is data that QA, analysis, identification, the report and the simulator all
read; this package sits below all of them (it imports only units, errors and numpy/pydantic).
"""

from vehval.vehicle.definition import BLOCKS, Vehicle, list_vehicles, load_vehicle

__all__ = ["BLOCKS", "Vehicle", "list_vehicles", "load_vehicle"]
