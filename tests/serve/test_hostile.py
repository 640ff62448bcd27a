"""The workbench against hostile or careless input, over real HTTP (a server on a free port).

Symlinks out of the workspace (data, template, qa/), loops, special files, a folder of 3,000
files, an empty folder, the workspace root as a test; the filesystem root or the home folder
as the workspace; a GET that would run QA; a POST from another local port; query parameters
and bodies of the wrong type, out of range, too large or nested 100,000 deep. Every case gets
a 2xx, 403, 409 or another 4xx with a message: never a 500, never a byte of the outside file.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path
from urllib.parse import urlsplit

import pytest

pytest.importorskip("uvicorn")
httpx = pytest.importorskip("httpx2")

import vehval  # noqa: E402
from vehval.cli import main  # noqa: E402
from vehval.serve.app import create_app, start  # noqa: E402

from .helpers import FUEL_COLUMN  # noqa: E402

pytestmark = pytest.mark.skipif(not hasattr(os, "symlink"), reason="no symlinks")

SRC = Path(vehval.__file__).resolve().parents[1]  # the vehval under test
SECRET_CHANNEL = "SecretChannelOutside"
SECRET_KEY = "secret_key_outside"
SECRET_FINDING = "SECRET FINDING FROM OUTSIDE"


class Server:
    """``vehval.serve.app.start`` on a free port, and an HTTP client holding the token."""

    def __init__(self, ws: Path) -> None:
        self.running = start(ws)
        wb = self.running.app.state.workbench
        self.origin = "{0.scheme}://{0.netloc}".format(urlsplit(self.running.url))
        self.csrf = wb.csrf
        self.http = httpx.Client(base_url=self.origin, timeout=300,
                                 headers={"X-Vehval-Token": wb.token})

    def get(self, path: str, **params):
        return self.http.get(path, params=params)

    def post(self, path: str, body=None, *, content: bytes | None = None, headers=None, **params):
        h = {"X-CSRF-Token": self.csrf, "Origin": self.origin, **(headers or {})}
        if content is not None:
            return self.http.post(path, params=params, content=content,
                                  headers={**h, "Content-Type": "application/json"})
        return self.http.post(path, params=params, json={} if body is None else body, headers=h)

    def close(self) -> None:
        self.http.close()
        self.running.stop()


@pytest.fixture()
def serve():
    servers: list[Server] = []

    def _start(ws: Path) -> Server:
        servers.append(Server(ws))
        return servers[-1]
    yield _start
    for s in servers:
        s.close()


def _csv(path: Path, chan: str = "Speed") -> Path:
    path.write_text(f"Time[s],{chan}[km/h]\n0,0\n1,42\n2,43\n", encoding="utf-8")
    return path


@pytest.fixture()
def outside(tmp_path) -> Path:
    """A folder beside the workspace: a data file, a template and QA outputs of its own."""
    out = tmp_path / "outside"
    (out / "qa").mkdir(parents=True)
    _csv(out / "data.csv", SECRET_CHANNEL)
    (out / "template.yaml").write_text(f"{SECRET_KEY}: 1\nfiles: 3\n", encoding="utf-8")
    (out / "qa" / "findings.json").write_text(json.dumps(
        {"findings": [{"kind": "unit", "severity": "error", "signal": "x",
                       "message": SECRET_FINDING}], "summary": None}), encoding="utf-8")
    return out


def _no_leak(r, *secrets: str) -> None:
    assert r.status_code < 500, r.text
    for s in secrets:
        assert s not in r.text


# --------------------------------------------------------------------------- symlinks out
def test_data_file_linked_outside_is_never_read(serve, tmp_path, outside):
    ws = tmp_path / "ws"
    (ws / "t").mkdir(parents=True)
    (ws / "t" / "run.csv").symlink_to(outside / "data.csv")
    s = serve(ws)
    r = s.get("/api/test", dir="t")
    _no_leak(r, SECRET_CHANNEL)
    assert {"name": "run.csv", "why": "links outside the workspace"} in r.json()["left_out"]
    r = s.get("/api/channel", dir="t", file="run.csv", raw=SECRET_CHANNEL)
    assert r.status_code == 403 and "outside the workspace" in r.json()["error"]
    _no_leak(r, "42")
    r = s.post("/api/template", {"fuel": "gasoline_e0"}, dir="t")
    _no_leak(r, SECRET_CHANNEL)
    assert r.status_code == 400 and "run.csv: links outside the workspace" in r.json()["error"]
    assert not (ws / "t" / "qa").exists()  # nothing imported from outside
    home = s.get("/")
    assert home.status_code == 200 and "t/run.csv" in home.text and "links outside" in home.text


def test_template_linked_outside_is_refused_without_its_content(serve, tmp_path, outside):
    ws = tmp_path / "ws"
    (ws / "t").mkdir(parents=True)
    _csv(ws / "t" / "run.csv")
    (ws / "t" / "template.yaml").symlink_to(outside / "template.yaml")
    s = serve(ws)
    for r in (s.get("/api/test", dir="t"), s.post("/api/template", {"fuel": ""}, dir="t"),
              s.post("/api/run", dir="t"), s.post("/api/selection", {"signal": "a",
                                                                      "action": "keep"}, dir="t")):
        assert r.status_code == 403, r.text
        assert "template.yaml: links outside the workspace" in r.json()["error"]
        _no_leak(r, SECRET_KEY)
    assert (outside / "template.yaml").read_text(encoding="utf-8").startswith(SECRET_KEY)


def test_qa_folder_linked_outside_is_not_read(serve, tmp_path, outside):
    ws = tmp_path / "ws"
    (ws / "t").mkdir(parents=True)
    _csv(ws / "t" / "run.csv")
    (ws / "t" / "qa").symlink_to(outside / "qa")
    s = serve(ws)
    r = s.get("/api/test", dir="t")
    _no_leak(r, SECRET_FINDING)
    assert "qa: a symlink" in r.json()["error"]
    assert ">done<" not in s.get("/").text
    r = s.post("/api/template", {}, dir="t")  # saved; QA never writes through the link
    _no_leak(r, SECRET_FINDING)
    assert (ws / "t" / "template.yaml").is_file() and "qa: a symlink" in r.json()["error"]
    assert sorted(p.name for p in (outside / "qa").iterdir()) == ["findings.json"]


def test_loop_fifo_empty_root_and_3000_files_give_no_500(serve, tmp_path):
    ws = tmp_path / "ws"
    for d in ("empty", "loop", "big", "special"):
        (ws / d).mkdir(parents=True)
    (ws / "loop" / "a.csv").symlink_to(ws / "loop" / "b.csv")
    (ws / "loop" / "b.csv").symlink_to(ws / "loop" / "a.csv")
    (ws / "deadlink").symlink_to(ws / "missing")
    (ws / "selfdir").symlink_to(ws)  # a folder linking to the workspace: listed once
    for i in range(3000):
        _csv(ws / "big" / f"f{i:04d}.csv")
    _csv(ws / "special" / "run.csv")
    if hasattr(os, "mkfifo"):
        os.mkfifo(ws / "special" / "pipe.csv")
    s = serve(ws)
    r = s.get("/api/test", dir="empty")
    assert r.status_code == 200 and "no raw data file" in r.json()["error"]
    r = s.get("/api/test", dir=".")  # the workspace root as a test: it holds no data file
    assert r.status_code == 200 and "no raw data file" in r.json()["error"]
    r = s.get("/api/test", dir="loop")
    assert r.status_code == 200 and "a.csv: symlink loop" in r.json()["error"]
    assert s.get("/api/test", dir="loop/a.csv").status_code == 400  # a loop as the folder
    r = s.get("/api/test", dir="big")
    m = r.json()
    assert r.status_code == 200 and m["error"] is None, r.text
    assert len(m["files"]) == 64  # bounded, and said so
    assert any(x["name"] == "(2,936 more data files)" and "too many files" in x["why"]
               for x in m["left_out"])
    if hasattr(os, "mkfifo"):
        r = s.get("/api/test", dir="special")
        assert r.status_code == 200 and r.json()["error"] is None
        assert {"name": "pipe.csv", "why": "not a regular file (a FIFO, device or socket)"} \
            in r.json()["left_out"]
        assert s.get("/api/channel", dir="special", file="pipe.csv", raw="x").status_code == 400
    home = s.get("/")
    assert home.status_code == 200
    assert "loop/a.csv" in home.text and "deadlink" in home.text and "broken symlink" in home.text
    assert home.text.count('href="/test?dir=big"') == 1  # not again through selfdir/


# --------------------------------------------------------------------------- workspaces refused
def _serve_cli(args: list[str], env: dict | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "vehval", "serve", *args, "--port", "0",
                           "--no-browser"], capture_output=True, text=True, timeout=60,
                          env=dict(os.environ, PYTHONPATH=os.pathsep.join([str(SRC), *sys.path]),
                                   **(env or {})))


def test_filesystem_root_is_refused_as_workspace():
    proc = _serve_cli(["/"])
    assert proc.returncode == 2, proc.stdout
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("vehval: error: /: the filesystem root")
    assert "open:" not in proc.stdout


def test_home_directory_is_refused_as_workspace(tmp_path, monkeypatch, capsys):
    home = tmp_path / "home"
    (home / "tests").mkdir(parents=True)
    proc = _serve_cli([str(home)], env={"HOME": str(home)})
    assert proc.returncode == 2 and "home directory" in proc.stderr, proc.stderr
    monkeypatch.setenv("HOME", str(home))
    assert main(["serve", str(tmp_path), "--no-browser"]) == 2  # a folder holding it
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "holding your home directory" in err
    create_app(home / "tests")  # a folder inside the home directory is a workspace


# --------------------------------------------------------------------------- no GET writes
def test_get_signal_never_runs_qa(serve, workspace):
    s = serve(workspace)
    r = s.get("/api/signal", dir="virtual", name="veh_spd_test")
    assert r.status_code == 409 and "POST /api/run" in r.json()["error"], r.text
    assert not (workspace / "virtual" / "qa").exists()
    for path, params in (("/api/test", {}), ("/api/channel", {"file": "run_d3.txt",
                                                              "raw": FUEL_COLUMN})):
        assert s.get(path, dir="virtual", **params).status_code == 200
    assert s.get("/test", dir="virtual").status_code == 200
    assert not (workspace / "virtual" / "qa").exists()
    # the page's flow: POST the run, then GET the signal
    assert s.post("/api/run", dir="virtual").status_code == 200
    r = s.get("/api/signal", dir="virtual", name="veh_spd_test", n=100)
    assert r.status_code == 200 and r.json()["unit"] == "m/s" and len(r.json()["t"]) <= 100


def test_writes_only_from_the_same_scheme_host_and_port(serve, tmp_path):
    ws = tmp_path / "ws"
    (ws / "t").mkdir(parents=True)
    s = serve(ws)
    port = urlsplit(s.origin).port
    for origin in (f"http://127.0.0.1:{port + 1 if port < 65535 else port - 1}",
                   f"https://127.0.0.1:{port}", "http://localhost:" + str(port), "null",
                   "http://127.0.0.1"):
        r = s.post("/api/run", dir="t", headers={"Origin": origin})
        assert r.status_code == 403 and "another origin" in r.json()["error"], origin
    assert s.post("/api/run", dir="t").status_code == 200  # its own origin
    # a page of another local port (an <img>, a fetch) gets nothing from the API
    r = s.http.get("/api/test", params={"dir": "t"}, headers={"Sec-Fetch-Site": "same-site"})
    assert r.status_code == 403
    assert s.http.get("/api/test", params={"dir": "t"},
                      headers={"Sec-Fetch-Site": "same-origin"}).status_code == 200


# --------------------------------------------------------------------------- typed requests
@pytest.fixture()
def small(serve, tmp_path):
    ws = tmp_path / "ws"
    (ws / "t").mkdir(parents=True)
    _csv(ws / "t" / "run.csv")
    return serve(ws)


@pytest.mark.parametrize("n", ["nan", "inf", "-inf", "-5", "0", "1e300", "99999999", "abc", ""])
def test_bad_n_is_a_400_naming_it(small, n):
    r = small.get("/api/channel", dir="t", file="run.csv", raw="Speed", n=n)
    assert r.status_code == 400 and r.json()["error"].startswith("bad query: n: "), r.text


@pytest.mark.parametrize("params, word", [
    ({"t0": "nan"}, "t0"), ({"t1": "inf"}, "t1"), ({"t0": "5", "t1": "1"}, "after"),
    ({"raw": None}, "raw: required"), ({"file": None}, "file: required"),
    ({"bogus": "1"}, "bogus: unknown key"), ({"file": "a\x00b"}, "not a data file"),
    ({"file": "../run.csv"}, "not a data file")])
def test_bad_query_is_a_400_naming_it(small, params, word):
    q = {"dir": "t", "file": "run.csv", "raw": "Speed", **params}
    r = small.get("/api/channel", **{k: v for k, v in q.items() if v is not None})
    assert r.status_code == 400 and word in r.json()["error"], r.text
    r = small.http.get("/api/test?dir=t&dir=u")
    assert r.status_code == 400 and "dir: given twice" in r.json()["error"]


@pytest.mark.parametrize("body, word", [
    ({"channels": "abc"}, "channels: Input should be a valid list"),
    ({"channels": [1, 2]}, "channels[0]"), ({"channels": {"file": 0}}, "channels"),
    ({"channels": [{"file": "0", "raw": "Speed"}]}, "channels[0].file"),
    ({"channels": [{"file": 0}]}, "channels[0].raw: required"),
    ({"channels": [{"file": 0, "raw": "Speed", "delete": "yes"}]}, "channels[0].delete"),
    ({"sources": ["dyno"]}, "sources"), ({"fuel": 3}, "fuel"), ({"fule": "e10"}, "fule"),
])
def test_bad_template_body_is_a_400_naming_the_key(small, body, word):
    r = small.post("/api/template", body, dir="t")
    assert r.status_code == 400 and word in r.json()["error"], r.text
    assert not (small.running.app.state.workbench.root / "t" / "template.yaml").exists()


def test_bad_bodies_are_4xx(small):
    deep = b"[" * 100_000 + b"]" * 100_000
    for content, status, word in (
            (deep, 400, "deeper than"), (b'{"a":' * 100_000 + b"1" + b"}" * 100_000, 400, "deeper"),
            (b"[1, 2]", 400, "JSON object"), (b"{not json", 400, "not JSON"),
            (b'{"fuel": "' + b"x" * (2 << 20) + b'"}', 413, "bytes")):
        r = small.post("/api/template", content=content, dir="t")
        assert r.status_code == status and word in r.json()["error"], r.text[:200]
    for body, word in (({}, "action: required"), ({"action": "keep"}, "signal: required"),
                       ({"signal": "x", "action": "explode"}, "action")):
        r = small.post("/api/selection", body, dir="t")
        assert r.status_code == 400 and word in r.json()["error"], r.text
    r = small.post("/api/run", {"force": True}, dir="t")
    assert r.status_code == 400 and "force: unknown key" in r.json()["error"]
    # a deep string is text, not nesting
    r = small.post("/api/template", content=json.dumps({"fuel": "[" * 1000}).encode(), dir="t")
    assert r.status_code != 400 or "deeper" not in r.json()["error"]


def test_catalog_queries_are_typed(small):
    for params, word in (({}, "db: required"), ({"db": "x.duckdb"}, "not found"),
                         ({"db": "t/run.csv", "nope": "1"}, "nope: unknown key")):
        r = small.get("/api/catalog", **params)
        assert 400 <= r.status_code < 500 and word in r.json()["error"], r.text
    r = small.get("/api/catalog/trace", db="t/run.csv", test="a", axis="sideways")
    assert r.status_code == 400 and "axis" in r.json()["error"]
