"""The ground-station link as a telemetry log (``.tlog``): what MAVProxy and QGC write,
and what pymavlink's ``mavlogdump.py`` reads.

Each record is an 8-byte big-endian timestamp in microseconds since the Unix epoch
followed by one MAVLink frame. Everything the vehicle sends is logged once (encoded for
the log with its own sequence numbers, so the log shows no false packet loss), and every
frame received from a ground station is logged as it arrived. Timestamps are the wall
time at which the service started plus the *simulation* time of the record, so the
intervals in the log are those of the flight whatever the speed-up.
"""
from __future__ import annotations

import struct
import time
from pathlib import Path

_TS = struct.Struct(">Q")


class TlogWriter:
    def __init__(self, path: str | Path, epoch_us: int | None = None):
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._f = open(self.path, "wb")  # closed by close(); the service owns its lifetime
        self.epoch_us = int(time.time() * 1e6) if epoch_us is None else epoch_us
        self.records = 0

    def write(self, t_us: int, frame: bytes) -> None:
        if self._f is None:
            return
        self._f.write(_TS.pack(self.epoch_us + t_us) + frame)
        self.records += 1

    def close(self) -> None:
        if self._f is not None:
            self._f.close()
            self._f = None
