"""One test folder of the workspace on the workbench: its template, raw channels, QA state.

A test folder holds the raw files of one test and (once saved) its ``template.yaml``. The
bench proposes a template when there is none (what ``vehval template init`` writes), applies
the edits of the page to the template's YAML (comments kept), and reruns import, QA and the
results stage, writing what ``vehval qa FOLDER/FILES -t template.yaml -o FOLDER/qa`` writes.

Every file the bench lists or reads (data files, ``template.yaml``, ``qa/``) is resolved and
must stay inside the workspace (:mod:`.security`); only a POST runs QA or writes: a view of a
test whose QA has not run says so (:class:`QANotRun`) instead of running it.
"""

from __future__ import annotations

import fnmatch
import json
import os
import threading
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from vehval.errors import ConfigError, InputFileError, VehvalError
from vehval.io import folder as data_folder
from vehval.serve import security as sec
from vehval.serve.series import series, series_figure
from vehval.serve.yamlcomments import carry_comments

#: The template file of a test folder, and the folder QA writes into.
TEMPLATE_NAME = "template.yaml"
QA_DIR = "qa"
#: Finding kinds shown as unit hints beside a channel.
UNIT_KINDS = ("unit", "unit_suspect")
#: Template constants of the tested car the page edits (test mass [kg], road load A [N],
#: B [N/(m/s)], C [N/(m/s)²]).
CAR_CONSTANTS = ("test_mass_kg", "road_load_a_n", "road_load_b_n_per_mps", "road_load_c_n_per_mps2")
#: Most data files of one test folder read (by name); a folder holding more is not one test.
MAX_DATA_FILES = 64


class QANotRun(VehvalError):
    """A view needing the test's QA run before the workbench has run it (answered 409: the
    page runs QA with a POST, then asks again; a GET never runs it)."""


def pick_data(listing: sec.Listing, template: Any = None,
              most: int | None = MAX_DATA_FILES) -> tuple[list[Path], list[dict]]:
    """Raw data files of a listed test folder (the template's ``match`` globs when it has
    them), at most ``most`` (:data:`MAX_DATA_FILES` for the files of one test; None for a
    folder of many tests, one file each, bounded by the listing); and the listing's left-out
    entries plus the count of data files beyond the bound (``[{"name", "why"}]``)."""
    data = data_folder.data_files(listing.files, template)
    left = list(listing.left_out)
    if most is not None and len(data) > most:
        left.append({"name": f"({len(data) - most:,} more data files)",
                     "why": f"too many files: the first {most} data files (by name) "
                            "are read; put each test's files in a folder of their own"})
        data = data[:most]
    return data, left


def data_files(folder: Path, template: Any = None,
               root: Path | None = None) -> tuple[list[Path], list[dict]]:
    """Raw data files of a test folder inside the workspace ``root`` (default: the folder
    itself) and what was left out (:func:`pick_data`)."""
    return pick_data(sec.list_folder(root or folder, folder), template)


@dataclass
class BenchState:
    """What the page shows of a test after the last run (or the error that stopped it)."""

    findings: dict | None = None
    results: dict | None = None
    error: str | None = None
    notes: list[str] = field(default_factory=list)


class Bench:
    """The workbench's view of one test folder.

    Parameters
    ----------
    folder : Path
        The test folder (inside the workspace, resolved).
    root : Path, optional
        The workspace (resolved; default: the folder): nothing outside it is read.
    test : str, optional
        One test of a folder of many (a data file of its own under a one-entry template, the
        batch rule: :func:`vehval.batch.discover.file_tests`); its QA goes to ``qa/TEST/``.
    """

    def __init__(self, folder: Path, root: Path | None = None, test: str | None = None) -> None:
        self.folder = folder
        self.root = root or folder
        self.test = test
        self.lock = threading.RLock()
        self._raw: dict[str, tuple[float, Any]] = {}
        self.run: Any = None
        self.state = BenchState()
        #: the last model comparison's normalised error of the fuel mass (for the headline)
        self.model_verdict: dict | None = None
        self._load_outputs()

    # ------------------------------------------------------------------ template
    @property
    def template_path(self) -> Path:
        return self.folder / TEMPLATE_NAME

    def saved(self) -> bool:
        """True when the folder holds its ``template.yaml`` (refused when it links outside)."""
        return sec.regular_file(self.root, self.template_path, TEMPLATE_NAME) is not None

    def template_text(self) -> str:
        """The saved template, or the proposal ``vehval template init`` would write."""
        if self.saved():
            return self.template_path.read_text(encoding="utf-8")
        from vehval.io.propose import propose_template

        files, left = data_files(self.folder, None, self.root)
        if not files:
            why = "; ".join(f"{x['name']}: {x['why']}" for x in left[:5])
            raise InputFileError(f"{self._label()}: no raw data file in the folder"
                                 + (f" (left out: {why})" if why else "")
                                 + ": put the test's raw files (D3 text, CSV, MDF4, Parquet) "
                                 "in it")
        tmpl, _ = propose_template(files)
        return _placeholder_text(tmpl)

    def _label(self) -> str:
        where = sec.relative(self.root, self.folder) if self.folder != self.root else \
            "the workspace folder"
        return f"{where} (test {self.test})" if self.test else where

    def test_files(self, tmpl: Any, listing: sec.Listing | None = None) -> tuple[list[Path], list[dict]]:
        """The data files of this test (all the folder's, or the one of :attr:`test`) and what
        the listing left out."""
        from vehval.batch.discover import file_tests

        listing = listing or sec.list_folder(self.root, self.folder)
        files, left = pick_data(listing, tmpl, MAX_DATA_FILES if self.test is None else None)
        if self.test is None:
            return files, left
        ordered = sorted(files, key=lambda p: p.name)
        for path, spec in zip(ordered, file_tests(ordered, tmpl)):
            if spec.test_id == self.test:
                return [path], left
        raise InputFileError(f"{self._label()}: no such test in the folder (its template "
                             "takes one file per test: open one listed on the home page)")

    @property
    def qa_path(self) -> Path:
        """Where QA writes: ``qa/`` of the folder, ``qa/TEST/`` for one test of many."""
        return self.folder / QA_DIR / self.test if self.test else self.folder / QA_DIR

    def template(self) -> Any:
        """The template model (saved or proposed), validated as ``vehval`` loads it."""
        from vehval.safe_yaml import load_yaml

        return _validate(load_yaml(self.template_text(), TEMPLATE_NAME))

    def raw(self, name: str) -> Any:
        """The raw table of one data file of the folder (cached while unchanged)."""
        from vehval.io.readers import read_raw

        path = self.folder / name
        if not name or name.startswith(".") or "\x00" in name or "/" in name or "\\" in name \
                or path.parent != self.folder:
            raise InputFileError(f"{name[:200]}: not a data file of {self.folder.name}")
        real = sec.regular_file(self.root, path, name)
        if real is None:
            raise InputFileError(f"{name[:200]}: not a data file of {self.folder.name}")
        mtime = real.stat().st_mtime
        hit = self._raw.get(name)
        if hit is None or hit[0] != mtime:
            hit = (mtime, read_raw(real))
            self._raw[name] = hit
        return hit[1]

    # ------------------------------------------------------------------ edits
    def save_edits(self, edits: dict) -> None:
        """Apply the page's edits to the template YAML and write it (comments kept).

        ``edits``: ``channels`` (list of ``{file, raw, name, unit, delete, reason}``, ``file``
        the index of the file entry), ``sources`` (``{file index: source tag}``), ``fuel``
        (a fuel name, or ``""`` to leave it out).
        """
        from vehval.safe_yaml import load_yaml

        with self.lock:
            old = self.template_text()
            data = load_yaml(old, TEMPLATE_NAME)
            files = data.get("files") if isinstance(data, dict) else None
            if not isinstance(files, list):
                raise ConfigError(f"{TEMPLATE_NAME}: no 'files:' list to edit")
            for ch in edits.get("channels") or []:
                _edit_channel(files, ch)
            for idx, src in (edits.get("sources") or {}).items():
                _entry(files, idx)["source"] = str(src)
            for key in ("fuel", "vehicle", "vehicle_name"):
                if key in edits:
                    if edits[key] and str(edits[key]).strip():
                        data[key] = str(edits[key]).strip()
                    else:
                        data.pop(key, None)
            if edits.get("vehicle"):
                _check_vehicle(data["vehicle"], self.root)
            consts = data.get("constants") or {}
            for key, value in (edits.get("constants") or {}).items():
                if value is None:
                    consts.pop(key, None)
                else:
                    consts[key] = value
            if consts:
                data["constants"] = consts
            else:
                data.pop("constants", None)
            self._write(old, data)

    def decide(self, signal: str, action: str, reason: str = "") -> None:
        """Keep or drop a signal (the template's ``selection``), or clear the user's decision."""
        from vehval.safe_yaml import load_yaml

        if action not in ("keep", "drop", "clear"):
            raise ConfigError(f"selection: unknown action '{action}' (keep, drop or clear)")
        if action == "drop" and not reason.strip():
            raise ConfigError(f"selection: give the reason for dropping {signal}")
        with self.lock:
            old = self.template_text()
            data = load_yaml(old, TEMPLATE_NAME)
            sel = data.setdefault("selection", {}) or {}
            data["selection"] = sel
            keep = [k for k in sel.get("keep") or [] if k != signal]
            drop = {k: v for k, v in (sel.get("drop") or {}).items() if k != signal}
            if action == "keep":
                keep.append(signal)
            elif action == "drop":
                drop[signal] = reason.strip()
            sel["keep"], sel["drop"] = keep, drop
            self._write(old, data)

    def _write(self, old: str, data: dict) -> None:
        from vehval.io.atomic import write_text_atomic

        tmpl = _validate(data)
        write_text_atomic(self.template_path, carry_comments(old, tmpl.to_yaml()))

    # ------------------------------------------------------------------ runs
    def rerun(self) -> BenchState:
        """Import, QA and results as ``vehval qa`` does; outputs written into ``qa/``."""
        from vehval.io.atomic import atomic_dir, write_text_atomic
        from vehval.io.parquet import write_test
        from vehval.qa.select import save_final_template
        from vehval.workflow import TestRun

        with self.lock:
            try:
                if not self.saved():
                    raise ConfigError(f"{TEMPLATE_NAME}: save the template before running QA")
                self._qa_dir()
                from vehval.io.template import load_template

                tmpl = load_template(self.template_path)
                sec.vehicle_inside(self.root, tmpl.vehicle, TEMPLATE_NAME)
                files, _ = self.test_files(tmpl)
                if not files:
                    raise InputFileError(f"{self._label()}: no raw data file the template "
                                         "matches in the folder")
                run = TestRun.load(files, tmpl)
                qa = run.qa()
                results = run.results().results
                with atomic_dir(self.qa_path) as stage:
                    write_text_atomic(stage / "findings.json", json.dumps(qa.document, indent=1))
                    write_text_atomic(stage / "results.json", json.dumps(results.to_dict(), indent=1))
                    write_test(qa.result.validated, stage / "validated.parquet")
                    save_final_template(run.template, qa.result.selection,
                                        stage / "template_final.yaml")
            except sec.OutsideWorkspace:
                raise
            except VehvalError as exc:
                self.state = BenchState(error=str(exc), findings=self.state.findings,
                                        results=self.state.results)
                return self.state
            self.run = run
            self.model_verdict = None
            self.state = BenchState(findings=qa.document, results=results.to_dict(),
                                    notes=list(qa.document.get("notes") or []))
            return self.state

    def _qa_dir(self) -> Path:
        """``qa/`` of the folder: absent or a folder of its own (never a link, a file...)."""
        for d in (self.folder / QA_DIR, self.qa_path):
            if os.path.lexists(d) and (os.path.islink(d) or not d.is_dir()):
                raise InputFileError(f"{sec.relative(self.folder, d)}: a symlink or a file, not "
                                     "the test's own folder: refused: remove it so QA can "
                                     "write its outputs there")
        return self.qa_path

    def _load_outputs(self) -> None:
        """The last QA outputs of the folder (``qa/``), when present (never through a link
        leading out of the workspace)."""
        from vehval.safe_yaml import load_json

        try:
            d = self._qa_dir()
            for name in ("findings.json", "results.json"):
                path = sec.regular_file(self.root, d / name, f"{QA_DIR}/{name}")
                if path is not None:
                    doc = load_json(path.read_text(encoding="utf-8"))
                    setattr(self.state, name.split(".")[0], doc)
        except VehvalError as exc:
            self.state.error = str(exc)

    # ------------------------------------------------------------------ views
    def overview(self) -> dict:
        """The page's model: files and channels with their mapping and hints, findings,
        selection, headline result, error."""
        saved = self.saved()  # a template linked out of the workspace is refused here (403)
        listing = sec.list_folder(self.root, self.folder)
        left = listing.left_out
        try:
            tmpl = self.template()
            files, left = self.test_files(tmpl, listing) if saved else pick_data(listing, None)
        except sec.OutsideWorkspace:
            raise
        except VehvalError as exc:
            return {"error": str(exc), "files": [], "saved": saved, "left_out": left}
        from vehval.results.all_findings import stage_findings

        findings = stage_findings(self.state.findings, self.state.results)
        hints: dict[str, list[dict]] = {}
        for f in findings:
            if f.get("kind") in UNIT_KINDS:
                hints.setdefault(f.get("signal") or "", []).append(f)
        out_files = []
        for i, entry in enumerate(tmpl.files):
            path = _file_for(entry, files, i)
            out_files.append(self._file_view(i, entry, path, hints))
        from vehval.fuels import known_fuels

        selection = _with_user_drops((self.state.findings or {}).get("selection") or {},
                                     tmpl.selection.drop)
        summary = (self.state.findings or {}).get("summary")
        if isinstance(summary, dict):   # the user's drops count (removed before QA saw them)
            summary = {**summary, "dropped": len(selection["dropped"])}
        return {"saved": saved, "files": out_files, "left_out": left,
                "todo": self._todo(tmpl, files, saved),
                "vehicle": tmpl.vehicle, "vehicle_name": tmpl.vehicle_name,
                "constants": {k: getattr(tmpl.constants, k, None) for k in CAR_CONSTANTS},
                "fuel": tmpl.fuel if isinstance(tmpl.fuel, str) or tmpl.fuel is None else "explicit",
                "fuels": list(known_fuels()), "findings": findings,
                "selection": selection,
                "user_selection": tmpl.selection.model_dump(),
                "headline": headline(self.state.results, self.model_verdict),
                "summary": summary,
                "error": self.state.error, "notes": self.state.notes}

    def _todo(self, tmpl: Any, files: list[Path], saved: bool) -> list[str]:
        """What is still to do on the template, as the command line says it: the "to do"
        lines of ``vehval template init`` for a proposal, the errors and warnings of
        ``vehval template check`` for a saved template."""
        from vehval.io.propose import check_template, propose_template

        if not files:
            return []
        if not saved:
            return [f"to do: {t}" for t in propose_template(files)[0].todo]
        rep = check_template(tmpl, files)
        return [f"error: {e}" for e in rep.errors] + [f"warning: {w}" for w in rep.warnings]

    def _file_view(self, i: int, entry: Any, path: Path | None, hints: dict) -> dict:
        from vehval.io.propose import match_channel, unit_known
        from vehval.nomenclature import registry

        reg = registry()
        raw = self.raw(path.name) if path is not None else None
        header = dict(zip(raw.names, raw.units)) if raw is not None else {}
        chans = []
        names = list(entry.channels)
        names += [n for n in header if n not in entry.channels and n != getattr(raw, "time_name", None)]
        for raw_name in names:
            spec = entry.channels.get(raw_name)
            hunit = header.get(raw_name)
            proposed = match_channel(raw_name, hunit if unit_known(hunit) else None)
            si = None
            if spec is not None and spec.name:
                try:
                    si = reg[reg.parse(spec.name).base].unit
                except VehvalError:
                    si = None
            base = None
            if spec is not None and spec.name:
                try:
                    base = reg.parse(spec.name).base
                except VehvalError:
                    base = None
            confidence = _confidence(spec, proposed, base, hunit if unit_known(hunit) else None,
                                     si)
            chans.append({"raw": raw_name, "header_unit": hunit, "in_file": raw_name in header,
                          "in_template": spec is not None,
                          "name": spec.name if spec else None, "unit": spec.unit if spec else None,
                          "delete": bool(spec.delete) if spec else True,
                          "reason": spec.reason if spec else "not in the template",
                          "si_unit": si, "confidence": confidence,
                          "hints": hints.get(spec.name or "", []) if spec else []})
        return {"index": i, "file": path.name if path else None, "match": entry.match,
                "source": entry.source, "format": entry.format, "channels": chans,
                "notes": list(raw.notes) if raw is not None else []}

    def channel(self, file: str, raw_name: str, t0: float | None, t1: float | None,
                n: int) -> dict:
        """Samples of one raw channel in its file's (engineering) unit, for a plot."""
        raw = self.raw(file)
        if raw_name not in raw.data:
            raise InputFileError(f"{file}: no channel '{raw_name}'")
        y = np.asarray(raw.data[raw_name], float)
        if raw_name in raw.times:
            t = np.asarray(raw.times[raw_name], float)
        elif raw.time_name is not None:
            t = np.asarray(raw.data[raw.time_name], float)
        else:
            t = np.arange(y.size, dtype=float)
        unit = dict(zip(raw.names, raw.units)).get(raw_name)
        s = series(t, y, t0, t1, n)
        return {"file": file, "raw": raw_name, "unit": unit, **s,
                "figure": series_figure(s, raw_name, unit or "", f"{raw_name} as in {file}")}

    def signal(self, name: str, t0: float | None, t1: float | None, n: int) -> dict:
        """Samples of one imported signal [SI], on the test's aligned time, for triage.

        Raises
        ------
        QANotRun
            QA has not run on the test since the workbench started (a view never runs it).
        """
        run = self._run_or_409()
        test = run.qa().validated
        sig = test[name] if name in test else None
        if sig is None and name in run.test:
            sig = run.test[name]
        if sig is None:
            raise InputFileError(f"{name}: no such signal in the test")
        from vehval.display import to_display

        shown, label = to_display(np.asarray(sig.values, float), sig.unit, signal=name)
        s = series(sig.time, shown, t0, t1, n)
        # t, y in SI as before; the figure in the display unit
        return {"name": name, "unit": sig.unit, "display_unit": label,
                **series(sig.time, sig.values, t0, t1, n),
                "figure": series_figure(s, name, label, name)}

    def finding_figure(self, index: int) -> dict:
        """The figure of the page's finding number ``index`` (:func:`stage_findings` order),
        made for its kind in display units (:mod:`vehval.report.finding_figures`).

        Raises
        ------
        QANotRun
            QA has not run on the test since the workbench started.
        """
        from vehval.report.finding_figures import finding_figure
        from vehval.results.all_findings import stage_findings

        run = self._run_or_409()
        found = stage_findings(self.state.findings, self.state.results)
        if not 0 <= index < len(found):
            raise InputFileError(f"finding {index}: the test has {len(found)} finding(s)")
        qa = run.qa()
        fig = finding_figure(qa.validated, found[index], results=self.state.results,
                             calc=qa.result.calculations, vehicle=run.vehicle,
                             imported=run.test)
        return {"index": index, "kind": found[index].get("kind"), "figure": fig}

    def _run_or_409(self) -> Any:
        run = self.run
        if run is None:
            last = f" (the last run stopped: {self.state.error})" if self.state.error else ""
            raise QANotRun(f"{self._label()}: QA has not run on this test since the workbench "
                           f"started{last}: run it first (the page's Rerun QA, POST /api/run), "
                           "then ask again")
        return run

    def _ensure_run(self) -> Any:
        if self.run is None:
            self.rerun()
            if self.run is None:
                raise ConfigError(self.state.error or "the test could not be run")
        return self.run


def _confidence(spec: Any, proposed: str | None, base: str | None, header_unit: str | None,
                si: str | None) -> str:
    """How sure the mapping of one channel is: ``unmapped``, ``unit missing`` (neither the
    template nor the file gives a unit: a fraction is read 0..1, anything else fails),
    ``high`` (the proposed name and a unit from the file header), ``medium`` (the proposed
    name, the unit from the template) or ``edited``."""
    if spec is None or spec.delete:
        return "unmapped"
    if not spec.unit and not header_unit:
        return "unit missing"
    if proposed is not None and proposed == base:
        return "high" if header_unit else "medium"
    return "edited"


def headline(results: dict | None, model: dict | None = None) -> dict | None:
    """The page's headline of ``results.json`` (:func:`vehval.results.headline.headline_of`:
    figure with U, rule, every caveat, J1711 status, the model's verdict when it ran)."""
    from vehval.results.headline import headline_of

    h = headline_of(results, model=model)
    return None if h is None else h.to_dict()


def _with_user_drops(selection: dict, user_drop: dict[str, str]) -> dict:
    """QA's selection plus the user's drops (removed at import, so QA never saw them)."""
    dropped = dict(selection.get("dropped") or {})
    for name, reason in user_drop.items():
        dropped.setdefault(name, f"dropped by the user: {reason}")
    return {"kept": dict(selection.get("kept") or {}), "dropped": dropped}


def _placeholder_text(tmpl: Any) -> str:
    """The text ``template init`` writes for ``tmpl`` (with its ``# fuel:`` placeholder)."""
    import tempfile

    with tempfile.TemporaryDirectory() as d:
        p = tmpl.save(Path(d) / TEMPLATE_NAME, placeholders=True)
        return p.read_text(encoding="utf-8")


def _check_vehicle(name: str, root: Path) -> None:
    """The vehicle a template names loads as the command line loads it (one line when not);
    a vehicle file outside the workspace is refused before it is read."""
    from vehval.vehicle import load_vehicle

    sec.vehicle_inside(root, name, TEMPLATE_NAME)
    try:
        load_vehicle(name)
    except VehvalError as exc:
        raise ConfigError(f"{TEMPLATE_NAME}: vehicle: {str(exc).splitlines()[0]}") from None


def _validate(data: Any) -> Any:
    """A template model from YAML data, with the messages ``load_template`` gives."""
    from vehval.io.template import template_from_data

    if not isinstance(data, dict):
        raise ConfigError(f"{TEMPLATE_NAME}: a template must be a YAML mapping with 'files:'")
    return template_from_data(data, TEMPLATE_NAME)


def _entry(files: list, idx: Any) -> dict:
    try:
        entry = files[int(idx)]
    except (ValueError, TypeError, IndexError):
        raise ConfigError(f"{TEMPLATE_NAME}: no file entry {idx!r}") from None
    if not isinstance(entry, dict):
        raise ConfigError(f"{TEMPLATE_NAME}: files[{idx}] is not a mapping")
    return entry


def _edit_channel(files: list, ch: dict) -> None:
    """One channel edit on the YAML data: only the keys the page sends change."""
    entry = _entry(files, ch.get("file"))
    raw = str(ch.get("raw") or "")
    if not raw:
        raise ConfigError(f"{TEMPLATE_NAME}: a channel edit needs the raw channel name")
    chans = entry.setdefault("channels", {})
    spec = dict(chans.get(raw) or {})
    for key in ("name", "unit", "reason"):
        if key in ch:
            val = ch[key]
            if val is None or str(val).strip() == "":
                spec.pop(key, None)
            else:
                spec[key] = str(val).strip()
    if "delete" in ch:
        if ch["delete"]:
            spec["delete"] = True
            spec.setdefault("reason", "deleted in the workbench")
        else:
            spec.pop("delete", None)
            spec.pop("reason", None)
    chans[raw] = spec


def _file_for(entry: Any, files: list[Path], i: int) -> Path | None:
    if entry.match:
        hits = [p for p in files if fnmatch.fnmatch(p.name, entry.match)]
        return hits[0] if hits else None
    return files[i] if i < len(files) else None
