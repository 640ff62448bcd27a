"""The virtual dyno: realistic synthetic test files with known, injected faults.

``make_virtual_test`` simulates a vehicle on a cycle and writes what a test facility would
record (a D3-style facility file and an OBD logger file), the import template, and a
``truth.json`` with every offset, sensor model and fault that was injected.
"""

from vehval.synth.dyno import SynthOutput, make_virtual_test
from vehval.synth.faults import load_fault_specs

__all__ = ["SynthOutput", "make_virtual_test", "load_fault_specs"]
