"""What the navigation filters no longer compute every step (autopilot/nav/base.py): the
output's wind array, made once per wind estimate, and the health's covariance test,
read again only when P has changed. Both must give, at every step, what computing them
afresh gives."""
from __future__ import annotations

import math

import numpy as np
import pytest

from autopilot.nav import InsGpsEkf, InsGpsUkf
from autopilot.nav.simulate import SimConfig, simulate_flight

CFG = SimConfig()
PARAMS = {"EK_MAG_DEC": math.radians(CFG.mag_declination_deg), "EK_MAG_AUTODEC": 0}


def _health_afresh(filt, t: int) -> bool:
    """NavFilterBase._update_health without its cache: the four diagonal entries of P."""
    if not (filt.aligned and filt._pos_src == "gps"):
        return False
    d = np.diag(filt.P)
    pn, pe = d[0], d[1]
    ok = bool(np.isfinite(pn + pe + d[6] + d[8]) and pn + pe <= filt.params["EK_HPOS_MAX"] ** 2)
    tout = filt.params["EK_REJ_TOUT"] * 1e6
    return ok and all(t - since <= tout for since in filt._rej_since.values())


@pytest.mark.parametrize("cls, cov_div", [(InsGpsEkf, 1), (InsGpsEkf, 4), (InsGpsUkf, None)])
def test_cached_health_and_wind_are_those_computed_afresh_at_every_step(cls, cov_div):
    # GIVEN a simulated fixed-wing flight with a GPS outage (the health drops and returns)
    sim = simulate_flight(np.random.default_rng(5), CFG, duration_s=60.0,
                          gps_outages=[(30.0, 42.0)])
    kw = {} if cov_div is None else {"cov_div": cov_div}
    filt = cls(PARAMS, "plane", CFG.origin(), **kw)
    healthy = []
    outs = []
    # WHEN it is flown, EK_HPOS_MAX lowered below the position sigma for two seconds
    for k, frame in enumerate(sim.frames()):
        if k == 2000:
            filt.params["EK_HPOS_MAX"] = 1e-3
        elif k == 2200:
            filt.params["EK_HPOS_MAX"] = PARAMS.get("EK_HPOS_MAX", InsGpsEkf().params["EK_HPOS_MAX"])
        nav = filt.update(frame)
        # THEN the health is the one computed afresh from P, the limit's change included
        assert nav.healthy == _health_afresh(filt, frame.t_us), k
        healthy.append(nav.healthy)
        # AND the output's wind is the estimate's, unchanged in the outputs handed out before
        assert nav.wind_ned.tolist() == [*filt.nom.wind, 0.0]
        outs.append((nav, nav.wind_ned.tolist()))
    assert all(nav.wind_ned.tolist() == w for nav, w in outs)
    # (and the flight exercised both values of the health, and the lowered limit)
    assert any(healthy) and not all(healthy[1000:])
    assert not any(healthy[2000:2200]) and healthy[2300]
    # (the EKF's wind array is shared between steps and replaced when the estimate
    # changes; the UKF folds its mean error into the nominal state every step)
    winds = {id(nav.wind_ned) for nav, _ in outs}
    assert 1 < len(winds)
    if cls is InsGpsEkf:
        assert len(winds) < len(outs) // 2
