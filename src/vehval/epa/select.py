"""Select tests of the EPA Test Car List by make, model, year and test attributes.

A make or model that matches nothing raises :class:`~vehval.errors.InputFileError` with
the closest names in the list, so a typo ("PRIU", "toyta") is one step from the answer.
"""

from __future__ import annotations

import difflib
from collections import defaultdict
from dataclasses import dataclass, replace

from vehval.epa.procedures import procedure_key
from vehval.epa.reader import EpaTest
from vehval.errors import ConfigError, InputFileError

#: keys a test selector may use (``model=PRIUS,originator=EPA``)
SELECTOR_KEYS = ("make", "model", "year", "vehicle", "originator", "procedure", "number",
                 "config")


def _close(word: str, names: set[str], n: int = 4) -> str:
    upper = {name.upper(): name for name in names}
    hits = difflib.get_close_matches(word.upper(), list(upper), n=n, cutoff=0.5)
    hits += [upper[k] for k in sorted(upper) if word.upper() in k and upper[k] not in hits]
    hits = [upper.get(h, h) for h in hits][:n]
    return f"; did you mean {', '.join(repr(h) for h in hits)}?" if hits else ""


def _match_model(tests: list[EpaTest], model: str) -> list[EpaTest]:
    """Exact (case-insensitive) model match; else the models that contain ``model``."""
    exact = [t for t in tests if t.model.upper() == model.upper()]
    if exact:
        return exact
    return [t for t in tests if model.upper() in t.model.upper()]


def model_note(tests: list[EpaTest], model: str | None, make: str | None = None,
               year: int | str | None = None) -> str | None:
    """What a ``model`` selection took, when it may not be what was meant: no model is named
    ``model`` and it was taken as part of the names; or one is, and other names (of the
    same make and year, when given) that contain it were left out (``F150`` is a Roush's
    exact name and part of 13 Ford names). None otherwise."""
    if not model or not model.strip():
        return None
    want = model.strip().upper()
    pool = [t for t in tests
            if (year is None or str(year).strip() in map(str, t.listed_years))
            and (not make or t.make.upper() == make.strip().upper())]
    exact = sorted({t.model for t in pool if t.model.upper() == want})
    part = sorted({t.model for t in pool if want in t.model.upper()} - set(exact))
    if not part:
        return None
    shown = ", ".join(repr(n) for n in part[:6]) + (" ..." if len(part) > 6 else "")
    if not exact:
        return f"no model is named '{model.strip()}'; taken as part of a name: {shown}"
    makes = sorted({t.make for t in pool if t.model in exact})
    return (f"'{model.strip()}' is the exact name of a model ({', '.join(makes)}), which alone "
            f"is selected; {len(part)} other name(s) contain it: {shown}: give the full name "
            "(and --make / make=) to select one of those")


def select_tests(tests: list[EpaTest], make: str | None = None, model: str | None = None,
                 year: int | None = None) -> list[EpaTest]:
    """Tests of one make / model / year (each optional; case-insensitive).

    ``model`` matches a model name exactly, or failing that every model containing it
    (``PRIUS`` is the Prius only; ``CAMRY`` finds ``CAMRY HYBRID``...).

    Raises
    ------
    InputFileError
        The make, model or year matches no test (close names are suggested).
    """
    out = tests
    if year is not None:
        # a test listed again in a later year's list (carried over) is found under each
        # year, and read as of the year asked for
        y = int(year)
        out = [t if t.year == y else replace(t, year=y) for t in out if y in t.listed_years]
        if not out:
            years = sorted({y_ for t in tests for y_ in t.listed_years})
            raise InputFileError(f"no test of model year {year} in the list (years: "
                                 f"{', '.join(map(str, years))})")
    if make:
        sel = [t for t in out if t.make.upper() == make.strip().upper()]
        if not sel:
            raise InputFileError(f"unknown make '{make}'" + _close(make, {t.make for t in out}))
        out = sel
    if model:
        sel = _match_model(out, model.strip())
        if not sel:
            raise InputFileError(f"unknown model '{model}'"
                                 + (f" for make '{make}'" if make else "")
                                 + _close(model, {t.model for t in out}))
        out = sel
    return out


def parse_selector(text: str) -> dict[str, str]:
    """``key=value[,key=value...]`` -> dict; keys from :data:`SELECTOR_KEYS`.

    A bare word (no ``=``) is a model name.
    """
    out: dict[str, str] = {}
    for part in (p.strip() for p in text.split(",")):
        if not part:
            continue
        key, sep, value = part.partition("=")
        if not sep:
            key, value = "model", part
        key = key.strip().lower()
        if key not in SELECTOR_KEYS:
            raise ConfigError(f"test selector '{text}': unknown key '{key}' (use "
                              f"{', '.join(SELECTOR_KEYS)}, e.g. model=PRIUS,originator=EPA)")
        if not value.strip():
            raise ConfigError(f"test selector '{text}': '{key}' needs a value")
        if out.get(key, value.strip()) != value.strip():  # the last one was taken silently
            raise ConfigError(f"test selector '{text}': '{key}' given twice ('{out[key]}', "
                              f"'{value.strip()}'; a bare word is a model): one value per "
                              "key; run the command once per value")
        out[key] = value.strip()
    if not out:
        raise ConfigError("empty test selector: give e.g. model=PRIUS,originator=EPA")
    return out


def apply_selector(tests: list[EpaTest], selector: str | dict[str, str]) -> list[EpaTest]:
    """Tests matching a selector (see :func:`parse_selector`).

    ``procedure`` accepts a procedure key (``ftp75``, ``hwfet``, ``us06``, ``sc03``,
    ``coldco``...) or a code; ``vehicle`` a test vehicle ID; ``number`` a test number.
    """
    sel = parse_selector(selector) if isinstance(selector, str) else dict(selector)
    year = sel.get("year")
    try:
        year_i = int(year) if year is not None else None
    except ValueError:
        raise ConfigError(f"test selector: year must be a number, got '{year}'") from None
    out = select_tests(tests, sel.get("make"), sel.get("model"), year_i)
    for key, attr in (("vehicle", "vehicle_id"), ("originator", "originator"),
                      ("number", "test_number"), ("config", "config")):
        if key in sel:
            pool = out
            out = [t for t in out if getattr(t, attr).upper() == sel[key].upper()]
            if not out:
                raise InputFileError(f"no test with {key} '{sel[key]}' among the selected "
                                     "tests" + _close(sel[key], {getattr(t, attr)
                                                                for t in pool}))
    if "procedure" in sel:
        want = sel["procedure"].lower()
        out = [t for t in out if procedure_key(t) == want or str(t.procedure_code) == want]
        if not out:
            raise InputFileError(f"no test with procedure '{sel['procedure']}' among the "
                                 "selected tests (ftp75, hwfet, us06, sc03, coldco, cd_udds, "
                                 "cd_hwfet or a procedure code)")
    return out


@dataclass(frozen=True)
class VehicleEntry:
    """One make/model/year of the list with its test vehicles and number of tests."""

    year: int
    make: str
    model: str
    vehicle_ids: tuple[str, ...]
    n_tests: int
    mass_kg: tuple[float, ...]
    displacement_l: float

    def to_dict(self) -> dict:
        return {"year": self.year, "make": self.make, "model": self.model,
                "vehicle_ids": list(self.vehicle_ids), "n_tests": self.n_tests,
                "mass_kg": list(self.mass_kg),
                "displacement_l": None if self.displacement_l != self.displacement_l
                else self.displacement_l}


def vehicles(tests: list[EpaTest]) -> list[VehicleEntry]:
    """One entry per (year, make, model), sorted."""
    groups: dict[tuple, list[EpaTest]] = defaultdict(list)
    for t in tests:
        groups[(t.year, t.make, t.model)].append(t)
    out = []
    for (year, make, model), ts in sorted(groups.items()):
        disp = [t.displacement_l for t in ts if t.displacement_l == t.displacement_l]
        out.append(VehicleEntry(year, make, model,
                                tuple(sorted({t.vehicle_id for t in ts})), len(ts),
                                tuple(sorted({round(t.mass_kg, 1) for t in ts})),
                                disp[0] if disp else float("nan")))
    return out
