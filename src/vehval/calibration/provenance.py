"""The provenance of a calibrated value, and the one way it goes into the vehicle file.

Every calibrated value's ``sources`` entry in the written vehicle file reads::

    calibrated by <command> on tests <ids> on <date>: <objective> <before> -> <after>
    (<search>; start <value>, <bounds or grid>; dt <step> s[; <details>][; held out <ids>])

Untuned values keep their sources. Vehicle files written before this format (older
``vehval epa calibrate`` and conventional calibrations) keep their text: a source is read
as written, never rewritten.

Which tests a vehicle file was calibrated on is read back from these texts
(:func:`calibration_tests`, :func:`in_sample`): a figure of such a test is *in-sample* for
the file (the file was fitted to it), every other figure is *held out*. Both the current
text and the older ``calibrated by <command> on the EPA Test Car List tests <ids>`` are
understood.

A test named in a vehicle file is the same test as an id spelled otherwise only by the
characters a path cannot hold (:func:`same_test`, the one matching rule: the file's
``61410013 Test Data`` is a batch's ``61410013_Test_Data``); every in-sample check
(:func:`in_sample`, the validation ladder, ``vehval predict``'s identification tests) uses it.
"""

from __future__ import annotations

import datetime as _dt
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterable

import numpy as np
import yaml

from vehval.io.atomic import write_text_atomic
from vehval.io.paths import sanitize_id


def bounds_text(lo: float, hi: float) -> str:
    """``bounds [lo, hi]`` as the provenance states a search range."""
    return f"bounds [{lo:.6g}, {hi:.6g}]"


def grid_text(values: list[float]) -> str:
    """``grid v1, v2, ...`` as the provenance states a grid."""
    return "grid " + ", ".join(f"{v:g}" for v in values)


@dataclass
class Provenance:
    """What a calibration did, stated once for each value it tuned.

    Attributes
    ----------
    by : str
        The command (``vehval calibrate``, ``vehval epa calibrate``).
    tests : list of str
        Tuning tests.
    objective : str
        What was minimised (``objective``, ``RMS error of the judged figures``).
    start_value, best_value : float
        The objective before and after.
    method : str
        The search that ran.
    start : dict
        Start value of each parameter (dotted name).
    ranges : dict
        Search range of each parameter as text (:func:`bounds_text`, :func:`grid_text`).
    dt : float
        Simulation step [s].
    details : list of str
        Other conditions of the calibration (e.g. a speed low-pass).
    holdout : list of str
        Held-out tests.
    percent : bool
        The objective is a relative error shown in per cent.
    date : str
        ISO date of the calibration (default today).
    """

    by: str
    tests: list[str]
    objective: str
    start_value: float
    best_value: float
    method: str
    start: dict[str, float]
    ranges: dict[str, str]
    dt: float
    details: list[str] = field(default_factory=list)
    holdout: list[str] = field(default_factory=list)
    percent: bool = False
    date: str = field(default_factory=lambda: _dt.date.today().isoformat())

    def _value(self, v: float) -> str:
        return f"{100 * v:.1f} %" if self.percent else f"{v:.4g}"

    def text(self, name: str) -> str:
        """The ``sources`` entry of the calibrated parameter ``name``."""
        parts = [self.method, f"start {self.start[name]:.6g}, {self.ranges[name]}",
                 f"dt {self.dt:g} s", *self.details]
        if self.holdout:
            parts.append(f"held out {', '.join(self.holdout)}")
        return (f"calibrated by {self.by} on tests {', '.join(self.tests)} on {self.date}: "
                f"{self.objective} {self._value(self.start_value)} -> "
                f"{self._value(self.best_value)} ({'; '.join(parts)})")


def vehicle_with_values(vehicle: Any, values: dict[str, float],
                        provenance: Callable[[str], str], note: str = "") -> Any:
    """Validated copy of ``vehicle`` (any architecture) with ``values`` (dotted names), each
    value's source set to ``provenance(name)``, ``note`` appended to the description."""
    data = vehicle.with_overrides(values).model_dump()
    for name in values:
        blk, key = name.split(".", 1)
        data[blk]["sources"][key] = provenance(name)
    if note:
        data["description"] = (data.get("description") or "").rstrip() + note
    return type(vehicle).model_validate(data)


def _plain(obj: Any) -> Any:
    if isinstance(obj, dict):
        return {str(k): _plain(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_plain(v) for v in obj]
    if isinstance(obj, np.generic):
        return obj.item()
    return obj


def write_vehicle_yaml(vehicle: Any, path: str | Path, by: str) -> Path:
    """Write a calibrated vehicle YAML atomically; it loads with ``load_vehicle``."""
    text = (f"# Calibrated by {by}; calibrated values carry their provenance in the block's "
            "'sources'.\n" + yaml.safe_dump(_plain(vehicle.model_dump(exclude_none=True)),
                                            sort_keys=False, width=100, allow_unicode=True))
    write_text_atomic(path, text)
    return Path(path)


#: ``calibrated by <command> on [the ... ]tests <id>, <id>...`` in a value's source text
_CALIBRATED_ON = re.compile(
    r"calibrated by vehval[\w ]*? on (?:the [\w ]*?)?tests? "
    r"(.+?)(?= on \d{4}-\d{2}-\d{2}\b| \(|[:;]|$)")


def ids_in_source(text: str) -> list[str]:
    """Test ids a source text says the value was calibrated on ([] when it does not).

    Examples
    --------
    >>> ids_in_source("calibrated by vehval calibrate on tests a, b on 2026-01-02: ...")
    ['a', 'b']
    """
    out: list[str] = []
    for m in _CALIBRATED_ON.finditer(" ".join(str(text).split())):
        out += [t for t in m.group(1).split(", ") if t not in out]
    return out


def _sources(vehicle: Any) -> Iterable[tuple[str, str]]:
    """(dotted parameter name, source text) of every block of a vehicle (model or dict)."""
    data = vehicle if isinstance(vehicle, dict) else vehicle.model_dump()
    for blk, body in data.items():
        if isinstance(body, dict) and isinstance(body.get("sources"), dict):
            for key, text in body["sources"].items():
                if isinstance(text, str):
                    yield f"{blk}.{key}", text


def calibration_tests(vehicle: Any) -> dict[str, list[str]]:
    """Test id -> the parameters (dotted names) the vehicle file was calibrated on it.

    Read from the provenance of the calibrated values (``sources``); tests are listed in
    the order they first appear, parameters sorted.

    Parameters
    ----------
    vehicle : Vehicle or dict
        A loaded vehicle (any architecture) or its ``model_dump()``.
    """
    out: dict[str, list[str]] = {}
    for name, text in _sources(vehicle):
        for t in ids_in_source(text):
            params = out.setdefault(t, [])
            if name not in params:
                params.append(name)
    return {t: sorted(p) for t, p in out.items()}


def same_test(test_id: object, names: Iterable[object]) -> bool:
    """Whether ``test_id`` is one of the test ``names`` a vehicle file lists, compared as
    test ids (:func:`vehval.io.paths.sanitize_id`): a name with spaces or other characters a
    path cannot hold is the same test as its id (``61410013 Test Data`` is
    ``61410013_Test_Data``, the id a batch gives the file or folder). An empty name matches
    nothing."""
    key = sanitize_id(test_id, default="")
    return bool(key) and any(sanitize_id(n, default="") == key for n in names)


def in_sample(vehicle: Any, test_id: str,
              calibrated: dict[str, list[str]] | None = None) -> bool:
    """Whether ``test_id`` is one the vehicle file was calibrated on (its figures are then
    in-sample, not a prediction; matched by :func:`same_test`). ``calibrated``:
    :func:`calibration_tests` of the vehicle, when already computed."""
    cal = calibration_tests(vehicle) if calibrated is None else calibrated
    return same_test(test_id, cal)
