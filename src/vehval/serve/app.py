"""The workbench's web application (Starlette) and its server (uvicorn).

Pages are jinja2 templates (autoescaped) with one script file (``static/workbench.js``) and
the plotly.js bundled with plotly (served from the workbench, never a CDN). Data goes through
a small JSON API whose queries and bodies are typed models (:mod:`.params`); every write is a
POST guarded by the CSRF value and the origin (:mod:`.security`), and no GET writes or runs QA.
"""

from __future__ import annotations

import os
import re
import socket
import threading
from functools import lru_cache
from pathlib import Path
from typing import Any, Callable
from urllib.parse import urlencode

from starlette.applications import Starlette
from starlette.middleware import Middleware
from starlette.middleware.base import BaseHTTPMiddleware
from starlette.requests import Request
from starlette.responses import HTMLResponse, JSONResponse, RedirectResponse, Response
from starlette.routing import Route

from vehval.errors import InputFileError, VehvalError
from vehval.jsonsafe import clean
from vehval.serve import params as prm
from vehval.serve import security as sec
from vehval.serve.bench import MAX_DATA_FILES, QA_DIR, TEMPLATE_NAME, Bench, QANotRun, pick_data

STATIC = Path(__file__).with_name("static")
#: The one path served without the token: the plotly.js bundled with plotly (a report from the
#: workspace runs sandboxed, without the cookie, and loads it from here).
PUBLIC_PATH = "/static/plotly.min.js"
#: A batch report's reference to its shared plotly.js copy (``../../assets/plotly-X.min.js``).
_ASSET_SRC = re.compile(rb'src="[^"<>]*assets/plotly-[0-9A-Za-z.\-]*\.min\.js"')
#: Files of the workspace the page may open, and their media type.
SERVED_TYPES = {".html": "text/html; charset=utf-8", ".json": "application/json",
                ".yaml": "text/plain; charset=utf-8", ".txt": "text/plain; charset=utf-8",
                ".csv": "text/plain; charset=utf-8", ".png": "image/png"}
#: Folders never listed as tests (outputs).
SKIP_DIRS = {QA_DIR, "assets", "tests", "__pycache__", "node_modules"}
#: Most folders and entries the home page's listing looks at (it says so when it stops).
MAX_TESTS = 500
MAX_WALK_ENTRIES = 50_000
#: ``Sec-Fetch-Site`` values of a request made by a page of another origin (another port of
#: this machine is "same-site"): refused on the API, whatever the method.
FOREIGN_SITES = {"cross-site", "same-site"}


@lru_cache(maxsize=1)
def _plotly_js() -> bytes:
    from plotly.offline import get_plotlyjs

    return get_plotlyjs().encode("utf-8")


@lru_cache(maxsize=1)
def _jinja() -> Any:
    import jinja2

    return jinja2.Environment(loader=jinja2.PackageLoader("vehval.serve", "templates"),
                              autoescape=True, undefined=jinja2.StrictUndefined)


class _Guard(BaseHTTPMiddleware):
    """Host check, token, CSRF and the content policy on every response."""

    async def dispatch(self, request: Request, call_next: Callable) -> Response:
        wb: Workbench = request.app.state.workbench
        if not sec.host_allowed(request.headers.get("host"), wb.extra_hosts):
            return _forbidden("host not allowed: open the workbench at 127.0.0.1")
        if request.url.path == PUBLIC_PATH and request.method == "GET":
            return await call_next(request)  # plotly.js itself: no secret, no data
        given = request.query_params.get("token")
        if given is not None:
            if not sec.same(given, wb.token):
                return _forbidden("wrong token: open the URL `vehval serve` printed", request)
            if request.method == "GET":  # the token leaves the URL for a cookie
                query = urlencode([(k, v) for k, v in request.query_params.multi_items()
                                   if k != "token"])
                resp: Response = RedirectResponse(request.url.path + (f"?{query}" if query else ""),
                                                  status_code=303)
                resp.set_cookie(sec.TOKEN_COOKIE, wb.token, httponly=True, samesite="strict",
                                path="/")
                return resp
        elif not (sec.same(request.cookies.get(sec.TOKEN_COOKIE), wb.token)
                  or sec.same(request.headers.get(sec.TOKEN_HEADER), wb.token)):
            return _forbidden("token required: open the URL `vehval serve` printed", request)
        if request.url.path.startswith("/api/") and \
                request.headers.get("sec-fetch-site") in FOREIGN_SITES:
            return _forbidden("request refused: made by a page of another origin")
        if request.method not in ("GET", "HEAD"):
            origin = request.headers.get("origin")
            if origin is not None and not sec.same_origin(origin, request.url.scheme,
                                                          request.headers.get("host")):
                return _forbidden("write refused: request from another origin (scheme, host "
                                  "and port must be the workbench's own)")
            if not sec.same(request.headers.get(sec.CSRF_HEADER), wb.csrf):
                return _forbidden("write refused: CSRF token missing or wrong: reload the page")
        response = await call_next(request)
        response.headers.setdefault("Content-Security-Policy", sec.PAGE_CSP)
        response.headers["X-Content-Type-Options"] = "nosniff"
        response.headers["Referrer-Policy"] = "no-referrer"
        response.headers.setdefault("Cache-Control", "no-store")
        return response


def _forbidden(message: str, request: Request | None = None) -> Response:
    """403: JSON ``{"error"}`` for the API and clients asking for JSON; for a browser
    opening a page, an HTML page saying what to do."""
    if request is None or request.url.path.startswith("/api/") or \
            "text/html" not in request.headers.get("accept", ""):
        return JSONResponse({"error": message}, status_code=403)
    # no token: the page carries no CSRF value and names no workspace
    return HTMLResponse(_jinja().get_template("refused.html").render(message=message),
                        status_code=403)


async def _body(request: Request) -> bytes:
    """The request body, read no further than :data:`.params.MAX_BODY_BYTES`."""
    declared = request.headers.get("content-length")
    if declared is not None and (not declared.isdigit() or int(declared) > prm.MAX_BODY_BYTES):
        raise prm.BadRequest(f"the request body is over {prm.MAX_BODY_BYTES:,} bytes: refused",
                             413)
    buf = bytearray()
    async for chunk in request.stream():
        buf += chunk
        if len(buf) > prm.MAX_BODY_BYTES:
            raise prm.BadRequest(f"the request body is over {prm.MAX_BODY_BYTES:,} bytes: "
                                 "refused", 413)
    return bytes(buf)


def _api(fn: Callable[..., Any], query: type, body: type | None = None) -> Callable[[Request], Any]:
    """A JSON endpoint: ``fn(workbench, query, body)`` with the query parameters and the body
    parsed by their models first (a bad request: 4xx); vehval errors become
    ``{"error": ...}`` (the CLI's message): 403 outside the workspace, 409 before QA ran."""
    async def endpoint(request: Request) -> Response:
        from starlette.concurrency import run_in_threadpool

        try:
            q = prm.parse_query(query, request.query_params.multi_items())
            b = prm.parse_body(body, await _body(request)) if body is not None else None
            out = await run_in_threadpool(fn, request.app.state.workbench, q, b)
        except prm.BadRequest as exc:
            return JSONResponse({"error": str(exc)}, status_code=exc.status)
        except sec.OutsideWorkspace as exc:
            return JSONResponse({"error": str(exc)}, status_code=403)
        except QANotRun as exc:
            return JSONResponse({"error": str(exc)}, status_code=409)
        except VehvalError as exc:
            return JSONResponse({"error": str(exc)}, status_code=400)
        except Exception as exc:  # noqa: BLE001 - the page shows it; the server goes on
            if os.environ.get("VEHVAL_DEBUG"):
                raise
            return JSONResponse({"error": f"internal error: {type(exc).__name__}: {exc}"},
                                status_code=500)
        return JSONResponse(clean(out))
    return endpoint


class Workbench:
    """The server's state: workspace, secrets, one :class:`Bench` per open test folder."""

    def __init__(self, workspace: Path, token: str | None = None,
                 extra_hosts: frozenset[str] = frozenset()) -> None:
        self.root = Path(workspace).resolve()
        if not self.root.is_dir():
            raise InputFileError(f"{workspace}: workspace folder not found")
        sec.check_workspace(self.root)
        self.token = token or sec.new_secret()
        self.csrf = sec.new_secret()
        self.extra_hosts = extra_hosts
        self._benches: dict[tuple[Path, str | None], Bench] = {}
        self._lock = threading.Lock()

    def bench(self, rel: str | None, test: str | None = None) -> Bench:
        """The bench of folder ``rel`` (of its test ``test`` in a folder of many tests)."""
        folder = sec.inside_workspace(self.root, rel)
        if not folder.is_dir():
            raise InputFileError(f"{rel}: not a folder of the workspace")
        if test is not None and test not in folder_tests(self.root, folder):
            raise InputFileError(f"{rel}: no test '{test[:80]}' in the folder (open one the "
                                 "home page lists)")
        with self._lock:
            if (folder, test) not in self._benches:
                self._benches[(folder, test)] = Bench(folder, self.root, test)
            return self._benches[(folder, test)]

    def tests(self, limit: int = MAX_TESTS) -> tuple[list[dict], list[dict]]:
        """Folders holding raw data files or a template (3 levels deep at most), and what the
        listing left out (``[{"name", "why"}]``: links out of the workspace, loops, special
        files, folders beyond the bounds).

        Symlinks are resolved: one leading out of the workspace is left out; a linked folder
        inside is listed under its link once (never twice, never in a loop).
        """
        out: list[dict] = []
        left: list[dict] = []
        seen = {self.root}
        queue: list[tuple[Path, int]] = [(self.root, 0)]
        budget = MAX_WALK_ENTRIES
        while queue:
            d, depth = queue.pop(0)
            if budget <= 0 or len(out) >= limit:
                why = (f"too many files: the listing stops after {MAX_WALK_ENTRIES:,} entries"
                       if budget <= 0 else f"at most {limit} test folders are listed")
                left.append({"name": sec.relative(self.root, d), "why": why})
                break
            listing = sec.list_folder(self.root, d, max_entries=min(sec.MAX_ENTRIES, budget))
            budget -= len(listing.files) + len(listing.dirs) + len(listing.left_out)
            rel = sec.relative(self.root, d)
            has_tpl = any(p.name == TEMPLATE_NAME for p in listing.files)
            many = folder_tests(self.root, d, listing) if has_tpl else {}
            data, gone = pick_data(listing, most=None if many else MAX_DATA_FILES)
            left += [{"name": f"{rel}/{x['name']}".removeprefix("./"), "why": x["why"]}
                     for x in gone]
            if data or has_tpl:
                for tid, name in many.items():
                    out.append({"dir": rel, "test": tid, "files": [name], "template": True,
                                "qa": _qa_done(self.root, d / QA_DIR / tid)})
                if not many:
                    out.append({"dir": rel, "test": None, "files": [p.name for p in data],
                                "template": has_tpl, "qa": _qa_done(self.root, d / QA_DIR)})
            if depth >= 3:
                continue
            for sub in listing.dirs:
                real = sub.resolve()
                if sub.name not in SKIP_DIRS and real not in seen:
                    seen.add(real)
                    queue.append((sub, depth + 1))
        return out, sec.bounded_left_out(left, 100)


def _qa_done(root: Path, qa: Path) -> bool:
    """True when the QA folder ``qa`` holds ``findings.json`` (inside the workspace)."""
    try:
        return sec.regular_file(root, qa / "findings.json", "findings") is not None
    except VehvalError:
        return False


def folder_tests(root: Path, folder: Path, listing: sec.Listing | None = None) -> dict[str, str]:
    """``{test id: file name}`` of a folder of many tests (its saved template takes one file
    per test: :func:`vehval.batch.discover.file_tests`); ``{}`` for a folder of one test or
    without a readable template."""
    from vehval.batch.discover import file_tests
    from vehval.io.template import template_from_data
    from vehval.safe_yaml import load_yaml

    try:
        path = sec.regular_file(root, folder / TEMPLATE_NAME, TEMPLATE_NAME)
        if path is None:
            return {}
        tmpl = template_from_data(load_yaml(path.read_text(encoding="utf-8"), TEMPLATE_NAME),
                                  TEMPLATE_NAME)
        # one file per test: every data file of the folder (the listing bounds them), not
        # the first MAX_DATA_FILES the files of one test are read up to
        data, _ = pick_data(listing or sec.list_folder(root, folder), tmpl, most=None)
    except VehvalError:
        return {}
    ordered = sorted(data, key=lambda p: p.name)
    return {spec.test_id: p.name for p, spec in zip(ordered, file_tests(ordered, tmpl))}


# --------------------------------------------------------------------------- pages
def _page(name: str, request: Request, status: int = 200, **ctx: Any) -> HTMLResponse:
    wb: Workbench = request.app.state.workbench
    html = _jinja().get_template(name).render(csrf=wb.csrf, workspace=wb.root.name, **ctx)
    return HTMLResponse(html, status_code=status)


def _error_page(request: Request, exc: VehvalError) -> HTMLResponse:
    """The error page of a refused page request, with the status the API gives the same
    error: 403 outside the workspace, the parser's 4xx for a bad query, else 400."""
    status = 403 if isinstance(exc, sec.OutsideWorkspace) else \
        exc.status if isinstance(exc, prm.BadRequest) else 400
    return _page("error.html", request, status=status, message=str(exc))


async def home(request: Request) -> Response:
    from starlette.concurrency import run_in_threadpool

    from vehval.serve.catalog_view import find_catalogs

    wb: Workbench = request.app.state.workbench
    tests, left = await run_in_threadpool(wb.tests)
    found, gone = await run_in_threadpool(find_catalogs, wb.root)
    cats = [sec.relative(wb.root, p) for p in found]
    return _page("home.html", request, tests=tests, catalogs=cats,
                 left_out=sec.bounded_left_out(left + gone, 100))


async def test_page(request: Request) -> Response:
    wb: Workbench = request.app.state.workbench
    try:
        q = prm.parse_query(prm.DirQuery, request.query_params.multi_items())
        wb.bench(q.dir, q.test)
        many = folder_tests(wb.root, sec.inside_workspace(wb.root, q.dir)) if q.test is None else {}
    except VehvalError as exc:
        return _error_page(request, exc)
    if many:
        return _page("error.html", request, message=(
            f"{q.dir}: {len(many)} tests under one template (one data file each): open one "
            "of them from the home page's list"))
    return _page("test.html", request, dir=q.dir, test=q.test)


async def catalog_page(request: Request) -> Response:
    wb: Workbench = request.app.state.workbench
    try:
        q = prm.parse_query(prm.CatalogQuery, request.query_params.multi_items())
        sec.regular_file(wb.root, sec.inside_workspace(wb.root, q.db), q.db)
    except VehvalError as exc:
        return _error_page(request, exc)
    return _page("catalog.html", request, db=q.db)


async def static(request: Request) -> Response:
    name = request.path_params["name"]
    if name == "plotly.min.js":
        return Response(_plotly_js(), media_type="text/javascript",
                        headers={"Cache-Control": "private, max-age=86400"})
    path = STATIC / name
    if "/" in name or not path.is_file():
        return JSONResponse({"error": f"{name}: not found"}, status_code=404)
    kind = "text/javascript" if name.endswith(".js") else "text/css"
    return Response(path.read_bytes(), media_type=kind, headers={"Cache-Control": "no-cache"})


async def files(request: Request) -> Response:
    """A file of the workspace (a report, a JSON output); reports keep their own policy."""
    wb: Workbench = request.app.state.workbench
    rel = request.path_params["path"]
    try:
        path = sec.inside_workspace(wb.root, rel)
    except sec.OutsideWorkspace as exc:
        return JSONResponse({"error": str(exc)}, status_code=403)
    except VehvalError as exc:
        return JSONResponse({"error": str(exc)}, status_code=404)
    kind = SERVED_TYPES.get(path.suffix.lower())
    if not path.is_file() or kind is None:
        return JSONResponse({"error": f"{rel}: not a file the workbench opens"}, status_code=404)
    if path.suffix.lower() != ".html":   # streamed from disk, never read whole
        from starlette.responses import FileResponse

        return FileResponse(path, media_type=kind)
    size = path.stat().st_size
    if size > prm.MAX_PAGE_BYTES:
        return JSONResponse({"error": f"{rel}: {size / 2**20:.0f} MiB, more than the "
                             f"{prm.MAX_PAGE_BYTES >> 20} MiB a report page may have: open it "
                             "from the file system"}, status_code=413)
    # a page from the workspace runs sandboxed (an origin of its own: no cookie, no API); a
    # batch report's shared plotly.js ('file:' in its own policy) comes from the workbench's
    # public copy instead
    body = _ASSET_SRC.sub(f'src="{PUBLIC_PATH}"'.encode(), path.read_bytes(), count=1)
    body = body.replace(b" file:;", b" 'self';", 1)
    return Response(body, media_type=kind,
                    headers={"Content-Security-Policy": sec.REPORT_CSP})


# --------------------------------------------------------------------------- API
def api_test(wb: Workbench, q: prm.DirQuery, body: None) -> dict:
    """The test page's model (GET: reads only)."""
    return {"dir": q.dir, **wb.bench(q.dir, q.test).overview()}


def api_channel(wb: Workbench, q: prm.ChannelQuery, body: None) -> dict:
    return wb.bench(q.dir, q.test).channel(q.file, q.raw, q.t0, q.t1, q.n)


def api_signal(wb: Workbench, q: prm.SignalQuery, body: None) -> dict:
    """One signal of the last QA run (409 before QA ran: a GET never runs it)."""
    return wb.bench(q.dir, q.test).signal(q.name, q.t0, q.t1, q.n)


def api_finding(wb: Workbench, q: prm.FindingQuery, body: None) -> dict:
    """The figure of one finding (a plotly spec the page draws; 409 before QA ran)."""
    import json

    from vehval.report.figures import figure_json

    out = wb.bench(q.dir, q.test).finding_figure(q.i)
    out["figure"] = json.loads(figure_json(out["figure"]))
    return out


def api_save(wb: Workbench, q: prm.DirQuery, body: prm.TemplateEdits) -> dict:
    b = wb.bench(q.dir, q.test)
    b.save_edits(body.edits())
    b.rerun()
    return api_test(wb, q, None)


def api_run(wb: Workbench, q: prm.DirQuery, body: prm.NoBody) -> dict:
    wb.bench(q.dir, q.test).rerun()
    return api_test(wb, q, None)


def api_selection(wb: Workbench, q: prm.DirQuery, body: prm.Decision) -> dict:
    b = wb.bench(q.dir, q.test)
    b.decide(body.signal, body.action, body.reason)
    b.rerun()
    return api_test(wb, q, None)


def api_model(wb: Workbench, q: prm.DirQuery, body: prm.NoBody | None) -> dict:
    """Model and test: GET the vehicle it will simulate and the kept result; POST runs it."""
    from vehval.serve import flow

    b = wb.bench(q.dir, q.test)
    return flow.kept(b) if body is None else flow.run_model(b)


def api_report(wb: Workbench, q: prm.DirQuery, body: prm.NoBody) -> dict:
    """Build the test's static report (``vehval report``'s code) and name it."""
    from vehval.serve import flow

    return flow.build_report(wb.bench(q.dir, q.test))


def _report_of(wb: Workbench, base: Path, test_id: Any) -> str | None:
    """A catalog test's ``tests/ID/report.html`` (relative), when it is a file of the
    workspace."""
    name = str(test_id)
    if not name or name.startswith(".") or "/" in name or "\\" in name:
        return None
    path = base / "tests" / name / "report.html"
    try:
        return sec.relative(wb.root, path) if sec.regular_file(wb.root, path, name) else None
    except VehvalError:
        return None


def api_catalog(wb: Workbench, q: prm.CatalogQuery, body: None) -> dict:
    from vehval.serve.catalog_view import rows

    db = sec.inside_workspace(wb.root, q.db)
    sec.regular_file(wb.root, db, q.db)
    out = rows(db, q.model_dump(exclude={"db"}, exclude_none=True))
    for r in out["rows"]:
        r["report"] = _report_of(wb, db.parent, r["test_id"])
    return out


def api_trace(wb: Workbench, q: prm.TraceQuery, body: None) -> dict:
    from vehval.serve.catalog_view import test_traces

    db = sec.inside_workspace(wb.root, q.db)
    sec.regular_file(wb.root, db, q.db)
    return test_traces(wb.root, db, q.test, q.q, q.n, per_phase=q.axis == "phase")


def api_overlay(wb: Workbench, q: prm.OverlayQuery, body: None) -> dict:
    """The overlay figure of catalog tests (a spec the page draws; a test without the
    quantity's signal is named in ``missing``)."""
    import json

    from vehval.report.figures import figure_json
    from vehval.serve.catalog_view import overlay_figure

    db = sec.inside_workspace(wb.root, q.db)
    sec.regular_file(wb.root, db, q.db)
    out = overlay_figure(wb.root, db, q.ids(), q.q, q.n, per_phase=q.axis == "phase")
    out["figure"] = json.loads(figure_json(out["figure"]))
    return out


def create_app(workspace: str | Path, *, token: str | None = None,
               extra_hosts: frozenset[str] = frozenset()) -> Starlette:
    """The workbench application over ``workspace``.

    Parameters
    ----------
    workspace : path
        Folder whose files the workbench reads and writes (nothing outside it).
    token : str, optional
        Access token (default: a fresh random one, ``app.state.workbench.token``).
    extra_hosts : frozenset of str
        Host names answered besides 127.0.0.1, localhost and [::1].
    """
    routes = [
        Route("/", home), Route("/test", test_page), Route("/catalog", catalog_page),
        Route("/static/{name}", static), Route("/files/{path:path}", files),
        Route("/favicon.ico", lambda request: Response(status_code=204)),
        Route("/api/test", _api(api_test, prm.DirQuery)),
        Route("/api/channel", _api(api_channel, prm.ChannelQuery)),
        Route("/api/signal", _api(api_signal, prm.SignalQuery)),
        Route("/api/finding", _api(api_finding, prm.FindingQuery)),
        Route("/api/template", _api(api_save, prm.DirQuery, prm.TemplateEdits), methods=["POST"]),
        Route("/api/run", _api(api_run, prm.DirQuery, prm.NoBody), methods=["POST"]),
        Route("/api/selection", _api(api_selection, prm.DirQuery, prm.Decision),
              methods=["POST"]),
        Route("/api/model", _api(api_model, prm.DirQuery, prm.NoBody), methods=["POST"]),
        Route("/api/model", _api(api_model, prm.DirQuery)),
        Route("/api/report", _api(api_report, prm.DirQuery, prm.NoBody), methods=["POST"]),
        Route("/api/catalog", _api(api_catalog, prm.CatalogQuery)),
        Route("/api/catalog/trace", _api(api_trace, prm.TraceQuery)),
        Route("/api/catalog/overlay", _api(api_overlay, prm.OverlayQuery)),
    ]
    app = Starlette(routes=routes, middleware=[Middleware(_Guard)])
    app.state.workbench = Workbench(Path(workspace), token, extra_hosts)
    return app


# --------------------------------------------------------------------------- server
def bind(host: str, port: int) -> socket.socket:
    """A listening socket on ``host:port`` (port 0: any free port)."""
    fam = socket.AF_INET6 if ":" in host else socket.AF_INET
    sock = socket.socket(fam, socket.SOCK_STREAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        sock.bind((host, port))
    except OSError as exc:
        sock.close()
        raise InputFileError(f"cannot listen on {host}:{port}: {exc.strerror or exc} "
                             "(pass another --port, or --port 0 for any free one)") from None
    sock.listen(64)
    return sock


def url_of(host: str, port: int, token: str) -> str:
    name = f"[{host}]" if ":" in host else host
    return f"http://{name}:{port}/?token={token}"


class Running:
    """A server started by :func:`start`: its ``url`` and :meth:`stop`."""

    def __init__(self, server: Any, thread: threading.Thread, url: str, app: Starlette) -> None:
        self.server, self.thread, self.url, self.app = server, thread, url, app

    def stop(self) -> None:
        self.server.should_exit = True
        self.thread.join(timeout=10)


def start(workspace: str | Path, *, host: str = "127.0.0.1", port: int = 0) -> Running:
    """Start the workbench in a background thread (tests, benchmarks, notebooks)."""
    import time

    import uvicorn

    app = create_app(workspace, extra_hosts=frozenset({host}))
    sock = bind(host, port)
    config = uvicorn.Config(app, log_level="warning", lifespan="off")
    server = uvicorn.Server(config)
    thread = threading.Thread(target=server.run, kwargs={"sockets": [sock]}, daemon=True)
    thread.start()
    for _ in range(200):
        if server.started:
            break
        time.sleep(0.02)
    return Running(server, thread, url_of(host, sock.getsockname()[1],
                                          app.state.workbench.token), app)


def run_server(workspace: str | Path, *, host: str = "127.0.0.1", port: int = 8890,
               open_browser: bool = True, echo: Callable[[str], None] = print) -> None:
    """Serve the workbench until interrupted (``vehval serve``)."""
    import uvicorn

    app = create_app(workspace, extra_hosts=frozenset({host}))
    sock = bind(host, port)
    url = url_of(host, sock.getsockname()[1], app.state.workbench.token)
    echo(f"vehval workbench on {app.state.workbench.root}")
    echo(f"open: {url}")
    echo("(Ctrl+C stops it; the token in the URL is the key: do not share it)")
    if open_browser:
        import webbrowser

        threading.Timer(0.5, webbrowser.open, args=(url,)).start()
    uvicorn.Server(uvicorn.Config(app, log_level="warning", lifespan="off")).run(sockets=[sock])
