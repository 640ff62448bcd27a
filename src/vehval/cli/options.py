"""Option parsing shared by several commands."""

from __future__ import annotations

import yaml

from vehval.errors import ConfigError


def parse_assignments(items: list[str], option: str, example: str) -> dict:
    """Parse repeated ``KEY=VALUE`` options; values are read as YAML scalars or lists.

    Parameters
    ----------
    items : list of str
        The option values as given on the command line.
    option : str
        The option name, for messages (e.g. ``--set``).
    example : str
        An example assignment shown when one is malformed.
    """
    out: dict = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise ConfigError(f"{option} '{item}': expected KEY=VALUE (for example {option} {example})")
        try:
            out[key.strip()] = yaml.safe_load(value)
        except yaml.YAMLError:
            raise ConfigError(f"{option} '{item}': the value is not a number, list or text") from None
    return out
