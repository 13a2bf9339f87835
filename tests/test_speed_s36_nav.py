"""The navigation filters' step kernels on their arrays held in place (autopilot/nav/base.py:
``inject_into``, ``push_history`` / ``delayed``, ``output_into``, ``aux_into``) against
the Python they replaced, written out once more here, bit for bit; the delayed-state
lookup (``_delayed``) on the history ring those kernels write."""
from __future__ import annotations

import math

import numpy as np

from autopilot.geo import LocalFrame, euler_to_quat, wrap_pi
from autopilot.nav.base import (_AUX_AIR, _AUX_BARO, _AUX_MAG, _B_H, _B_S, _B_SIZE, _BA_MAX,
                                _HIST, _MAG_REF_GAIN, S_AIR, S_BARO, S_BB0, S_BHGT, S_CP, S_CV, S_HI,
                                S_MAG, S_MREF, S_MREF_SET, S_N_AIR, S_N_BARO, S_N_MAG, S_ORG,
                                S_QS, S_SF, S_SIZE, S_W0, aux_into, inject_into, output_into,
                                push_history)
from autopilot.nav.ekf import InsGpsEkf
from autopilot.nav.strapdown import Nominal, rotate_global


def _nominal(rng) -> Nominal:
    nom = Nominal()
    nom.set_attitude(euler_to_quat(0.3, -0.1, 2.0))
    nom.p, nom.v = (rng.standard_normal(3) * 100.0).tolist(), (rng.standard_normal(3) * 20.0).tolist()
    nom.ba, nom.bg = [0.05, -1.99, 0.1], [0.01, 0.0, -0.01]
    nom.bb, nom.gb, nom.wind = 3.0, [0.5, -0.3, 1.0], [3.0, -2.0]
    return nom


def test_inject_into_is_the_injection_written_out():
    rng = np.random.default_rng(1)
    for n in (19, 21):
        nom = _nominal(rng)
        s = np.zeros(S_SIZE)
        s[S_CP:S_CP + 6] = rng.standard_normal(6)
        dx = rng.standard_normal(n) * 0.01
        dx[10] = -0.05                                  # b_a,y beyond _BA_MAX: clamped
        p, v, q, ba, bg, gb, w = nom.p, nom.v, nom.q, nom.ba, nom.bg, nom.gb, nom.wind
        cp, cv, bb = s[S_CP:S_CP + 3].tolist(), s[S_CV:S_CV + 3].tolist(), nom.bb
        d = dx.tolist()
        inject_into(nom.x, s, dx)
        assert nom.p == [p[i] + d[i] for i in range(3)]
        assert nom.v == [v[i] + d[3 + i] for i in range(3)]
        assert s[S_CP:S_CP + 3].tolist() == [cp[i] + d[i] for i in range(3)]
        assert s[S_CV:S_CV + 3].tolist() == [cv[i] + d[3 + i] for i in range(3)]
        q1, R1 = rotate_global(tuple(q), d[6], d[7], d[8])
        assert nom.q == list(q1) and nom.R == R1
        ba1 = [ba[i] + d[9 + i] for i in range(3)]
        assert nom.ba == [min(max(c, -_BA_MAX), _BA_MAX) for c in ba1] and nom.ba[1] == -_BA_MAX
        assert nom.bg == [bg[i] + d[12 + i] for i in range(3)]
        assert nom.bb == bb + d[15]
        assert nom.gb == [gb[i] + d[16 + i] for i in range(3)]
        assert nom.wind == ([w[0] + d[19], w[1] + d[20]] if n == 21 else w)


def test_delayed_is_the_nearest_history_row_with_the_later_corrections():
    rng = np.random.default_rng(2)
    f = InsGpsEkf()
    nom, s, hist = f.nom, f._s, f._hist
    rows = []
    t = 1_000_000
    for k in range(_HIST + 40):                         # (the ring wraps)
        nom.p = (np.array(nom.p) + rng.standard_normal(3)).tolist()
        s[S_CP:S_CP + 3] += rng.standard_normal(3) * 0.1
        s[S_CV:S_CV + 3] += rng.standard_normal(3) * 0.1
        s[S_SF:S_SF + 3] += rng.standard_normal(3)
        s[S_QS:S_QS + 3] += rng.random(3)
        push_history(nom.x, s, hist, t)
        rows.append((t, nom.p, nom.v, s[S_CP:S_CP + 3].tolist(), s[S_CV:S_CV + 3].tolist(),
                     s[S_SF:S_SF + 3].tolist(), s[S_QS:S_QS + 3].tolist()))
        t += 10_000
    assert s[S_HI] == (_HIST + 40) % _HIST
    cp, cv, sf, qs = (s[a:a + 3].tolist() for a in (S_CP, S_CV, S_SF, S_QS))
    for t_valid in (t - 10_000, t - 154_000, t - 155_000, t - 10_000_000, t + 10**6):
        kept = rows[-_HIST:]
        best = min(kept, key=lambda r: abs(r[0] - t_valid))   # (ties: the earlier row)
        _, p, v, cp0, cv0, sf0, qs0 = best
        want = ([(p[i] - cp0[i]) + cp[i] for i in range(3)] + [(v[i] - cv0[i]) + cv[i] for i in range(3)]
                + [sf[i] - sf0[i] for i in range(3)] + [qs[i] - qs0[i] for i in range(3)])
        p, v, dv, qs_since = f._delayed(t_valid)
        assert list(p + v + dv + qs_since) == want, t_valid


def test_output_into_is_the_output_written_out():
    rng = np.random.default_rng(3)
    nom = _nominal(rng)
    frame = LocalFrame.from_degrees(-35.3, 149.1, 580.0)
    s = np.zeros(S_SIZE)
    s[S_W0:S_W0 + 3] = (0.1, -0.2, 0.3)
    a = np.empty(13)
    # no origin, no baro height: the filter's own height; the air velocity v - (w, 0)
    v, w = nom.v, nom.wind
    air = (v[0] - w[0], v[1] - w[1], v[2])
    assert output_into(nom.x, s, a) == (0.0, 0.0, -nom.p[2]) + air
    s[S_ORG], s[S_ORG + 1:S_ORG + 7] = 1.0, frame.fast_constants()
    s[S_BHGT], s[S_BB0] = 1.0, 1.25
    lat, lon, alt, *air2 = output_into(nom.x, s, a)
    p = nom.p
    p = [p[0], p[1], p[2] - (nom.bb - 1.25)]
    assert (lat, lon, alt) == frame.to_geodetic_fast(p) and tuple(air2) == air
    assert a.tolist() == p + nom.v + nom.q + [(0.1, -0.2, 0.3)[k] - nom.bg[k] for k in range(3)]
    # the interpreted source of the inverse is that of the compiled one, near the 180th meridian too
    e = 250.0
    lat = frame.lat0_rad + (100.0 - e * e * frame._bend) / frame._rm
    assert frame.to_geodetic_fast((100.0, e, -20.0)) == (
        lat, wrap_pi(frame.lon0_rad + e / (frame._rn0 * math.cos(lat))), frame.alt0_m + 20.0)
    far = LocalFrame.from_degrees(10.0, 179.9999, 0.0)
    assert far.to_geodetic_fast((0.0, 5000.0, 0.0))[1] < -math.pi + 0.01


def test_aux_into_is_the_running_sums_written_out():
    rng = np.random.default_rng(4)
    b = np.zeros(_B_SIZE)                       # the filter's buffer of x, s and the history
    b[:_B_S] = _nominal(rng).x
    nom, s = Nominal(b[:_B_S]), b[_B_S:_B_H]
    R = nom.R
    baro, n_baro, mag, n_mag, air, n_air, ref = 0.0, 0, [0.0, 0.0], 0, 0.0, 0, None
    for k in range(40):
        which = (_AUX_BARO if k % 2 else 0) | (_AUX_MAG if k % 3 else 0) | (_AUX_AIR if k % 5 else 0)
        alt, tas = 580.0 + rng.standard_normal(), 20.0 + rng.standard_normal()
        m = rng.standard_normal(3) * 0.3
        if k % 7 == 0:
            m = np.array(R).reshape(3, 3).T @ np.array((0.001, 0.0, 0.5))   # nearly vertical: no heading
        got = aux_into(b, which, alt, *m.tolist(), tas)
        if which & _AUX_BARO:
            baro += alt
            n_baro += 1
        if which & _AUX_MAG:
            mx, my, mz = m.tolist()
            mn = R[0] * mx + R[1] * my + R[2] * mz
            me = R[3] * mx + R[4] * my + R[5] * mz
            md = R[6] * mx + R[7] * my + R[8] * mz
            bh2 = mn * mn + me * me
            if bh2 > 0.05 * (bh2 + md * md):
                if ref is None:
                    ref = [mn, me, md]
                else:
                    ref = [ref[0] + (mn - ref[0]) * _MAG_REF_GAIN, ref[1] + (me - ref[1]) * _MAG_REF_GAIN,
                           ref[2] + (md - ref[2]) * _MAG_REF_GAIN]
                mag = [mag[0] + mn, mag[1] + me]
                n_mag += 1
        if which & _AUX_AIR:
            air += tas
            n_air += 1
        assert got == (n_baro + n_mag + n_air > 0)
        assert s[S_BARO:S_N_AIR + 1].tolist() == [baro, n_baro, *mag, n_mag, air, n_air]
        assert s[S_MREF_SET] == (ref is not None)
        if ref is not None:
            assert s[S_MREF:S_MREF + 3].tolist() == ref
    assert 0 < n_mag < sum(1 for k in range(40) if k % 3)    # some fields refused
    assert (S_N_BARO, S_MAG, S_N_MAG, S_AIR) == (S_BARO + 1, S_BARO + 2, S_BARO + 4, S_BARO + 5)


def test_the_nominal_state_the_step_array_and_the_history_are_views_of_one_buffer():
    # imu_step takes the buffer alone: the views the other kernels and the Python side
    # read must be its memory, after a reset as well
    f = InsGpsEkf()
    for _ in range(2):
        b = f._buf
        assert f.nom.x.base is b and f._s.base is b and f._hist.base is b and f._o.base is b
        b[:] = np.arange(b.size)
        assert f.nom.x[0] == 0.0 and f._s[0] == f.nom.x.size
        assert f._hist[0, 0] == f.nom.x.size + f._s.size
        # (the output last: stop 41)
        assert f._hist[-1, -1] + 1 == f._o[0] and f._o[-1] == b.size - 1
        f.reset()
