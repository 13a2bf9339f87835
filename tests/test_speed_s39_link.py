"""Stop 39, link room: the codec calls its CRC with the data alone, relying on the
binding's start value being MAVLink's (0xFFFF)."""
import random

from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from autopilot.link.codec import _crc16


def test_crc_of_the_data_alone_is_mavlinks_x25_crc():
    rng = random.Random(39)
    for n in (0, 1, 9, 70, 255):
        data = bytes(rng.randrange(256) for _ in range(n))
        ref = mavlink2.x25crc()          # pymavlink's own: starts at 0xFFFF
        ref.accumulate(data)
        assert _crc16(data) == ref.crc == _crc16(data, 0xFFFF)
