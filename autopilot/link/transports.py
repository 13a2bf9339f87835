"""Byte transports for MAVLink: an in-process memory pipe, TCP and UDP.

A transport moves bytes and nothing else; the codec makes and reads frames. Every
transport has the same two calls: ``send(data)`` and ``recv(timeout_s) -> bytes`` (empty
on timeout). URLs, as ArduPilot/MAVProxy spell them:

* ``memory``                in-process pipe (see :func:`memory_pair`)
* ``tcp:HOST:PORT``         connect to a server
* ``tcpin:HOST:PORT``       listen and serve one peer at a time (the simulator end)
* ``udp:HOST:PORT`` / ``udpout:HOST:PORT``   send to HOST:PORT, receive the replies
* ``udpin:HOST:PORT``       bind and reply to whoever spoke last
"""
from __future__ import annotations

import os
import select
import socket
import threading
import time
from collections import deque


class TransportError(OSError):
    pass


class MemoryEndpoint:
    """One end of an in-process byte pipe. Thread-safe, so it also works when the two
    programs run in separate threads; in one thread ``recv`` never blocks.

    The inbox is a deque, whose ``append`` and ``popleft`` are atomic: a sender appends
    and takes the lock only to wake a receiver that waits (``_waiting``); a receiver
    sets ``_waiting`` under the lock before it looks at the inbox and sleeps, so a
    datagram is either seen by that look or followed by the sender's notify."""

    def __init__(self):
        self._inbox: deque[bytes] = deque()
        self._cond = threading.Condition()
        self._waiting = False
        self.peer: MemoryEndpoint | None = None
        self.closed = False

    def send(self, data: bytes) -> None:
        peer = self.peer
        if peer is None or peer.closed:
            return
        peer._inbox.append(data)
        if peer._waiting:
            with peer._cond:
                peer._cond.notify()

    def recv(self, timeout_s: float = 0.0) -> bytes:
        inbox = self._inbox
        if not inbox and timeout_s > 0:
            with self._cond:
                self._waiting = True
                try:
                    if not inbox:
                        self._cond.wait(timeout_s)
                finally:
                    self._waiting = False
        if not inbox:
            return b""
        data = inbox.popleft()
        if not inbox:
            return data
        parts = [data]
        while inbox:
            parts.append(inbox.popleft())
        return b"".join(parts)

    def close(self) -> None:
        self.closed = True


def memory_pair() -> tuple[MemoryEndpoint, MemoryEndpoint]:
    a, b = MemoryEndpoint(), MemoryEndpoint()
    a.peer, b.peer = b, a
    return a, b


def _split_url(url: str) -> tuple[str, str, int]:
    try:
        kind, host, port = url.split(":")
        return kind, host, int(port)
    except ValueError:
        raise TransportError(f"bad link URL {url!r}: expected KIND:HOST:PORT") from None


def _send_all(sock: socket.socket, data: bytes) -> bool:
    """Send all of ``data`` on a non-blocking TCP socket; False if the connection failed.
    One ``send`` when the socket buffer has room (every lockstep step: a few hundred
    bytes), else the rest blocking (the peer is slow to read: wait for it, as before)."""
    try:
        n = sock.send(data)
    except BlockingIOError:
        n = 0
    except OSError:
        return False
    if n == len(data):
        return True
    sock.setblocking(True)
    try:
        sock.sendall(memoryview(data)[n:])
    except OSError:
        return False
    sock.setblocking(False)
    return True


# How long a stream receive spins before it sleeps in select [s]. In lockstep each end
# waits for the other's step (the simulator's plant and sensors, the autopilot's control
# path: 50-150 us each); one that sleeps in select is woken by the scheduler tens of
# microseconds after its data came, twice a step. Spinning that long first, yielding the
# core on every turn (sched_yield: a busy machine's other processes lose nothing), the
# two-process loop over TCP ran at 1.01-1.07 of the memory pipe's speed on a quiet
# two-core host, against 0.62-0.68 sleeping at once (alternating runs, 40-300 s flights).
SPIN_S = 200e-6


def _recv_stream(sock: socket.socket, timeout_s: float):
    """Receive from a non-blocking stream socket: bytes, b"" when the peer closed, None
    when nothing came within ``timeout_s`` (tried at once, then spun for up to SPIN_S
    yielding the core each turn, then waited for in select)."""
    try:
        return sock.recv(65536)
    except BlockingIOError:
        pass
    except OSError:
        return b""
    if timeout_s <= 0.0:
        return None
    clock = time.perf_counter
    end = clock() + (SPIN_S if SPIN_S < timeout_s else timeout_s)
    recv = sock.recv
    yield_ = os.sched_yield
    while clock() < end:
        yield_()
        try:
            return recv(65536)
        except BlockingIOError:
            pass
        except OSError:
            return b""
    r, _, _ = select.select([sock], [], [], timeout_s)
    if not r:
        return None
    try:
        return recv(65536)
    except BlockingIOError:
        return None
    except OSError:
        return b""


class TcpClient:
    def __init__(self, host: str, port: int, connect_timeout_s: float = 10.0):
        deadline = time.monotonic() + connect_timeout_s
        last_err: Exception | None = None
        while True:
            try:
                self.sock = socket.create_connection((host, port), timeout=2.0)
                break
            except OSError as e:  # the server may not be up yet: retry until deadline
                last_err = e
                if time.monotonic() > deadline:
                    raise TransportError(f"cannot connect to tcp:{host}:{port}: {last_err}") from None
                time.sleep(0.1)
        self.sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self.sock.setblocking(False)
        self.closed = False

    def send(self, data: bytes) -> None:
        if self.closed:
            return
        if not _send_all(self.sock, data):
            self.closed = True

    def recv(self, timeout_s: float = 0.0) -> bytes:
        if self.closed:
            return b""
        data = _recv_stream(self.sock, timeout_s)
        if data is None:
            return b""
        if not data:
            self.closed = True
        return data

    def close(self) -> None:
        self.closed = True
        self.sock.close()


class TcpServerOne:
    """Listens and talks to one peer at a time (the simulator end of the HIL link)."""

    def __init__(self, host: str, port: int):
        self.listener = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self.listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        self.listener.bind((host, port))
        self.listener.listen(1)
        self.port = self.listener.getsockname()[1]
        self.conn: socket.socket | None = None
        self.closed = False

    def accept(self, timeout_s: float | None = None) -> bool:
        r, _, _ = select.select([self.listener], [], [], timeout_s)
        if not r:
            return False
        conn, _ = self.listener.accept()
        conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        conn.setblocking(False)
        if self.conn is not None:
            self.conn.close()
        self.conn = conn
        return True

    @property
    def connected(self) -> bool:
        return self.conn is not None

    def send(self, data: bytes) -> None:
        if self.conn is None:
            return
        if not _send_all(self.conn, data):
            self.conn.close()
            self.conn = None

    def recv(self, timeout_s: float = 0.0) -> bytes:
        if self.conn is None:
            return b""
        data = _recv_stream(self.conn, timeout_s)
        if data is None:
            return b""
        if not data:
            self.conn.close()
            self.conn = None
        return data

    def close(self) -> None:
        self.closed = True
        if self.conn is not None:
            self.conn.close()
        self.listener.close()


class Udp:
    """UDP: ``udpin`` binds and answers the last sender; ``udpout`` sends to a fixed
    address and receives on an ephemeral port."""

    def __init__(self, host: str, port: int, listen: bool):
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        if listen:
            self.sock.bind((host, port))
            self.peer = None
        else:
            self.sock.bind(("127.0.0.1" if host in ("127.0.0.1", "localhost") else "", 0))
            self.peer = (host, port)
        self.port = self.sock.getsockname()[1]
        self.sock.setblocking(False)
        self.closed = False

    def send(self, data: bytes) -> None:
        if self.peer is None:
            return
        try:
            self.sock.sendto(data, self.peer)
        except OSError:
            pass

    def recv(self, timeout_s: float = 0.0) -> bytes:
        r, _, _ = select.select([self.sock], [], [], max(0.0, timeout_s))
        if not r:
            return b""
        chunks = []
        while True:
            try:
                data, addr = self.sock.recvfrom(65536)
            except (BlockingIOError, OSError):
                break
            self.peer = addr
            chunks.append(data)
        return b"".join(chunks)

    def close(self) -> None:
        self.closed = True
        self.sock.close()


def open_url(url: str, connect_timeout_s: float = 10.0):
    """Open a transport from a URL (``memory`` is not openable by URL: use
    :func:`memory_pair`)."""
    kind, host, port = _split_url(url)
    if kind == "tcp":
        return TcpClient(host, port, connect_timeout_s)
    if kind == "tcpin":
        return TcpServerOne(host, port)
    if kind in ("udp", "udpout"):
        return Udp(host, port, listen=False)
    if kind == "udpin":
        return Udp(host, port, listen=True)
    raise TransportError(f"bad link URL {url!r}: unknown kind {kind!r}")
