"""The ``landing`` figures of summary.json, scored on truth while the run goes.

The flight log (50 Hz) is too coarse for a touchdown, so the session hands every
plant step to ``LandingScore.update``. The touchdown is the first ground contact of
the airframe (JSBSim's contacts) while a NAV_LAND is being flown; from it:

* ``touchdown_along_m`` / ``touchdown_cross_m``: the true position at that instant
  from the land point, along the approach (+ beyond the point) and across it (+ right);
* ``sink_rate_mps``: the true vertical speed (down +) at that instant;
* ``bounce_m``: how high the centre of gravity rose above its height at the touchdown
  while every contact was off the ground again (0: it stayed down);
* ``disarmed``: the vehicle disarmed after the landing (LAND_DISARMDELAY);
* ``go_arounds``: approaches abandoned (MAV_CMD_DO_GO_AROUND or an automatic abort).

None when the run flew no landing.
"""
from __future__ import annotations

import math


class LandingScore:
    def __init__(self, terrain_alt_m: float):
        self.terrain_alt_m = terrain_alt_m     # the ground away from the launcher (MSL)
        self.flown = False
        self.touchdown: dict | None = None
        self._h_td = 0.0
        self.bounce_m = 0.0

    def update(self, state, vehicle, plant) -> None:
        """After each plant step: ``state`` the plant's new state, ``plant`` the plant
        (asked whether it is still on its launcher only at a ground contact)."""
        seq = vehicle.sequencer
        land = seq.landing if seq is not None else None
        if land is None or vehicle.home_frame is None:
            return
        self.flown = True
        h = state.alt_m - self.terrain_alt_m
        if self.touchdown is None:
            if state.on_ground and not plant.on_launcher:
                p = vehicle.home_frame.to_ned_fast(state.lat_rad, state.lon_rad, state.alt_m)
                p_ne = (float(p[0]), float(p[1]))
                self.touchdown = {
                    "t_s": round(state.t_us * 1e-6, 3),
                    "along_m": land.along(p_ne) - land.length,
                    "cross_m": land.cross(p_ne),
                    "sink_rate_mps": float(state.v_ned[2]),
                    "phase": land.phase,
                }
                self._h_td = h
        elif not state.on_ground:
            self.bounce_m = max(self.bounce_m, h - self._h_td)

    def figures(self, vehicle) -> dict | None:
        if not self.flown:
            return None
        td = self.touchdown
        seq = vehicle.sequencer

        def r(x):
            return None if x is None or not math.isfinite(x) else round(x, 3)

        return {
            "touchdown_along_m": r(td["along_m"]) if td else None,
            "touchdown_cross_m": r(td["cross_m"]) if td else None,
            "sink_rate_mps": r(td["sink_rate_mps"]) if td else None,
            "touchdown_s": td["t_s"] if td else None,
            "touchdown_phase": td["phase"] if td else None,
            "bounce_m": r(self.bounce_m) if td else None,
            "disarmed": bool(getattr(vehicle, "land_done", False) and not vehicle.armed),
            "go_arounds": int(getattr(seq, "go_arounds", 0)) if seq is not None else 0,
        }
