"""A ``--scheduler`` address checked before a batch hands it to ``dask.distributed``.

``distributed`` reads the first 8 bytes a server sends as the length of its first message
and allocates that many bytes: a server that is not a Dask scheduler (an HTTP server, an SSH
daemon) makes it ask for exabytes (``MemoryError``), and a server that accepts and says
nothing holds it for its whole connect timeout. A Dask scheduler speaks first: on every new
connection it sends its handshake, a message of a few hundred bytes naming its
``compression`` and ``pickle-protocol``. :func:`check_scheduler` connects with a timeout,
reads that handshake within the same timeout and refuses, naming the address, anything else.
"""

from __future__ import annotations

import socket
import struct
import time

from vehval.errors import ConfigError

#: [s] to connect and to receive the scheduler's handshake (a local or LAN scheduler answers
#: in milliseconds; a loaded one within a second)
PROBE_TIMEOUT_S = 5.0
#: [bytes] largest handshake accepted (Dask's is a few hundred bytes)
MAX_HANDSHAKE_BYTES = 64 * 1024
DEFAULT_PORT = 8786
_EXAMPLE = "e.g. tcp://127.0.0.1:8786"


def _host_port(address: str) -> tuple[str, str, int]:
    """(scheme, host, port) of ``tcp://host:port``, ``tls://host:port`` or ``host[:port]``."""
    scheme, sep, rest = address.partition("://")
    if not sep:
        scheme, rest = "tcp", address
    host, port = rest, str(DEFAULT_PORT)
    if rest.startswith("["):                       # [IPv6]:port
        host, _, tail = rest[1:].partition("]")
        port = tail[1:] if tail.startswith(":") else port
    elif rest.count(":") == 1:
        host, port = rest.split(":")
    if scheme not in ("tcp", "tls") or not host or not port.isdigit() or not 0 < int(port) < 65536:
        raise ConfigError(f"--scheduler '{address}': not a Dask scheduler address ({_EXAMPLE})")
    return scheme, host, int(port)


def _recv_exactly(sock: socket.socket, n: int, deadline: float) -> bytes:
    out = b""
    while len(out) < n:
        sock.settimeout(max(deadline - time.monotonic(), 0.01))
        chunk = sock.recv(n - len(out))
        if not chunk:
            raise ConnectionError("the server closed the connection")
        out += chunk
    return out


def check_scheduler(address: str, timeout_s: float = PROBE_TIMEOUT_S) -> None:
    """Refuse ``address`` in one line unless a Dask scheduler answers there within
    ``timeout_s`` [s]: connect, then (``tcp://``) receive its handshake. A ``tls://``
    scheduler is only connected to (its handshake needs the cluster's certificates).

    Raises
    ------
    ConfigError
        Not an address, nothing listening, no answer in time, or an answer that is not a
        Dask handshake; the line names the address.
    """
    scheme, host, port = _host_port(address)
    where = f"--scheduler '{address}'"
    deadline = time.monotonic() + timeout_s
    try:
        sock = socket.create_connection((host, port), timeout=timeout_s)
    except TimeoutError:
        raise ConfigError(f"{where}: no connection within {timeout_s:g} s: check the address "
                          f"and that the scheduler runs ({_EXAMPLE})") from None
    except OSError as exc:
        raise ConfigError(f"{where}: cannot connect ({exc.strerror or exc}): check the address "
                          f"and that the scheduler runs ({_EXAMPLE})") from None
    with sock:
        if scheme == "tls":
            return
        try:
            (n,) = struct.unpack("Q", _recv_exactly(sock, 8, deadline))
            body = (_recv_exactly(sock, n, deadline) if 0 < n <= MAX_HANDSHAKE_BYTES else b"")
        except TimeoutError:
            raise ConfigError(f"{where}: the server there sent no Dask handshake within "
                              f"{timeout_s:g} s: it is not a Dask scheduler (or it hangs); "
                              f"check the address ({_EXAMPLE})") from None
        except OSError as exc:
            raise ConfigError(f"{where}: the server closed the connection without a Dask "
                              f"handshake ({exc}): it is not a Dask scheduler; check the "
                              f"address ({_EXAMPLE})") from None
    if b"compression" not in body or b"pickle-protocol" not in body:
        raise ConfigError(f"{where}: the server there does not speak the Dask protocol (its "
                          f"first bytes are no Dask handshake): it is not a Dask scheduler; "
                          f"check the address and the port ({_EXAMPLE})")
