"""EPA Test Car List: read certification dyno results and validate vehicle models against them.

``read_lists`` reads the list files, ``select_tests`` / ``apply_selector`` pick tests,
``procedures`` turns a test procedure into a simulation plan (runs, bags, composite) and
``validation.validate_tests`` simulates each test with its own weight and road load.
"""

from vehval.epa.procedures import plan_for, procedure_key
from vehval.epa.reader import EpaTest, read_lists, read_test_car_list
from vehval.epa.select import apply_selector, parse_selector, select_tests, vehicles

__all__ = ["EpaTest", "apply_selector", "parse_selector", "plan_for", "procedure_key",
           "read_lists", "read_test_car_list", "select_tests", "vehicles"]
