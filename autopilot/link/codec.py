"""MAVLink 2 codec: bytes in, messages out; messages in, bytes out. No sockets here.

Uses pymavlink's generated ``ardupilotmega`` dialect class directly (never ``mavutil``,
whose dialect and protocol version are chosen by environment variables at import). A
corrupt frame never raises: pymavlink's robust parsing turns it into a bad-data record,
which is counted and dropped.
"""
from __future__ import annotations

from pymavlink.dialects.v20 import ardupilotmega as mavlink2

MAV = mavlink2  # the dialect module: message classes and enums


class Codec:
    """One MAVLink endpoint identity (system id, component id) with its own sequence
    counter and parser state."""

    def __init__(self, system_id: int = 1, component_id: int = 1):
        self.mav = mavlink2.MAVLink(None, srcSystem=system_id, srcComponent=component_id)
        self.mav.robust_parsing = True
        self.bad_frames = 0
        self.received = 0

    @property
    def system_id(self) -> int:
        return self.mav.srcSystem

    @property
    def component_id(self) -> int:
        return self.mav.srcComponent

    def encode(self, msg) -> bytes:
        """Pack a message object (from ``codec.mav.<name>_encode(...)``) as MAVLink 2."""
        buf = msg.pack(self.mav)
        self.mav.seq = (self.mav.seq + 1) % 256
        return buf

    def decode(self, data: bytes) -> list:
        """Feed received bytes; return the complete, valid messages among them."""
        out = []
        if not data:
            return out
        msgs = self.mav.parse_buffer(data)
        if not msgs:
            return out
        for m in msgs:
            if m.get_type() == "BAD_DATA":
                self.bad_frames += 1
                continue
            out.append(m)
        self.received += len(out)
        return out
