"""The dyno files of `vehval epa vehicle`: each in one role, its units as QA reads them."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from vehval.errors import ConfigError, InputFileError


def check_roles(calibrate: list[Path], predict: list[Path]) -> None:
    """Refuse a dyno file given to both --calibrate and --predict (a test the fuel model is
    fitted on is no held-out prediction: its fit error is already shown, in-sample) or twice
    to one of them (it would count twice in the fit)."""
    def same(a: Path, b: Path) -> bool:
        try:
            return os.path.samefile(a, b)
        except OSError:
            return a.resolve() == b.resolve()

    for k, f in enumerate(calibrate):
        for g in predict:
            if same(f, g):
                raise ConfigError(f"{g}: given to both --calibrate and --predict: a test the "
                                  "fuel model is fitted on is no held-out prediction (its "
                                  "in-sample fit error is shown with --calibrate); give it to "
                                  "one of them")
    for opt, files in (("--calibrate", calibrate), ("--predict", predict)):
        for k, f in enumerate(files):
            if any(same(f, g) for g in files[:k]):
                raise ConfigError(f"{f}: given twice to {opt}; give each test once")


def unit_hints(path: Path, test: Any, template: Any, force: bool) -> list[dict[str, str]]:
    """The unit hints of the results stage (:func:`vehval.qa.plausibility.run_plausibility`)
    on the speed and fuel signals `epa vehicle` uses; refused unless ``force``."""
    from vehval.qa.findings import Kind
    from vehval.qa.plausibility import run_plausibility

    used = ("veh_spd_test", "fuel_rate_test")
    found = [{"signal": f.signal, "message": f.message, "fix": f.fix}
             for f in run_plausibility(test, template=template)
             if f.kind == Kind.UNIT_SUSPECT and f.signal in used]
    if found and not force:
        h = found[0]
        raise InputFileError(f"{path}: {h['message']}: {h['fix']} (a fuel model fitted or "
                             "judged on it would be wrong by that factor; --force uses it "
                             "anyway)")
    return found
