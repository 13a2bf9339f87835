"""MAVLink 2 message signing (mavlink.io, "Message Signing"), sans-IO, and its key file.

A signed frame is an ordinary MAVLink 2 frame with bit 0x01 of its incompatibility
flags set (before the CRC is computed) and 13 bytes appended after the CRC:

    link id (1 byte) | timestamp (6 bytes, little-endian) | signature (6 bytes)

    signature = first 6 bytes of SHA-256(secret_key + header + payload + CRC + link id + timestamp)

The timestamp counts 10 microsecond units since 1 January 2015 GMT (Unix time
1420070400 s). The rules this module applies, from the specification and ArduPilot's
``GCS_Signing.cpp``:

* once a key is set, every message we send is signed; our timestamp goes up by at least
  one per message sent and never falls behind the clock;
* an incoming frame is accepted only if its signature is right for our key, and its
  timestamp is newer than the last one accepted on its stream, a stream being
  (system id, component id, link id) -- one table for every connection, so a frame
  captured on one connection and replayed on another is still a replay; a stream not
  seen before is accepted only if its timestamp is at most one minute behind ours;
* the timestamp of an accepted frame moves ours forward when it is ahead;
* unsigned frames are refused except RADIO_STATUS and RADIO (ArduPilot's
  ``accept_unsigned_callback``: telemetry radios inject them unsigned);
* at start-up our timestamp is the larger of the clock's and just over one minute past
  the stored one (ArduPilot: one minute past; the timestamp is stored every 30 s and at
  shutdown, so a frame accepted before a clean restart is refused after it).

The secret key never appears in logs: ``Codec.unsigned`` turns a signed frame into the
same frame unsigned for the telemetry log, as the specification asks.
"""
from __future__ import annotations

import hashlib
import os
import struct
import time
from pathlib import Path

EPOCH_2015_S = 1420070400          # Unix time of 1 January 2015 00:00 GMT
UNITS_PER_S = 100_000              # timestamp units: 10 us
ONE_MINUTE = 60 * UNITS_PER_S      # the new-stream window and the restart margin
TIMESTAMP_MAX = (1 << 48) - 1      # the signature's 48-bit timestamp
SIGNATURE_LEN = 13
IFLAG_SIGNED = 0x01
KEY_LEN = 32
MAX_STREAMS = 256                  # remembered (sysid, compid, link id) streams
# accepted unsigned (ArduPilot's accept list): RADIO_STATUS 109, RADIO 166
ACCEPT_UNSIGNED = frozenset({109, 166})

UNSIGNED, BAD_SIGNATURE, REPLAY, TOO_OLD, TABLE_FULL = ("unsigned", "bad signature", "replay",
                                                       "too old", "stream table full")
_TS = struct.Struct("<Q")


def clock_timestamp(unix_s: float) -> int:
    """Signing timestamp (10 us units since 2015) of a Unix time."""
    return max(int((unix_s - EPOCH_2015_S) * UNITS_PER_S), 0)


def passphrase_key(passphrase: str) -> bytes:
    """The 32-byte key of a passphrase, as MAVProxy's ``signing setup PASSPHRASE`` makes
    it: SHA-256 of the passphrase's bytes."""
    return hashlib.sha256(passphrase.encode("utf-8")).digest()


class KeyFileError(ValueError):
    pass


def read_key_file(path: str | Path) -> bytes:
    """A key file for ``--signing-key``: its first line is either 64 hexadecimal digits
    (the key itself) or a passphrase (hashed as MAVProxy's ``signing setup`` does, so
    the same passphrase there and here gives the same key)."""
    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as e:
        raise KeyFileError(f"signing key {path}: {e}") from None
    line = text.splitlines()[0].strip() if text.strip() else ""
    if not line:
        raise KeyFileError(f"signing key {path}: empty (expected a passphrase or 64 hex digits)")
    if len(line) == 2 * KEY_LEN:
        try:
            key = bytes.fromhex(line)
        except ValueError:
            key = passphrase_key(line)
    else:
        key = passphrase_key(line)
    if not any(key):
        raise KeyFileError(f"signing key {path}: an all-zero key means 'no key'")
    return key


def group_or_other_readable(path: str | Path) -> bool:
    try:
        return bool(os.stat(path).st_mode & 0o077)
    except OSError:
        return False


class KeyStore:
    """The key and its last timestamp in a text file readable by the owner only (mode
    0600), beside the parameter store: ``key HEX`` and ``timestamp N`` lines. Written
    to a temporary file created 0600 and renamed over the old one, so a crash leaves
    either the old key or the new one."""

    def __init__(self, path: str | Path):
        self.path = Path(path)

    def load(self) -> tuple[bytes, int] | None:
        """(key, timestamp), or None when there is no usable stored key."""
        try:
            lines = self.path.read_text(encoding="ascii").splitlines()
        except (OSError, UnicodeDecodeError):
            return None
        fields = dict(ln.split(None, 1) for ln in lines if ln.strip() and not ln.startswith("#")
                      and len(ln.split(None, 1)) == 2)
        try:
            key = bytes.fromhex(fields["key"].strip())
            ts = int(fields.get("timestamp", "0"))
        except (KeyError, ValueError):
            return None
        if len(key) != KEY_LEN or not any(key) or ts < 0:
            return None
        return key, ts

    def save(self, key: bytes, timestamp: int) -> None:
        tmp = self.path.with_name(self.path.name + ".tmp")
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
        try:
            os.fchmod(fd, 0o600)   # also when the file was left behind by an earlier crash
            os.write(fd, (f"# MAVLink 2 signing key: keep secret (owner-only file)\n"
                          f"key {key.hex()}\ntimestamp {int(timestamp)}\n").encode("ascii"))
        finally:
            os.close(fd)
        os.replace(tmp, self.path)

    def remove(self) -> bool:
        try:
            self.path.unlink()
            return True
        except FileNotFoundError:
            return False


def key_store_beside(param_store: str | Path) -> KeyStore:
    """The key store of a parameter store: ``NAME.parm`` -> ``NAME.signing``."""
    p = Path(param_store)
    return KeyStore(p.with_name(p.stem + ".signing"))


class Signing:
    """The vehicle's signing state: key, timestamp, and the streams seen. Inactive (no
    key) accepts everything, as an autopilot without a key does."""

    def __init__(self, key: bytes | None = None, timestamp: int = 0, clock=time.time):
        self.clock = clock
        self.key: bytes | None = None
        self.timestamp = 0
        self.streams: dict[tuple[int, int, int], int] = {}
        if key is not None:
            self.set_key(key, timestamp)

    @property
    def active(self) -> bool:
        return self.key is not None

    def set_key(self, key: bytes | None, timestamp: int = 0) -> None:
        """Set the key (None or all zeros: signing off) and the least timestamp."""
        if key is None or not any(key):
            self.key = None
            self.streams.clear()
            return
        if len(key) != KEY_LEN:
            raise ValueError(f"a signing key is {KEY_LEN} bytes, not {len(key)}")
        self.key = bytes(key)
        self.streams.clear()
        self.timestamp = min(max(self.timestamp, int(timestamp), clock_timestamp(self.clock())),
                             TIMESTAMP_MAX)

    def restore(self, key: bytes, stored_timestamp: int) -> None:
        """Start-up from the store: just over one minute past the stored timestamp (or
        the clock, if later), so that no frame at or before the stored timestamp -- every
        frame seen before a clean shutdown, which stores the last one -- is accepted
        again on a stream the restart has forgotten."""
        self.set_key(key, stored_timestamp + ONE_MINUTE + 1)

    # ------------------------------------------------------------------ sending ---
    def next_timestamp(self) -> int:
        ts = self.timestamp + 1
        now = clock_timestamp(self.clock())
        if now > ts:
            ts = now
        if ts > TIMESTAMP_MAX:              # 48 bits: about 890 years after 2015
            ts = TIMESTAMP_MAX
        self.timestamp = ts
        return ts

    def signature(self, frame: bytes, link_id: int) -> bytes:
        """The 13 bytes to append to ``frame`` (a MAVLink 2 frame whose incompatibility
        flags already have IFLAG_SIGNED, CRC included)."""
        tail = bytes((link_id & 0xFF,)) + _TS.pack(self.next_timestamp())[:6]
        return tail + hashlib.sha256(self.key + frame + tail).digest()[:6]

    # ---------------------------------------------------------------- receiving ---
    def check(self, frame: bytes) -> str | None:
        """None if the frame is accepted, else why it is refused (a module constant).
        Call only while active. ``frame`` is the whole frame as received."""
        signed = len(frame) > 12 and frame[0] == 0xFD and frame[2] & IFLAG_SIGNED
        if not signed:
            msg_id = (frame[7] | frame[8] << 8 | frame[9] << 16) if frame[0] == 0xFD else frame[5]
            return None if msg_id in ACCEPT_UNSIGNED else UNSIGNED
        if hashlib.sha256(self.key + frame[:-6]).digest()[:6] != frame[-6:]:
            return BAD_SIGNATURE
        ts = _TS.unpack(frame[-12:-6] + b"\0\0")[0]
        stream = (frame[5], frame[6], frame[-13])
        last = self.streams.get(stream)
        if last is not None:
            if ts <= last:
                return REPLAY
        else:
            if ts + ONE_MINUTE < self.timestamp:
                return TOO_OLD
            if len(self.streams) >= MAX_STREAMS and not self._forget_a_stale_stream():
                return TABLE_FULL
        self.streams[stream] = ts
        if ts > self.timestamp:
            self.timestamp = ts
        return None

    def _forget_a_stale_stream(self) -> bool:
        """Forget the stream with the oldest timestamp if it is more than a minute behind
        ours (any frame of it would be refused as too old anyway); else keep them all."""
        stream, ts = min(self.streams.items(), key=lambda kv: kv[1])
        if ts + ONE_MINUTE < self.timestamp:
            del self.streams[stream]
            return True
        return False

