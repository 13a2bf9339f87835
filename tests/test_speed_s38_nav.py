"""Stop 38's fusion with fewer layers (autopilot/nav/base.py): a fusion whose rows all pass
their gates, with no source rejected before and none forced, fuses every row without the
per-source gate loop, and its records, P and state are those of that loop, bit for bit;
a Batch builds its z and h0 arrays only when asked, equal to its lists."""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from autopilot.nav import InsGpsEkf
from autopilot.nav.base import Batch
from autopilot.nav.records import InnovationRecord
from autopilot.nav.simulate import SimConfig, simulate_flight


class _EveryFusionThroughTheLoop(InsGpsEkf):
    """The reference: every fusion through the per-source gate (_gate_sources)."""

    def _fuse(self, batch, t):
        self._sync_covariance()
        self._gate_stats(batch)
        y = tuple(batch.y.tolist())
        Sd = tuple(batch.Sd.tolist())
        ratio = tuple([yi * yi / (gi * si) for yi, gi, si in zip(y, batch.g2, Sd)])
        rejected = self._gate_sources(batch, ratio, (), t)
        z = batch.z_tuple
        for k, name in enumerate(batch.src):
            a = batch.start[k]
            e = a + batch.size[k]
            self.innovations.append(InnovationRecord.make(
                t, name, z[a:e], y[a:e], Sd[a:e], ratio[a:e], rejected[k],
                batch.reset[k] or not rejected[k]))


def test_the_fusion_without_the_gate_loop_is_the_loops_bit_for_bit():
    # GIVEN a simulated fixed-wing flight through the EKF and through the reference
    cfg = SimConfig()
    sim = simulate_flight(np.random.default_rng(5), cfg, duration_s=40.0)
    prm = {"EK_MAG_DEC": math.radians(cfg.mag_declination_deg), "EK_MAG_AUTODEC": 0}
    filt = InsGpsEkf(prm, "plane", cfg.origin(), cov_div=4)
    ref = _EveryFusionThroughTheLoop(prm, "plane", cfg.origin(), cov_div=4)
    looped = []
    gate_sources = filt._gate_sources
    filt._gate_sources = lambda *a: looped.append(a[-1]) or gate_sources(*a)
    fusions = 0
    for frame in sim.frames():
        if frame.gps is not None and 20e6 <= frame.t_us < 23e6:
            # a GPS position 60 m off for 3 s: rejected, a source in the loop's keeping
            frame = replace(frame, gps=replace(frame.gps, lat_rad=frame.gps.lat_rad + 1e-5))
        nav, nav_ref = filt.update(frame), ref.update(frame)
        # THEN the outputs, the records and P are the same, bit for bit
        assert repr(nav) == repr(nav_ref)
        assert filt.innovations == ref.innovations
        assert np.array_equal(filt.P, ref.P) and np.array_equal(filt.nom.x, ref.nom.x)
        fusions += bool(filt.innovations)
    # AND most fusions went without the loop, those with the GPS rejected through it
    assert fusions > 100 and 0 < len(looped) < fusions // 2


def test_a_batch_builds_z_and_h0_when_asked():
    z, h0, R = [1.0, 2.5, -3.0], [0.5, 2.0, -1.0], [0.1, 0.2, 0.3]
    bt = Batch(["gps_pos"], [0], [3], [False], z, h0, R, [9.0] * 3, np.zeros((3, 21)))
    assert bt._zh is None
    assert bt.z.tolist() == z and bt.h0.tolist() == h0 and bt.R.tolist() == R
    assert bt.z.base is bt.h0.base           # (built once, for both)
    assert bt.y0.tolist() == [zi - hi for zi, hi in zip(z, h0)]
