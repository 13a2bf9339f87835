"""The downward rangefinder on a fixed-wing landing (RNGFND_LANDING), as ArduPlane uses it.

What ArduPlane does (ArduPlane/altitude.cpp ``rangefinder_height_update``,
``rangefinder_correction``, ``get_landing_height``; the wiki's "Using a Rangefinder for
Autolanding"): the rangefinder's reading, corrected for attitude (the range along the
sensor's axis rotated into NED: its down component), is the height above the ground.
After 10 good readings that differ from the first one seen by more than 5 % of the
sensor's maximum range (a stuck sensor never gets there; a jump of 20 % of the maximum
range starts the count again) it is *in range*. While in range, the difference between
the navigation's height above the land point and the rangefinder's height is the
*correction*, low-pass filtered per reading (0.8 old + 0.2 new), taken whole when the
last one is more than 5 s old, and dropped (the rangefinder disengaged) when it moves
more than 30 m from its first value. On a landing (ArduPlane's LAND flight stage, with
RNGFND_LANDING 1) the landing's height above the land point is the navigation's less
the correction: the glide slope's end, the flare trigger and the flare's height law fly
the rangefinder's height while the correction is fresh (a reading in range within the
last 5 s), the navigation's otherwise. The rest of the flight, and every height that is
not the landing's, is untouched.

Ours, written after that description: ``RangefinderHeight`` keeps the same state and
the same constants (``IN_RANGE_COUNT``, ``STUCK_FRAC``, ``JUMP_FRAC``, ``CORR_KEEP``,
``CORR_STALE_S``, ``CORR_RESET_M``). Two choices of ours: the reading is judged in
range by RNGFND1_MIN_CM / RNGFND1_MAX_CM (as ArduPilot's driver status does), by the
simulator's "invalid signal" flag (DISTANCE_SENSOR ``signal_quality`` 1), and only a
downward sensor (orientation 25, ROTATION_PITCH_270) is read; and
RNGFND1_GNDCLEAR (ArduPilot's "the reading when landed") is subtracted from the
tilt-corrected reading, so that the height is that of the centre of gravity above where
it rests on the ground, which is what a land point's altitude means here (the plan's
land point is the ground at the height the aircraft rests on it). The correction is
computed only while a landing is flown (the navigation's height above its land point is
what it corrects). Over a terrain model (``--terrain``), the terrain's height under the
aircraft less the land point's is added to the rangefinder's height first, as
ArduPlane's ``rangefinder_terrain_correction`` does.
"""
from __future__ import annotations

from ..params import Param

RNGFND_PARAMS = (
    Param("RNGFND1_TYPE", 0, 0, 100, "", "downward rangefinder: 0 none; 10 (MAVLink) or 100 (SITL, ArduPilot's numbers): read DISTANCE_SENSOR from the link", is_int=True),
    Param("RNGFND1_MIN_CM", 20, 0, 32767, "cm", "rangefinder readings shorter than this are out of range", is_int=True),
    Param("RNGFND1_MAX_CM", 700, 0, 32767, "cm", "rangefinder readings longer than this are out of range", is_int=True),
    Param("RNGFND1_GNDCLEAR", 10, 0, 127, "cm", "the rangefinder's tilt-corrected reading when landed (subtracted: height 0 on the ground)", is_int=True),
    Param("RNGFND_LANDING", 0, 0, 1, "", "1: a landing's height above the land point (glide slope end, flare) corrected by the rangefinder when in range (ArduPlane's)", is_int=True),
)
IN_RANGE_COUNT = 10     # good readings before the rangefinder is in range (ArduPlane)
STUCK_FRAC = 0.05       # ... each this fraction of the maximum range from the first one seen
JUMP_FRAC = 0.2         # a jump of this fraction of the maximum range restarts the count
CORR_KEEP = 0.8         # the correction's low-pass per reading: 0.8 old + 0.2 new
CORR_STALE_S = 5.0      # a correction older than this is not used, and is taken afresh
CORR_RESET_M = 30.0     # a correction that moves this far from its first value: disengaged


class RangefinderHeight:
    """The rangefinder's state on a fixed-wing (module docstring). ``update`` once per
    loop step with the step's reading (or None); ``correction_m`` is what the landing
    subtracts from the navigation's height above its land point."""

    def __init__(self, params):
        self.params = params
        self.reset()
        self.height_m: float | None = None     # the last in-range height above ground [m]

    def reset(self) -> None:
        self.have_initial = False
        self.initial_range_m = 0.0
        self.last_distance_m = 0.0
        self.count = 0
        self.in_range = False
        self.in_use = False
        self.correction = 0.0
        self.initial_correction = 0.0
        self.last_corr_us: int | None = None

    @property
    def enabled(self) -> bool:
        return self.params["RNGFND1_TYPE"] != 0

    def update(self, t_us: int, sample, q_nb, h_nav_m: float | None, landing: bool,
               terrain_m: float = 0.0) -> str | None:
        """Take the step's reading ``sample`` (a RangeSample or None: none this step);
        ``q_nb`` the navigation's attitude; ``h_nav_m`` the navigation's height above the
        land point while a landing is flown (else None); ``terrain_m`` the terrain's
        height under the aircraft less the land point's, where a terrain model gives
        both (ArduPlane's ``rangefinder_terrain_correction``: the ground the beam meets is
        not the land point's), else 0. Returns a notice to announce ("Rangefinder
        engaged at ..." / "... disengaged ..."), or None."""
        if sample is None or not self.enabled:
            return None
        p = self.params
        d = float(sample.distance_m)
        ok = (sample.signal_quality != 1 and p["RNGFND1_MIN_CM"] <= d * 100.0 <= p["RNGFND1_MAX_CM"]
              and sample.orientation == 25)
        if ok:
            w, x, y, z = (float(v) for v in q_nb)
            cz = 1.0 - 2.0 * (x * x + y * y)      # the body z axis' down component
            if cz <= 0.0:
                ok = False                          # not pointing at the ground
        note = None
        if not ok:
            self.count = 0
            self.in_range = False
            self.height_m = None
            return None
        max_m = p["RNGFND1_MAX_CM"] * 0.01
        if not self.have_initial:
            self.have_initial = True
            self.initial_range_m = d
        self.height_m = d * cz - p["RNGFND1_GNDCLEAR"] * 0.01
        if self.count < IN_RANGE_COUNT:
            if d != self.last_distance_m and abs(self.initial_range_m - d) > STUCK_FRAC * max_m:
                self.count += 1
            if abs(self.last_distance_m - d) > JUMP_FRAC * max_m:
                self.count = 0
        else:
            self.in_range = True
            if not self.in_use and landing and p["RNGFND_LANDING"] > 0:
                self.in_use = True
                note = f"Rangefinder engaged at {self.height_m:.2f}m"
        self.last_distance_m = d
        if self.in_range and h_nav_m is not None:
            corr = h_nav_m - (self.height_m + terrain_m)
            if self.last_corr_us is None or (t_us - self.last_corr_us) * 1e-6 > CORR_STALE_S:
                self.correction = self.initial_correction = corr
            else:
                self.correction = CORR_KEEP * self.correction + (1.0 - CORR_KEEP) * corr
                if abs(self.correction - self.initial_correction) > CORR_RESET_M:
                    if self.in_use:
                        note = f"Rangefinder disengaged at {self.height_m:.2f}m"
                    self.reset()
                    return note
            self.last_corr_us = t_us
        return note

    def correction_m(self, t_us: int, landing: bool) -> float:
        """The landing's correction [m] (navigation height less rangefinder height): 0
        unless RNGFND_LANDING is on, a landing is flown and the last correction is at
        most CORR_STALE_S old (ArduPlane's ``rangefinder_correction``)."""
        if not landing or self.params["RNGFND_LANDING"] <= 0 or not self.enabled \
                or self.last_corr_us is None or (t_us - self.last_corr_us) * 1e-6 > CORR_STALE_S:
            return 0.0
        return self.correction
