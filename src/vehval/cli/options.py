"""Option parsing shared by several commands: ``KEY=VALUE`` assignments, the bounds of
every numeric option and the output policy of every output option.

``BOUNDS`` is the one table of numeric option limits: each entry gives the closed range and
the reason for it, which the refusal repeats, and optionally the one value outside the
range that switches the option off (``--monte-carlo 0``: first-order propagation). Commands attach :func:`bounded` as the option's
``callback``; a value outside its range (or not finite) is refused before anything runs, with
one ``vehval: error:`` line. Memory is checked separately, where an allocation's size is known
(:mod:`vehval.sim.budget`).

Every option naming an output (``-o``, ``--report``...) takes :func:`output_file` or
:func:`output_dir` as its ``callback``: a device node, FIFO or socket (or a link to one),
a directory given for a file or a file for a directory is refused while the command line
is parsed (:func:`vehval.io.paths.check_output_path`, the one owner of the rule); the
command then checks its outputs against its inputs (:func:`vehval.io.paths.check_outputs`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable

import typer

from vehval.constants import MIN_MC_DRAWS
from vehval.errors import ConfigError


@dataclass(frozen=True)
class Bound:
    """Closed range ``[lo, hi]`` of a numeric option, its unit and the reason for it."""

    lo: float
    hi: float
    unit: str
    reason: str
    #: A value outside the range that switches the option off (``--monte-carlo 0``).
    off: float | None = None


SEED_MAX = 2**32 - 1
#: Fewest Monte Carlo draws of any command that draws (0 switches the draws off).
MC_MIN_DRAWS = MIN_MC_DRAWS
_MC_FEW = (f"fewer than {MC_MIN_DRAWS} draws give a standard deviation uncertain by more than 7 % of "
           "itself (1/sqrt(2(n-1)))")

BOUNDS: dict[str, Bound] = {
    "dt": Bound(1e-3, 1.0, "s", "0.2 s is already within 0.3 % of 0.1 s on US06: a step "
                "below 1 ms changes no result and only costs time and memory; one above 1 s "
                "misses the cycle's accelerations"),
    "soc": Bound(0.0, 1.0, "-", "a state of charge is a fraction"),
    "mc_results": Bound(MC_MIN_DRAWS, 10_000_000, "draws", "0 is first-order propagation; "
                        f"{_MC_FEW}; GUM Supplement 1 asks for about 10^6 "
                        "draws for a 95 % interval good to two digits; more adds time and "
                        "memory, not accuracy", off=0),
    "mc_sensitivity": Bound(MC_MIN_DRAWS, 10_000, "draws", f"0 is none; {_MC_FEW} (and "
                            "5/95 % percentiles of a few draws are single draws); every "
                            "draw is one simulation per cycle and 10^4 draws of five cycles "
                            "take hours", off=0),
    "seed": Bound(0, SEED_MAX, "-", "numpy and scipy generators take seeds in [0, 2^32 - 1]"),
    "workers": Bound(0, 64, "processes", "each worker process holds its own copy of the "
                     "model and a test, a few hundred MB; more than 64 only exhausts memory"),
    "refine": Bound(0, 6, "rounds", "each round halves the grid step; after six the step is "
                    "below 2 % of the grid's and the judged figures no longer change"),
    "popsize": Bound(1, 100, "x parameters", "scipy's differential evolution; the search "
                     "costs popsize x parameters simulations per generation"),
    "maxiter": Bound(1, 10_000, "generations", "the search stops earlier once converged; "
                     "10^4 generations is beyond any convergence"),
    "max_offset": Bound(0.0, 3600.0, "s", "sources of one test are recorded by one facility; "
                        "an offset over one hour is a different test, not a clock error"),
    "window": Bound(0.01, 60.0, "s", "engine starts and stops are matched within seconds"),
    "tolerance_pct": Bound(0.0, 100.0, "%", "a relative error tolerance in percent"),
    "soc_points": Bound(0.0, 100.0, "SOC points", "a SOC difference in percentage points"),
    "smooth_hz": Bound(1e-3, 50.0, "Hz", "a cut-off below the 100 Hz rate of a fast "
                       "acquisition and above one cycle per 1000 s"),
    "year": Bound(1900, 2100, "-", "a model year"),
    "confidence": Bound(0.5, 0.999, "-", "the level of a confidence interval: below one half "
                        "it is no interval worth stating, above 99.9 % the chi-square tails "
                        "of a few dozen pairs say nothing"),
    "test_timeout": Bound(0.0, 7 * 86400.0, "s", "0 means no limit; a week is far beyond the "
                          "longest test a batch runs"),
    "query_rows": Bound(1, 10_000_000, "rows", "rows are printed to the terminal; export "
                        "larger results with the catalog's own SQL through DuckDB"),
    "query_timeout": Bound(0.1, 3600.0, "s", "a catalog query over thousands of tests takes "
                           "seconds; an hour means a runaway join"),
    # identify's declared specification: the same limits as the spec file's keys
    # (vehval.identify.spec._RANGES; a test keeps the two equal)
    "rated_power_kw": Bound(5, 1000, "kW", "passenger cars and light trucks"),
    "rated_speed_rpm": Bound(1500, 12000, "rpm", "engine speed at rated power of road engines"),
    "peak_torque_nm": Bound(20, 2000, "N·m", "peak engine torque of road engines"),
    "displacement_l": Bound(0.3, 10, "L", "displacement of road engines"),
    "gears": Bound(1, 12, "gears", "forward gears of production gearboxes"),
    "splits": Bound(0, 20, "tests", "each split fits the model once: every N of the given "
                    "tests, so N is at most the few tests a car has"),
    "port": Bound(0, 65535, "-", "a TCP port; 0 picks a free one"),
}


def check_bound(kind: str, value: Any, option: str) -> Any:
    """``value`` if it lies within ``BOUNDS[kind]`` (``None`` passes), else a ConfigError.

    Parameters
    ----------
    kind : str
        Key of :data:`BOUNDS`.
    value : int or float or None
        The parsed option value.
    option : str
        The option name for the message, e.g. ``--dt``.
    """
    if value is None:
        return value
    b = BOUNDS[kind]
    v = float(value)
    if b.off is not None and v == b.off:
        return value
    if not math.isfinite(v) or not (b.lo <= v <= b.hi):
        unit = "" if b.unit == "-" else f" {b.unit}"
        off = f"{_num(b.off)} or " if b.off is not None else ""
        raise ConfigError(f"{option} {value}: must be {off}within [{_num(b.lo)}, {_num(b.hi)}]"
                          f"{unit}; {b.reason}")
    return value


def _num(x: float) -> str:
    return str(int(x)) if float(x).is_integer() else f"{x:g}"


def bounded(kind: str) -> Callable[..., Any]:
    """An option ``callback`` refusing values outside ``BOUNDS[kind]`` (see :func:`check_bound`)."""
    if kind not in BOUNDS:
        raise KeyError(kind)

    def callback(ctx: typer.Context, param: typer.CallbackParam, value: Any) -> Any:
        if ctx.resilient_parsing:
            return value
        name = max(param.opts, key=len) if param.opts else str(param.name)
        return check_bound(kind, value, name)

    return callback


def _output_callback(directory: bool) -> Callable[..., Any]:
    def callback(ctx: typer.Context, param: typer.CallbackParam, value: Any) -> Any:
        if ctx.resilient_parsing or value is None:
            return value
        from vehval.io.paths import check_output_path

        name = min(param.opts, key=len) if param.opts else str(param.name)  # -o, as documented
        check_output_path(value, name, directory=directory)
        return value

    return callback


def output_file(ctx: typer.Context, param: typer.CallbackParam, value: Any) -> Any:
    """Option ``callback`` of an output file: absent or a regular file (see
    :func:`vehval.io.paths.output_problem`), else one ``vehval: error:`` line."""
    return _output_callback(False)(ctx, param, value)


def output_dir(ctx: typer.Context, param: typer.CallbackParam, value: Any) -> Any:
    """Option ``callback`` of an output directory: absent or a directory."""
    return _output_callback(True)(ctx, param, value)


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
            from vehval.safe_yaml import load_yaml  # yaml only when an option is parsed

            out[key.strip()] = load_yaml(value, f"{option} '{item}'")
        except ConfigError as exc:
            raise ConfigError(f"{option} '{item}': the value is not a finite number, list or "
                              f"text ({exc})") from None
    return out
