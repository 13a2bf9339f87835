"""The MAVLink parameter service (mavlink.io/en/services/parameter.html), sans-IO.

* PARAM_REQUEST_LIST: every parameter as PARAM_VALUE, streamed to the asking client
  ``batch`` at a time, at most one batch per ``period_s`` of wall time (rosflight's
  one-per-tick pacing, quicker), so a list never floods a link.
* PARAM_REQUEST_READ: by index (``param_index >= 0``) or by name (``-1``). An unknown
  name or index gets no PARAM_VALUE (there is no value to send) but a STATUSTEXT.
* PARAM_SET: always answered by a PARAM_VALUE echo, sent to every client (as ArduPilot
  does, so all ground stations stay in step): the new value, or the old one when the
  vehicle refuses the new one (range, integer type), with a STATUSTEXT saying why.
  Accepted changes are written to the persistent store, atomically. An accepted new
  value of a parameter that takes effect only at the next start (``at_start``) is
  followed by the vehicle's STATUSTEXT NOTICE saying so (VehicleBase.set_param).

Values travel as ArduPilot sends them (MAV_PROTOCOL_CAPABILITY_PARAM_FLOAT): the
numeric value in the float field, with param_type INT32 for integer parameters and
REAL32 for the others.
"""
from __future__ import annotations

import math
from pathlib import Path

from ..link.codec import MAV
from ..params import Param, ParamError, ParamStore

GCS_PARAMS = (
    Param("FS_GCS_ENABL", 1, 0, 1, "", "ground-station failsafe: 1 = RTL (plane) / RTL or LAND "
          "(quad) when heartbeats stop after a ground station has been seen", is_int=True),
    Param("FS_GCS_TIMEOUT", 5.0, 1.0, 120.0, "s", "ground-station heartbeat loss before the failsafe"),
)

PARAM_BATCH = 10          # PARAM_VALUEs per batch of a list
PARAM_PERIOD_S = 0.005    # wall time between batches


def param_id(name) -> str:
    """PARAM_SET/READ param_id -> str (pymavlink gives str or bytes, NUL-padded)."""
    if isinstance(name, bytes):
        name = name.decode("ascii", "replace")
    return str(name).split("\x00", 1)[0].strip()


def load_lenient(store: ParamStore, path: Path) -> tuple[list[str], list[str]]:
    """Apply a persisted ``.parm`` store line by line: unknown names and refused values
    are skipped (a store written by another version must not stop the vehicle).
    Returns (names set, problems)."""
    done, problems = [], []
    with open(path, encoding="utf-8") as f:
        for lineno, raw in enumerate(f, 1):
            line = raw.split("#", 1)[0].strip()
            if not line:
                continue
            parts = line.replace(",", " ").split()
            if len(parts) != 2:
                problems.append(f"{path}:{lineno}: expected 'NAME VALUE'")
                continue
            try:
                store.set(parts[0], parts[1])
                done.append(parts[0])
            except ParamError as e:
                problems.append(f"{path}:{lineno}: {e}")
    return done, problems


class _Listing:
    __slots__ = ("cid", "next_index", "next_at")

    def __init__(self, cid):
        self.cid = cid
        self.next_index = 0
        self.next_at = 0.0


class ParamServer:
    """``send(cid, msg)`` to one client, ``broadcast(msg)`` to all, ``say(sev, text)``
    a STATUSTEXT, ``persist()`` saves the store; ``clock()`` is wall time."""

    def __init__(self, vehicle, send, broadcast, say, clock, persist=None,
                 batch: int = PARAM_BATCH, period_s: float = PARAM_PERIOD_S):
        self.vehicle = vehicle
        self.send = send
        self.broadcast = broadcast
        self.say = say
        self.clock = clock
        self.persist = persist
        self.batch = batch
        self.period_s = period_s
        self.listings: dict[int, _Listing] = {}

    @property
    def store(self) -> ParamStore:
        return self.vehicle.params

    def value_message(self, name: str):
        st = self.store
        decl = st.declaration(name)
        ptype = MAV.MAV_PARAM_TYPE_INT32 if decl.is_int else MAV.MAV_PARAM_TYPE_REAL32
        return MAV.MAVLink_param_value_message(name.encode("ascii"), float(st[name]), ptype, len(st), st.index(name))

    def handle(self, cid: int, msg, t_us: int) -> bool:
        name = msg.get_type()
        if name == "PARAM_REQUEST_LIST":
            self.listings[cid] = _Listing(cid)
            self.tick()
        elif name == "PARAM_REQUEST_READ":
            self._read(cid, msg)
        elif name == "PARAM_SET":
            self._set(cid, msg)
        else:
            return False
        return True

    def client_gone(self, cid: int) -> None:
        self.listings.pop(cid, None)

    def tick(self) -> None:
        if not self.listings:
            return
        now = self.clock()
        names = self.store.names()
        for cid, lst in list(self.listings.items()):
            if now < lst.next_at:
                continue
            end = min(lst.next_index + self.batch, len(names))
            for i in range(lst.next_index, end):
                self.send(cid, self.value_message(names[i]))
            lst.next_index = end
            lst.next_at = now + self.period_s
            if end >= len(names):
                del self.listings[cid]

    def _read(self, cid, msg) -> None:
        st = self.store
        idx = int(msg.param_index)
        if idx >= 0:
            names = st.names()
            if idx >= len(names):
                self.say(4, f"Param index {idx} out of range")
                return
            self.send(cid, self.value_message(names[idx]))
            return
        name = param_id(msg.param_id)
        if name not in st:
            self.say(4, f"Unknown parameter {name[:24]}")
            return
        self.send(cid, self.value_message(name))

    def _set(self, cid, msg) -> None:
        name = param_id(msg.param_id)
        st = self.store
        if name not in st:
            self.say(4, f"Unknown parameter {name[:24]}")
            return
        value = float(msg.param_value)
        old = st[name]
        reason = None
        if not math.isfinite(value):
            reason = f"{name}: not finite"
        else:
            reason = self.vehicle.set_param(name, value)
        if reason is not None:
            self.say(4, f"Param {name} refused: {reason}"[:50])
            self.send(cid, self.value_message(name))  # the old value, to the asker
            return
        self.broadcast(self.value_message(name))
        if st[name] != old and self.persist is not None:
            self.persist()
