"""The HIL link's lean codec path (issue 18, stop 36): Codec.dispatch hands each lockstep
message to its id's handler exactly as Codec.decode's pairs give it, stream split
anywhere, garbage and other messages around it; Codec.frame of a payload packed straight
from the values is encode_values' frame, byte for byte; the ends' direct packing and
unpacking is the field-by-field formula it replaced, bit for bit."""
import math
import struct

import numpy as np
import pytest

from autopilot.link.codec import MAV, Codec, Routes
from autopilot.link.hil import (HIL_IDS, ID_ACTUATORS, ID_ESC, ID_GPS, ID_SENSOR, ID_STATE,
                                RAD_TO_E7, AutopilotHilEnd, TruthSample)
from autopilot.messages import ActuatorOutputs
from sim_bridge.hil import SimulatorHilEnd, truth_ints

_RANGES = {"uint8_t": (0, 255), "uint16_t": (0, 65535), "uint32_t": (0, 2**32 - 1),
           "uint64_t": (0, 2**64 - 1), "int8_t": (-128, 127), "int16_t": (-32768, 32767),
           "int32_t": (-2**31, 2**31 - 1)}


def _wire_values(msg_id, rng, zero_tail: int = 0) -> tuple:
    """Random values of a message in its payload's own order (arrays flattened), the last
    ``zero_tail`` of them 0 (so that MAVLink 2's truncation is exercised)."""
    cls = MAV.mavlink_map[msg_id]
    out = []
    for name in cls.ordered_fieldnames:
        i = cls.fieldnames.index(name)
        ftype = cls.fieldtypes[i]
        for _ in range(cls.array_lengths[cls.orders[i]] or 1):
            if ftype in ("float", "double"):
                out.append(float(np.float32(rng.normal(0.0, 300.0))))
            else:
                lo, hi = _RANGES[ftype]
                out.append(int(rng.integers(lo, hi, endpoint=True, dtype=np.uint64 if lo == 0 else np.int64)))
    if zero_tail:
        out[-zero_tail:] = [0.0 if type(x) is float else 0 for x in out[-zero_tail:]]
    return tuple(out)


class _Seen:
    """Routes whose handlers write down what they got."""

    def __init__(self, ids):
        self.got = []
        self.routes = Routes({i: (lambda v, i=i: self.got.append((i, v))) for i in ids})


def _stream(rng):
    tx = Codec(1, 25)
    frames = []
    for k in range(40):
        mid = (ID_SENSOR, ID_STATE, ID_GPS, ID_ACTUATORS, ID_ESC)[k % 5]
        frames.append(tx.encode_values(mid, _wire_values(mid, rng, k % 4), wire=True))
    cmd = tx.encode(MAV.MAVLink_command_long_message(1, 25, 400, 0, 1, 0, 0, 0, 0, 0, 0))
    bad = bytearray(frames[3])
    bad[-1] ^= 0x5A                                  # a CRC that fails: costs only itself
    return frames, cmd, bytes(bad)


@pytest.mark.parametrize("cut_every", [None, 1, 7, 61])
def test_dispatch_hands_over_what_decode_pairs_give(cut_every):
    rng = np.random.default_rng(36)
    frames, cmd, bad = _stream(rng)
    stream = b"".join(frames[:10]) + b"\x00garbage\xfd" + b"".join(frames[10:20]) + cmd + bad \
        + b"".join(frames[20:])
    chunks = [stream] if cut_every is None else \
        [stream[k:k + cut_every] for k in range(0, len(stream), cut_every)]
    ref = Codec(1, 1)
    want_pairs, want_others = [], []
    for c in chunks:
        for m in ref.decode(c, HIL_IDS, pairs=True):
            (want_pairs if type(m) is tuple else want_others).append(m)
    ours, seen, others = Codec(1, 1), _Seen(HIL_IDS), []
    for c in chunks:
        others += ours.dispatch(c, seen.routes)
    assert seen.got == want_pairs and len(want_pairs) == 40     # (the bad copy refused)
    assert [m.get_type() for m in others] == [m.get_type() for m in want_others] == ["COMMAND_LONG"]
    assert ours.received == ref.received and ours.bad_frames == ref.bad_frames > 0
    assert ours.pending == ref.pending == 0


def test_frame_of_a_packed_payload_is_encode_values_frame():
    rng = np.random.default_rng(7)
    for mid in sorted(HIL_IDS):
        for tail in (0, 1, 5, 10**6):
            v = _wire_values(mid, rng, min(tail, len(MAV.mavlink_map[mid].ordered_fieldnames)))
            a, b = Codec(3, 9), Codec(3, 9)
            a.mav.seq = b.mav.seq = 255
            assert a.frame(mid, MAV.mavlink_map[mid].unpacker.pack(*v)) == b.encode_values(mid, v, wire=True)
            assert a.mav.seq == b.mav.seq == 0


class _Sink:
    def __init__(self):
        self.sent = []

    def send(self, data):
        self.sent.append(data)

    def recv(self, timeout_s=0.0):
        return b""


@pytest.mark.parametrize("k", range(17))
def test_answer_pads_are_the_full_layouts_zeros(k):
    """HIL_ACTUATOR_CONTROLS packed from k controls (flags and the other controls as pad
    bytes): the frame the full layout makes of the same values with zeros."""
    c = tuple(math.sin(0.7 * j) for j in range(k))
    for armed in (False, True):
        end = AutopilotHilEnd(_Sink(), Codec(1, 1))
        end.answer(ActuatorOutputs(123_456, c, armed))
        ref = Codec(1, 1).encode_values(ID_ACTUATORS, (123_456, 0, *c, *(0.0,) * (16 - k),
                                                       MAV.MAV_MODE_FLAG_SAFETY_ARMED if armed else 0),
                                        wire=True)
        assert end.transport.sent == [ref]


class _Readings:
    """A SensorReadings' fields as send_step reads them."""

    def __init__(self, rng, t_us):
        self.t_us = t_us
        self.accel_b, self.gyro_b, self.mag_b_gauss = (tuple(rng.normal(0, 5, 3)) for _ in range(3))
        self.pressure_pa, self.diff_pressure_pa = 95000.0 + rng.normal(0, 50), 300.0 + rng.normal(0, 20)
        self.pressure_alt_m, self.temperature_k = 500.0 + rng.normal(0, 5), 280.0 + rng.normal(0, 1)
        self.mag_updated, self.baro_updated, self.airspeed_updated = (bool(x) for x in rng.integers(0, 2, 3))
        self.gps = None


class _Truth:
    def __init__(self, rng, t_us):
        self.t_us = t_us
        q = rng.normal(size=4)
        self.q_nb = tuple(q / np.linalg.norm(q))
        self.omega_b, self.v_ned, self.f_b = (tuple(rng.normal(0, 10, 3)) for _ in range(3))
        self.lat_rad, self.lon_rad, self.alt_m = -0.6 + rng.normal(0, 1e-3), 2.6, 400.0 + rng.normal(0, 50)
        self.airspeed_mps, self.rho_kgm3 = 20.0 + rng.normal(0, 3), 1.1


def test_send_step_frames_are_the_declared_values_frames():
    """HIL_SENSOR and HIL_STATE_QUATERNION packed straight from the readings and the
    truth: the frames of the flat values the link sent before (declared order through
    encode_values), seq for seq."""
    rng = np.random.default_rng(3)
    end = SimulatorHilEnd(_Sink(), Codec(1, 25))
    ref = Codec(1, 25)
    for k in range(50):
        r, tr = _Readings(rng, 10_000 * k), _Truth(rng, 10_000 * k)
        end.send_step(r, tr)
        flags = 0x3F | (0x1C0 if r.mag_updated else 0) | (0x1A00 if r.baro_updated else 0) \
            | (0x400 if r.airspeed_updated else 0)
        want = ref.encode_values(ID_STATE, (tr.t_us, *tr.q_nb, *tr.omega_b) + truth_ints(
            tr.lat_rad, tr.lon_rad, tr.alt_m, *tr.v_ned, tr.airspeed_mps, tr.rho_kgm3, *tr.f_b))
        want += ref.encode_values(ID_SENSOR, (
            r.t_us, *r.accel_b, *r.gyro_b, *r.mag_b_gauss, r.pressure_pa * 0.01,
            r.diff_pressure_pa * 0.01, r.pressure_alt_m, r.temperature_k - 273.15, flags, 0))
        assert end.transport.sent[-1] == want


def test_truth_sample_is_the_formula_on_the_payload():
    rng = np.random.default_rng(11)
    for _ in range(200):
        v = _wire_values(ID_STATE, rng)
        t = TruthSample(v)
        assert t.t_us == v[0] and t.q_nb == v[1:5] and t.omega_b == v[5:8]
        assert (t.lat_rad, t.lon_rad, t.alt_m) == (v[8] / RAD_TO_E7, v[9] / RAD_TO_E7, v[10] * 1e-3)
        assert t.v_ned == (v[11] * 0.01, v[12] * 0.01, v[13] * 0.01) and t.airspeed_mps == v[15] * 0.01
        assert t.f_b == tuple(x * 9.80665e-3 for x in v[16:19])


def test_lockstep_round_trip_through_both_ends():
    """Simulator end -> bytes -> autopilot end -> bytes -> simulator end: the answer's
    controls and the step's values arrive, the stale answer is counted."""
    from autopilot.link.transports import memory_pair
    a, b = memory_pair()
    sim, ap = SimulatorHilEnd(a), AutopilotHilEnd(b)
    rng = np.random.default_rng(5)
    r, tr = _Readings(rng, 20_000), _Truth(rng, 20_000)
    sim.send_step(r, tr)
    (frame, truth), = ap.poll()
    assert frame.t_us == truth.t_us == 20_000
    assert frame.imu.f_b == tuple(float(np.float32(x)) for x in r.accel_b)
    ap.answer(ActuatorOutputs(10_000, (0.5,) * 4, True))     # an older step's: stale
    ap.answer(ActuatorOutputs(20_000, (0.25, -0.5, 0.125, 1.0), True))
    controls = sim.poll_answer(20_000)
    assert controls == (0.25, -0.5, 0.125, 1.0) + (0.0,) * 12 and sim.armed and sim.stale == 1
    assert struct.calcsize("<Q8x4f48xB") == MAV.mavlink_map[ID_ACTUATORS].unpacker.size
