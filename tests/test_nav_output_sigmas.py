"""``NavFilterBase.output_sigmas9`` (autopilot/nav/base.py) is worked out again only when P
has changed: GIVEN the nav simulator's flight, WHEN it is asked at every step, THEN it is
bit for bit the formula on the present P (the barometric height reference included),
also after a reset."""
from __future__ import annotations

import math

import numpy as np
import pytest

from autopilot.nav import InsGpsEkf, InsGpsUkf
from autopilot.nav.layout import BBIAS, POS
from autopilot.nav.simulate import SimConfig, simulate_flight

CFG = SimConfig()


@pytest.fixture(scope="module")
def sim():
    return simulate_flight(np.random.default_rng(5), CFG, duration_s=30.0)


def _formula(f) -> tuple:
    P = np.array(f.P)
    d = P.diagonal()[:9].copy()
    if int(f.params["EK_HGT_REF"]) == 0 and f._baro_ok:
        i, b = POS.start + 2, BBIAS.start
        d[2] = P[i, i] + P[b, b] - 2.0 * P[i, b] + f._bb0_var
    return tuple(math.sqrt(x) if x > 0.0 else 0.0 for x in d.tolist())


@pytest.mark.parametrize("cls,kw,hgt_ref,n", [(InsGpsEkf, {"cov_div": 4}, 0, 3000),
                                              (InsGpsEkf, {}, 1, 3000),
                                              (InsGpsUkf, {}, 0, 800)])
def test_output_sigmas_follow_p_bit_for_bit(sim, cls, kw, hgt_ref, n):
    params = {"EK_MAG_DEC": math.radians(CFG.mag_declination_deg), "EK_MAG_AUTODEC": 0,
              "EK_HGT_REF": hgt_ref}
    f = cls(params, "plane", CFG.origin(), **kw)
    changed = 0
    last = None
    for k, frame in enumerate(sim.frames(0, n)):
        f.update(frame)
        if k == n // 2:
            f.reset()                       # (P's version starts again)
        s = f.output_sigmas9()
        assert s == _formula(f)
        changed += s != last
        last = s
    # the sigmas changed along the flight, and the barometric datum was in them
    assert changed > n // 10
    assert hgt_ref == 1 or f._baro_ok
