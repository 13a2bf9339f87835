"""Ground-station transports: the sockets, non-blocking, polled between lockstep steps.

A :class:`GcsLinks` owns every endpoint named by the ``--gcs`` URLs and turns them into
*peers*: one per TCP client, one per ``udpout`` destination, one per ``udpin`` socket
(answering the last sender whose message was accepted). It moves bytes only; the
codec and the protocol state machines live elsewhere (sans-IO: they never touch a socket,
so tests drive them with bytes).

* ``tcpin:HOST:PORT``   a server for any number of clients at once (port 0: any free port)
* ``udpout:HOST:PORT``  send to HOST:PORT, receive the replies on an ephemeral port
* ``udpin:HOST:PORT``   bind, answer the last sender whose message the service accepted

``--gcs`` alone listens on the loopback interface only (``DEFAULT_URLS``): a link anyone on
the network can reach is something the user asks for by address (:func:`exposed` names
them, so the caller can warn when no signing key guards them).

Input is read only from peers the service has not paused (``Peer.paused``: a client over
its input budget, see ``service.py``), at most ``READ_SIZE`` bytes per TCP client per
poll; a paused client's bytes wait in the kernel, and TCP flow control slows the sender.
At most ``MAX_TCP_CLIENTS`` TCP clients at once: a connection beyond them makes room by
closing the client the service names (``evictable``: one that has had nothing accepted
for a while, ``evicted``), or else is closed at once (``refused_connections``).

Output to a TCP client is written without blocking. What the kernel will not take at
once waits in a per-peer buffer; telemetry is dropped for a peer whose buffer holds more
than ``TELEMETRY_BACKLOG`` bytes (a slow client loses telemetry, never a protocol
reply), and a peer whose buffer passes ``MAX_BACKLOG`` is disconnected. A client that
disconnects or errors is closed and forgotten; the others never notice.
"""
from __future__ import annotations

import errno
import select
import socket
from dataclasses import dataclass, field

TELEMETRY_BACKLOG = 64 * 1024
MAX_BACKLOG = 4 * 1024 * 1024
READ_SIZE = 16 * 1024               # bytes read from one TCP client per poll
MAX_TCP_CLIENTS = 16
LISTEN_BACKLOG = 4 * MAX_TCP_CLIENTS   # connections queued in the kernel before accept
DEFAULT_URLS = ("tcpin:127.0.0.1:5760", "udpout:127.0.0.1:14550")
_KINDS = ("tcpin", "udpout", "udpin", "udp")


class LinkUrlError(ValueError):
    pass


def parse_url(url: str) -> tuple[str, str, int]:
    """``KIND:HOST:PORT`` -> (kind, host, port); ``udp`` means ``udpout``."""
    parts = url.strip().split(":")
    if len(parts) != 3 or parts[0] not in _KINDS:
        raise LinkUrlError(f"bad ground-station URL {url!r}: expected tcpin:HOST:PORT, "
                           "udpout:HOST:PORT or udpin:HOST:PORT")
    kind, host, port_s = parts
    try:
        port = int(port_s)
    except ValueError:
        raise LinkUrlError(f"bad ground-station URL {url!r}: port is not a number") from None
    if not 0 <= port <= 65535 or (port == 0 and kind not in ("tcpin", "udpin")):
        raise LinkUrlError(f"bad ground-station URL {url!r}: port out of range")
    return ("udpout" if kind == "udp" else kind), host or "0.0.0.0", port


def is_loopback(host: str) -> bool:
    return host == "localhost" or host.startswith("127.") or host == "::1"


def exposed(urls) -> list[str]:
    """The URLs other machines can reach: a server bound to an address other than
    loopback, or a UDP destination that is not this machine."""
    return [u for u in urls if not is_loopback(parse_url(u)[1])]


@dataclass(eq=False)
class Peer:
    """One ground-station connection as the service sees it."""

    pid: int
    name: str                      # e.g. "tcp 127.0.0.1:50312"
    kind: str                      # "tcp" | "udpout" | "udpin"
    sock: socket.socket
    addr: tuple | None = None      # UDP destination (None: udpin nobody has spoken yet)
    out: bytearray = field(default_factory=bytearray)
    closed: bool = False
    heard: bool = False            # something was received from it
    sent_bytes: int = 0
    dropped: int = 0               # telemetry messages dropped (backlog)
    paused: bool = False           # over its input budget: not read until unpaused


class GcsLinks:
    """Every ground-station endpoint of one service."""

    def __init__(self, urls):
        self._next_id = 1
        self.listeners: list[socket.socket] = []
        self.peers: dict[int, Peer] = {}
        self._udp: dict[socket.socket, Peer] = {}
        self._tcp: dict[socket.socket, Peer] = {}
        self.new_peers: list[Peer] = []      # opened since the last poll
        self.gone_peers: list[Peer] = []     # closed since the last poll
        self.refused_connections = 0         # TCP clients beyond MAX_TCP_CLIENTS
        self.evicted = 0                     # ... and stale ones closed to make room
        self.evictable = None                # () -> a Peer to close for a newcomer, or None
        try:
            for url in urls:
                self._open(*parse_url(url))
        except OSError:
            self.close()
            raise

    def _peer(self, name, kind, sock, addr=None) -> Peer:
        p = Peer(self._next_id, name, kind, sock, addr)
        self._next_id += 1
        self.peers[p.pid] = p
        self.new_peers.append(p)
        return p

    def _open(self, kind: str, host: str, port: int) -> None:
        if kind == "tcpin":
            s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
            s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            s.bind((host, port))
            # a burst of connections (a ground station reopening its links, a swarm of
            # clients) waits in the kernel's queue until the next poll takes it, in
            # arrival order; a queue shorter than MAX_TCP_CLIENTS dropped the rest's
            # handshakes into retransmits a second or more away, so clients were served or
            # refused in whatever order the retransmits landed
            s.listen(LISTEN_BACKLOG)
            s.setblocking(False)
            self.listeners.append(s)
            return
        s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        s.setblocking(False)
        if kind == "udpin":
            s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            s.bind((host, port))
            self._udp[s] = self._peer(f"udpin {host}:{s.getsockname()[1]}", "udpin", s)
        else:
            s.bind(("127.0.0.1" if host in ("127.0.0.1", "localhost") else "", 0))
            self._udp[s] = self._peer(f"udpout {host}:{port}", "udpout", s, (host, port))

    # ------------------------------------------------------------------ queries ---
    def tcp_ports(self) -> list[tuple[str, int]]:
        return [s.getsockname() for s in self.listeners]

    def udp_ports(self) -> list[tuple[str, int]]:
        return [s.getsockname() for s in self._udp]

    def fds(self) -> list:
        return self.listeners + [p.sock for p in self.peers.values() if not p.closed and not p.paused]

    # -------------------------------------------------------------------- input ---
    def poll(self, timeout_s: float = 0.0) -> list[tuple[Peer, bytes, tuple | None]]:
        """Accept new clients and read what has arrived: [(peer, bytes, sender)], the
        sender's address for ``udpin`` (the service answers it once it has accepted a
        message from it: an unsigned datagram cannot steer the replies), else None."""
        fds = self.fds()
        if not fds:
            return []
        try:
            readable, _, _ = select.select(fds, [], [], max(timeout_s, 0.0))
        except (OSError, ValueError):
            self._reap()
            return []
        got = []
        for s in readable:
            if s in self.listeners:
                self._accept(s)
                continue
            peer = self._udp.get(s)
            if peer is not None:
                if peer.paused:
                    continue
                runs: list[list] = []          # [sender, datagrams] in arrival order
                size = 0
                for _ in range(256):
                    try:
                        data, addr = s.recvfrom(65536)
                    except (BlockingIOError, InterruptedError):
                        break
                    except OSError:
                        break  # e.g. ICMP port unreachable on udpout: nobody there yet
                    if peer.kind != "udpin":
                        if addr[1] != peer.addr[1]:
                            continue  # not from the ground station we send to
                        addr = None
                    if runs and runs[-1][0] == addr:
                        runs[-1][1].append(data)
                    else:
                        runs.append([addr, [data]])
                    size += len(data)
                    if size >= READ_SIZE:
                        break
                if runs:
                    peer.heard = True
                    got.extend((peer, b"".join(chunks), addr) for addr, chunks in runs)
                continue
            peer = self._tcp_peer(s)
            if peer is None or peer.paused:
                continue
            try:
                data = s.recv(READ_SIZE)
            except (BlockingIOError, InterruptedError):
                continue
            except OSError:
                data = b""
            if not data:
                self._close_peer(peer)
                continue
            peer.heard = True
            got.append((peer, data, None))
        return got

    def _tcp_peer(self, s) -> Peer | None:
        p = self._tcp.get(s)
        return None if p is None or p.closed else p

    def _accept(self, listener) -> None:
        for _ in range(16):
            try:
                conn, addr = listener.accept()
            except (BlockingIOError, InterruptedError):
                return
            except OSError:
                return
            if len(self._tcp) >= MAX_TCP_CLIENTS:
                victim = self.evictable() if self.evictable is not None else None
                if victim is None or victim.closed:
                    self.refused_connections += 1
                    conn.close()
                    continue
                self._close_peer(victim)
                self.evicted += 1
            conn.setblocking(False)
            try:
                conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            except OSError:
                pass
            self._tcp[conn] = self._peer(f"tcp {addr[0]}:{addr[1]}", "tcp", conn)

    # ------------------------------------------------------------------- output ---
    def send(self, peer: Peer, data: bytes, telemetry: bool = False) -> bool:
        """Queue and write ``data``; False if it was dropped or the peer is gone."""
        if peer.closed:
            return False
        if peer.kind != "tcp":
            if peer.addr is None:
                return False
            try:
                peer.sock.sendto(data, peer.addr)
                peer.sent_bytes += len(data)
            except OSError:
                return False  # nobody listening (yet): UDP is fire and forget
            return True
        if telemetry and len(peer.out) > TELEMETRY_BACKLOG:
            peer.dropped += 1
            return False
        peer.out += data
        if len(peer.out) > MAX_BACKLOG:
            self._close_peer(peer)
            return False
        self._flush(peer)
        return not peer.closed

    def _flush(self, peer: Peer) -> None:
        while peer.out and not peer.closed:
            try:
                n = peer.sock.send(peer.out)
            except (BlockingIOError, InterruptedError):
                return
            except OSError as e:
                if e.errno in (errno.EAGAIN, errno.EWOULDBLOCK):
                    return
                self._close_peer(peer)
                return
            peer.sent_bytes += n
            del peer.out[:n]

    def flush(self) -> None:
        for p in list(self.peers.values()):
            if p.kind == "tcp" and p.out:
                self._flush(p)

    # ---------------------------------------------------------------- lifecycle ---
    def _close_peer(self, peer: Peer) -> None:
        if peer.closed:
            return
        peer.closed = True
        if peer.kind == "tcp":
            self._tcp.pop(peer.sock, None)
            try:
                peer.sock.close()
            except OSError:
                pass
        self.gone_peers.append(peer)

    def _reap(self) -> None:
        for p in list(self.peers.values()):
            if p.kind == "tcp" and p.sock.fileno() < 0:
                self._close_peer(p)

    def take_events(self) -> tuple[list[Peer], list[Peer]]:
        """(peers opened, peers closed) since the last call; closed peers are forgotten."""
        new, gone = self.new_peers, self.gone_peers
        self.new_peers, self.gone_peers = [], []
        for p in gone:
            self.peers.pop(p.pid, None)
        return new, gone

    def close(self) -> None:
        self.flush()
        for p in list(self.peers.values()):
            if p.kind == "tcp":
                self._close_peer(p)
        for s in list(self._udp) + self.listeners:
            try:
                s.close()
            except OSError:
                pass
        self.listeners = []
        self._udp = {}
