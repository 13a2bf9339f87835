"""The fault monitor's per-step work cut (stop 37), nothing else changed: the three
fixed-wing balances' step in one compiled call (balances.py) against the identifiers
stepping alone, and the R adapter's window filled from the records while its hook is off
the filter (radapt.RAdapter.observe) against the hook, bit for bit."""
from __future__ import annotations

import math
import random
from types import SimpleNamespace

import numpy as np
import pytest

from autopilot.geo import G0
from autopilot.monitor.actuator import ElevatorIdentifier
from autopilot.monitor.airframe import AEROSONDE, C172P
from autopilot.monitor.balances import Balances
from autopilot.monitor.lateral import AEROSONDE_LAT, C172P_LAT, LateralIdentifier
from autopilot.monitor.radapt import R_MULTIPLE, RAdapter, attach
from autopilot.monitor.throttle import AEROSONDE_THRUST, C172P_THRUST, ThrottleIdentifier
from autopilot.nav import InsGpsEkf
from autopilot.nav.simulate import SimConfig, simulate_flight


def _identifiers(airframe, lat, thrust, nav):
    el = ElevatorIdentifier(model=airframe)
    return el, LateralIdentifier(lat, prop=airframe, nav=nav), ThrottleIdentifier(thrust)


def _state(idents):
    el, la, th = idents
    out = [el.ratio, el.residual, el.ready, el.lam, el.gamma.tolist(), el.balance.c.tolist(), el.balance.hist[-5:],
           la._lp.tolist(), la._st.tolist(), th._lp.tolist(), th._st.tolist(), th.axes["throttle"] is th._rotor_axis,
           el.balance._lp.tolist(), el.balance._st.tolist()]
    for ident in (la, th._thrust_axis, th._rotor_axis):
        for ax in getattr(ident, "axes", {"": ident}).values():
            out += [ax.ratio, ax.residual, ax.r_var, ax.c.tolist(), ax.hist[-5:]]
    return out


@pytest.mark.parametrize("name, airframe, lat, thrust, rpm_every", [
    ("aerosonde", AEROSONDE, AEROSONDE_LAT, AEROSONDE_THRUST, 5),
    ("c172p", C172P, C172P_LAT, C172P_THRUST, 10),
])
def test_balances_step_is_the_identifiers_own_bit_for_bit(name, airframe, lat, thrust, rpm_every):
    # GIVEN the same identifiers twice, one set stepped through Balances, the other alone,
    # on the same smoothly wandering flight (gaps, a landing and a second take-off, no
    # specific force now and then, the rotor's speed measured for a while)
    rng = random.Random(37)
    nav_a = SimpleNamespace(accel_bias=np.array((0.01, -0.02, 0.03)))
    nav_b = SimpleNamespace(accel_bias=nav_a.accel_bias.copy())
    a = _identifiers(airframe, lat, thrust, nav_a)
    b = _identifiers(airframe, lat, thrust, nav_b)
    assert Balances.fits(*a)
    bal = Balances(*a)
    t, V, p, q, r, thr = 1_000_000, 22.0, 0.0, 0.0, 0.0, 0.5
    renewed = 0
    for k in range(9000):
        t += 20_000 if k % 997 else 400_000                # a gap now and then
        V = min(max(V + rng.gauss(0.0, 0.05), 8.0 if 3000 < k < 3300 else 15.0), 45.0)
        p, q, r = (0.98 * x + rng.gauss(0.0, 0.02) for x in (p, q, r))
        thr = min(max(thr + rng.gauss(0.0, 0.02), 0.0), 1.0)
        controls = (rng.gauss(0.0, 0.1), rng.gauss(0.05, 0.1), rng.gauss(0.0, 0.05), thr)
        f_b = None if k % 301 == 0 else (rng.gauss(0.3, 0.2), rng.gauss(0.0, 0.3), rng.gauss(-9.8, 0.5))
        nav = SimpleNamespace(airspeed_mps=V, omega_b=np.array((p, q, r)), alt_m=400.0 + 0.01 * k,
                              q_nb=np.array((1.0, 0.02, 0.01, 0.0)))
        flying = not 5000 < k < 5200
        if 2000 < k < 7000 and k % rpm_every == 0:
            for ident in (a[2], b[2]):
                ident.measure_rpm(t, 5000.0 + 2000.0 * thr if name == "aerosonde" else 1800.0 + 700.0 * thr)
        if k == 6000:
            for ident in a + b:
                ident.freeze(t)
        # WHEN one set steps through Balances and the other alone
        got = bal.step(t, nav, controls, flying, f_b)
        want = False
        for ident in b[1:]:
            want = ident.step(t, nav, controls, flying, f_b) or want
        want = b[0].step(t, nav, controls[1], flying, controls[3],
                         None if f_b is None else -f_b[2] / G0) or want
        # THEN they say the same, and hold the same state, bit for bit
        assert got == want, k
        renewed += got
        if k % 50 == 0:
            assert _state(a) == _state(b), k
    assert _state(a) == _state(b)
    assert renewed > 100 and a[0].ready


def test_the_r_adapters_window_from_the_records_is_the_hooks():
    # GIVEN the nav simulator's flight through two filters with an R adapter each: one's
    # hook always on the filter, the other's only while it adapts, its window filled from
    # the filter's records meanwhile (as the monitor runs it)
    cfg = SimConfig()
    params = {"EK_MAG_DEC": math.radians(cfg.mag_declination_deg), "EK_MAG_AUTODEC": 0}
    sim = simulate_flight(np.random.default_rng(7), cfg, duration_s=40.0)
    fa, fb = InsGpsEkf(params, "plane", cfg.origin()), InsGpsEkf(params, "plane", cfg.origin())
    a, b = RAdapter(R_MULTIPLE, window=10), RAdapter(R_MULTIPLE, window=10)
    assert attach(fa, a) and attach(fb, b)
    fb.r_scale_hook = None
    adapted = 0
    for k, frame in enumerate(sim.frames(0, 4000)):
        na, nb = fa.update(frame), fb.update(frame)
        if fb.r_scale_hook is None:
            b.observe(fb.innovations)
        # (the monitor's decisions come after the filter's step, the hook with them)
        if k in (1500, 3000):                      # adapting from here to there
            a.active.add("gps_pos")
            b.active.add("gps_pos")
        if k == 2500:
            a.active.clear()
            b.active.clear()
        fb.r_scale_hook = b.hook if b.active else None
        # THEN the filters are the same, and so are the windows, the factors and the
        # optimal filter's variances the monitor reads
        assert na.p_ned.tolist() == nb.p_ned.tolist(), k
        assert a._ring == b._ring and a.okf_sd == b.okf_sd, k
        assert a.last.keys() == b.last.keys() and all(np.array_equal(a.last[s], b.last[s]) for s in a.last), k
        adapted += bool(a.last)
    assert adapted > 100 and a._ring["gps_pos"][2] > 100
