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
        """Feed received bytes; return the complete, valid messages among them.

        Resynchronisation: when a frame fails (bad CRC, bad length), pymavlink has
        consumed as many bytes as its corrupt header claimed, which may swallow good
        frames behind it. We rewind to the byte after the failed frame's start marker
        and scan again, as a byte-wise parser would, so garbage costs only itself."""
        out = []
        if not data:
            return out
        mav = self.mav
        m = mav.parse_char(data)
        while m is not None:
            if isinstance(m, mavlink2.MAVLink_bad_data):
                self.bad_frames += 1
                if m.reason != "Bad prefix" and len(m.data) > 1:
                    mav.buf_index -= len(m.data) - 1
                    mav.expected_length = 8
            elif isinstance(m, mavlink2.MAVLink_unknown):
                # an id this dialect does not know: its CRC cannot be checked, so it is
                # as likely garbage as a frame; drop it and rescan behind its marker
                self.bad_frames += 1
                buf = m.get_msgbuf()
                if len(buf) > 1:
                    mav.buf_index -= len(buf) - 1
                    mav.expected_length = 8
            else:
                out.append(m)
            m = mav.parse_char(b"")
        self.received += len(out)
        return out
