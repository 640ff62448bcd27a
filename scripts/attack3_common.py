"""Attack campaign III, common part: the case, how it runs and how it is classified.

A case is a real ``python -m vehval`` process (60 s timeout, its process group killed then,
a 4 GiB address-space limit), or, with ``request``, a real HTTP request against a
``vehval serve`` process or a Chromium page load (:mod:`attack3_web`). Outcomes are those of
campaign II (``scripts/attack_campaign2.py``):

* ``breach``: the case's breach check holds (a device node, FIFO or socket replaced by a
  regular file, an input overwritten, outside content returned or imported, a GET that wrote);
* ``hang``: no answer within the timeout (a case marked ``estimate_ok`` that printed its
  ``must`` text, an estimate of the run time, before the timeout is *handled*);
* ``internal error``: exit 3, killed by a signal (exit 134 is SIGABRT), a 5xx answer, the
  server gone, or ``Traceback`` / ``Exception ignored`` / ``internal error`` in the output;
* ``clean error``: a refusal (exit 1/2 with an error line, or a 4xx with a message) that
  says what it must (``refusal_must``);
* ``handled``: an answer (exit 0, or another code of ``ok_codes``; a 2xx) with ``must``;
* ``silently wrong``: anything else: an answer without ``must`` (a figure stated with no
  finding naming the problem), a refusal not naming what it must.
"""

from __future__ import annotations

import os
import re
import resource
import signal
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Union

HANG_S = 60
#: address-space limit of every case that sets none: a bomb fails instead of taking the machine
LIMIT_AS = 4 * 2**30
KINDS = ["clean error", "handled", "internal error", "hang", "silently wrong", "breach"]
SECRET = "SECRET-0UTS1DE-T0KEN"
REPO = Path(__file__).resolve().parents[1]

#: A text check: a regular expression (case-insensitive) or a function of the output.
Check = Union[str, Callable[[str], bool]]


@dataclass
class Case:
    """One attack and what a correct answer looks like.

    ``expect``: ``error`` (only a refusal is right) or ``ok`` (an answer with ``must``; a
    refusal saying ``refusal_must`` is a clean error too).
    """

    cls: str
    name: str
    args: list = field(default_factory=list)
    expect: str = "error"
    must: Check = ""
    refusal_must: Check = ""
    breach: Callable[[str], bool] = lambda text: False
    forbidden: Callable[[], bool] = lambda: False
    prepare: Callable[[], None] | None = None
    limit_as: int | None = None          # address-space limit of the process [bytes]
    cwd: Path | None = None
    env: dict = field(default_factory=dict)
    timeout: float = HANG_S              # [s]
    ok_codes: tuple = (0,)               # exit codes of an answer (4: a headline withheld)
    estimate_ok: bool = False            # a run still going at the timeout, ``must`` printed
    repeat: int = 1                      # run the process this many times (worst outcome)
    #: instead of a process: ``() -> (code, text)``, code as an exit code (0 answer, 2
    #: refusal, 3 server error or server gone) or "hang"
    request: Callable[[], tuple] | None = None


def check(spec: Check, text: str) -> bool:
    """True when ``spec`` (regex or function) holds on ``text``; an empty spec always holds."""
    if not spec:
        return True
    if callable(spec):
        return bool(spec(text))
    return re.search(spec, text, re.I | re.S) is not None


def never(text: str) -> bool:
    """``refusal_must`` of a valid input: any refusal of it is wrong."""
    return False


#: Lines that report a problem: findings, refusals, withheld figures, warnings.
_FINDING_LINE = re.compile(r"^\s*(warning|error|vehval: error|note)\b|withheld|refus|"
                           r"not stated|suspect|implausible", re.I)


def named(*patterns: str, exclude: str = "") -> Callable[[str], bool]:
    """A check: one line reporting a problem (a finding, a warning, a refusal, a withheld
    figure) matches every pattern (case-insensitive), so a figure's own line or the
    header does not count as naming the problem; lines matching ``exclude`` do not count."""
    def chk(text: str) -> bool:
        for line in text.splitlines():
            if exclude and re.search(exclude, line, re.I):
                continue
            if _FINDING_LINE.search(line) and all(re.search(p, line, re.I) for p in patterns):
                return True
        return False
    chk.__doc__ = f"a finding line matching {patterns}"
    return chk


def run_process(args: list, *, env: dict | None = None, cwd: Path | None = None,
                limit_as: int | None = None, timeout: float = HANG_S) -> tuple:
    """``python -m vehval ARGS``: ``(exit code or 'hang', stdout+stderr, stderr)``."""
    full_env = {**os.environ, "PYTHONUNBUFFERED": "1", **(env or {})}
    full_env.pop("VEHVAL_DEBUG", None)
    lim = limit_as or LIMIT_AS

    def pre() -> None:
        if lim:
            resource.setrlimit(resource.RLIMIT_AS, (lim, lim))

    proc = subprocess.Popen([sys.executable, "-m", "vehval", *map(str, args)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            stdin=subprocess.DEVNULL, env=full_env, cwd=cwd,
                            start_new_session=True, preexec_fn=pre)
    try:
        out, err = proc.communicate(timeout=timeout)
        code: int | str = proc.returncode
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)  # the case's own process group
        out, err = proc.communicate()
        code = "hang"
    e = err.decode("utf-8", "replace")
    return code, out.decode("utf-8", "replace") + e, e


def run_case(case: Case) -> dict:
    """Run one case; its row with exit code, outcome and last message line."""
    row = {"class": case.cls, "case": case.name}
    if case.prepare is not None:
        try:
            case.prepare()
        except Exception as exc:  # noqa: BLE001 - a broken case is reported, not an outcome
            return {**row, "exit": None, "outcome": "not run",
                    "message": f"{type(exc).__name__}: {exc}"[:200]}
    worst = None
    for _ in range(max(case.repeat, 1)):
        if case.request is not None:
            try:
                code, text = case.request()
            except Exception as exc:  # noqa: BLE001 - the harness failed: reported as such
                return {**row, "exit": None, "outcome": "not run",
                        "message": f"{type(exc).__name__}: {exc}"[:200]}
            stderr = ""
        else:
            code, text, stderr = run_process(case.args, env=case.env, cwd=case.cwd,
                                             limit_as=case.limit_as, timeout=case.timeout)
        outcome = classify3(case, code, text, stderr)
        lines = [ln for ln in text.strip().splitlines() if ln.strip()]
        msg = (lines[-1] if lines else "")[:200]
        r = {**row, "exit": code, "outcome": outcome, "message": msg}
        if worst is None or _rank(outcome) > _rank(worst["outcome"]):
            worst = r
        if outcome not in ("clean error", "handled"):
            break
    assert worst is not None
    return worst


def _rank(outcome: str) -> int:
    return KINDS.index(outcome) if outcome in KINDS else len(KINDS)


def classify3(case: Case, code, text: str, stderr: str = "") -> str:
    """Outcome of one case (see the module doc)."""
    if case.breach(text):
        return "breach"
    if code == "hang":
        return "handled" if case.estimate_ok and case.must and check(case.must, text) \
            else "hang"
    if (isinstance(code, int) and (code < 0 or code == 3 or code >= 128)) \
            or "Exception ignored" in stderr or "Traceback" in text \
            or "internal error" in text.lower():
        return "internal error"
    if case.forbidden():
        return "silently wrong"
    low = text.lower()
    said_error = "error" in low or "failed" in low or "refus" in low
    if code in (1, 2) and said_error:
        return "clean error" if check(case.refusal_must, text) else "silently wrong"
    if case.expect == "ok" and code in case.ok_codes and check(case.must, text):
        return "handled"
    return "silently wrong"
