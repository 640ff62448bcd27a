"""The workbench's guards: token, CSRF, host, content policy, workspace-only paths."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

pytest.importorskip("starlette")
pytest.importorskip("httpx2")
from starlette.testclient import TestClient  # noqa: E402

from vehval.serve.app import create_app  # noqa: E402
from vehval.serve.security import OutsideWorkspace, host_allowed, inside_workspace  # noqa: E402

BASE = "http://127.0.0.1"


@pytest.fixture()
def ws(tmp_path) -> Path:
    root = tmp_path / "ws"
    (root / "t1").mkdir(parents=True)
    (root / "t1" / "run.csv").write_text("Time[s],Speed[km/h]\n0,0\n1,1\n", encoding="utf-8")
    (tmp_path / "secret.txt").write_text("outside", encoding="utf-8")
    return root


@pytest.fixture()
def app(ws):
    return create_app(ws)


def _authed(app, **headers) -> TestClient:
    wb = app.state.workbench
    return TestClient(app, base_url=BASE, headers={"X-Vehval-Token": wb.token, **headers})


def test_no_token_is_403(app):
    c = TestClient(app, base_url=BASE)
    for path in ("/", "/api/test?dir=t1", "/static/workbench.js", "/files/t1/run.csv"):
        r = c.get(path)
        assert r.status_code == 403, path
        assert "token" in r.json()["error"]
    assert c.get("/?token=wrong").status_code == 403


def test_token_in_url_becomes_a_cookie(app):
    c = TestClient(app, base_url=BASE)
    r = c.get(f"/test?dir=t1&token={app.state.workbench.token}", follow_redirects=False)
    assert r.status_code == 303 and r.headers["location"] == "/test?dir=t1"
    cookie = r.headers["set-cookie"]
    assert "HttpOnly" in cookie and "SameSite=strict" in cookie.replace("Strict", "strict")
    assert c.get("/").status_code == 200  # the cookie is enough now


def test_pages_carry_the_policy(app):
    r = _authed(app).get("/")
    csp = r.headers["content-security-policy"]
    assert "default-src 'none'" in csp and "script-src 'self'" in csp
    assert "connect-src 'self'" in csp and "unsafe-eval" not in csp and "http" not in csp
    assert r.headers["x-content-type-options"] == "nosniff"


@pytest.mark.parametrize("rel", ["..", "../secret.txt", "/etc/passwd", "t1/../../secret.txt",
                                 "C:/Windows", "t1/\x00x"])
def test_paths_outside_the_workspace_are_refused(app, rel):
    c = _authed(app)
    r = c.get("/api/test", params={"dir": rel})
    assert r.status_code == 403, r.text
    assert "workspace" in r.json()["error"] or "path" in r.json()["error"]


def test_files_route_stays_inside(app, ws):
    c = _authed(app)
    assert c.get("/files/t1/run.csv").status_code == 200
    assert c.get("/files/%2E%2E/secret.txt").status_code in (403, 404)
    r = c.get("/files/..%2Fsecret.txt")
    assert r.status_code in (403, 404) and "outside" not in r.text.replace("outside the", "")


def test_files_are_streamed_and_a_huge_page_refused(app, ws, monkeypatch):
    """A workspace file is streamed from disk; a report page above the limit is a 413 naming
    the file, never read into memory whole."""
    import vehval.serve.params as prm

    c = _authed(app)
    data = (ws / "t1" / "run.csv").read_bytes()
    r = c.get("/files/t1/run.csv")
    assert r.status_code == 200 and r.content == data
    (ws / "t1" / "big.html").write_text("<p>" + "x" * 4096, encoding="utf-8")
    monkeypatch.setattr(prm, "MAX_PAGE_BYTES", 1024)
    r = c.get("/files/t1/big.html")
    assert r.status_code == 413 and "t1/big.html" in r.json()["error"]
    monkeypatch.setattr(prm, "MAX_PAGE_BYTES", 1 << 20)
    assert c.get("/files/t1/big.html").status_code == 200


@pytest.mark.skipif(not hasattr(os, "symlink"), reason="no symlinks")
def test_symlink_out_of_the_workspace_is_refused(app, ws, tmp_path):
    (ws / "link").symlink_to(tmp_path)
    c = _authed(app)
    assert c.get("/files/link/secret.txt").status_code == 403
    assert c.get("/api/test", params={"dir": "link"}).status_code == 403


def test_write_without_csrf_is_refused(app):
    c = _authed(app)
    r = c.post("/api/run", params={"dir": "t1"}, json={})
    assert r.status_code == 403 and "CSRF" in r.json()["error"]
    r = c.post("/api/run", params={"dir": "t1"}, json={}, headers={"X-CSRF-Token": "guess"})
    assert r.status_code == 403
    # the right value from another origin is refused too
    r = c.post("/api/run", params={"dir": "t1"}, json={},
               headers={"X-CSRF-Token": app.state.workbench.csrf, "Origin": "http://evil.example"})
    assert r.status_code == 403 and "origin" in r.json()["error"]


def test_csrf_value_is_in_the_page_not_the_token(app):
    wb = app.state.workbench
    html = _authed(app).get("/test?dir=t1").text
    assert f'name="vehval-csrf" content="{wb.csrf}"' in html
    assert wb.token not in html


def test_foreign_host_is_refused(app):
    c = TestClient(app, base_url="http://rebind.example:8890",
                   headers={"X-Vehval-Token": app.state.workbench.token})
    assert c.get("/").status_code == 403


def test_host_allowed():
    assert host_allowed("127.0.0.1:8890") and host_allowed("localhost") and host_allowed("[::1]:80")
    assert not host_allowed("127.0.0.1.evil.example:80") and not host_allowed(None)


def test_inside_workspace(tmp_path):
    root = tmp_path.resolve()
    (root / "a").mkdir()
    assert inside_workspace(root, "a") == root / "a"
    assert inside_workspace(root, ".") == root
    with pytest.raises(OutsideWorkspace):
        inside_workspace(root, "../a")
    with pytest.raises(OutsideWorkspace):
        inside_workspace(root, str(root / "a"))  # absolute, even when inside


def test_workspace_html_runs_sandboxed(app, ws):
    (ws / "t1" / "page.html").write_text("<script>fetch('/api/test?dir=t1')</script>", encoding="utf-8")
    (ws / "t1" / "x.js").write_text("alert(1)", encoding="utf-8")
    c = _authed(app)
    r = c.get("/files/t1/page.html")
    assert r.status_code == 200 and "sandbox allow-scripts" in r.headers["content-security-policy"]
    assert "allow-same-origin" not in r.headers["content-security-policy"]
    assert c.get("/files/t1/x.js").status_code == 404  # no script of the workspace is served
    # plotly.js alone is public (a sandboxed report loads it without the cookie)
    anon = TestClient(app, base_url=BASE)
    assert anon.get("/static/plotly.min.js").status_code == 200
    assert anon.get("/static/workbench.js").status_code == 403
