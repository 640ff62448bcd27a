"""Attack campaign III, workbench class: real HTTP requests against a ``vehval serve`` process
the campaign starts on 127.0.0.1 (loopback only), and a headless Chromium page load for the
GET-writes-from-another-port case.

Breach: an outside file's channel, value or key in an answer, an outside file imported into
``qa/``, an outside folder written, a GET that wrote ``qa/``, a write accepted from another
origin, the workbench started over the filesystem root or the home folder. Internal error: a
5xx, the server gone, a traceback in the server's log.
"""

from __future__ import annotations

import http.client
import http.server
import json
import os
import re
import resource
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Callable, Iterator
from urllib.parse import quote, urlparse

import numpy as np
from attack3_common import HANG_S, LIMIT_AS, Case
from attack_campaign import TEMPLATE, write_d3

#: A channel name and a value only the outside file holds.
MARK_CHANNEL = "Secret0uts1deChan"
MARK_VALUE = "12345.678"
CHROMIUM = os.environ.get("VEHVAL_CHROMIUM") or shutil.which("chromium") or "/usr/bin/chromium"


def _marked(text: str) -> bool:
    return MARK_CHANNEL.lower() in text.lower() or MARK_VALUE in text


def write_outside_d3(path: Path) -> Path:
    """A D3 file outside the workspace: the template's channels plus a marked one."""
    path.parent.mkdir(parents=True, exist_ok=True)
    t = np.arange(600) * 0.1
    lines = [f"Time[s]\tDyno_Speed[mph]\tEngine_Speed[rpm]\t{MARK_CHANNEL}[V]"]
    lines += [f"{a:.1f}\t{20 + 10 * np.sin(a / 10):.4f}\t{1200 + 300 * np.sin(a / 7):.2f}\t"
              f"{MARK_VALUE}" for a in t]
    path.write_text("\n".join(lines) + "\n")
    return path


# ----------------------------------------------------------------------------------------
# the server

class Workbench:
    """``vehval serve WS --port 0 --no-browser`` as a process; requests with its token."""

    def __init__(self, ws: Path) -> None:
        self.ws = ws
        self.proc: subprocess.Popen | None = None
        self.lock = threading.Lock()
        self.port = 0
        self.token = ""
        self._csrf = ""
        self.log = ws.parent / "serve.log"
        self._seen = 0

    def ensure(self) -> Workbench:
        with self.lock:
            if self.proc is not None and self.proc.poll() is None:
                return self
            self.ws.mkdir(parents=True, exist_ok=True)
            code, text, self.proc = start_serve([self.ws], log=self.log, keep=True)
            m = re.search(r"open: (http://\S+)", text)
            if self.proc is None or m is None:
                raise RuntimeError(f"vehval serve did not start: {text[-300:]}")
            url = urlparse(m.group(1))
            self.port = url.port or 80
            self.token = dict(p.split("=", 1) for p in url.query.split("&"))["token"]
            self._csrf = ""
            WORKBENCHES.append(self)
            return self

    def csrf(self) -> str:
        if not self._csrf:
            _, page = self.request("GET", "/")
            m = re.search(r'name="vehval-csrf" content="([^"]+)"', page)
            self._csrf = m.group(1) if m else ""
        return self._csrf

    def origin(self) -> str:
        return f"http://127.0.0.1:{self.port}"

    def request(self, method: str, path: str, body: bytes | None = None, *,
                headers: dict | None = None, token: bool = True,
                timeout: float = HANG_S) -> tuple:
        """One request: ``(code, text)``, code 0 for 2xx/3xx, 2 for 4xx, 3 for 5xx or the
        server gone, "hang" without an answer in time; text: status, body, new server log."""
        h = {"Host": f"127.0.0.1:{self.port}"}
        if token:
            h["X-Vehval-Token"] = self.token
        if method == "POST":
            h.update({"Origin": self.origin(), "X-CSRF-Token": self.csrf(),
                      "Content-Type": "application/json"})
        h.update(headers or {})
        conn = http.client.HTTPConnection("127.0.0.1", self.port, timeout=timeout)
        try:
            conn.request(method, path, body=body, headers=h)
            resp = conn.getresponse()
            status, text = resp.status, resp.read().decode("utf-8", "replace")
        except (socket.timeout, TimeoutError):
            return "hang", f"no answer within {timeout:g} s" + self.new_log()
        except (ConnectionError, http.client.HTTPException, OSError) as exc:
            return 3, f"server gone: {type(exc).__name__}: {exc}" + self.new_log()
        finally:
            conn.close()
        code = 0 if status < 400 else 2 if status < 500 else 3
        time.sleep(0.5)  # the server logs an exception after its answer: read it with it
        return code, f"HTTP {status}\n{text}" + self.new_log()

    def new_log(self) -> str:
        """Lines the server logged since the last request (tracebacks count)."""
        try:
            data = self.log.read_bytes()
        except OSError:
            return ""
        new, self._seen = data[self._seen:], len(data)
        return ("\n" + new.decode("utf-8", "replace")) if new.strip() else ""

    def stop(self) -> None:
        if self.proc is not None and self.proc.poll() is None:
            os.killpg(self.proc.pid, signal.SIGTERM)
            try:
                self.proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                os.killpg(self.proc.pid, signal.SIGKILL)
                self.proc.wait()


WORKBENCHES: list[Workbench] = []


def stop_workbenches() -> None:
    while WORKBENCHES:
        WORKBENCHES.pop().stop()


def start_serve(args: list, *, log: Path, keep: bool, env: dict | None = None,
                wait_s: float = HANG_S) -> tuple:
    """Start ``vehval serve ARGS --port 0 --no-browser``; wait for its URL or its exit.

    Returns ``(exit code, 0 when it started, or 'hang'; its output; the process when
    ``keep`` and it started, else None)``. A server not kept is stopped at once.
    """
    full_env = {**os.environ, "PYTHONUNBUFFERED": "1", **(env or {})}
    full_env.pop("VEHVAL_DEBUG", None)
    log.parent.mkdir(parents=True, exist_ok=True)
    err = open(log, "ab")  # noqa: SIM115 - the server's log for its whole life

    def pre() -> None:
        resource.setrlimit(resource.RLIMIT_AS, (LIMIT_AS, LIMIT_AS))

    proc = subprocess.Popen([sys.executable, "-m", "vehval", "serve", *map(str, args),
                             "--port", "0", "--no-browser"], stdout=subprocess.PIPE,
                            stderr=err, stdin=subprocess.DEVNULL, env=full_env,
                            start_new_session=True, preexec_fn=pre)
    err.close()
    lines: list[str] = []
    started = threading.Event()

    def read() -> None:
        assert proc.stdout is not None
        for raw in proc.stdout:
            lines.append(raw.decode("utf-8", "replace"))
            if "open: http" in lines[-1]:
                started.set()
        started.set()
    threading.Thread(target=read, daemon=True).start()
    started.wait(wait_s)
    text = "".join(lines)
    if "open: http" not in text:  # stdout closed: give the exiting process time to be reaped
        try:
            proc.wait(timeout=5)
        except subprocess.TimeoutExpired:
            pass
    if proc.poll() is not None and "open: http" not in text:
        proc.wait()
        time.sleep(0.2)
        text = "".join(lines) + log.read_text(encoding="utf-8", errors="replace")
        return proc.returncode, text, None
    if "open: http" not in text:
        os.killpg(proc.pid, signal.SIGKILL)
        return "hang", text, None
    if keep:
        return 0, text, proc
    os.killpg(proc.pid, signal.SIGTERM)
    proc.wait(timeout=10)
    return 0, text, None


# ----------------------------------------------------------------------------------------
# the page on another port (Chromium)

def chromium_ok() -> bool:
    if not Path(CHROMIUM).exists():
        return False
    try:
        import playwright.sync_api  # noqa: F401
    except ImportError:
        return False
    return True


class PageServer:
    """A page on another local port (its own HTTP server on 127.0.0.1)."""

    def __init__(self, html: str) -> None:
        body = html.encode()

        class H(http.server.BaseHTTPRequestHandler):
            def do_GET(self):  # noqa: N802 - the standard library's name
                self.send_response(200)
                self.send_header("Content-Type", "text/html")
                self.send_header("Content-Length", str(len(body)))
                self.end_headers()
                self.wfile.write(body)

            def log_message(self, *a):
                pass
        self.httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), H)
        self.port = self.httpd.server_address[1]
        threading.Thread(target=self.httpd.serve_forever, daemon=True).start()

    def close(self) -> None:
        self.httpd.shutdown()
        self.httpd.server_close()


def cross_port_img(wb: Workbench, target: str) -> tuple:
    """Open the workbench with its token (the cookie is set), then a page of another local
    port whose ``<img>`` points at ``target``; ``(0, what happened)`` once the image failed
    or loaded (its request answered)."""
    from playwright.sync_api import sync_playwright

    page_srv = PageServer(
        "<html><body><img id=i src='http://127.0.0.1:%d%s' "
        "onerror=\"document.title='done'\" onload=\"document.title='done'\"></body></html>"
        % (wb.port, target))
    try:
        with sync_playwright() as p:
            b = p.chromium.launch(executable_path=CHROMIUM, args=[
                "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
                "--disable-background-networking", "--disable-component-update"])
            try:
                ctx = b.new_context()
                page = ctx.new_page()
                page.goto(f"http://127.0.0.1:{wb.port}/?token={wb.token}", timeout=60_000)
                page.goto(f"http://127.0.0.1:{page_srv.port}/", timeout=60_000)
                page.wait_for_function("document.title === 'done'", timeout=HANG_S * 1000)
                cookies = [c["name"] for c in ctx.cookies()]
            finally:
                b.close()
    finally:
        page_srv.close()
    return 0, f"page loaded; cookies {cookies}" + wb.new_log()


# ----------------------------------------------------------------------------------------
# the class

class Kit:
    """The workbench class's workspace, server and case builders."""

    def __init__(self, root: Path) -> None:
        self.base = root / "wb"
        self.ws, self.outside = self.base / "ws", self.base / "elsewhere"  # no LEAK word
        self.wb = Workbench(self.ws)
        self.secret_d3 = self.outside / "secret_d3.txt"

    def folder(self, name: str, *, data: bool = True, template: bool = True) -> Path:
        """A test folder of the workspace (a small D3 file, the template)."""
        d = self.ws / name
        d.mkdir(parents=True, exist_ok=True)
        if data and not (d / "run_d3.txt").exists():
            write_d3(d / "run_d3.txt")
        if template and not (d / "template.yaml").exists():
            (d / "template.yaml").write_text(TEMPLATE)
        return d

    @staticmethod
    def link(path: Path, target: Path) -> None:
        path.parent.mkdir(parents=True, exist_ok=True)
        if not path.is_symlink():
            path.symlink_to(target)

    def http(self, name: str, method: str, path: str, setup: Callable[[], object] = lambda: None,
             body: bytes | None = None, headers: dict | None = None, **kw) -> Case:
        """A case: one request to the workbench after ``setup``."""
        case = Case("workbench", name, [], **kw)
        case.prepare = lambda: (self.wb.ensure(), setup())
        case.request = lambda: self.wb.request(method, path, body, headers=headers)
        return case


#: A refusal or a listing naming what was left out.
LEAK = r"outside|symlink|left out|skipped|not listed|refused"


def workbench(root: Path, rng: np.random.Generator) -> Iterator[Case]:
    """Symlinks out of the workspace, serve / and ~, GET writes, cross-port POST, bad input."""
    kit = Kit(root)
    yield from _symlinks(kit)
    yield from _serve_root(kit)
    yield from _writes(kit, rng)
    yield from _bad_requests(kit)
    yield from _odd_folders(kit, rng)


def _symlinks(kit: Kit) -> Iterator[Case]:
    """A data file, template.yaml, qa/ or a test folder linked outside the workspace."""
    ws, outside, secret_d3, link, folder = (kit.ws, kit.outside, kit.secret_d3, kit.link,
                                            kit.folder)

    def s_data():
        folder("link_data", data=False)
        write_outside_d3(secret_d3)
        link(ws / "link_data" / "run_d3.txt", secret_d3)
    yield kit.http("symlinked data file: GET /api/test", "GET", "/api/test?dir=link_data",
                   s_data, expect="ok", must=LEAK, refusal_must=LEAK, breach=_marked)
    yield kit.http("symlinked data file: GET /api/channel", "GET",
                   f"/api/channel?dir=link_data&file=run_d3.txt&raw={MARK_CHANNEL}", s_data,
                   refusal_must=LEAK, breach=_marked)
    yield kit.http("symlinked data file: POST /api/template (imports it)", "POST",
                   "/api/template?dir=link_data", s_data, body=b"{}", expect="ok",
                   must=LEAK, refusal_must=LEAK, breach=lambda text: _marked(text) or (
                       ws / "link_data" / "qa" / "validated.parquet").exists())

    def s_mixed():
        folder("link_mixed")
        write_outside_d3(secret_d3)
        link(ws / "link_mixed" / "other_d3.txt", secret_d3)
    yield kit.http("a symlinked file beside a real one: GET /api/test (listing)", "GET",
                   "/api/test?dir=link_mixed", s_mixed, expect="ok", must=LEAK,
                   refusal_must=LEAK, breach=_marked)

    # an outside YAML file whose key (valid YAML) or line (invalid) an error would show
    for k, body in enumerate([f"template_version: 1\n{MARK_CHANNEL}_key: 1\nfiles: []\n",
                              f"{MARK_CHANNEL}_key: [1,\n  other: ]]\n"]):
        name = f"link_tpl{k}"

        def s_tpl(name=name, body=body):
            folder(name, template=False)
            (outside / f"tpl{k}.yaml").parent.mkdir(parents=True, exist_ok=True)
            (outside / f"tpl{k}.yaml").write_text(body)
            link(ws / name / "template.yaml", outside / f"tpl{k}.yaml")
        for method, path in (("GET", f"/api/test?dir={name}"), ("POST", f"/api/run?dir={name}")):
            yield kit.http(f"template.yaml linked outside ({'valid' if k == 0 else 'invalid'} "
                           f"YAML): {method} {path.split('?')[0]}", method, path, s_tpl,
                           body=b"{}" if method == "POST" else None, expect="ok", must=LEAK,
                           refusal_must=LEAK, breach=_marked)

    qa_out = outside / "qa_out"

    def s_qa():
        folder("link_qa")
        qa_out.mkdir(parents=True, exist_ok=True)
        (qa_out / "findings.json").write_text(json.dumps({"findings": [
            {"kind": "x", "severity": "error", "signal": MARK_CHANNEL,
             "message": MARK_CHANNEL}]}))
        link(ws / "link_qa" / "qa", qa_out)
    yield kit.http("qa/ linked outside: GET /api/test", "GET", "/api/test?dir=link_qa", s_qa,
                   expect="ok", must=LEAK, refusal_must=LEAK, breach=_marked)
    yield kit.http("qa/ linked outside: POST /api/run (writes there)", "POST",
                   "/api/run?dir=link_qa", s_qa, body=b"{}", expect="ok", must=LEAK,
                   refusal_must=LEAK, breach=lambda text: _marked(text) or any(
                       p.name != "findings.json" for p in qa_out.iterdir()))

    def s_dir():
        write_outside_d3(outside / "folder" / "run_d3.txt")
        (outside / "folder" / "template.yaml").write_text(TEMPLATE)
        link(ws / "link_dir", outside / "folder")
    yield kit.http("a test folder linked outside: GET /api/test", "GET",
                   "/api/test?dir=link_dir", s_dir, refusal_must=LEAK, breach=_marked)


def _serve_root(kit: Kit) -> Iterator[Case]:
    """``vehval serve`` over the filesystem root or the home folder: refused."""
    base = kit.base
    home = base / "hm"  # the refusal must say "home", not echo the path
    for what, target, env in (("/", "/", {}), ("//", "//", {}),
                              ("a symlink to /", base / "rl", {}),
                              ("the home folder", home, {"HOME": str(home)}),
                              ("the home folder with a trailing slash", f"{home}/",
                               {"HOME": str(home)})):
        case = Case("workbench", f"vehval serve {what}", [], refusal_must=r"root|home|whole|"
                    r"filesystem|too broad", breach=lambda text: "open: http" in text)

        def prep():
            home.mkdir(parents=True, exist_ok=True)
            kit.link(base / "rl", Path("/"))
        case.prepare = prep
        case.request = lambda target=target, env=env: start_serve(
            [target], log=base / "serve_root.log", keep=False, env=env)[:2]
        yield case


def _writes(kit: Kit, rng: np.random.Generator) -> Iterator[Case]:
    """A GET that writes (directly, and from a page on another port), a POST from another
    origin (with the page's CSRF value)."""
    ws, wb, folder = kit.ws, kit.wb, kit.folder
    yield kit.http("GET /api/signal before QA has run (writes qa/?)", "GET",
                   "/api/signal?dir=gw&name=veh_spd_test", lambda: folder("gw"), expect="ok",
                   breach=lambda text: (ws / "gw" / "qa").exists())
    target = "/api/signal?dir=gw_img&name=veh_spd_test"
    if chromium_ok():
        case = Case("workbench", "a page on another port: <img> at /api/signal (Chromium)", [],
                    expect="ok", breach=lambda text: (ws / "gw_img" / "qa").exists())
        case.prepare = lambda: (wb.ensure(), folder("gw_img"))
        case.request = lambda: cross_port_img(wb, target)
    else:
        case = kit.http("a page on another port: GET /api/signal with the cookie (no "
                        "Chromium: a plain cross-port request)", "GET", target,
                        lambda: folder("gw_img"), expect="ok",
                        breach=lambda text: (ws / "gw_img" / "qa").exists())
        case.request = lambda: wb.request("GET", target, token=False, headers={
            "Cookie": f"vehval_workbench={wb.token}",
            "Referer": f"http://127.0.0.1:{wb.port + 1}/", "Sec-Fetch-Site": "same-site"})
    yield case
    other = int(rng.integers(1025, 65000))
    for k, origin in enumerate([f"http://127.0.0.1:{other}", f"http://localhost:{other}",
                                "https://127.0.0.1:{port}", "http://127.0.0.1"]):
        name = f"po{k}"
        case = kit.http(f"POST /api/run from origin {origin.replace('{port}', 'PORT')}",
                        "POST", f"/api/run?dir={name}", lambda name=name: folder(name),
                        body=b"{}", refusal_must=r"origin",
                        breach=lambda text, name=name: (ws / name / "qa").exists())
        case.request = lambda name=name, origin=origin: wb.request(
            "POST", f"/api/run?dir={name}", b"{}",
            headers={"Origin": origin.replace("{port}", str(wb.port))})
        yield case


def _bad_requests(kit: Kit) -> Iterator[Case]:
    """Query parameters and bodies of the wrong type or value: a 4xx naming them."""
    ws, wb, http_case, folder = kit.ws, kit.wb, kit.http, kit.folder
    def ready():
        folder("bad")
        if not (ws / "bad" / "qa" / "findings.json").is_file():
            wb.request("POST", "/api/run?dir=bad", b"{}")
    chan = "/api/channel?dir=bad&file=run_d3.txt&raw=Dyno_Speed"
    for q in ("n=nan", "n=inf", "n=-inf", "n=abc", "t0=nan&t1=1", "t0=inf&t1=-inf"):
        key = q.split("=")[0]
        yield http_case(f"GET /api/channel {q}", "GET", f"{chan}&{q}", ready,
                        refusal_must=rf"\b{key}\b")
    for q in ("n=1e300", "n=-1"):  # finite: refused, or answered within bounds
        yield http_case(f"GET /api/channel {q}", "GET", f"{chan}&{q}", ready, expect="ok",
                        refusal_must=r"\bn\b")
    yield http_case("GET /api/signal n=nan", "GET",
                    "/api/signal?dir=bad&name=veh_spd_test&n=nan", ready,
                    refusal_must=r"\bn\b")
    bodies = {
        'channels = "x"': (b'{"channels": "x"}', "channels"),
        "channels = 5": (b'{"channels": 5}', "channels"),
        "channels = [1, 2]": (b'{"channels": [1, 2]}', "channels"),
        "channel raw = 5": (b'{"channels": [{"file": 0, "raw": 5, "unit": []}]}',
                            "raw|unit|channels"),
        "sources = [1]": (b'{"sources": [1]}', "sources"),
        "fuel = {}": (b'{"fuel": {"a": 1}}', "fuel"),
        "channels = NaN": (b'{"channels": NaN}', "channels|nan|json"),
        "fuel = 1e999": (b'{"fuel": 1e999}', "fuel|json|finite"),
        "a list body": (b"[1, 2]", "body|object|mapping|json"),
        "a string body": (b'"x"', "body|object|mapping|json"),
        "JSON nested 100,000 deep": (b"[" * 100_000 + b"]" * 100_000, "deep|nest|json"),
        "a mapping nested 100,000 deep": (b'{"a":' * 100_000 + b"1" + b"}" * 100_000,
                                          "deep|nest|json"),
    }
    for what, (body, key) in bodies.items():
        yield http_case(f"POST /api/template {what}", "POST", "/api/template?dir=bad", ready,
                        body=body, refusal_must=key)
    yield http_case("POST /api/selection action = [keep], signal = 5", "POST",
                    "/api/selection?dir=bad", ready,
                    body=b'{"signal": 5, "action": ["keep"]}', refusal_must=r"action|signal")


def _odd_folders(kit: Kit, rng: np.random.Generator) -> Iterator[Case]:
    """An empty folder, the workspace root, symlink loops, a folder of 3,000 files."""
    ws, http_case, folder = kit.ws, kit.http, kit.folder
    empty_must = r"no (raw |data )?(data )?files?|empty|nothing|no test"
    yield http_case("GET /api/test of an empty folder", "GET", "/api/test?dir=empty",
                    lambda: (ws / "empty").mkdir(parents=True, exist_ok=True), expect="ok",
                    must=empty_must, refusal_must=empty_must)
    yield http_case("GET /api/test of the workspace root", "GET", "/api/test?dir=.",
                    lambda: folder("bad"), expect="ok", must=empty_must,
                    refusal_must=empty_must)

    def loops():
        if not (ws / "loop").is_symlink():
            (ws / "loop").symlink_to(ws / "loop")
        (ws / "la").mkdir(parents=True, exist_ok=True)
        if not (ws / "la" / "lb").is_symlink():
            (ws / "la" / "lb").symlink_to(ws / "la")
    yield http_case("GET /api/test of a self symlink", "GET", "/api/test?dir=loop", loops,
                    refusal_must=r"loop|symlink|not found|not a folder")
    yield http_case("GET /api/test of a two-folder loop, 40 deep", "GET",
                    "/api/test?dir=" + quote("la/" + "lb/" * 40), loops, expect="ok",
                    refusal_must=r"loop|symlink|deep|long")
    yield http_case("GET / (home listing) with symlink loops", "GET", "/", loops, expect="ok",
                    must=r"<html")
    n = 3000

    def many():
        d = ws / "many"
        if (d / f"f{n - 1:04d}.txt").is_file():
            return
        d.mkdir(parents=True, exist_ok=True)
        vals = rng.normal(size=n)
        for i in range(n):
            (d / f"f{i:04d}.txt").write_text(f"Time[s]\tX[V]\n0\t{vals[i]:.4f}\n1\t0\n")
    yield http_case("GET /api/test of a folder of 3,000 files", "GET", "/api/test?dir=many",
                    many, expect="ok", refusal_must=r"files|too many")
    yield http_case("GET / (home listing) with a folder of 3,000 files", "GET", "/", many,
                    expect="ok", must=r"<html")
    yield http_case("GET /test page of a folder of 3,000 files", "GET", "/test?dir=many",
                    many, expect="ok", must=r"<html")
