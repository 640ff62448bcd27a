"""Errors a user can cause. The CLI prints them without a traceback and exits non-zero."""

from __future__ import annotations


class VehvalError(Exception):
    """Base class for every error caused by user input (files, templates, vehicles, options).

    The message must name the file, line, key or signal at fault and say what to do.
    """

    exit_code = 2


class InputFileError(VehvalError):
    """A data file cannot be read or is malformed."""


class ConfigError(VehvalError):
    """A template, vehicle, calculation or fault file is invalid."""


class SignalError(VehvalError):
    """A signal is missing, duplicated or inconsistent."""


class UnitError(VehvalError):
    """A unit is unknown or cannot be converted to the signal's SI unit."""
