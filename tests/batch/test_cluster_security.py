"""The batch's local Dask cluster is private: TLS with credentials made for it alone, no
dashboard unless asked for. A client without the credentials, or with another cluster's,
is refused; the batch's own client works."""

from __future__ import annotations

import pytest

from vehval.batch.runner import local_cluster, shutdown

pytestmark = pytest.mark.xdist_group("dask_cluster")


@pytest.fixture(scope="module")
def cluster():
    client, cl = local_cluster(1)
    yield client, cl
    shutdown(client, cl)


def test_scheduler_listens_on_loopback_tls_without_dashboard(cluster):
    client, cl = cluster
    assert cl.scheduler_address.startswith("tls://127.0.0.1:")
    assert client.submit(sum, [1, 2, 3]).result(timeout=60) == 6
    # the scheduler runs in this process: all it listens on is loopback
    import psutil
    listening = [c.laddr for c in psutil.Process().net_connections("tcp") if c.status == "LISTEN"]
    assert listening and all(a.ip == "127.0.0.1" for a in listening)
    # its HTTP server serves nothing without --dashboard
    from urllib.error import HTTPError
    from urllib.request import urlopen
    port = cl.scheduler.http_server.port
    for path in ("/status", "/info/main/workers.html", "/health", "/metrics"):
        with pytest.raises(HTTPError) as err:
            urlopen(f"http://127.0.0.1:{port}{path}", timeout=5)
        assert err.value.code == 404


def _identity(address: str, security=None) -> dict:
    """Connect at the comm level (no Client object left to the garbage collector) and ask
    the scheduler who it is."""
    import asyncio

    from distributed.comm import connect

    async def ask():
        args = security.get_connection_args("client") if security is not None else {}
        comm = await connect(address, timeout="5s", **args)
        try:
            await comm.write({"op": "identity"})
            return await comm.read()
        finally:
            comm.abort()

    return asyncio.run(ask())


def test_the_cluster_credentials_are_accepted(cluster):
    client, cl = cluster
    assert _identity(cl.scheduler_address, client.security)["type"] == "Scheduler"


def test_connection_without_credentials_is_refused(cluster):
    """A plain client (no TLS, no certificate): the scheduler drops the connection."""
    _, cl = cluster
    with pytest.raises(OSError):
        _identity(cl.scheduler_address.replace("tls://", "tcp://"))


def test_connection_with_foreign_credentials_is_refused(cluster):
    """TLS with a certificate of another authority: the handshake is refused."""
    from distributed import Security

    _, cl = cluster
    with pytest.raises(OSError):
        _identity(cl.scheduler_address, Security.temporary())


def test_dashboard_only_when_asked_for():
    client, cl = local_cluster(1, dashboard=True)
    try:
        from urllib.request import urlopen
        link = client.dashboard_link
        assert link.startswith("http://127.0.0.1:")
        assert urlopen(link.replace("/status", "/health"), timeout=10).status == 200
    finally:
        shutdown(client, cl)
