"""Option parsing shared by several commands."""

from __future__ import annotations

from vehval.errors import ConfigError
from vehval.safe_yaml import load_yaml


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
            out[key.strip()] = load_yaml(value, f"{option} '{item}'")
        except ConfigError as exc:
            raise ConfigError(f"{option} '{item}': the value is not a finite number, list or "
                              f"text ({exc})") from None
    return out
