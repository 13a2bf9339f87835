"""The simulator side's HIL packing (stop 35's speed room): the compiled truth fields
against the law written out (round half away from zero, then saturate) bit for bit."""
from __future__ import annotations

import math
from math import ceil, floor

import numpy as np
import pytest

from autopilot.link.codec import Codec
from autopilot.link.hil import ID_STATE, RAD_TO_E7
from sim_bridge.hil import MG_PER_MS2, _round_sat, round_sat, truth_ints
from sim_bridge.plants.base import PlantState


def _law(v, lo, hi):
    i = floor(v + 0.5) if v >= 0.0 else ceil(v - 0.5)
    return lo if i < lo else hi if i > hi else i


def _values(rng, n):
    """Random values of every magnitude, halves and the fields' bounds among them."""
    v = list(rng.standard_normal(n) * 10.0 ** rng.uniform(-3, 11, n))
    v += [k + 0.5 for k in range(-5, 5)] + [0.0, -0.0, 0.49999999999999994, -0.49999999999999994]
    v += [b + d for b in (32767, -32767, 65535, 65534, 254, 2**31 - 1, -2**31, 900000000,
                          1800000000) for d in (-0.5, 0.0, 0.5, 1.0, -1.0)]
    return v


def test_round_sat_is_the_law_compiled_and_interpreted():
    rng = np.random.default_rng(35)
    for lo, hi in ((-32767, 32767), (0, 65535), (0, 254), (-2**31, 2**31 - 1)):
        for v in _values(rng, 2000):
            want = _law(v, lo, hi)
            assert round_sat(v, float(lo), float(hi)) == want
            got = _round_sat(v, float(lo), float(hi))
            assert got == want and type(got) is int
    # beyond the integers: saturated (the law itself cannot convert an infinity)
    assert round_sat(math.inf, 0.0, 254.0) == _round_sat(math.inf, 0.0, 254.0) == 254
    assert round_sat(-math.inf, -5.0, 5.0) == _round_sat(-1e300, -5.0, 5.0) == -5


def test_a_nan_is_refused_by_name_compiled_and_interpreted():
    # (compiled, its conversion gave -2**63, refused only later by the packing)
    for f in (round_sat, _round_sat):
        with pytest.raises(ValueError, match="NaN in a MAVLink integer field"):
            f(math.nan, -32767.0, 32767.0)
    with pytest.raises(ValueError, match="NaN"):
        truth_ints(math.nan, 0.1, 100.0, 1.0, 2.0, 3.0, 20.0, 1.2, 0.0, 0.0, -9.8)


def _truth_reference(codec, truth):
    """HIL_STATE_QUATERNION as the interpreted law packed it before the kernel."""
    qw, qx, qy, qz = truth.q_nb
    vn, ve, vd = truth.v_ned
    fx, fy, fz = truth.f_b
    wx, wy, wz = truth.omega_b
    tas = truth.airspeed_mps
    ias = tas * math.sqrt(truth.rho_kgm3 / 1.225)
    return codec.encode_values(ID_STATE, (
        truth.t_us, qw, qx, qy, qz, wx, wy, wz,
        _law(truth.lat_rad * RAD_TO_E7, -900000000, 900000000),
        _law(truth.lon_rad * RAD_TO_E7, -1800000000, 1800000000),
        _law(truth.alt_m * 1000.0, -2**31, 2**31 - 1),
        _law(vn * 100.0, -32767, 32767), _law(ve * 100.0, -32767, 32767),
        _law(vd * 100.0, -32767, 32767),
        _law(ias * 100.0, 0, 65535), _law(tas * 100.0, 0, 65535),
        _law(fx * MG_PER_MS2, -32767, 32767), _law(fy * MG_PER_MS2, -32767, 32767),
        _law(fz * MG_PER_MS2, -32767, 32767)))


def test_truth_message_bytes_as_the_interpreted_law():
    from sim_bridge.hil import SimulatorHilEnd
    rng = np.random.default_rng(7)
    end = SimulatorHilEnd(transport=None, codec=Codec(1, 51))
    ref = Codec(1, 51)
    for k in range(3000):
        big = 10.0 ** rng.uniform(-2, 4)          # up to beyond the int16 fields' range
        q = rng.standard_normal(4)
        q /= np.linalg.norm(q)
        truth = PlantState(
            k * 10_000, float(rng.uniform(-math.pi / 2, math.pi / 2)),
            float(rng.uniform(-math.pi, math.pi)), float(rng.uniform(-500.0, 5000.0)),
            tuple((rng.standard_normal(3) * big).tolist()), tuple(q.tolist()),
            tuple(rng.standard_normal(3).tolist()), tuple((rng.standard_normal(3) * big).tolist()),
            (0.0, 0.0, 0.0), float(abs(rng.standard_normal()) * big), 0.0, 0.0, False,
            float(rng.uniform(0.5, 1.3)))
        assert end._truth_message(truth) == _truth_reference(ref, truth)
    assert truth_ints(math.pi / 2, math.pi, 1e30, 1e9, -1e9, 0.5, 1e9, 1.225, 0.0, 0.0, -1e9)[:4] == (
        900000000, 1800000000, 2**31 - 1, 32767)
