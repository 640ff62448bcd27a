"""Control-strategy analysis from test data: engine on/off rule, modes, SOC regulation,
operating points and braking split. Entry point: :func:`analyze`."""

from vehval.analysis.inputs import from_simulation, prepare_inputs
from vehval.analysis.summary import AnalysisResult, analyze

__all__ = ["AnalysisResult", "analyze", "from_simulation", "prepare_inputs"]
