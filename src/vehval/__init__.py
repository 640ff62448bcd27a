"""vehval: vehicle test data to trusted knowledge."""
__version__ = "0.1.0"

