"""MAVLink 2 codec: bytes in, messages out; messages in, bytes out. No sockets here.

Messages are pymavlink's generated ``ardupilotmega`` dialect classes, used directly
(never ``mavutil``, whose dialect and protocol version are chosen by environment
variables at import). The framing, however, is our own, for two reasons:

* speed: the lockstep loop moves four messages per 10 ms step, and pymavlink's
  general-purpose parser costs more than the flight software itself. Frames are found
  with ``bytes.find``, checked with the C CRC that pymavlink itself uses when it is
  installed (``fastcrc``'s CRC-16/MCRF4XX, the X.25 CRC of the MAVLink specification),
  and payloads are unpacked with each message class's own ``struct`` layout. The
  lockstep ends pack each payload with one struct call straight from their values
  (``frame``) and hand each received one to its message id's handler, chosen once
  (``dispatch`` with a :class:`Routes`);
* robustness: a frame that fails its CRC, carries an unknown message id or an unknown
  incompatibility flag costs only its start byte: scanning resumes right behind it, so
  garbage on a link never swallows the good frames that follow it.

MAVLink 1 frames are understood (decoded); we send MAVLink 2. Signed frames are handed
to pymavlink's decoder (the signature is checked by the caller, ``signing.py``); with a
:class:`~autopilot.link.signing.Signing` in ``Codec.signing`` every frame ``encode``
makes is signed. Everything on the wire stays standard MAVLink bytes.
"""
from __future__ import annotations

import struct
from operator import itemgetter

from pymavlink.dialects.v20 import ardupilotmega as mavlink2

# (called with the data alone: its start value is the MAVLink one, 0xFFFF, and a second
# argument costs the Rust binding about 150 instructions a call to read)
try:  # the C CRC pymavlink uses when available
    from fastcrc.crc16 import mcrf4xx as _crc16
except ImportError:  # pragma: no cover - pure-Python fallback, same results
    def _crc16(data: bytes, crc: int = 0xFFFF) -> int:
        c = mavlink2.x25crc()
        c.crc = crc
        c.accumulate(data)
        return c.crc

MAV = mavlink2  # the dialect module: message classes and enums

STX_V2 = 0xFD
STX_V1 = 0xFE
_V2_HEADER = struct.Struct("<BBBBBBBHB")
# the header after the magic byte, flags 0, up to its sequence number: what changes from
# frame to frame of one message (the rest, the ids, is the same: Codec._frame_ends)
_LEN_SEQ = struct.Struct("<BxxB").pack
# the lockstep decoder's look at a header: magic, length with the incompatibility flags
# above it, and the 3-byte message id read with the payload's first byte above it
_fast_head = struct.Struct("<BH4xI").unpack_from
_V1_HEADER = struct.Struct("<BBBBBB")
_CRC = struct.Struct("<H")
_MAP = mavlink2.mavlink_map
_EXTRA = {msg_id: bytes((cls.crc_extra,)) for msg_id, cls in _MAP.items()}  # CRC extra byte


def _field_plan(cls):
    """(start, length) of each declared field in the unpacked wire-order tuple, or None
    when the message has text fields (decoded by pymavlink instead)."""
    if "s" in cls.unpacker.format or "c" in cls.unpacker.format:
        return None
    plan = []
    for order in cls.orders:
        plan.append((sum(cls.lengths[:order]), cls.lengths[order]))
    return tuple(plan)


_PLANS: dict[int, tuple | None] = {}


class _Flat:
    """For one message class: the declared-order flat field list <-> the wire-order
    tuple of its struct (arrays flattened in place), as C-level itemgetters (``tuple``,
    which hands a tuple back as it is, when the two orders agree: HIL_SENSOR,
    HIL_STATE_QUATERNION); what framing needs (the struct, the zeros its truncated
    payloads lost, the CRC extra byte, the id's header fields); in a :class:`Routes`, the
    handler its messages go to."""

    __slots__ = ("cls", "msg_id", "to_declared", "to_wire", "n", "pack", "unpack_from",
                 "extra", "zeros", "size", "id_low", "id_high", "handler")

    def __init__(self, cls, handler=None):
        plan = _field_plan(cls)
        if plan is None:
            raise ValueError(f"{cls.msgname} has text fields: no flat form")
        flat = [k for s, ln in plan for k in range(s, s + ln)]
        inverse = [0] * len(flat)
        for declared, wire in enumerate(flat):
            inverse[wire] = declared
        self.cls = cls
        if flat == inverse == list(range(len(flat))):
            self.to_declared = self.to_wire = tuple
        else:
            self.to_declared = itemgetter(*flat)
            self.to_wire = itemgetter(*inverse)
        self.n = len(flat)
        self.pack = cls.unpacker.pack
        self.unpack_from = cls.unpacker.unpack_from
        self.extra = bytes((cls.crc_extra,))
        self.size = cls.unpacker.size
        self.zeros = bytes(self.size)     # pads a truncated payload back to its size
        self.msg_id = msg_id = cls.id
        self.id_low, self.id_high = msg_id & 0xFFFF, msg_id >> 16
        self.handler = handler   # a Routes entry's: called with the payload's values


_FLAT: dict[int, _Flat] = {}


def _flat(msg_id: int) -> _Flat:
    f = _FLAT.get(msg_id)
    if f is None:
        f = _FLAT[msg_id] = _Flat(_MAP[msg_id])
    return f


_RAW: dict[frozenset, dict[int, _Flat]] = {}
_NOTHING = ()   # dispatch's other messages when there were none


def _raw_flats(raw_ids: frozenset) -> dict[int, _Flat]:
    """msg_id -> _Flat of the ids a decode is asked to return raw (one look-up a frame)."""
    flats = _RAW.get(raw_ids)
    if flats is None:
        flats = _RAW[raw_ids] = {i: _flat(i) for i in raw_ids if i in _MAP and _field_plan(_MAP[i])}
    return flats


class Routes:
    """What a lockstep end does with each message id it reads, decided once (not per
    decode, nor per message by comparing ids): ``{msg_id: handler}``, each handler called
    with the message's values in the payload's own order (as ``encode_values(...,
    wire=True)`` takes them), in the order the messages arrive. For
    :meth:`Codec.dispatch`."""

    __slots__ = ("ids", "table")

    def __init__(self, handlers: dict):
        self.ids = frozenset(handlers)
        self.table = {i: _Flat(_MAP[i], h) for i, h in handlers.items()}

    def route(self, msgs: list) -> list:
        """``decode(..., self.ids, pairs=True)``'s pairs to their handlers; the other
        messages back."""
        others = []
        table = self.table
        for m in msgs:
            if type(m) is tuple:
                table[m[0]].handler(m[1])
            else:
                others.append(m)
        return others


class RawMessage:
    """A decoded message as a flat tuple of its field values in declared order (arrays
    flattened in place), with its source ids: what ``decode`` gives for ``raw_ids`` (the
    formation peers read it; the lockstep link asks for bare ``(msg_id, values)`` pairs, in
    the payload's own order)."""

    __slots__ = ("msg_id", "src_system", "src_component", "values")

    def __init__(self, msg_id: int, src_system: int, src_component: int, values: tuple):
        self.msg_id = msg_id
        self.src_system = src_system
        self.src_component = src_component
        self.values = values

    def get_type(self) -> str:
        return _MAP[self.msg_id].msgname


class Codec:
    """One MAVLink endpoint identity (system id, component id) with its own sequence
    counter and receive buffer."""

    def __init__(self, system_id: int = 1, component_id: int = 1):
        self.mav = mavlink2.MAVLink(None, srcSystem=system_id, srcComponent=component_id)
        self.mav.robust_parsing = True
        self._buf = bytearray()
        self.bad_frames = 0
        self.received = 0
        self.signing = None     # a Signing with a key: encode() signs every frame
        self.link_id = 0        # our link id in the signatures we make
        self.limited = False    # the last decode stopped at its limit (more may be pending)
        self._ends: dict[int, tuple[bytes, bytes]] = {}   # frame: msg_id -> its fixed bytes

    @property
    def pending(self) -> int:
        """Bytes received and not yet decoded (an incomplete frame, or what a
        ``decode(limit=...)`` left for later)."""
        return len(self._buf)

    @property
    def system_id(self) -> int:
        return self.mav.srcSystem

    @property
    def component_id(self) -> int:
        return self.mav.srcComponent

    # ------------------------------------------------------------------ encode ---
    def encode(self, msg, mavlink1: bool = False) -> bytes:
        """Pack a message object (from ``codec.mav.<name>_encode(...)``)."""
        if mavlink1:
            buf = msg.pack(self.mav, force_mavlink1=True)
        else:
            msg_id = msg._header.msgId  # (not msg.id: some messages have a field "id")
            mav = self.mav
            signing = self.signing if self.signing is not None and self.signing.active else None

            def frame(_mav, crc_extra, payload, force_mavlink1=False):
                p = payload.rstrip(b"\x00") or b"\x00"
                head = _V2_HEADER.pack(STX_V2, len(p), 0 if signing is None else 1, 0, mav.seq,
                                       mav.srcSystem, mav.srcComponent, msg_id & 0xFFFF, msg_id >> 16)
                body = head[1:] + p
                f = head[:1] + body + _CRC.pack(_crc16(body + bytes((crc_extra,))))
                return f if signing is None else f + signing.signature(f, self.link_id)

            msg._pack = frame  # the generated pack() lays out the payload, we frame it
            buf = msg.pack(mav)
        self.mav.seq = (self.mav.seq + 1) % 256
        return buf

    def encode_values(self, msg_id: int, values, wire: bool = False) -> bytes:
        """Pack a message from its field values in declared order, arrays flattened
        (the fast path of the lockstep link: no message object is built); with ``wire``
        in the payload's own order instead (the fields sorted by type size, as
        ``ordered_fieldnames``), which spares the reordering."""
        f = _FLAT.get(msg_id) or _flat(msg_id)
        return self.frame(msg_id, f.pack(*(values if wire else f.to_wire(values))))

    def frame(self, msg_id: int, payload: bytes) -> bytes:
        """The MAVLink 2 frame of a packed payload, in the message's own layout: what a
        lockstep end packs with one struct call straight from its values (a struct of
        its own may stand pad bytes for the fields it always leaves zero)."""
        p = payload.rstrip(b"\x00") or b"\x00"       # (MAVLink 2 truncates trailing zeros)
        ids, extra = self._ends.get(msg_id) or self._frame_ends(msg_id)
        mav = self.mav
        seq = mav.seq
        mav.seq = (seq + 1) % 256
        # header after the magic byte: len, incompat 0, compat 0, seq, then the ids
        body = _LEN_SEQ(len(p), seq) + ids + p
        # (one CRC call over body + extra byte: the same CRC, a call's cost less)
        return b"\xfd" + body + _CRC.pack(_crc16(body + extra))

    def _frame_ends(self, msg_id: int) -> tuple[bytes, bytes]:
        """A message's bytes that are the same in every frame we make of it: the header's
        sysid, compid and message id (after the sequence number), and its CRC extra byte."""
        f = _FLAT.get(msg_id) or _flat(msg_id)
        mav = self.mav
        ends = self._ends[msg_id] = (struct.pack("<BBHB", mav.srcSystem, mav.srcComponent, f.id_low,
                                                 f.id_high), f.extra)
        return ends

    # ------------------------------------------------------------------ decode ---
    def decode(self, data: bytes, raw_ids: frozenset = frozenset(), limit: int | None = None,
               pairs: bool = False) -> list:
        """Feed received bytes; return the complete, valid messages among them.
        Messages whose id is in ``raw_ids`` come back as :class:`RawMessage`, or with
        ``pairs`` as plain ``(msg_id, values)`` tuples whose values are in the payload's
        own order, as ``encode_values(..., wire=True)`` takes them (no object to build,
        no source ids, no reordering: what :meth:`dispatch` hands to its handlers).
        With ``limit``: stop after that many frames (messages plus rejected frames or
        stretches of garbage) and keep the rest for the next call (``pending``)."""
        buf = self._buf
        if buf:                 # the incomplete tail of the last call comes first
            buf += data
            data = bytes(buf)
            buf.clear()
        elif not data:
            return []
        elif type(data) is not bytes:
            data = bytes(data)
        out = []
        n = len(data)
        i = 0
        crc16 = _crc16
        if limit is None and raw_ids:
            i = self._whole_frames(data, _RAW.get(raw_ids) or _raw_flats(raw_ids), out, pairs)
            if i == n:
                self.limited = False
                self.received += len(out)
                return out
        find = data.find
        stop_at = None if limit is None else self.bad_frames + limit
        self.limited = False
        while i < n:
            if stop_at is not None and len(out) + self.bad_frames >= stop_at:
                self.limited = True
                break
            j = i
            c = data[j]
            if c != STX_V2 and c != STX_V1:
                j2 = find(b"\xfd", i)
                j1 = find(b"\xfe", i)
                if j2 < 0 and j1 < 0:
                    self.bad_frames += 1
                    i = n
                    break
                j = j2 if j1 < 0 or (0 <= j2 < j1) else j1
                self.bad_frames += 1  # bytes outside any frame
                c = data[j]
            if c == STX_V2:
                if n - j < 10:
                    i = j
                    break
                plen, incompat = data[j + 1], data[j + 2]
                hlen = 10
                total = 12 + plen + (13 if incompat & 0x01 else 0)
                if n - j < total:
                    i = j
                    break
                msg_id = data[j + 7] | (data[j + 8] << 8) | (data[j + 9] << 16)
            else:
                if n - j < 6:
                    i = j
                    break
                plen, incompat = data[j + 1], 0
                hlen = 6
                total = 8 + plen
                if n - j < total:
                    i = j
                    break
                msg_id = data[j + 5]
            cls = _MAP.get(msg_id)
            end = j + hlen + plen
            if cls is None or incompat & ~0x01 or \
                    (data[end] | (data[end + 1] << 8)) != crc16(_EXTRA[msg_id], crc16(data[j + 1:end])):
                self.bad_frames += 1  # unknown id, unknown flags or bad CRC: resync
                i = j + 1
                continue
            if msg_id in raw_ids and not incompat:
                f = _FLAT.get(msg_id) or _flat(msg_id)
                t = f.unpack_from(data[j + hlen:end] + f.zeros)
                if pairs:
                    out.append((msg_id, t))
                elif hlen == 10:
                    out.append(RawMessage(msg_id, data[j + 5], data[j + 6], f.to_declared(t)))
                else:
                    out.append(RawMessage(msg_id, data[j + 3], data[j + 4], f.to_declared(t)))
                i = j + total
                continue
            m = self._message(cls, msg_id, data[j:j + total], hlen, plen, incompat)
            if m is not None:
                out.append(m)
            i = j + total
        if i < n:
            buf += data[i:]
        self.received += len(out)
        return out

    def dispatch(self, data: bytes, routes: Routes) -> list | tuple:
        """Feed received bytes: each message whose id ``routes`` knows goes to its handler
        (the lockstep link's form: no message object, no pair, no list of them); the
        other messages come back as ``decode`` gives them."""
        if self._buf or type(data) is not bytes:     # (the tail of the last call comes first)
            return routes.route(self.decode(data, routes.ids, pairs=True))
        i = self._whole_frames(data, routes.table, None, True)
        if i == len(data):
            self.limited = False
            return _NOTHING
        return routes.route(self.decode(data[i:], routes.ids, pairs=True))

    def _whole_frames(self, data: bytes, table: dict, out: list | None, pairs: bool) -> int:
        """The lockstep stream's case: whole unsigned MAVLink 2 frames of ``table``'s ids
        (msg_id -> _Flat) back to back, read without the general loop's cases. Each goes
        to its entry's handler, or without one into ``out`` (a pair with ``pairs``, else a
        RawMessage). Returns where it stopped: at the end, or at anything else (another
        message, a partial frame, garbage, a signature), which the general loop reads."""
        n = len(data)
        i = handled = 0
        while n - i >= 12:
            stx, plen, word = _fast_head(data, i)
            f = table.get(word & 0xFFFFFF)
            end = i + 10 + plen
            if stx != STX_V2 or plen > 255 or f is None or end + 2 > n:   # (> 255: incompat flags)
                break
            body = data[i + 1:end]
            if (data[end] | (data[end + 1] << 8)) != _crc16(body + f.extra):
                break
            # the payload, its truncated zeros restored (unpack_from reads what it needs)
            t = f.unpack_from(data, i + 10) if plen == f.size else f.unpack_from(body + f.zeros, 9)
            handler = f.handler
            if handler is not None:
                handler(t)
                handled += 1
            elif pairs:
                out.append((f.msg_id, t))
            else:
                out.append(RawMessage(f.msg_id, data[i + 5], data[i + 6], f.to_declared(t)))
            i = end + 2
        self.received += handled
        return i

    @staticmethod
    def unsigned(frame: bytes) -> bytes:
        """The same MAVLink 2 frame without its signature (flag cleared, CRC recomputed),
        for logs: the specification keeps signatures out of telemetry logs."""
        if not (len(frame) > 25 and frame[0] == STX_V2 and frame[2] & 0x01):
            return bytes(frame)
        msg_id = frame[7] | (frame[8] << 8) | (frame[9] << 16)
        extra = _EXTRA.get(msg_id)
        if extra is None:
            return bytes(frame)
        plen = frame[1]
        body = bytes((plen, frame[2] & 0xFE)) + bytes(frame[3:10 + plen])
        return b"\xfd" + body + _CRC.pack(_crc16(extra, _crc16(body)))

    def _message(self, cls, msg_id: int, frame: bytes, hlen: int, plen: int, incompat: int):
        plan = _PLANS.get(msg_id, False)
        if plan is False:
            plan = _PLANS[msg_id] = _field_plan(cls)
        if plan is None or incompat:
            try:
                return self.mav.decode(bytearray(frame))
            except mavlink2.MAVError:
                self.bad_frames += 1
                return None
        payload = frame[hlen:hlen + plen]
        size = cls.unpacker.size
        if plen < size:
            payload = payload + bytes(size - plen)
        t = cls.unpacker.unpack(payload[:size])
        args = [t[s] if ln == 1 else list(t[s:s + ln]) for s, ln in plan]
        m = cls(*args)
        if hlen == 10:
            _, _, incompat_f, compat_f, seq, sysid, compid, _, _ = _V2_HEADER.unpack_from(frame)
        else:
            _, _, seq, sysid, compid, _ = _V1_HEADER.unpack_from(frame)
            incompat_f = compat_f = 0
        m._header = mavlink2.MAVLink_header(msg_id, incompat_f, compat_f, plen, seq, sysid, compid)
        m._msgbuf = bytearray(frame)
        m._payload = payload
        m._crc = _CRC.unpack_from(frame, hlen + plen)[0]
        return m
