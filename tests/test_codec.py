"""The MAVLink codec: our framing against pymavlink's reference encoder and parser."""
import numpy as np

from autopilot.link.codec import MAV, Codec


def _messages(mav):
    return [
        mav.hil_actuator_controls_encode(123, [0.1 * i for i in range(16)], 128, 5),
        mav.hil_state_quaternion_encode(5, [1, 0, 0, 0], 0.1, 0.2, 0.3, -353632620, 1491652370,
                                        584000, 100, -200, 30, 2500, 2500, 0, 0, -1000),
        mav.hil_sensor_encode(1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 1),
        mav.hil_gps_encode(7, 3, -353632620, 1491652370, 584000, 120, 200, 2500, 2400, -300, 10, 35900, 12),
        mav.statustext_encode(4, b"hello world"),
        mav.heartbeat_encode(1, 3, 0, 0, 0),
        mav.param_value_encode(b"RLL_KP", 1.5, 9, 10, 2),
        mav.mission_item_int_encode(1, 1, 3, 3, 16, 0, 1, 0, 0, 0, 0, -353632620, 1491652370, 100.0, 0),
    ]


def test_encoded_bytes_equal_pymavlink_and_decode_identically():
    ours = Codec(7, 1)
    ref = MAV.MAVLink(None, srcSystem=7, srcComponent=1)
    rx = Codec(1, 1)
    for m in _messages(ours.mav):
        ref.seq = ours.mav.seq
        expected = m.pack(ref)
        buf = ours.encode(m)
        assert buf == expected, m.get_type()
        (got,) = rx.decode(buf)
        assert got.get_type() == m.get_type()
        assert got.to_dict() == ref.decode(bytearray(expected)).to_dict()
        assert got.get_srcSystem() == 7 and got.get_seq() == ref.seq


def test_stream_split_at_every_byte_and_mavlink1_frames():
    tx, rx = Codec(3, 1), Codec(1, 1)
    stream = b"".join(tx.encode(m) for m in _messages(tx.mav))
    ref = MAV.MAVLink(None, srcSystem=9, srcComponent=1)
    stream += ref.heartbeat_encode(6, 8, 0, 0, 0).pack(ref, force_mavlink1=True)
    got = []
    for b in stream:
        got += rx.decode(bytes([b]))
    assert [m.get_type() for m in got] == [m.get_type() for m in _messages(tx.mav)] + ["HEARTBEAT"]
    assert got[-1].get_srcSystem() == 9 and rx.bad_frames == 0


def test_bad_crc_unknown_id_and_noise_cost_only_themselves():
    tx, rx = Codec(2, 1), Codec(1, 1)
    hb = tx.encode(tx.mav.heartbeat_encode(1, 3, 0, 0, 0))
    corrupt = bytearray(hb)
    corrupt[-1] ^= 0x55
    unknown = bytearray(hb)
    unknown[7] = 0xEE        # an id the dialect lacks (CRC cannot match)
    rng = np.random.default_rng(11)
    noise = rng.integers(0, 256, 5000, dtype=np.uint8).tobytes()
    msgs = rx.decode(bytes(corrupt) + hb + bytes(unknown) + hb + noise + hb * 3 + b"\xfd\xff" + hb * 20)
    assert all(m.get_type() == "HEARTBEAT" for m in msgs)
    # everything behind the corrupt frames and the noise is recovered; a corrupt header
    # claiming a long frame may hold back at most the frames inside its claimed length
    assert len(msgs) >= 2 + 3 + 20 - 13
    assert rx.bad_frames >= 3
