"""The workbench's web application (Starlette) and its server (uvicorn).

Pages are jinja2 templates (autoescaped) with one script file (``static/workbench.js``) and
the plotly.js bundled with plotly (served from the workbench, never a CDN). Data goes through
a small JSON API; every write is a POST guarded by the CSRF value (:mod:`.security`).
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
from vehval.serve import security as sec
from vehval.serve.bench import NOT_DATA, QA_DIR, RAW_EXT, TEMPLATE_NAME, Bench

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
                return _forbidden("wrong token: open the URL `vehval serve` printed")
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
            return _forbidden("token required: open the URL `vehval serve` printed")
        if request.method not in ("GET", "HEAD"):
            origin = request.headers.get("origin")
            if origin is not None and not sec.host_allowed(origin.split("://", 1)[-1],
                                                           wb.extra_hosts):
                return _forbidden("write refused: request from another origin")
            if not sec.same(request.headers.get(sec.CSRF_HEADER), wb.csrf):
                return _forbidden("write refused: CSRF token missing or wrong: reload the page")
        response = await call_next(request)
        response.headers.setdefault("Content-Security-Policy", sec.PAGE_CSP)
        response.headers["X-Content-Type-Options"] = "nosniff"
        response.headers["Referrer-Policy"] = "no-referrer"
        response.headers.setdefault("Cache-Control", "no-store")
        return response


def _forbidden(message: str) -> Response:
    return JSONResponse({"error": message}, status_code=403)


def _api(fn: Callable[..., Any]) -> Callable[[Request], Any]:
    """A JSON endpoint: vehval errors become ``{"error": ...}`` (the CLI's message)."""
    async def endpoint(request: Request) -> Response:
        from starlette.concurrency import run_in_threadpool

        try:
            body = await request.json() if request.method == "POST" else {}
        except ValueError:
            return JSONResponse({"error": "the request body is not JSON"}, status_code=400)
        try:
            out = await run_in_threadpool(fn, request.app.state.workbench, request.query_params,
                                          body if isinstance(body, dict) else {})
        except sec.OutsideWorkspace as exc:
            return JSONResponse({"error": str(exc)}, status_code=403)
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
        self.token = token or sec.new_secret()
        self.csrf = sec.new_secret()
        self.extra_hosts = extra_hosts
        self._benches: dict[Path, Bench] = {}
        self._lock = threading.Lock()

    def bench(self, rel: str | None) -> Bench:
        folder = sec.inside_workspace(self.root, rel)
        if not folder.is_dir():
            raise InputFileError(f"{rel}: not a folder of the workspace")
        with self._lock:
            if folder not in self._benches:
                self._benches[folder] = Bench(folder)
            return self._benches[folder]

    def tests(self, limit: int = 500) -> list[dict]:
        """Folders holding raw data files or a template (3 levels deep at most)."""
        out = []
        for dirpath, dirnames, filenames in os.walk(self.root):
            d = Path(dirpath)
            depth = len(d.relative_to(self.root).parts)
            dirnames[:] = sorted(n for n in dirnames if not n.startswith(".") and n not in SKIP_DIRS
                                 and depth < 3)
            data = [f for f in filenames if Path(f).suffix.lower() in RAW_EXT
                    and f.lower() not in NOT_DATA and not f.startswith(".")]
            if data or TEMPLATE_NAME in filenames:
                out.append({"dir": sec.relative(self.root, d), "files": sorted(data),
                            "template": TEMPLATE_NAME in filenames,
                            "qa": (d / QA_DIR / "findings.json").is_file()})
                if len(out) >= limit:
                    break
        return out


# --------------------------------------------------------------------------- pages
def _page(name: str, request: Request, **ctx: Any) -> HTMLResponse:
    wb: Workbench = request.app.state.workbench
    html = _jinja().get_template(name).render(csrf=wb.csrf, workspace=wb.root.name, **ctx)
    return HTMLResponse(html)


async def home(request: Request) -> Response:
    from vehval.serve.catalog_view import find_catalogs

    wb: Workbench = request.app.state.workbench
    cats = [sec.relative(wb.root, p) for p in find_catalogs(wb.root)]
    return _page("home.html", request, tests=wb.tests(), catalogs=cats)


async def test_page(request: Request) -> Response:
    wb: Workbench = request.app.state.workbench
    rel = request.query_params.get("dir", ".")
    try:
        wb.bench(rel)
    except sec.OutsideWorkspace as exc:
        return _page("error.html", request, message=str(exc))
    except VehvalError as exc:
        return _page("error.html", request, message=str(exc))
    return _page("test.html", request, dir=rel)


async def catalog_page(request: Request) -> Response:
    wb: Workbench = request.app.state.workbench
    rel = request.query_params.get("db", "")
    try:
        sec.inside_workspace(wb.root, rel)
    except VehvalError as exc:
        return _page("error.html", request, message=str(exc))
    return _page("catalog.html", request, db=rel)


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
    body = path.read_bytes()
    headers = {}
    if path.suffix.lower() == ".html":
        # a page from the workspace runs sandboxed (an origin of its own: no cookie, no API);
        # a batch report's shared plotly.js ('file:' in its own policy) comes from the
        # workbench's public copy instead
        body = _ASSET_SRC.sub(f'src="{PUBLIC_PATH}"'.encode(), body, count=1)
        body = body.replace(b" file:;", b" 'self';", 1)
        headers["Content-Security-Policy"] = sec.REPORT_CSP
    return Response(body, media_type=kind, headers=headers)


# --------------------------------------------------------------------------- API
def _f(q: Any, key: str) -> float | None:
    v = q.get(key)
    if v in (None, "", "null"):
        return None
    try:
        return float(v)
    except ValueError:
        raise InputFileError(f"{key}: not a number: {v[:40]!r}") from None


def _n(q: Any) -> int:
    v = _f(q, "n")
    return 4000 if v is None else int(v)


def api_test(wb: Workbench, q: Any, body: dict) -> dict:
    b = wb.bench(q.get("dir"))
    return {"dir": q.get("dir"), **b.overview()}


def api_channel(wb: Workbench, q: Any, body: dict) -> dict:
    return wb.bench(q.get("dir")).channel(q.get("file", ""), q.get("raw", ""), _f(q, "t0"),
                                          _f(q, "t1"), _n(q))


def api_signal(wb: Workbench, q: Any, body: dict) -> dict:
    return wb.bench(q.get("dir")).signal(q.get("name", ""), _f(q, "t0"), _f(q, "t1"), _n(q))


def api_save(wb: Workbench, q: Any, body: dict) -> dict:
    b = wb.bench(q.get("dir"))
    b.save_edits(body)
    b.rerun()
    return api_test(wb, q, body)


def api_run(wb: Workbench, q: Any, body: dict) -> dict:
    wb.bench(q.get("dir")).rerun()
    return api_test(wb, q, body)


def api_selection(wb: Workbench, q: Any, body: dict) -> dict:
    b = wb.bench(q.get("dir"))
    b.decide(str(body.get("signal") or ""), str(body.get("action") or ""),
             str(body.get("reason") or ""))
    b.rerun()
    return api_test(wb, q, body)


def api_model(wb: Workbench, q: Any, body: dict) -> dict:
    from vehval.serve.model_view import model_overlay

    return model_overlay(wb.bench(q.get("dir")))


def api_catalog(wb: Workbench, q: Any, body: dict) -> dict:
    from vehval.serve.catalog_view import rows

    db = sec.inside_workspace(wb.root, q.get("db"))
    out = rows(db, dict(q))
    base = db.parent
    for r in out["rows"]:
        rep = base / "tests" / str(r["test_id"]) / "report.html"
        r["report"] = sec.relative(wb.root, rep) if rep.is_file() else None
    return out


def api_trace(wb: Workbench, q: Any, body: dict) -> dict:
    from vehval.serve.catalog_view import test_traces

    db = sec.inside_workspace(wb.root, q.get("db"))
    return test_traces(wb.root, db, q.get("test", ""), q.get("q", "speed"), _n(q),
                       per_phase=q.get("axis") == "phase")


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
        Route("/api/test", _api(api_test)), Route("/api/channel", _api(api_channel)),
        Route("/api/signal", _api(api_signal)),
        Route("/api/template", _api(api_save), methods=["POST"]),
        Route("/api/run", _api(api_run), methods=["POST"]),
        Route("/api/selection", _api(api_selection), methods=["POST"]),
        Route("/api/model", _api(api_model), methods=["POST"]),
        Route("/api/catalog", _api(api_catalog)), Route("/api/catalog/trace", _api(api_trace)),
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
