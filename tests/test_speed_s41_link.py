"""The HIL link's lean packing (issue 18, stop 41): Codec.frame's fixed bytes worked out
once per message and codec are the header pymavlink writes, for any identity and any
sequence number; DISTANCE_SENSOR and ESC_TELEMETRY_1_TO_4 packed from the fields a
reading sets (the others as pad bytes) are the frames of the full values, byte for byte."""
import numpy as np
import pytest

from autopilot.link.codec import MAV, Codec
from autopilot.link.hil import HIL_IDS, ID_DISTANCE, ID_ESC
from sim_bridge.hil import _round_sat, distance_sensor_payload, esc_telemetry_payload
from sim_bridge.sensors.rangefinder import RangeReading
from sim_bridge.sensors.rpm import RpmReading


@pytest.mark.parametrize("system_id, component_id", [(1, 1), (1, 25), (7, 190), (255, 0)])
def test_frame_is_pymavlinks_frame_for_any_identity(system_id, component_id):
    ours = Codec(system_id, component_id)
    ref = MAV.MAVLink(None, srcSystem=system_id, srcComponent=component_id)
    msgs = [MAV.MAVLink_distance_sensor_message(5, 5, 4000, 1234, 0, 0, 25, 6, 0.0, 0.0, [0.0] * 4, 100),
            MAV.MAVLink_esc_telemetry_1_to_4_message([0] * 4, [1] * 4, [0] * 4, [0] * 4,
                                                      [6000, 0, 0, 0], [9, 0, 0, 0]),
            MAV.MAVLink_hil_actuator_controls_message(123, [0.5] * 16, 0, 128)]
    for k in range(300):                    # the sequence number wraps
        m = msgs[k % 3]
        theirs = m.pack(ref)
        ref.seq = (ref.seq + 1) % 256
        assert ours.frame(m._header.msgId, theirs[10:-2]) == theirs   # (m.id: a field)


def test_two_codecs_keep_their_own_fixed_bytes():
    a, b = Codec(1, 1), Codec(2, 3)
    payload = bytes(range(1, 45))
    fa, fb = a.frame(ID_ESC, payload), b.frame(ID_ESC, payload)
    assert (fa[5], fa[6]) == (1, 1) and (fb[5], fb[6]) == (2, 3) and fa[10:-2] == fb[10:-2]


def test_distance_payload_is_the_full_values_frame():
    rng = np.random.default_rng(41)
    for k in range(300):
        lo_m, hi_m, sigma_m = (0.05, 40.0, 0.025) if k % 2 else (0.2, 12.0, 0.1)
        d = None if k % 7 == 0 else float(rng.uniform(-1.0, 50.0))
        r = RangeReading(int(rng.integers(0, 10**10)), d, lo_m, hi_m, sigma_m)
        lo, hi = round(lo_m * 100), round(hi_m * 100)
        cur = hi + 1 if d is None else _round_sat(d * 100.0, 0.0, hi)
        full = (r.t_us // 1000, lo, hi, cur, MAV.MAV_DISTANCE_SENSOR_LASER, 0,
                MAV.MAV_SENSOR_ROTATION_PITCH_270, round((sigma_m * 100) ** 2),
                0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1 if d is None else 100)
        assert Codec(1, 25).frame(ID_DISTANCE, distance_sensor_payload(r)) == \
            Codec(1, 25).encode_values(ID_DISTANCE, full)


def test_esc_payload_is_the_full_values_frame():
    rng = np.random.default_rng(42)
    for k in range(300):
        rpm = float(rng.uniform(-100.0, 70000.0))
        count = int(rng.integers(0, 2**20))
        full = (0,) * 16 + (_round_sat(rpm, 0.0, 65535.0), 0, 0, 0) + (count & 0xFFFF, 0, 0, 0)
        assert Codec(1, 25).frame(ID_ESC, esc_telemetry_payload(RpmReading(0, rpm), count)) == \
            Codec(1, 25).encode_values(ID_ESC, full)


def test_lockstep_ids_frame_through_the_fixed_bytes():
    """Every lockstep message id gets its own fixed bytes (the message id in the header,
    the CRC extra byte of its own class): pymavlink reads each frame as that message."""
    c = Codec(1, 1)
    for mid in sorted(HIL_IDS):
        f = c.frame(mid, b"\x01")
        assert f[7] | (f[8] << 8) | (f[9] << 16) == mid
        assert MAV.MAVLink(None, 255, 0).decode(bytearray(f)).get_type() == MAV.mavlink_map[mid].msgname
