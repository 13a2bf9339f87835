"""The navigation filters' adaptation hooks (autopilot/nav/base.py ``r_scale_hook``,
``q_scale_hook``) used by the fault monitor: GIVEN the nav simulator's flight, WHEN a hook
is installed that returns None or factors of one, THEN the filter is bit for bit the one
without hooks; WHEN it returns factors > 1, THEN R (Q) is scaled where it says."""
from __future__ import annotations

import math

import numpy as np
import pytest

from autopilot.monitor.radapt import R_MULTIPLE, RAdapter, attach
from autopilot.nav import InsGpsEkf, InsGpsUkf
from autopilot.nav.simulate import SimConfig, golden_numbers, run_filter, simulate_flight

CFG = SimConfig()
PARAMS = {"EK_MAG_DEC": math.radians(CFG.mag_declination_deg), "EK_MAG_AUTODEC": 0}


@pytest.fixture(scope="module")
def sim():
    return simulate_flight(np.random.default_rng(7), CFG, duration_s=40.0)


def _run(cls, sim, r_hook=None, q_hook=None, stop=None):
    f = cls(PARAMS, "plane", CFG.origin())
    f.r_scale_hook = r_hook
    f.q_scale_hook = q_hook
    tr = run_filter(f, sim, stop=stop)
    return f, golden_numbers(f, tr)


@pytest.mark.parametrize("cls,stop", [(InsGpsEkf, None), (InsGpsUkf, 1500)])
def test_inactive_hooks_are_bit_identical(cls, sim, stop):
    _, ref = _run(cls, sim, stop=stop)
    calls = {"r": 0, "q": 0}

    def r_none(source, y, hph, r):
        calls["r"] += 1
        return None if calls["r"] % 2 else np.ones(len(y))

    def q_ones(dt):
        calls["q"] += 1
        return None if calls["q"] % 2 else np.ones(21)

    _, got = _run(cls, sim, r_none, q_ones, stop=stop)
    assert calls["r"] > 100 and calls["q"] > 1000
    assert got == ref                                   # exact, not approximate


def test_r_hook_scales_the_rows_it_names(sim):
    seen = {}

    def hook(source, y, hph, r):
        seen.setdefault(source, (y, hph, r))
        return np.full(len(y), 100.0) if source == "gps_pos" else None

    f = InsGpsEkf(PARAMS, "plane", CFG.origin())
    f.r_scale_hook = hook
    last = None
    for frame in sim.frames(0, 3000):
        f.update(frame)
        for rec in f.innovations:
            if rec.source == "gps_pos":
                last = rec
    assert {"gps_pos", "gps_vel", "baro"} <= set(seen)
    # the hook's arguments: tuples of floats, one per row
    assert all(type(v) is tuple and len(v) == 3 for v in seen["gps_pos"])
    # the record's innovation variance holds the scaled R: diag(S) >= 100 R
    r_gps = seen["gps_pos"][2]
    assert np.all(np.array(last.innovation_variance) >= 100.0 * np.array(r_gps) - 1e-9)


def test_q_hook_fades_the_process_noise():
    f = InsGpsEkf(PARAMS, "plane", CFG.origin())
    f._process_noise(0.01)
    q = f._q.copy()                                      # diag Q of the 0.01 s step
    lam = np.ones(21)
    lam[12:15] = 50.0                                    # gyro bias states
    f.q_scale_hook = lambda dt: lam
    P0 = np.eye(21) * 1e-6
    f._P = P0.copy()
    f._predict(0.01, [0.0, 0.0, -9.8], [0.0, 0.0, 0.0], 10_000)
    # P = F P F^T + Lambda Q: with the hook, the gyro-bias diagonal grows by 50 q
    assert f._P[13, 13] == pytest.approx(1e-6 + 50.0 * q[13], rel=1e-12)
    assert f._P[15, 15] == pytest.approx(1e-6 + q[15], rel=1e-12)


def test_monitor_adapter_attaches_through_the_hook(sim):
    f = InsGpsEkf(PARAMS, "plane", CFG.origin())
    a = RAdapter(R_MULTIPLE, window=10)
    assert attach(f, a) and f.r_scale_hook is not None
    a.active.add("gps_pos")
    for frame in sim.frames(0, 3000):
        f.update(frame)
    assert "gps_pos" in a.okf_sd and a.last["gps_pos"].shape == (3,)
    assert np.all(a.last["gps_pos"] >= 1.0)


def test_the_window_variance_is_numpys_over_the_ring_bit_for_bit():
    """RAdapter keeps its window as rows of floats: the factors are numpy's sample variance
    of the last M innovations as an (M, s) ring array of them gives it (its first rows while
    the window fills), bit for bit."""
    rng = np.random.default_rng(3)
    a = RAdapter(R_MULTIPLE, window=10)
    a.active.add("gps_pos")
    buf = np.zeros((10, 3))
    for k in range(37):
        y = rng.standard_normal(3) * 2.0
        hph, r = rng.uniform(0.1, 1.0, 3), rng.uniform(0.1, 1.0, 3)
        s = a.scale("gps_pos", y, hph, r)
        buf[k % 10] = y
        n = k + 1
        e2 = y * y if n < 3 else (buf if n >= 10 else buf[:n]).var(axis=0, ddof=1)
        assert np.array_equal(s, np.maximum(1.0, (e2 - hph) / r)) and s.max() > 1.0
