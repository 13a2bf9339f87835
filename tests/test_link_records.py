"""The @message records' constructors (autopilot/frozen.py): ``Record(...)`` and
``Record.make(...)`` build the same immutable record; copy and pickle rebuild it; and
the HIL link's end builds the same SensorFrame as the class calls would."""
import copy
import dataclasses
import math
import pickle

import numpy as np
import pytest

from autopilot.frozen import message
from autopilot.link.hil import (AutopilotHilEnd, BARO_FLAGS, DIFF_FLAG, ESC_RPM, MAG_FLAGS,
                                RHO0, gps_fix_from, range_sample_from)
from autopilot.messages import (AirspeedSample, ActuatorOutputs, BaroSample, GpsFix, ImuSample,
                                MagSample, NavState, RangeSample, RpmSample, SensorFrame)


@message
class Rec:
    t_us: int
    v: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(3))
    ok: bool = True


def test_make_and_the_class_call_build_the_same_frozen_record():
    for r in (Rec(5, ok=False), Rec.make(5, ok=False)):
        assert type(r) is Rec and (r.t_us, r.v.tolist(), r.ok) == (5, [0.0, 0.0, 0.0], False)
        with pytest.raises(dataclasses.FrozenInstanceError):
            r.ok = True
    assert Rec.make(1).v is not Rec.make(1).v            # a fresh default every time
    with pytest.raises(TypeError):
        Rec.make()
    with pytest.raises(TypeError):
        Rec(1, np.zeros(3), True, 4)                      # too many arguments
    with pytest.raises(TypeError):
        @message
        class Bad:
            make: int


def test_records_copy_and_pickle_through_their_constructor():
    n = NavState(1, np.zeros(3), np.ones(3), np.array([1.0, 0, 0, 0]), np.zeros(3), 0.1, 0.2, 3.0,
                 4.0, source="ekf")
    for c in (copy.copy(n), copy.deepcopy(n), pickle.loads(pickle.dumps(n))):
        assert type(c) is NavState and c.source == "ekf" and c.v_ned.tolist() == [1.0, 1.0, 1.0]
        with pytest.raises(dataclasses.FrozenInstanceError):
            c.t_us = 2
    a = ActuatorOutputs(7, (0.5, -0.25), True)
    assert pickle.loads(pickle.dumps(a)) == a and copy.copy(a) == a
    assert dataclasses.replace(a, armed=False) == ActuatorOutputs(7, (0.5, -0.25), False)


def _end_frame(v, gps=None, rng=None, esc=None):
    """The SensorFrame the autopilot's end builds of HIL_SENSOR's values ``v`` with a
    pending fix, range and ESC telemetry."""
    end = AutopilotHilEnd(None)
    end._gps, end._range, end._esc = gps, rng, esc
    end._on_sensor(v)
    (frame, truth), = end._steps
    assert truth is None and (end._gps, end._range, end._esc) == (None, None, None)
    return frame


def _class_call_frame(v, gps=None, rng=None, esc=None):
    """The end's SensorFrame spelt with class calls (the reference): the vectors are tuples of
    floats."""
    t_us, flags = v[0], v[14]
    q = 2.0 * (v[11] * 100.0) / RHO0
    return SensorFrame(
        t_us, ImuSample(t_us, tuple(v[1:4]), tuple(v[4:7])),
        MagSample(t_us, tuple(v[7:10])) if flags & MAG_FLAGS else None,
        BaroSample(t_us, v[10] * 100.0, v[12], v[13] + 273.15) if flags & BARO_FLAGS else None,
        AirspeedSample(t_us, v[11] * 100.0, math.sqrt(max(q, 0.0))) if flags & DIFF_FLAG else None,
        gps, rng, None if esc is None else RpmSample(t_us, float(esc[ESC_RPM])))


def _same(a, b):
    """Field by field, arrays bit for bit, records recursively."""
    assert type(a) is type(b)
    if a is None:
        return
    for f in dataclasses.fields(a):
        x, y = getattr(a, f.name), getattr(b, f.name)
        if dataclasses.is_dataclass(x):
            _same(x, y)
        elif isinstance(x, np.ndarray):
            assert x.dtype == y.dtype == np.float64 and x.tobytes() == y.tobytes(), f.name
        elif isinstance(x, tuple):
            assert type(y) is tuple and all(type(e) is float for e in x) and x == y, f.name
        else:
            assert type(x) is type(y) and x == y, f.name


def test_the_ends_sensor_frame_matches_the_class_calls_bit_for_bit():
    rng = np.random.default_rng(4)
    esc = (0,) * 12 + (5321, 0, 0, 0) + (0,) * 8
    for k in range(50):
        floats = tuple(float(x) for x in rng.standard_normal(13) * 10.0)
        flags = int(rng.integers(0, 1 << 13))
        v = (1000 * k, *floats, flags, 0)
        g = gps_fix_from((1000 * k, 123456789, -234567890, 100000, 120, 200, 1500, 1400, -300, 20,
                          9000, 3, 12, 0, 0))
        r = range_sample_from((k, 20, 4000, 1234, 0, 0, 25, 0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 100))
        for args in ((v, None), (v, g, r, esc)):
            _same(_end_frame(*args), _class_call_frame(*args))
    assert type(g) is GpsFix and type(r) is RangeSample and r.distance_m == 12.34


def test_answer_pads_the_controls_to_sixteen():
    sent = []

    class Pipe:
        def send(self, data):
            sent.append(data)

    from autopilot.link.codec import Codec
    from autopilot.link.hil import HIL_IDS, ID_ACTUATORS
    end = AutopilotHilEnd(Pipe())
    for n in (0, 1, 4, 8, 16):
        c = tuple(0.125 * (i + 1) for i in range(n))
        end.answer(ActuatorOutputs(1000 + n, c, n % 2 == 0))
        (mid, v), = Codec(1, 1).decode(sent[-1], HIL_IDS, pairs=True)
        assert mid == ID_ACTUATORS and v[0] == 1000 + n
        assert v[2:18] == c + (0.0,) * (16 - n) and (v[18] != 0) == (n % 2 == 0)
