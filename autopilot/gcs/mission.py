"""The MAVLink mission service (mavlink.io/en/services/mission.html), vehicle side, sans-IO.

Messages in, messages out, on a clock the caller passes in (wall time: the ground station
answers in wall time), so tests drive every path with a fake clock.

Upload (GCS -> vehicle)::

    MISSION_COUNT(n) -> MISSION_REQUEST_INT(0) -> MISSION_ITEM_INT(0) -> ... -> MISSION_ACK

One upload at a time per mission type (mission, fence and rally uploads may overlap,
as MAVProxy sends them and ArduPilot takes them): a second client's MISSION_COUNT during
an upload is answered MAV_MISSION_DENIED; the same client's restarts it. An item
request unanswered for ``timeout_s`` is sent again, at most ``retries`` times, then the upload is cancelled
(MAV_MISSION_OPERATION_CANCELLED). Items are checked one by one as they arrive
(``item_problem``) and the whole mission at the end (``validate_mission``), both for the
vehicle served: a command it does not fly is MAV_MISSION_UNSUPPORTED, a mission that
cannot be flown (a DO_JUMP loop without a navigation item) MAV_MISSION_INVALID_PARAM1,
each with a STATUSTEXT naming the item. Any refusal ends the upload with the matching
MAV_MISSION_RESULT, and only a complete, valid mission replaces the active one
(``vehicle.set_mission``), atomically. A duplicate item (already
received) is ignored; an item from the future is ignored and the expected one requested
again. Legacy clients: a MISSION_ITEM answers a request like a MISSION_ITEM_INT, and a
client that speaks the legacy messages (or ignores the first MISSION_REQUEST_INT) is
asked with MISSION_REQUEST from then on.

Download (vehicle -> GCS) is driven by the ground station, which owns its timeouts:
MISSION_REQUEST_LIST -> MISSION_COUNT, then each MISSION_REQUEST_INT / MISSION_REQUEST
is answered with the item as MISSION_ITEM_INT / MISSION_ITEM. The items sent back are
the ones uploaded, byte for byte (item 0 included); the vehicle itself flies a copy whose
item 0 is replaced by home when the uploaded one is not a usable absolute position
(MAVSDK clears an ArduPilot mission by uploading a lone relative-frame item 0).

MISSION_CLEAR_ALL leaves the home item only.

Fence and rally points (MAV_MISSION_TYPE_FENCE / _RALLY) go through the same exchanges
with their mission_type in every message, for a vehicle that has a ``geofence``
(autopilot/fence): no home item there, item 0 is the first zone vertex or rally point.
Each item is checked as it arrives (``fence_item_problem``) and the whole set at the end
(``fence_items_problem``: a polygon's vertex count, vertices that disagree with it, two
return points), a refusal answered with its MAV_MISSION_RESULT and a STATUSTEXT, the
fence or rally points in force kept. A count of 0, or MISSION_CLEAR_ALL of the type,
clears them; MISSION_CLEAR_ALL of MAV_MISSION_TYPE_ALL clears all three.
"""
from __future__ import annotations

import math

from ..fence.geofence import (MISSION_TYPE_FENCE, MISSION_TYPE_RALLY, fence_item_problem,
                              fence_items_problem, rally_items_problem)
from ..link.codec import MAV
from ..mission.items import (ABSOLUTE_ALT_FRAMES, FRAME_GLOBAL, MISSION_TYPE_MISSION, NAV_WAYPOINT,
                             Mission, MissionItem, item_problem, validate_mission, vehicle_kind)

MISSION_TIMEOUT_S = 1.5     # mavlink.io: item request timeout (ms 1500)
MISSION_RETRIES = 5
MAX_ITEMS = 5000            # above this: MAV_MISSION_NO_SPACE


def result_code(name: str) -> int:
    return int(getattr(MAV, name, MAV.MAV_MISSION_ERROR))


class _Upload:
    __slots__ = ("cid", "sysid", "compid", "count", "items", "expected", "deadline",
                 "tries", "legacy", "mtype")

    def __init__(self, cid, sysid, compid, count, now, timeout_s, legacy, mtype=MISSION_TYPE_MISSION):
        self.mtype = mtype
        self.cid, self.sysid, self.compid = cid, sysid, compid
        self.count = count
        self.items: list[MissionItem] = []
        self.expected = 0
        self.deadline = now + timeout_s
        self.tries = 0
        self.legacy = legacy


class MissionServer:
    """``send(cid, msg)`` delivers a reply to one client; ``say(severity, text)``
    broadcasts a STATUSTEXT; ``home_item()`` gives home as an absolute MissionItem or
    None; ``clock()`` is the wall clock of the protocol timers."""

    def __init__(self, vehicle, send, say, home_item, clock, timeout_s: float = MISSION_TIMEOUT_S,
                 retries: int = MISSION_RETRIES, max_items: int = MAX_ITEMS):
        self.vehicle = vehicle
        self.kind = vehicle_kind(vehicle.mav_type)   # what it flies (mission.items)
        self.send = send
        self.say = say
        self.home_item = home_item
        self.clock = clock
        self.timeout_s = timeout_s
        self.retries = retries
        self.max_items = max_items
        self.uploads: dict[int, _Upload] = {}   # by mission_type: each type has its own
        self.legacy_clients: set[int] = set()
        self._wire: tuple[MissionItem, ...] = ()
        self._flown: Mission | None = None       # the Mission object _wire belongs to
        self.uploads_accepted = 0
        self.uploads_refused = 0

    # ------------------------------------------------------------------- state ---
    @property
    def upload(self) -> _Upload | None:
        """The plain mission's upload in progress, else any (None: none)."""
        return self.uploads.get(MISSION_TYPE_MISSION) or next(iter(self.uploads.values()), None)

    @property
    def wire_items(self) -> tuple[MissionItem, ...]:
        """The mission as a ground station downloads it (item 0 = home)."""
        m = self.vehicle.mission
        if m is not self._flown:
            # set by someone else (the mission file at start): show it as it is
            self._flown = m
            self._wire = tuple(m.items) if m is not None else ()
            if not self._wire:
                h = self.home_item()
                self._wire = (h,) if h is not None else ()
        return self._wire

    # ---------------------------------------------------------------- dispatch ---
    def handle(self, cid: int, msg, t_us: int) -> bool:
        """Handle one mission message; False if it is not one."""
        name = msg.get_type()
        fn = _HANDLERS.get(name)
        if fn is None:
            return False
        fn(self, cid, msg, t_us)
        return True

    def client_gone(self, cid: int) -> None:
        self.legacy_clients.discard(cid)
        for t, up in list(self.uploads.items()):
            if up.cid == cid:
                del self.uploads[t]  # the old mission stays

    def tick(self) -> None:
        """Timeouts and retries of the upload in progress."""
        for up in list(self.uploads.values()):
            self._tick(up)

    def _tick(self, up: _Upload) -> None:
        now = self.clock()
        if now < up.deadline:
            return
        if up.tries >= self.retries:
            self.uploads.pop(up.mtype, None)
            self.uploads_refused += 1
            self._ack(up.cid, up.sysid, up.compid, "MAV_MISSION_OPERATION_CANCELLED", up.mtype)
            self.say(4, f"{_TYPE_WORD[up.mtype]} upload timed out at item {up.expected} of {up.count}")
            return
        up.tries += 1
        if up.tries == 1 and not up.legacy and up.expected == 0:
            up.legacy = True  # no answer to MISSION_REQUEST_INT: try the legacy request
        elif up.tries > 1 and up.expected == 0:
            up.legacy = not up.legacy
        self._request(up, now)

    # ------------------------------------------------------------------ upload ---
    def _ack(self, cid, sysid, compid, code: str, mission_type: int = MISSION_TYPE_MISSION):
        self.send(cid, MAV.MAVLink_mission_ack_message(sysid, compid, result_code(code), mission_type))

    def _request(self, up: _Upload, now: float) -> None:
        cls = MAV.MAVLink_mission_request_message if up.legacy else MAV.MAVLink_mission_request_int_message
        self.send(up.cid, cls(up.sysid, up.compid, up.expected, up.mtype))
        up.deadline = now + self.timeout_s

    def _on_count(self, cid, msg, t_us) -> None:
        sysid, compid = msg.get_srcSystem(), msg.get_srcComponent()
        mtype = getattr(msg, "mission_type", MISSION_TYPE_MISSION)
        if not self._supported(mtype):
            self._ack(cid, sysid, compid, "MAV_MISSION_UNSUPPORTED", mtype)
            return
        current = self.uploads.get(mtype)
        if current is not None and current.cid != cid:
            self._ack(cid, sysid, compid, "MAV_MISSION_DENIED", mtype)
            self.say(4, f"{_TYPE_WORD[mtype]} upload refused: another upload in progress")
            return
        count = int(msg.count)
        if count > self.max_items:
            self.uploads.pop(mtype, None)
            self._ack(cid, sysid, compid, "MAV_MISSION_NO_SPACE", mtype)
            self.say(4, f"{_TYPE_WORD[mtype]} upload refused: {count} items, at most {self.max_items}")
            return
        if count == 0:
            self.uploads.pop(mtype, None)
            self._clear_type(mtype, t_us)
            self._ack(cid, sysid, compid, "MAV_MISSION_ACCEPTED", mtype)
            return
        now = self.clock()
        up = self.uploads[mtype] = _Upload(cid, sysid, compid, count, now, self.timeout_s,
                                           cid in self.legacy_clients, mtype)
        self._request(up, now)

    def _on_item(self, cid, msg, t_us) -> None:
        legacy = msg.get_type() == "MISSION_ITEM"
        if legacy:
            self.legacy_clients.add(cid)
        mtype = getattr(msg, "mission_type", MISSION_TYPE_MISSION)
        up = self.uploads.get(mtype)
        if up is None or up.cid != cid:
            return  # nothing asked for it: ignore (a late duplicate)
        seq = int(msg.seq)
        if seq < up.expected:
            return  # a duplicate of an item we already have
        if seq > up.expected:
            self._request(up, self.clock())  # out of order: ask again for the expected one
            return
        up.legacy = legacy
        try:
            item = MissionItem.from_float(msg) if legacy else MissionItem.from_int(msg)
        except (TypeError, ValueError, OverflowError):
            item = None
        if mtype != MISSION_TYPE_MISSION:
            problem = None
            if item is not None:
                problem = (fence_item_problem(item) if mtype == MISSION_TYPE_FENCE
                           else rally_items_problem((item,)))
            if item is None or problem is not None:
                code = problem.code if problem is not None else "MAV_MISSION_INVALID"
                self._fail(up, code, problem.text if problem
                           else f"item {seq}: not a {_TYPE_WORD[mtype].lower()} item")
                return
        else:
            problem = item_problem(item, self.kind) if item is not None else None
        if item is None or (problem is not None and seq > 0):
            code = problem.code if problem is not None else "MAV_MISSION_INVALID"
            self._fail(up, code, f"item {seq}: {problem.text if problem else 'not a mission item'}")
            return
        if problem is not None:  # item 0 (home) is replaced for flying; keep it encodable
            item = item.replace(x_lat_deg=_clip(item.x_lat_deg, 90.0), y_lon_deg=_clip(item.y_lon_deg, 180.0),
                                z_alt_m=_finite(item.z_alt_m))
        up.items.append(item)
        up.expected += 1
        up.tries = 0
        if up.expected < up.count:
            self._request(up, self.clock())
            return
        self._finish(up, t_us)

    def _fail(self, up: _Upload, code: str, text: str) -> None:
        self.uploads.pop(up.mtype, None)
        self.uploads_refused += 1
        self._ack(up.cid, up.sysid, up.compid, code, up.mtype)
        self.say(4, f"{_TYPE_WORD[up.mtype]} refused: {text}")

    def _finish(self, up: _Upload, t_us: int) -> None:
        wire = tuple(up.items)
        if up.mtype != MISSION_TYPE_MISSION:
            self._finish_other(up, wire, t_us)
            return
        flown = self._flown_copy(wire)
        problem = validate_mission(flown, self.kind)
        if problem is not None:
            self._fail(up, problem.code, f"item {problem.seq}: {problem.text}")
            return
        mission = Mission(flown)
        reason = self.vehicle.set_mission(mission, t_us)
        if reason is not None:
            self._fail(up, "MAV_MISSION_DENIED", reason)
            return
        self.uploads.pop(up.mtype, None)
        self._wire, self._flown = wire, mission
        self.uploads_accepted += 1
        self._ack(up.cid, up.sysid, up.compid, "MAV_MISSION_ACCEPTED")
        self.say(6, f"Mission: {len(wire) - 1} items received")

    def _finish_other(self, up: _Upload, wire: tuple, t_us: int) -> None:
        """The end of a fence or rally upload: the whole set checked, then handed over."""
        fence = up.mtype == MISSION_TYPE_FENCE
        problem = fence_items_problem(wire) if fence else rally_items_problem(wire)
        if problem is not None:
            self._fail(up, problem.code, problem.text)
            return
        setter = self.vehicle.set_fence if fence else self.vehicle.set_rally
        reason = setter(wire, t_us)
        if reason is not None:
            self._fail(up, "MAV_MISSION_DENIED", reason)
            return
        self.uploads.pop(up.mtype, None)
        self.uploads_accepted += 1
        self._ack(up.cid, up.sysid, up.compid, "MAV_MISSION_ACCEPTED", up.mtype)
        self.say(6, f"{_TYPE_WORD[up.mtype]}: {len(wire)} items received")

    def _supported(self, mtype: int) -> bool:
        if mtype == MISSION_TYPE_MISSION:
            return True
        return mtype in (MISSION_TYPE_FENCE, MISSION_TYPE_RALLY) and hasattr(self.vehicle, "geofence")

    def _items_of(self, mtype: int) -> tuple:
        if mtype == MISSION_TYPE_MISSION:
            return self.wire_items
        g = self.vehicle.geofence
        return g.fence_items if mtype == MISSION_TYPE_FENCE else g.rally_items

    def _clear_type(self, mtype: int, t_us: int) -> None:
        if mtype == MISSION_TYPE_MISSION:
            self._clear(t_us)
        elif mtype == MISSION_TYPE_FENCE:
            if self.vehicle.set_fence((), t_us) is None:
                self.say(6, "Fence cleared")
        else:
            if self.vehicle.set_rally((), t_us) is None:
                self.say(6, "Rally points cleared")

    def _flown_copy(self, wire: tuple[MissionItem, ...]) -> tuple[MissionItem, ...]:
        """The uploaded items with a usable home as item 0 (the vehicle's copy)."""
        if not wire:
            return wire
        h0 = wire[0]
        usable = (h0.command == NAV_WAYPOINT and h0.frame in ABSOLUTE_ALT_FRAMES
                  and (h0.x_lat_deg, h0.y_lon_deg) != (0.0, 0.0) and item_problem(h0) is None)
        if usable:
            return wire
        h = self.home_item()
        if h is None:
            h = MissionItem(0, FRAME_GLOBAL, NAV_WAYPOINT, 0, 1, 0, 0, 0, 0,
                            _finite(h0.x_lat_deg), _finite(h0.y_lon_deg), _finite(h0.z_alt_m))
        return (h.replace(seq=0),) + wire[1:]

    def _clear(self, t_us: int) -> None:
        h = self.home_item()
        if h is None:
            wire = self.wire_items
            if not wire:
                return
            h = wire[0]
        mission = Mission(self._flown_copy((h.replace(seq=0),)))
        if self.vehicle.set_mission(mission, t_us) is None:
            self._wire, self._flown = (h.replace(seq=0),), mission
            self.say(6, "Mission cleared")

    def _on_clear(self, cid, msg, t_us) -> None:
        sysid, compid = msg.get_srcSystem(), msg.get_srcComponent()
        mtype = getattr(msg, "mission_type", MISSION_TYPE_MISSION)
        if mtype == MAV.MAV_MISSION_TYPE_ALL:
            types = [t for t in (MISSION_TYPE_MISSION, MISSION_TYPE_FENCE, MISSION_TYPE_RALLY)
                     if self._supported(t)]
        elif self._supported(mtype):
            types = [mtype]
        else:
            self._ack(cid, sysid, compid, "MAV_MISSION_UNSUPPORTED", mtype)
            return
        if any(t in self.uploads for t in types):
            self._ack(cid, sysid, compid, "MAV_MISSION_DENIED", mtype)
            return
        for t in types:
            self._clear_type(t, t_us)
        self._ack(cid, sysid, compid, "MAV_MISSION_ACCEPTED", mtype)

    def _on_ack(self, cid, msg, t_us) -> None:
        up = self.uploads.get(getattr(msg, "mission_type", MISSION_TYPE_MISSION))
        if up is not None and up.cid == cid and msg.type != MAV.MAV_MISSION_ACCEPTED:
            del self.uploads[up.mtype]  # the ground station gave up: the old mission stays

    # ---------------------------------------------------------------- download ---
    def _on_request_list(self, cid, msg, t_us) -> None:
        sysid, compid = msg.get_srcSystem(), msg.get_srcComponent()
        mtype = getattr(msg, "mission_type", MISSION_TYPE_MISSION)
        if not self._supported(mtype):
            self._ack(cid, sysid, compid, "MAV_MISSION_UNSUPPORTED", mtype)
            return
        self.send(cid, MAV.MAVLink_mission_count_message(sysid, compid, len(self._items_of(mtype)),
                                                         mtype))

    def _on_request(self, cid, msg, t_us) -> None:
        sysid, compid = msg.get_srcSystem(), msg.get_srcComponent()
        mtype = getattr(msg, "mission_type", MISSION_TYPE_MISSION)
        if not self._supported(mtype):
            self._ack(cid, sysid, compid, "MAV_MISSION_UNSUPPORTED", mtype)
            return
        legacy = msg.get_type() == "MISSION_REQUEST"
        if legacy:
            self.legacy_clients.add(cid)
        wire = self._items_of(mtype)
        seq = int(msg.seq)
        if not 0 <= seq < len(wire):
            self._ack(cid, sysid, compid, "MAV_MISSION_INVALID_SEQUENCE", mtype)
            return
        it = wire[seq]
        current = 1 if mtype == MISSION_TYPE_MISSION and seq == self.vehicle.current_seq() else 0
        if legacy:
            self.send(cid, MAV.MAVLink_mission_item_message(
                sysid, compid, seq, it.frame, it.command, current, it.autocontinue,
                it.param1, it.param2, it.param3, it.param4, it.x_lat_deg, it.y_lon_deg,
                it.z_alt_m, mtype))
        else:
            f = it.to_int()
            self.send(cid, MAV.MAVLink_mission_item_int_message(
                sysid, compid, seq, it.frame, it.command, current, it.autocontinue,
                it.param1, it.param2, it.param3, it.param4, f["x"], f["y"], it.z_alt_m,
                mtype))

    # ------------------------------------------------------------- set current ---
    def set_current(self, seq: int, t_us: int) -> str | None:
        n = len(self.wire_items)
        if not 0 < seq < n:
            return f"no mission item {seq}"
        return self.vehicle.set_current(seq, t_us)

    def _on_set_current(self, cid, msg, t_us) -> None:
        reason = self.set_current(int(msg.seq), t_us)
        if reason is not None:
            self.say(4, f"Set current refused: {reason}")


_TYPE_WORD = {MISSION_TYPE_MISSION: "Mission", MISSION_TYPE_FENCE: "Fence", MISSION_TYPE_RALLY: "Rally"}


def _finite(v: float) -> float:
    return v if math.isfinite(v) else 0.0


def _clip(v: float, limit: float) -> float:
    return min(max(_finite(v), -limit), limit)


_HANDLERS = {
    "MISSION_COUNT": MissionServer._on_count,
    "MISSION_ITEM_INT": MissionServer._on_item,
    "MISSION_ITEM": MissionServer._on_item,
    "MISSION_REQUEST_LIST": MissionServer._on_request_list,
    "MISSION_REQUEST_INT": MissionServer._on_request,
    "MISSION_REQUEST": MissionServer._on_request,
    "MISSION_CLEAR_ALL": MissionServer._on_clear,
    "MISSION_SET_CURRENT": MissionServer._on_set_current,
    "MISSION_ACK": MissionServer._on_ack,
}
