"""Powertrain components: pydantic parameter models and their physics as pure functions.

Every parameter block carries a ``sources`` mapping (parameter name -> where the value
comes from); a block whose parameters are not all sourced is rejected at load time.
"""

from vehval.sim.components.base import Block, bp_check, table_check  # noqa: F401
