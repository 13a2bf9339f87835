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
"""
from __future__ import annotations

import sys
import time
from pathlib import Path

from ..link.codec import MAV, Codec
from .core import GcsCore
from .links import GcsLinks
from .tlog import TlogWriter

_V1_MAX_ID = 255


class GcsService:
    def __init__(self, vehicle, urls, hil=None, tlog_path: str | Path | None = None,
                 param_store_path: str | Path | None = None, clock=time.monotonic,
                 system_id: int = 1, component_id: int = 1, mission_timeout_s: float = 1.5,
                 mission_retries: int = 5):
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
        self.t_us = 0
        self.received = 0
        self.decode_errors = 0
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
        return (f"{self.received} messages received, {self.decode_errors} undecodable chunks, "
                f"{c.ignored} ignored, {c.errors} handler errors, "
                f"{c.missions.uploads_accepted} missions accepted, {c.missions.uploads_refused} refused")

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
            got = self.links.poll(min(remaining, 0.005) if busy else remaining)
            if got:
                self._read(got, t_us)
            if got or busy:
                self.core.timers()
                self._write()

    def close(self) -> None:
        self._write()
        self.links.close()
        if self.tlog is not None:
            self.tlog.close()

    # -------------------------------------------------------------------- input ---
    def _sync(self) -> None:
        new, gone = self.links.take_events()
        for p in gone:
            self.core.remove_client(p.pid)
            self._rx.pop(p.pid, None)
            self._tx.pop(p.pid, None)
        for p in new:
            self.core.add_client(p.pid, p.name, streaming=p.kind == "tcp")
            self._rx[p.pid] = Codec(self.system_id, self.component_id)
            self._tx[p.pid] = Codec(self.system_id, self.component_id)

    def _read(self, got, t_us: int) -> None:
        self._sync()
        for peer, data in got:
            codec = self._rx.get(peer.pid)
            if codec is None:
                continue
            if peer.kind != "tcp":
                self.core.heard(peer.pid)
            try:
                msgs = codec.decode(data)
            except Exception:  # noqa: BLE001 - garbage must not reach the flight software
                self.decode_errors += 1
                codec._buf.clear()
                continue
            for msg in msgs:
                self.received += 1
                buf = getattr(msg, "_msgbuf", None)
                v1 = bool(buf) and buf[0] == 0xFE
                if self.tlog is not None and buf:
                    self.tlog.write(t_us, bytes(buf))
                self.core.receive(peer.pid, msg, t_us, mavlink1=v1)
        self._sync()

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
