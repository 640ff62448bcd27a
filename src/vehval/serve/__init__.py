"""The workbench: ``vehval serve [WORKSPACE]``, a local web page over one workspace folder.

Template review (channels, units, plots, QA hints, save and rerun), QA triage (findings
linked to plots, keep or drop a signal with a reason), a catalog browser over batch outputs
and the model overlaid on a test. Starlette serves it on 127.0.0.1 with a token valid while
it runs (docs/workbench.md). Everything is imported lazily by the CLI: ``vehval --help`` never loads
the server.
"""

from __future__ import annotations

__all__ = ["create_app", "run_server"]


def __getattr__(name: str):  # lazy: the web stack loads only when the workbench starts
    if name in __all__:
        from vehval.serve import app

        return getattr(app, name)
    raise AttributeError(name)
