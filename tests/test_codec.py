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


# --- the lockstep link's lean path (Codec.encode_values, Codec.decode with raw_ids) ---
_RANGES = {"uint8_t": (0, 255), "uint16_t": (0, 65535), "uint32_t": (0, 2**32 - 1),
           "uint64_t": (0, 2**64 - 1), "int8_t": (-128, 127), "int16_t": (-32768, 32767),
           "int32_t": (-2**31, 2**31 - 1)}


def _flat_values(cls, rng, zero_from: float = 1.0) -> tuple:
    """Random flat field values (declared order, arrays flattened) for ``cls``; the
    fields in the last ``1 - zero_from`` of the wire order are 0, so that MAVLink 2's
    truncation of the payload's trailing zeros is exercised."""
    out = []
    nwire = len(cls.ordered_fieldnames)
    for i, ftype in enumerate(cls.fieldtypes):
        w = cls.orders[i]
        for _ in range(cls.array_lengths[w] or 1):
            if w >= zero_from * nwire:
                out.append(0.0 if ftype in ("float", "double") else 0)
            elif ftype in ("float", "double"):
                out.append(float(rng.normal(0.0, 300.0)))
            else:
                lo, hi = _RANGES[ftype]
                out.append(int(rng.integers(lo, hi, endpoint=True, dtype=np.uint64 if lo == 0 else np.int64)))
    return tuple(out)


def _pymavlink_message(cls, flat):
    """The pymavlink message of flat values (arrays as lists)."""
    args, k = [], 0
    for i in range(len(cls.fieldnames)):
        n = cls.array_lengths[cls.orders[i]]
        args.append(list(flat[k:k + n]) if n else flat[k])
        k += n or 1
    assert k == len(flat)
    return cls(*args)


def _flatten(msg) -> tuple:
    out = []
    for name in msg.fieldnames:
        v = getattr(msg, name)
        out += list(v) if isinstance(v, (list, tuple)) else [v]
    return tuple(out)


def test_lockstep_frames_are_pymavlinks_bytes_and_decode_as_pymavlink_decodes():
    """Every message of the HIL link, packed by the lean path from flat values: the same
    bytes as pymavlink's own MAVLink 2 encoding of the same fields (payload truncation
    included: trailing zero fields, an all-zero payload), and decoded back to the field
    values pymavlink decodes from them."""
    from autopilot.link.hil import HIL_IDS
    rng = np.random.default_rng(18)
    ours = Codec(1, 25)
    ref = MAV.MAVLink(None, srcSystem=1, srcComponent=25)
    rx = Codec(1, 1)
    assert len(HIL_IDS) == 6
    for msg_id in sorted(HIL_IDS):
        cls = MAV.mavlink_map[msg_id]
        for zero_from in (1.0, 1.0, 0.5, 0.9, 0.0):
            flat = _flat_values(cls, rng, zero_from)
            ref.seq = ours.mav.seq
            expected = bytes(_pymavlink_message(cls, flat).pack(ref))
            buf = ours.encode_values(msg_id, flat)
            assert buf == expected, (cls.msgname, zero_from)
            (got,) = rx.decode(buf, HIL_IDS)
            assert (got.msg_id, got.src_system, got.src_component) == (msg_id, 1, 25)
            assert got.values == _flatten(ref.decode(bytearray(expected))), cls.msgname
            # the general path (not asked for raw values) reads the same message
            (full,) = Codec(1, 1).decode(buf)
            assert _flatten(full) == got.values
    assert rx.bad_frames == 0


def test_signed_lockstep_messages_are_pymavlinks_signed_bytes():
    """With a signing key the codec signs what ``encode`` sends: the same bytes as
    pymavlink's signing of the same message (key, link id, timestamp); the lockstep
    link itself is never signed (``encode_values`` frames stay unsigned, as before)."""
    from autopilot.link.hil import ID_SENSOR
    from autopilot.link.signing import Signing, passphrase_key
    key = passphrase_key("lockstep")
    rng = np.random.default_rng(4)
    ours = Codec(1, 25)
    ours.signing = Signing(key, 10**12, clock=lambda: 1.75e9)
    ours.link_id = 3
    ref = MAV.MAVLink(None, srcSystem=1, srcComponent=25)
    ref.signing.secret_key, ref.signing.link_id, ref.signing.sign_outgoing = key, 3, True
    for msg_id in (ID_SENSOR, MAV.MAVLINK_MSG_ID_HIL_ACTUATOR_CONTROLS,
                   MAV.MAVLINK_MSG_ID_HIL_STATE_QUATERNION):
        cls = MAV.mavlink_map[msg_id]
        flat = _flat_values(cls, rng, 0.9)
        ref.seq = ours.mav.seq
        ref.signing.timestamp = ours.signing.timestamp + 1       # what ours signs with next
        expected = bytes(_pymavlink_message(cls, flat).pack(ref))
        assert expected[2] & 0x01 and len(expected) == 12 + expected[1] + 13
        assert ours.encode(_pymavlink_message(cls, flat)) == expected, cls.msgname
    unsigned = ours.encode_values(ID_SENSOR, _flat_values(MAV.mavlink_map[ID_SENSOR], rng))
    assert not unsigned[2] & 0x01 and len(unsigned) == 12 + unsigned[1]


def test_lockstep_decoder_round_trips_and_refuses_a_corrupted_crc():
    from autopilot.link.hil import HIL_IDS, ID_ACTUATORS, ID_SENSOR
    tx = Codec(1, 25)
    sensor = (123456789, 0.5, -0.25, -9.75, 0.125, 0.0625, -0.5, 0.25, 0.0, 0.375, 1001.5, 0.5,
              120.25, 15.5, 7167, 0)
    act = (123456789, 0.5, -0.25, 0.125, 0.75) + (0.0,) * 12 + (128, 0)
    good = tx.encode_values(ID_SENSOR, sensor) + tx.encode_values(ID_ACTUATORS, act)
    rx = Codec(1, 1)
    assert [(m.msg_id, m.values) for m in rx.decode(good, HIL_IDS)] == [(ID_SENSOR, sensor), (ID_ACTUATORS, act)]
    n = len(good) - len(tx.encode_values(ID_ACTUATORS, act))
    for k in (1, 12, n - 2, n - 1):                # length, payload, CRC low and high bytes
        bad = bytearray(good)
        bad[k] ^= 0x20
        rx = Codec(1, 1)
        got = rx.decode(bytes(bad), HIL_IDS)
        assert ID_SENSOR not in [m.msg_id for m in got] and rx.bad_frames >= 1, k
        if k != 1:                                 # (a wrong length may swallow what follows)
            assert [(m.msg_id, m.values) for m in got] == [(ID_ACTUATORS, act)], k


def test_pairs_are_what_raw_messages_say():
    """``decode(..., pairs=True)``: a ``(msg_id, values)`` pair wherever ``decode`` gives a
    RawMessage, its values in the payload's own order (what ``encode_values(...,
    wire=True)`` takes), through the lockstep fast path and the general loop alike (a
    stream cut at every byte, garbage, a message that is not raw, a MAVLink 1 frame of a
    raw id)."""
    from autopilot.link.hil import HIL_IDS, ID_ACTUATORS, ID_SENSOR
    rng = np.random.default_rng(33)
    tx = Codec(1, 25)
    frames = [tx.encode_values(i, _flat_values(MAV.mavlink_map[i], rng, z))
              for i in sorted(HIL_IDS) for z in (1.0, 0.5)]
    ref = MAV.MAVLink(None, srcSystem=1, srcComponent=25)
    v1 = bytes(_pymavlink_message(MAV.mavlink_map[ID_SENSOR], _flat_values(MAV.mavlink_map[ID_SENSOR], rng))
               .pack(ref, force_mavlink1=True))
    stream = (b"".join(frames[:4]) + b"\x00\xfdjunk" + tx.encode(tx.mav.heartbeat_encode(1, 3, 0, 0, 0))
              + frames[4] + v1 + b"".join(frames[5:]))

    def seen(msgs, pairs):
        out = []
        for m in msgs:
            if pairs and type(m) is tuple:
                out.append(m)
            elif not pairs and hasattr(m, "values"):
                # the payload's order: the wire-order frame of these values is this frame
                wire = _wire_order(MAV.mavlink_map[m.msg_id], m.values)
                assert Codec(1, 25).encode_values(m.msg_id, wire, wire=True) == \
                    Codec(1, 25).encode_values(m.msg_id, m.values)
                out.append((m.msg_id, wire))
            else:
                out.append(m.get_type())
        return out

    want = seen(Codec(1, 1).decode(stream, HIL_IDS), False)
    assert len(want) == len(frames) + 2 and "HEARTBEAT" in want
    assert (ID_SENSOR, _flatten(ref.decode(bytearray(v1)))) in want and ID_ACTUATORS in [w[0] for w in want if type(w) is tuple]
    for cut in range(0, len(stream) + 1, 7):
        c = Codec(1, 1)
        got = seen(c.decode(stream[:cut], HIL_IDS, pairs=True), True) \
            + seen(c.decode(stream[cut:], HIL_IDS, pairs=True), True)
        assert got == want, cut
        assert c.pending == 0


def _wire_order(cls, flat) -> tuple:
    """Declared-order flat values -> the payload's order (``ordered_fieldnames``)."""
    msg = _pymavlink_message(cls, flat)
    wire = []
    for name in cls.ordered_fieldnames:
        v = getattr(msg, name)
        wire += list(v) if isinstance(v, (list, tuple)) else [v]
    return tuple(wire)


def test_values_in_wire_order_give_the_same_frame():
    """``encode_values(..., wire=True)`` takes the payload's own field order
    (``ordered_fieldnames``) and makes the frame the declared order makes."""
    from autopilot.link.hil import HIL_IDS
    rng = np.random.default_rng(7)
    for msg_id in sorted(HIL_IDS):
        cls = MAV.mavlink_map[msg_id]
        flat = _flat_values(cls, rng, 0.9)
        a, b = Codec(1, 25), Codec(1, 25)
        assert a.encode_values(msg_id, flat) == b.encode_values(msg_id, _wire_order(cls, flat), wire=True), \
            cls.msgname
