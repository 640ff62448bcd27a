"""Every finding of every stage of a test: QA's (``findings.json``) and the results stage's
(``results.json``: drive quality outside SAE J2951, SAE J1711 beyond tolerance, a result that
cannot be given).

The command line prints both; the workbench's page and the batch's catalog list them from
here, each finding tagged with its ``stage`` (``qa`` or ``results``).
"""

from __future__ import annotations

__all__ = ["stage_findings"]


def stage_findings(qa: dict | None, results: dict | None) -> list[dict]:
    """QA's findings then the results stage's, each a copy with ``stage`` set; a results
    finding QA already holds (same kind, signal and message) is listed once."""
    out: list[dict] = []
    seen: set[tuple] = set()
    for stage, doc in (("qa", qa), ("results", results)):
        for f in (doc or {}).get("findings") or []:
            if not isinstance(f, dict):
                continue
            key = (f.get("kind"), f.get("signal"), f.get("message"))
            if key in seen:
                continue
            seen.add(key)
            out.append({**f, "stage": stage})
    return out
