"""The ground-station service: sockets + codec + the protocol core, polled by the loop.

No threads: the runner calls

* ``after_step(frame, outputs)`` after every vehicle step (records what telemetry needs;
  nothing at all while no client is connected),
* ``step(t_us)`` once per lockstep step: reads every socket without blocking, handles
  what arrived, sends the streams due at ``t_us`` and the replies,
* ``wait(timeout_s, t_us)`` instead of sleeping when the run is paced to real time, so
  replies go out as soon as a request arrives (a mission item round trip costs a
  fraction of a millisecond, not a lockstep period).

Streams are scheduled on simulation time, so the telemetry log of a run is the same
whatever the machine's speed. Faster than real time (``--speedup`` above 1, or ``max``)
the streams keep their rates in simulation time, so a ground station receives them
faster in wall time (ATTITUDE at 10 Hz becomes 100 Hz at ``--speedup 10``); a TCP
client that cannot keep up loses telemetry, never a protocol reply (``links.py``).
The protocol timers (mission upload retries, the heartbeat-loss failsafe, the pacing of
parameter lists) run on wall time, as the ground stations' own timers do.

Signing (``autopilot/link/signing.py``): with a key, every message sent is signed and
every message received is checked before the protocol core sees it; a refused message
changes nothing and is answered by nothing. The refusals are counted by reason
(``refused``) and announced by one STATUSTEXT at most every ``REFUSAL_REPORT_S``. The
key comes from ``signing_key`` or from the key store beside the parameter store, and
SETUP_SIGNING sets or (all-zero key, over a signed link) removes it; the store keeps
the key and its timestamp in an owner-only file, the timestamp saved every
``TIMESTAMP_SAVE_S`` and at close.

Input budget: every client may have ``INPUT_RATE`` frames a second handled (messages,
rejected frames and stretches of garbage alike), up to ``INPUT_BURST`` at once, and all
clients together ``TOTAL_INPUT_RATE`` (each gets min(INPUT_RATE, TOTAL_INPUT_RATE / n)
with n clients that sent something in the last ``ACTIVE_S``: idle connections do not
dilute the others' budgets). With signing on, when every TCP place is taken, a newcomer
closes the client that has had nothing accepted for longest, if that is over ``STALE_S``:
connections that only send unsigned traffic cannot keep a ground station out (nor can a
client without the key that only listens keep its place). A client over its budget is paused: what it sent waits in the codec's
buffer (at most one read, ``links.READ_SIZE`` bytes, plus a frame) and in the kernel, so
however fast the clients send they cost the flight loop at most ``TOTAL_INPUT_RATE``
frames a second, and this process at most ``READ_SIZE`` + ``links.MAX_BACKLOG`` bytes of
buffers per client.
"""
from __future__ import annotations

import sys
import time
from pathlib import Path

from ..link.codec import MAV, Codec
from ..link.signing import KeyStore, Signing, key_store_beside
from .core import SEV_WARNING, GcsCore
from .links import GcsLinks
from .tlog import TlogWriter

_V1_MAX_ID = 255
_SETUP_SIGNING = 256
INPUT_RATE = 1000.0        # frames a second a client may have handled
TOTAL_INPUT_RATE = 2000.0  # ... and every client together: each min(INPUT_RATE, this / clients)
INPUT_BURST = 200.0        # frames at once
ACTIVE_S = 1.0             # a client that sent something this recently shares the total
STALE_S = 10.0             # a TCP client with nothing accepted this long may make room
REFUSAL_REPORT_S = 10.0    # at most one STATUSTEXT about refused messages this often
TIMESTAMP_SAVE_S = 30.0    # the stored signing timestamp is refreshed this often


class GcsService:
    def __init__(self, vehicle, urls, hil=None, tlog_path: str | Path | None = None,
                 param_store_path: str | Path | None = None, clock=time.monotonic,
                 system_id: int = 1, component_id: int = 1, mission_timeout_s: float = 1.5,
                 mission_retries: int = 5, signing_key: bytes | None = None,
                 key_store: str | Path | None = None, wall_clock=time.time):
        self.vehicle = vehicle
        self.system_id = system_id
        self.component_id = component_id
        self.param_store_path = Path(param_store_path) if param_store_path else None
        self.links = GcsLinks(urls)
        self.core = GcsCore(vehicle, clock, relay=hil,
                            battery=(lambda: getattr(hil, "battery", None)) if hil is not None else None,
                            persist=self._persist if self.param_store_path else None,
                            system_id=system_id, component_id=component_id,
                            mission_timeout_s=mission_timeout_s, mission_retries=mission_retries)
        self.tlog = TlogWriter(tlog_path) if tlog_path else None
        self._log_codec = Codec(system_id, component_id)
        self._rx: dict[int, Codec] = {}
        self._tx: dict[int, Codec] = {}
        # pid -> [frames allowed now, when refilled, last input, last message accepted]
        self._budget: dict[int, list[float]] = {}
        self.clock = clock
        self.t_us = 0
        self.received = 0
        self.decode_errors = 0
        # signing: the key store (beside the parameter store unless told), the state
        if key_store is not None:
            self.key_store: KeyStore | None = KeyStore(key_store)
        elif self.param_store_path is not None:
            self.key_store = key_store_beside(self.param_store_path)
        else:
            self.key_store = None
        self.signing = Signing(clock=wall_clock)
        self.key_source = None
        stored = self.key_store.load() if self.key_store is not None else None
        if stored is not None:
            self.signing.restore(*stored)
            self.key_source = str(self.key_store.path)
        if signing_key is not None:
            self.signing.set_key(signing_key, self.signing.timestamp)
            self.key_source = "--signing-key"
            self._save_key()
        self.links.evictable = self._stale_peer
        self.core.signing = self.signing
        self.core.on_signing_change = self._signing_changed
        self.refused: dict[str, int] = {}
        self._refused_reported = 0
        self._refusal_report_at = -1e9
        self._timestamp_saved_at = clock()
        self._sync()

    # -------------------------------------------------------------------- facts ---
    def describe(self) -> str:
        parts = [f"tcp {h}:{p}" for h, p in self.links.tcp_ports()]
        parts += [p.name for p in self.links.peers.values() if p.kind != "tcp"]
        return "ground stations: " + ", ".join(parts)

    @property
    def tcp_port(self) -> int | None:
        ports = self.links.tcp_ports()
        return ports[0][1] if ports else None

    def stats(self) -> str:
        c = self.core
        why = ", ".join(f"{n} {k}" for k, n in sorted(self.refused.items()))
        return (f"{self.received} messages received, {self.decode_errors} undecodable chunks, "
                f"{c.ignored} ignored, {c.errors} handler errors, "
                f"{c.missions.uploads_accepted} missions accepted, {c.missions.uploads_refused} refused, "
                f"{self.links.refused_connections} connections over the limit closed, "
                f"{self.links.evicted} stale ones closed for newcomers, "
                f"signing {'on' if self.signing.active else 'off'}, "
                f"{self.refused_total} messages refused" + (f" ({why})" if why else ""))

    @property
    def refused_total(self) -> int:
        return sum(self.refused.values())

    @property
    def clients(self) -> int:
        return sum(1 for p in self.links.peers.values() if p.kind == "tcp" or p.heard)

    # ---------------------------------------------------------------- the loop ---
    def after_step(self, frame=None, outputs=None) -> None:
        for c in self.core.clients.values():
            if c.streaming:  # someone is listening to more than heartbeats
                self.core.observe(frame, outputs)
                return

    def step(self, t_us: int) -> None:
        """Once per lockstep step."""
        self.t_us = t_us
        self._read(self.links.poll(0.0), t_us)
        self._resume(t_us)
        self._signing_timers()
        self.core.tick(t_us)
        self._write()

    def wait(self, timeout_s: float, t_us: int | None = None) -> None:
        """Sleep up to ``timeout_s`` (wall), answering requests as they arrive."""
        t_us = self.t_us if t_us is None else t_us
        deadline = time.perf_counter() + timeout_s
        while True:
            remaining = deadline - time.perf_counter()
            if remaining <= 0:
                return
            if not self.links.fds():
                time.sleep(remaining)
                return
            busy = self.core.params.listings or self.core.missions.upload is not None
            paused = any(p.paused for p in self.links.peers.values())
            got = self.links.poll(min(remaining, 0.005) if busy or paused else remaining)
            if got:
                self._read(got, t_us)
            if paused:
                got = self._resume(t_us) or got
            if got or busy:
                self.core.timers()
                self._write()

    def close(self) -> None:
        self._write()
        self.links.close()
        if self.signing.active:
            self._save_key()
        if self.tlog is not None:
            self.tlog.close()

    # -------------------------------------------------------------------- input ---
    def _sync(self) -> None:
        new, gone = self.links.take_events()
        for p in gone:
            self.core.remove_client(p.pid)
            self._rx.pop(p.pid, None)
            self._tx.pop(p.pid, None)
            self._budget.pop(p.pid, None)
        for p in new:
            self.core.add_client(p.pid, p.name, streaming=p.kind == "tcp")
            self._rx[p.pid] = Codec(self.system_id, self.component_id)
            tx = self._tx[p.pid] = Codec(self.system_id, self.component_id)
            tx.signing = self.signing
            tx.link_id = p.pid & 0xFF
            now = self.clock()
            self._budget[p.pid] = [INPUT_BURST, now, -1e9, now]

    def _stale_peer(self):
        """With signing on, the TCP client to close for a newcomer when all places are
        taken: the one with nothing accepted for longest (since it connected), if over
        STALE_S. Without a key nothing tells an idle intruder from a ground station that
        only listens: the newcomer is refused."""
        if not self.signing.active:
            return None
        now = self.clock()
        stale = [(b[3], pid) for pid, b in self._budget.items()
                 if now - b[3] > STALE_S and self.links.peers.get(pid) is not None
                 and self.links.peers[pid].kind == "tcp"]
        return self.links.peers[min(stale)[1]] if stale else None

    def _allowance(self, pid: int) -> int:
        """Frames client ``pid`` may have handled now (its budget, refilled)."""
        b = self._budget.get(pid)
        if b is None:
            return 0
        now = self.clock()
        b[2] = now
        active = sum(1 for x in self._budget.values() if now - x[2] < ACTIVE_S)
        rate = min(INPUT_RATE, TOTAL_INPUT_RATE / max(active, 1))
        b[0] = min(INPUT_BURST, b[0] + (now - b[1]) * rate)
        b[1] = now
        return int(b[0])

    def _read(self, got, t_us: int) -> None:
        self._sync()
        for peer, data, sender in got:
            self._handle(peer, data, t_us, sender)
        self._sync()

    def _resume(self, t_us: int) -> bool:
        """Handle what paused clients left in their buffers, as their budgets allow."""
        resumed = False
        for peer in list(self.links.peers.values()):
            if peer.paused and not peer.closed:
                self._handle(peer, b"", t_us)
                resumed = True
        if resumed:
            self._sync()
        return resumed

    def _handle(self, peer, data: bytes, t_us: int, sender=None) -> None:
        codec = self._rx.get(peer.pid)
        if codec is None:
            return
        allowed = self._allowance(peer.pid)
        if allowed <= 0:
            if data:
                codec._buf += data
            peer.paused = True
            return
        bad0 = codec.bad_frames
        try:
            msgs = codec.decode(data, limit=allowed)
        except Exception:  # noqa: BLE001 - garbage must not reach the flight software
            self.decode_errors += 1
            codec._buf.clear()
            peer.paused = False
            return
        self._budget[peer.pid][0] -= len(msgs) + codec.bad_frames - bad0
        # paused while the limit left bytes in the buffer (else what is left is at most
        # an incomplete frame, waiting for the next read)
        peer.paused = codec.limited
        signing = self.signing
        accepted = 0
        for msg in msgs:
            self.received += 1
            buf = getattr(msg, "_msgbuf", None)
            if signing.active:
                why = signing.check(buf) if buf else "unsigned"
                if why is not None:
                    self.refused[why] = self.refused.get(why, 0) + 1
                    continue
            accepted += 1
            self._budget[peer.pid][3] = self.clock()
            if sender is not None:
                peer.addr = sender          # udpin: answer whoever was last accepted
            v1 = bool(buf) and buf[0] == 0xFE
            if self.tlog is not None and buf and msg._header.msgId != _SETUP_SIGNING:
                self.tlog.write(t_us, Codec.unsigned(buf))   # keys and signatures stay out of logs
            self.core.receive(peer.pid, msg, t_us, mavlink1=v1)
        if accepted and peer.kind != "tcp":
            self.core.heard(peer.pid)

    # ------------------------------------------------------------------ signing ---
    def _signing_changed(self) -> None:
        """SETUP_SIGNING changed the key (core.py): store it, or remove it."""
        if self.signing.active:
            self.key_source = "SETUP_SIGNING"
            self._save_key()
        else:
            self.key_source = None
            if self.key_store is not None:
                self.key_store.remove()

    def _save_key(self) -> None:
        if self.key_store is None or not self.signing.active:
            return
        try:
            self.key_store.save(self.signing.key, self.signing.timestamp)
        except OSError as e:
            print(f"gcs: cannot save the signing key to {self.key_store.path}: {e}", file=sys.stderr)
        self._timestamp_saved_at = self.clock()

    def _signing_timers(self) -> None:
        now = self.clock()
        total = self.refused_total
        if total > self._refused_reported and now - self._refusal_report_at >= REFUSAL_REPORT_S:
            n = total - self._refused_reported
            self._refused_reported = total
            self._refusal_report_at = now
            self.core.say(SEV_WARNING, f"Signing: refused {n} messages")
        if self.signing.active and now - self._timestamp_saved_at >= TIMESTAMP_SAVE_S:
            self._save_key()

    def warnings(self, urls) -> list[str]:
        """What a user starting this service should be told (see links.exposed)."""
        from .links import exposed
        open_urls = exposed(urls)
        if open_urls and not self.signing.active:
            return [f"{', '.join(open_urls)} can be reached from the network and no signing key is "
                    "set: anyone on the network can command the vehicle (--signing-key FILE, or "
                    "MAVProxy's 'signing setup PASSPHRASE' over a trusted link)"]
        return []

    # ------------------------------------------------------------------- output ---
    def _encode(self, codec: Codec, msg, v1: bool) -> bytes | None:
        try:
            if v1:
                if msg._header.msgId > _V1_MAX_ID:
                    return None
                msg.__dict__.pop("_pack", None)  # the codec's MAVLink 2 framing hook
                buf = msg.pack(codec.mav, force_mavlink1=True)
                codec.mav.seq = (codec.mav.seq + 1) % 256
                return buf
            return codec.encode(msg)
        except Exception:  # noqa: BLE001 - a message we cannot encode is dropped, counted
            self.core.errors += 1
            return None

    def _write(self) -> None:
        out = self.core.outbox
        if not out:
            self.links.flush()
            return
        self.core.outbox = []
        peers = self.links.peers
        clients = self.core.clients
        logged = set()
        for cid, msg, telemetry in out:
            if self.tlog is not None and id(msg) not in logged:
                logged.add(id(msg))
                buf = self._encode(self._log_codec, msg, False)
                if buf is not None:
                    self.tlog.write(self.t_us, buf)
            targets = [cid] if cid is not None else [c for c, cl in clients.items() if cl.streaming]
            for pid in targets:
                peer = peers.get(pid)
                cl = clients.get(pid)
                if peer is None or cl is None or peer.closed:
                    continue
                buf = self._encode(self._tx[pid], msg, cl.v1)
                if buf is not None:
                    self.links.send(peer, buf, telemetry)
        self.links.flush()

    # ------------------------------------------------------------------ storage ---
    def _persist(self) -> None:
        try:
            self.vehicle.params.save(self.param_store_path)
        except OSError as e:
            print(f"gcs: cannot save parameters to {self.param_store_path}: {e}", file=sys.stderr)


__all__ = ["GcsService", "MAV"]
