"""The results stage: what a laboratory reports for a test.

Per phase (emission bag) and for the whole test: distance, duration, fuel mass, volume,
economy and energy, CO2, battery energy; regulatory composites (FTP-75 weighting, HWFET and
US06 test runs); SAE J1711 SOC correction; SAE J2951 drive quality; and the uncertainty of
every result from the declared sensor accuracies. See docs/results.md.
"""

from vehval.fuels import Fuel, fuel_properties, known_fuels
from vehval.results.compute import (
                                    RESULTS_VERSION,
                                    TestResults,
                                    compute_results,
                                    results_from_template,
)

__all__ = [
                                    "RESULTS_VERSION",
                                    "Fuel",
                                    "TestResults",
                                    "compute_results",
                                    "fuel_properties",
                                    "known_fuels",
                                    "results_from_template",
]
