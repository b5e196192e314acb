"""What parallel work (an add, simulated episodes) may ask of the machine and of the network, checked first.

Two inputs of a few bytes could otherwise cost minutes or gigabytes:

- ``workers``: each local worker is a process (about 100 MB before it reads a
  file, a few hundred with a robosuite environment) working on one core, so a
  thousand of them on two cores only swap. At most :data:`WORKERS_PER_CORE` per core of this machine are
  started; ``SKILLBANK_MAX_WORKERS`` raises the bound (a machine whose
  workers wait on a slow file system), and a cluster of several machines is
  reached through ``scheduler`` instead.
- ``scheduler``: Dask's client waits up to ``distributed.comm.timeouts.connect``
  (30 s) for a host that drops packets, then as long again closing itself, and
  a peer that speaks another protocol (a web server, the dashboard) makes it
  read the reply's first eight bytes as a frame count and allocate exabytes.
  The address is parsed here, the host is reached with a plain socket within
  ``SKILLBANK_CONNECT_TIMEOUT`` seconds (:data:`CONNECT_TIMEOUT` by default),
  and on ``tcp://`` the peer's first bytes must be a Dask handshake before
  the client is made.
"""

from __future__ import annotations

import os
import re
import socket
import struct

__all__ = ["WORKERS_PER_CORE", "CONNECT_TIMEOUT", "max_workers", "check_workers", "check_scheduler",
           "probe_scheduler"]

#: Local worker processes per core of this machine (``SKILLBANK_MAX_WORKERS`` overrides the product).
WORKERS_PER_CORE = 2
#: Seconds to reach a scheduler's host and read its handshake (``SKILLBANK_CONNECT_TIMEOUT`` overrides).
CONNECT_TIMEOUT = 10.0
#: Dask's own transports; ``host:port`` alone means ``tcp://``.
_SCHEMES = ("tcp", "tls", "ws", "wss", "ucx", "inproc")
_ADDRESS = re.compile(r"^(?:(?P<scheme>[A-Za-z][A-Za-z0-9+.-]*)://)?(?P<rest>.*)$", re.S)
_HOST_PORT = re.compile(r"^(?:\[(?P<ip6>[0-9A-Fa-f:.]+)\]|(?P<host>[A-Za-z0-9_.-]+)):(?P<port>[0-9]{1,5})$")
#: A Dask message over TCP starts with its length, an unsigned 64-bit integer in the sender's byte
#: order: a handshake takes a few hundred bytes, while the first eight bytes of an HTTP reply
#: ("HTTP/1.1") read as 3.5e18.
_MAX_HANDSHAKE = 1 << 20


def _cores() -> int:
    try:
        return len(os.sched_getaffinity(0))  # the cores this process may run on, not the machine's
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def _positive_variable(name: str, *, integer: bool):
    text = os.environ.get(name, "").strip()
    if not text:
        return None
    try:
        value = int(text) if integer else float(text)
    except ValueError:
        value = None
    if value is None or not (0 < value < float("inf")):
        kind = "an integer" if integer else "a number of seconds"
        raise ValueError(f"{name}: expected {kind} > 0, got {text!r}")
    return value


def max_workers() -> int:
    """Local workers parallel work may start: :data:`WORKERS_PER_CORE` per core, or ``SKILLBANK_MAX_WORKERS``.

    Examples
    --------
    >>> max_workers() >= WORKERS_PER_CORE
    True
    """
    return _positive_variable("SKILLBANK_MAX_WORKERS", integer=True) or WORKERS_PER_CORE * _cores()


def check_workers(workers) -> int:
    """``workers`` if it is at most :func:`max_workers`; else one line naming the bound and how to go past it.

    Examples
    --------
    >>> check_workers(1)
    1
    """
    bound = max_workers()
    if workers > bound:
        raise ValueError(
            f"workers: at most {bound} local worker processes on this machine ({WORKERS_PER_CORE} per core "
            f"of {_cores()}; each is a process working on one core), got {workers}; set "
            "SKILLBANK_MAX_WORKERS to start more, or give --scheduler for a cluster of several machines")
    return workers


def check_scheduler(address) -> tuple:
    """``(scheme, host, port)`` of a Dask scheduler's address; one line saying how to write it otherwise.

    ``host:port`` alone is ``tcp://``; ``inproc://`` has no host (``host`` and
    ``port`` are None). An ``http(s)://`` address is the dashboard's, not the
    scheduler's.

    Examples
    --------
    >>> check_scheduler("tcp://10.0.0.5:8786")
    ('tcp', '10.0.0.5', 8786)
    >>> check_scheduler("[::1]:8786")
    ('tcp', '::1', 8786)
    """
    if not isinstance(address, str):
        raise ValueError("scheduler: expected an address such as tcp://HOST:8786, got "
                         f"{type(address).__name__}")
    shown = address if address.isprintable() and len(address) <= 200 else repr(address[:200])
    match = _ADDRESS.match(address)
    scheme = (match.group("scheme") or "tcp").lower()
    if scheme in ("http", "https"):
        raise ValueError(f"scheduler: {shown} is a web address (the dashboard's, usually port 8787); give "
                         "the scheduler's, which its log prints as 'Scheduler at: tcp://HOST:8786'")
    if scheme not in _SCHEMES:
        raise ValueError(f"scheduler: unknown transport {scheme}:// in {shown} (Dask's are "
                         f"{', '.join(s + '://' for s in _SCHEMES)}); write it as tcp://HOST:PORT")
    if scheme == "inproc":
        return scheme, None, None
    rest = match.group("rest")
    hp = _HOST_PORT.match(rest)
    if hp is None or not 0 < int(hp.group("port")) < 65536:
        raise ValueError(f"scheduler: expected {scheme}://HOST:PORT with a port from 1 to 65535, got {shown}")
    return scheme, hp.group("ip6") or hp.group("host"), int(hp.group("port"))


def connect_timeout() -> float:
    """Seconds allowed to reach a scheduler: ``SKILLBANK_CONNECT_TIMEOUT``, else :data:`CONNECT_TIMEOUT`."""
    return _positive_variable("SKILLBANK_CONNECT_TIMEOUT", integer=False) or CONNECT_TIMEOUT


def probe_scheduler(address, timeout: float | None = None) -> None:
    """Reach the scheduler at ``address`` within ``timeout`` seconds, else one ``OSError`` line saying why.

    On ``tcp://`` the peer must also send a Dask handshake first (a scheduler
    writes it as soon as a connection is accepted), whose length is that of a
    handshake. Other transports are only checked to accept a
    connection (their handshake is inside TLS or a web socket).
    """
    scheme, host, port = check_scheduler(address)
    if host is None:
        return
    timeout = connect_timeout() if timeout is None else timeout
    where = f"the Dask scheduler at {address!r}"
    try:
        sock = socket.create_connection((host, port), timeout=timeout)
    except TimeoutError:
        raise OSError(f"scheduler: cannot reach {where}: no answer within {timeout:g} s (is the host up and "
                      "the port open? SKILLBANK_CONNECT_TIMEOUT allows longer)") from None
    except OSError as exc:
        reason = exc.strerror or " ".join(str(exc).split()) or type(exc).__name__
        raise OSError(f"scheduler: cannot reach {where}: {reason}") from None
    with sock:
        if scheme != "tcp":
            return
        head = b""
        try:
            while len(head) < 8:
                chunk = sock.recv(8 - len(head))
                if not chunk:
                    break
                head += chunk
        except TimeoutError:
            raise OSError(f"scheduler: {where} accepted the connection but sent no Dask handshake within "
                          f"{timeout:g} s: is it a Dask scheduler's port (8786 by default)?") from None
        except OSError as exc:
            raise OSError(f"scheduler: cannot reach {where}: {exc.strerror or exc}") from None
    if len(head) < 8 or not 0 < struct.unpack("Q", head)[0] <= _MAX_HANDSHAKE:
        shown = head.decode("ascii", "backslashreplace")[:8]
        raise OSError(f"scheduler: {where} does not speak Dask's protocol (it sent {shown!r}): give the "
                      "address the scheduler prints as 'Scheduler at: tcp://HOST:8786'")
