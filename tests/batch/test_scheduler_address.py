"""`batch --scheduler` checks the address before anything runs: a server that is not a Dask
scheduler (garbage, or silence) is refused in one line naming the address, within the probe's
timeout and before any output is written. Servers listen on 127.0.0.1 only."""

from __future__ import annotations

import logging
import socket
import threading
import time

import pytest

from vehval.batch.scheduler import check_scheduler
from vehval.cli import main
from vehval.errors import ConfigError

from .helpers import write_d3


class _Server:
    """A plain TCP server on 127.0.0.1 that sends ``greeting`` (None: nothing) to each
    connection and then holds it open until stopped."""

    def __init__(self, greeting: bytes | None):
        self.sock = socket.create_server(("127.0.0.1", 0))
        self.port = self.sock.getsockname()[1]
        self.greeting = greeting
        self.stop = threading.Event()
        self.conns: list[socket.socket] = []
        self.thread = threading.Thread(target=self._serve, daemon=True)
        self.thread.start()

    def _serve(self):
        self.sock.settimeout(0.1)
        while not self.stop.is_set():
            try:
                conn, _ = self.sock.accept()
            except TimeoutError:
                continue
            self.conns.append(conn)
            if self.greeting is not None:
                conn.sendall(self.greeting)

    def close(self):
        self.stop.set()
        self.thread.join()
        for c in self.conns:
            c.close()
        self.sock.close()


@pytest.fixture(params=["garbage", "silent"])
def not_dask(request):
    srv = _Server(b"SSH-2.0-OpenSSH_9.6\r\n" + bytes(range(256)) if request.param == "garbage"
                  else None)
    yield request.param, f"tcp://127.0.0.1:{srv.port}"
    srv.close()


def test_a_server_that_is_not_dask_is_refused_naming_the_address(not_dask, tmp_path, capsys):
    kind, address = not_dask
    inp, out = tmp_path / "in", tmp_path / "out"
    write_d3(inp / "t0" / "run0.txt", seed=0)
    tpl = tmp_path / "t.yaml"
    from .helpers import TEMPLATE
    tpl.write_text(TEMPLATE, encoding="utf-8")
    t0 = time.monotonic()
    rc = main(["batch", str(inp), "-t", str(tpl), "-o", str(out), "--scheduler", address,
               "--no-report", "-q"])
    took = time.monotonic() - t0
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1, err
    assert f"--scheduler '{address}'" in err[0] and "not a Dask scheduler" in err[0], err
    assert ("within 5 s" in err[0]) == (kind == "silent"), err
    assert took < 12, took                     # the probe's 5 s, not distributed's 15 s or more
    assert not out.exists()


@pytest.mark.parametrize("address, says", [
    ("tcp://127.0.0.1:notaport", "not a Dask scheduler address"),
    ("http://127.0.0.1:8786", "not a Dask scheduler address"),
    ("tcp://127.0.0.1:1", "cannot connect")])
def test_a_bad_or_closed_address_is_one_line(address, says):
    with pytest.raises(ConfigError, match=says) as err:
        check_scheduler(address, timeout_s=2.0)
    assert address in str(err.value)


def test_a_dask_scheduler_passes_the_check():
    from distributed import LocalCluster

    with LocalCluster(n_workers=0, processes=False, host="127.0.0.1", protocol="tcp://",
                      dashboard_address="127.0.0.1:0", silence_logs=logging.ERROR) as c:
        assert c.scheduler_address.startswith("tcp://127.0.0.1:")
        check_scheduler(c.scheduler_address)
        check_scheduler(c.scheduler_address.removeprefix("tcp://"))   # host:port
