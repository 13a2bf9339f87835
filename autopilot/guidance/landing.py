"""Fixed-wing automatic landing: the NAV_LAND item, as ArduPlane flies it.

Phases (``Landing.phase``):

* ``approach``: the leg from the previous waypoint A to the land point B, tracked by L1
  (a straight line, extended past B), on a glide slope from A's altitude down to the
  ground, at the approach airspeed TECS_LAND_ARSPD (-1: midway between ARSPD_FBW_MIN
  and TRIM_ARSPD, as ArduPlane reads it). The throttle holds the airspeed and the
  pitch the slope, as on any leg, except that the speed priority (the pitch giving up
  height for airspeed, control/fixed_wing.py SPD_PRIO) is weighted by TECS_LAND_SPDWGT,
  -1 sliding from 1 at A to 0 at B as ArduPlane's TECS does: with full weight a gust's
  airspeed swing of 3-4 m/s pushes the aircraft 2-3 m off the glide slope over the last
  few hundred metres, and the flare (a height trigger) then starts anywhere from 30 to
  160 m before the land point. (The Aerosonde's parameter file keeps 1: faded, the
  fault monitor read a go-around's climb as an elevator fault, docs/status.md.)
* ``flare``: from LAND_FLARE_ALT above the land point, or LAND_FLARE_SEC before the
  ground at the glide slope's sink rate, whichever comes first (ArduPlane's two
  triggers; the slope's sink, not the measured one, so that a gust's sink does not
  start the flare high).
  The throttle goes to idle and the pitch flies a sink-rate demand
  hdot = -min(s_app, h' / tau + TECS_LAND_SINK + TECS_LAND_SRC d_past): the approach
  sink s_app until the exponential flare law's demand falls under it, then the classic
  exponential flare (the height decays with time constant tau towards a touchdown at
  TECS_LAND_SINK). s_app is the sink flown (its mean over the last ``SINK_MEAN_S``, the
  glide slope's at most), raised, at every step, to the sink that brings the height h
  down to the glide slope's ground point (``shift_m`` short of B, below) at the ground
  speed flown, up to ``FLARE_CAP_MAX`` times the slope's sink: an updraft just above
  the flare height lowers the mean sink and leaves the aircraft high on the slope, and
  a flare capped at that mean glided its first two metres at 0.6 m/s and floated 30-45
  m past B (issue 16's long landings); below the slope (an early flare) it stays at the
  mean, which does not push the aircraft down to the slope.
  The flare is steered to the land point: tau is, at every step, the time constant
  whose exponential reaches the ground from the height h in the time the aircraft needs
  to B at its ground speed along the approach, tau ln(1 + h / (tau s_td)) = t_go
  (``flare_tau``), kept within ``FLARE_TAU_MIN``..``FLARE_TAU_MAX`` times
  LAND_FLARE_SEC: a float (a gust's airspeed, a flare started late) shortens it and
  sinks more, a flare started early lengthens it. (With the floor at 0.75, the nominal
  flare's own tau, about 0.78 LAND_FLARE_SEC from 3 m on the slope, sat on it, and a
  float had nothing left to shorten.) Past B, ArduPlane's TECS_LAND_SRC
  adds sink per metre flown beyond the point (d_past). h' is the height LAND_FLR_LAG
  ahead (h less the last demand times the lag), a lead against the lag of the
  aircraft's sink rate behind the demand. The pitch is held at no less than LAND_PITCH_DEG
  (ArduPlane's LAND_PITCH_CD) and no more than LAND_PITCH_MAX; the bank is limited as
  just after launch (TKOFF_LVL_BANK).
  The climb rate is flown with its own gain, LAND_FLR_CLMB_KP (ArduPlane's TECS
  likewise tightens its height loop in the flare): at the cruise gain the aircraft lags
  the law by about 0.7 s and touches down early; a higher gain follows it closely in
  still air but chases the gusts' sink in turbulence and lands harder (docs/status.md).
* ``rollout``: touched down: in the flare, below LAND_FLARE_ALT, the sink rate has
  stayed under half TECS_LAND_SINK (which the flare law never asks for in the air)
  for ``TOUCH_S``: wings level, idle, the flare's pitch law goes on (held against the
  skids, it cannot lift the aircraft off at idle; a gust that floats it is flown as in
  the flare).
* ``descend``: the approach starts higher above its glide slope than it can lose before
  LAND_AB_CHK_ALT (half LAND_AB_HIGH, plus the altitude demand's fastest descent,
  DEM_CLMB_FRAC SINK_MAX, less the slope's sink, over the time to that height: the leg
  before it too short, or flown too slowly, to lose the height: a base leg cut
  short by its turn, a climb-out or a go-around ending above the slope): the height is
  lost first, as an ArduPlane user plans with NAV_LOITER_TO_ALT before the landing, on
  a circle tangent to the approach line at its start A (centred on the side the
  aircraft is on, turning towards the line, radius at TURN_BANK_DEG at the approach
  airspeed plus the wind), at the approach airspeed, down to the glide slope's start;
  the circle is left at A on the approach course, and the approach is flown from there
  (``descent_circle``, ``descent_done``). Without it the approach starts up to 70 m high,
  the aircraft (idle, about 2 m/s sink) reaches LAND_AB_CHK_ALT still far above the slope
  and goes around, and the go-around flies the same sequence again: the random-plane
  campaign's landings that went around 5-18 times (docs/status.md).
* ``go_around``: the approach abandoned (MAV_CMD_DO_GO_AROUND, or an automatic abort
  when, below LAND_AB_CHK_ALT and before the flare, the aircraft is LAND_AB_HIGH above
  or LAND_AB_LOW below the glide slope, LAND_AB_XTRK off the centreline, or its 1 s
  mean airspeed LAND_AB_SPD above the approach's): climb straight ahead on the
  approach line at TRIM_ARSPD to the abort altitude (the command's, else NAV_LAND
  param1, else LAND_ABORT_ALT, above home), then fly the landing again (the sequencer:
  guidance/mission.py ``_go_around_climb``).
* ``ground``: stopped (ground speed under ``STOP_GSPD`` after the flare, within
  LAND_FLARE_ALT of the land point): the landing is complete; the vehicle disarms
  LAND_DISARMDELAY seconds later.

The height. Every height above the land point above (the glide slope's, the flare's
triggers and law, the touchdown and ground tests, the abort checks) is the navigation's
altitude less the land point's, less ``h_corr_m``: with RNGFND_LANDING 1 and a downward
rangefinder in range, the difference between the navigation's height and the
rangefinder's (guidance/rangefinder.py, ArduPlane's rangefinder correction), so that
near the ground the landing flies the rangefinder's height; else 0 (the navigation's).

The aim point. A flare flown so ends beyond the point where the glide slope meets
the ground: with r = s_app / s_td and a flight path that follows the law exactly, the
exponential part takes tau ln r seconds from the height tau (s_app - s_td) where it
starts, which the glide slope would have flown in tau (1 - 1/r) seconds, so the
touchdown is gs tau (ln r - 1 + 1/r) past that point (gs the ground speed along the
approach, estimated in the wind when the approach starts). The aircraft's sink rate
follows the law's demand with a lag (its heave response and the pitch loop's),
LAND_FLR_LAG seconds as a first-order lag, which shortens the float: with r = 4.3 and
gs 23 m/s, 31 m without lag, 18 m with 0.4 s. ``flare_overshoot_m`` integrates that
lagged flare from the flare height (both triggers) to the ground, and the glide slope is
aimed that much short of the land point, so the touchdown, not the glide slope's end,
falls on it. LAND_FLR_LAG is a property of the airframe and LAND_FLR_CLMB_KP, measured
from calm-air landings (docs/status.md).
"""
from __future__ import annotations

import math

from ..params import Param

LAND_PARAMS = (
    Param("LAND_FLARE_ALT", 3.0, 0.0, 30.0, "m", "flare at this height above the land point"),
    Param("LAND_FLARE_SEC", 2.0, 0.5, 10.0, "s", "flare this long before the ground at the current sink rate; the flare law's time constant"),
    Param("LAND_PITCH_DEG", 0.0, -10.0, 20.0, "deg", "minimum pitch in the flare (ArduPlane LAND_PITCH_CD)"),
    Param("LAND_PITCH_MAX", 12.0, 0.0, 30.0, "deg", "maximum pitch in the flare (tail clearance, stall margin)"),
    Param("LAND_DISARMDELAY", 20.0, 0.0, 127.0, "s", "disarm this long after the landing is complete"),
    Param("TECS_LAND_ARSPD", -1.0, -1.0, 80.0, "m/s", "approach airspeed (-1: midway between ARSPD_FBW_MIN and TRIM_ARSPD)"),
    Param("TECS_LAND_SINK", 0.25, 0.0, 2.0, "m/s", "sink rate the flare ends at (touchdown)"),
    Param("LAND_FLR_CLMB_KP", 0.08, 0.0, 2.0, "rad s/m", "climb-rate error to pitch in the flare"),
    Param("LAND_FLR_LAG", 0.4, 0.0, 3.0, "s", "lag of the sink rate behind the flare law's demand (places the aim point)"),
    Param("TECS_LAND_SRC", 0.02, -2.0, 2.0, "1/s", "flare sink rate added per metre flown past the land point (ArduPlane's TECS_LAND_SRC)"),
    Param("TECS_LAND_SPDWGT", -1.0, -1.0, 2.0, "", "the speed priority's weight on the approach (-1: from 1 at its start to 0 at the land point)"),
    Param("RTL_AUTOLAND", 0, 0, 3, "", "RTL lands through the nearest DO_LAND_START: 0 no, 1 after reaching home, 2 at once, 3 only for a go-around", is_int=True),
    Param("LAND_ABORT_ALT", 30.0, 5.0, 300.0, "m", "go-around climb altitude above home when neither the command nor the NAV_LAND gives one"),
    Param("LAND_AB_CHK_ALT", 20.0, 0.0, 200.0, "m", "the approach is checked (LAND_AB_*) below this height above the land point"),
    Param("LAND_AB_HIGH", 8.0, 0.0, 100.0, "m", "abort: this far above the glide slope (0: no check)"),
    Param("LAND_AB_LOW", 8.0, 0.0, 100.0, "m", "abort: this far below the glide slope (0: no check)"),
    Param("LAND_AB_XTRK", 15.0, 0.0, 200.0, "m", "abort: this far off the approach's centreline (0: no check)"),
    Param("LAND_AB_SPD", 6.0, 0.0, 30.0, "m/s", "abort: airspeed (1 s mean) this much above the approach airspeed (0: no check)"),
)
AUTO_ABORTS_MAX = 2    # automatic aborts per landing; then it is flown down as ArduPlane flies
                       # every approach (ArduPlane has no automatic abort: only the command)
DESCENT_EXIT_DEG = 20.0   # the descent circle is left within this of the approach course
AB_SPD_TAU_S = 1.0     # the airspeed mean the overspeed abort reads [s]
STOP_GSPD = 3.0        # below this ground speed after the flare the aircraft is down [m/s]
SINK_MEAN_S = 1.0      # the approach's sink rate the flare starts from: its mean over this [s]
TOUCH_S = 0.3          # sink rate under TECS_LAND_SINK / 2 this long in the flare: touched down [s]
FLARE_TAU_MIN = 0.5    # the flare's time constant, steered to the land point, at least this (0.75 to c26d19e)
FLARE_TAU_MAX = 2.0    # and at most this, times LAND_FLARE_SEC
FLARE_CAP_MAX = 1.25   # the flare's sink cap, raised to reach B, at most this times the slope's sink


def flare_tau(h_m: float, t_go_s: float, s_td: float, lo: float, hi: float) -> float:
    """The time constant tau of the exponential flare hdot = -(h / tau + s_td) that
    reaches the ground from ``h_m`` in ``t_go_s`` seconds: T(tau) = tau ln(1 + h /
    (tau s_td)) = t_go, clamped to [lo, hi]. T grows monotonically with tau (from 0 to
    h / s_td), so the root is bracketed and found by bisection (on log tau)."""
    if h_m <= 0.0 or s_td <= 0.0:
        return lo

    def t_of(tau):
        return tau * math.log1p(h_m / (tau * s_td))

    if t_of(lo) >= t_go_s:
        return lo
    if t_of(hi) <= t_go_s:
        return hi
    a, b = math.log(lo), math.log(hi)
    for _ in range(24):
        m = 0.5 * (a + b)
        if t_of(math.exp(m)) < t_go_s:
            a = m
        else:
            b = m
    return math.exp(0.5 * (a + b))


def approach_airspeed(params) -> float:
    """TECS_LAND_ARSPD, or midway between ARSPD_FBW_MIN and TRIM_ARSPD when -1."""
    v = params["TECS_LAND_ARSPD"]
    if v > 0:
        return min(max(v, params["ARSPD_FBW_MIN"] * 0.75), params["ARSPD_FBW_MAX"])
    return 0.5 * (params["ARSPD_FBW_MIN"] + params["TRIM_ARSPD"])


def flare_overshoot_m(gs_mps: float, s_app: float, s_td: float, tau: float,
                      h_flare: float | None = None, lag_s: float = 0.0) -> float:
    """How far past the glide slope's ground point the flare touches down (module
    docstring). Without lag and from the law's own start height: gs tau (ln r - 1 +
    1/r), r = s_app / s_td; otherwise the flare from ``h_flare`` with the sink following
    the law's demand min(s_app, h / tau + s_td) through a first-order lag ``lag_s``,
    integrated (Euler, 5 ms) to the ground."""
    if s_td <= 0.0 or s_app <= s_td:
        return 0.0
    r = s_app / s_td
    if h_flare is None and lag_s <= 0.0:
        return gs_mps * tau * (math.log(r) - 1.0 + 1.0 / r)
    h = h_flare if h_flare is not None else tau * (s_app - s_td)
    h0, s, t, dt = h, s_app, 0.0, 0.005
    while h > 0.0 and t < 60.0:
        dem = min(s_app, h / tau + s_td)
        s += (dem - s) * (min(dt / lag_s, 1.0) if lag_s > 0.0 else 1.0)
        h -= s * dt
        t += dt
    return max(gs_mps * (t - h0 / s_app), 0.0)


class Landing:
    """One approach to the land point B from A (both NE of home [m]); ``alt_a`` and
    ``alt_b`` MSL [m]. ``step`` returns (altitude demand, sink-rate demand or None,
    phase) and moves the phases on."""

    def __init__(self, params, a_ne, b_ne, alt_a: float, alt_b: float, gs_mps: float):
        self.params = params
        self.a_ne, self.b_ne = a_ne, b_ne
        self.alt_a, self.alt_b = alt_a, alt_b
        ln = math.hypot(b_ne[0] - a_ne[0], b_ne[1] - a_ne[1])
        self.length = max(ln, 1.0)
        self.u = ((b_ne[0] - a_ne[0]) / self.length, (b_ne[1] - a_ne[1]) / self.length)
        self.airspeed_mps = approach_airspeed(params)
        dh = max(alt_a - alt_b, 0.0)
        s_app = dh / self.length * gs_mps
        h_flare = max(params["LAND_FLARE_ALT"], s_app * params["LAND_FLARE_SEC"])
        self.shift_m = min(flare_overshoot_m(gs_mps, s_app, params["TECS_LAND_SINK"],
                                             params["LAND_FLARE_SEC"], h_flare, params["LAND_FLR_LAG"]),
                           0.5 * self.length)
        self.aim_along = self.length - self.shift_m     # where the glide slope meets the ground
        self.slope = dh / max(self.aim_along, 1.0)
        self.phase = "approach"
        self.descent: tuple | None = None               # (centre NE, radius, direction): ``descend``
        self.flare_us: int | None = None
        self.flare_info: tuple | None = None            # (height, sink, airspeed, distance to go)
        self.landed_us: int | None = None
        self.touch_us: int | None = None
        self.ga_alt: float | None = None                # go-around: the climb's altitude (MSL)
        self._v_mean: float | None = None
        self._last_us: int | None = None
        self._sink_app: float | None = None
        self._slow_since: int | None = None
        self._sink_mean: float | None = None
        self._sink_us: int | None = None
        self.flare_tau_s: float | None = None          # the flare's time constant of the moment
        self.flare_cap_mps: float | None = None        # the flare's sink cap of the moment
        self._s_dem: float | None = None                # the flare's sink demand, last step
        # the rangefinder's correction of the navigation's height (RNGFND_LANDING,
        # guidance/rangefinder.py): every height above the land point the landing flies
        # is alt_m - alt_b - h_corr_m, and its altitude demands are in the navigation's
        # frame (+ h_corr_m); 0 without a rangefinder in range
        self.h_corr_m = 0.0
        self.ground_b_m: float | None = None            # the terrain's height at B (the vehicle's; NaN unknown)

    def along(self, p_ne) -> float:
        return (p_ne[0] - self.a_ne[0]) * self.u[0] + (p_ne[1] - self.a_ne[1]) * self.u[1]

    def cross(self, p_ne) -> float:
        return -(p_ne[0] - self.a_ne[0]) * self.u[1] + (p_ne[1] - self.a_ne[1]) * self.u[0]

    def line_end(self) -> tuple[float, float]:
        """A point well past B on the approach line (L1 tracks the line beyond B)."""
        return (self.b_ne[0] + 1000.0 * self.u[0], self.b_ne[1] + 1000.0 * self.u[1])

    def glide_alt(self, along: float) -> float:
        """The glide slope's altitude at ``along`` metres from A (MSL)."""
        a = min(max(along, 0.0), self.aim_along)
        return self.alt_b + self.slope * (self.aim_along - a)

    def glide_demand(self, along: float) -> float:
        """The glide slope's altitude at ``along`` as the navigation's altitude to fly:
        ``glide_alt`` plus the rangefinder's correction (``h_corr_m``)."""
        return self.glide_alt(along) + self.h_corr_m

    def speed_weight(self, along: float) -> float:
        """The weight of the speed priority (control/fixed_wing.py SPD_PRIO) on the
        approach: TECS_LAND_SPDWGT, or with -1 (ArduPlane's default, its TECS sliding
        scale) 1 at the approach's start down to 0 at the land point: near the ground the
        pitch holds the glide slope and the throttle alone the airspeed."""
        w = self.params["TECS_LAND_SPDWGT"]
        if w >= 0.0:
            return min(w, 2.0)
        return min(max(1.0 - along / self.length, 0.0), 1.0)

    def descent_circle(self, p_ne, alt_m: float, radius_m: float, sink_mps: float,
                       gs_mps: float) -> bool:
        """At the approach's start: if the aircraft is higher above the glide slope where
        it joins (``along`` of p_ne, at least 0) than the approach can lose before
        LAND_AB_CHK_ALT (half LAND_AB_HIGH plus (sink_mps - the slope's sink) times the
        time to that height at ``gs_mps``), plan the descent circle (module docstring,
        ``descend``) and return True. The circle is tangent to the approach line at A,
        centred on the aircraft's side of the line, and turns towards it: clockwise (+1)
        on the right, so that it passes A on the course."""
        p = self.params
        along0 = max(self.along(p_ne), 0.0)
        excess = alt_m - self.glide_alt(along0)
        gs = max(gs_mps, 1.0)
        along_chk = self.aim_along - (p["LAND_AB_CHK_ALT"] / self.slope if self.slope > 1e-6 else 0.0)
        lose = max(sink_mps - self.slope * gs, 0.0) * max(along_chk - along0, 0.0) / gs
        if excess <= 0.5 * p["LAND_AB_HIGH"] + lose:
            return False
        side = 1 if self.cross(p_ne) >= 0.0 else -1
        r = max(radius_m, 1.0)
        c = (self.a_ne[0] - side * r * self.u[1], self.a_ne[1] + side * r * self.u[0])
        self.descent = (c, r, side)
        self.phase = "descend"
        return True

    def descent_done(self, p_ne, course_rad: float | None, alt_m: float) -> bool:
        """The descent circle is left (the approach flown) at the glide slope's start
        height (within a quarter of LAND_AB_HIGH) and at A: within a radius of it along
        the line, within ``DESCENT_EXIT_DEG`` of the approach course."""
        if self.descent is None:
            return True
        _, r, _ = self.descent
        if alt_m - self.alt_a > 0.25 * self.params["LAND_AB_HIGH"] or course_rad is None:
            return False
        d = (course_rad - math.atan2(self.u[1], self.u[0]) + math.pi) % (2.0 * math.pi) - math.pi
        return abs(d) <= math.radians(DESCENT_EXIT_DEG) and abs(self.along(p_ne)) <= r

    def unsafe(self, p_ne, alt_m: float, airspeed_mps: float, t_us: int) -> str | None:
        """Why the approach must be abandoned, or None: below LAND_AB_CHK_ALT above the
        land point and before the flare, too far above or below the glide slope, off
        the centreline, or too fast (LAND_AB_*)."""
        p = self.params
        dt = 0.0 if self._last_us is None else (t_us - self._last_us) * 1e-6
        self._last_us = t_us
        if self._v_mean is None:
            self._v_mean = airspeed_mps
        self._v_mean += (airspeed_mps - self._v_mean) * min(dt / AB_SPD_TAU_S, 1.0)
        h = alt_m - self.alt_b - self.h_corr_m
        along = self.along(p_ne)
        if h > p["LAND_AB_CHK_ALT"] or along < 0.0:
            return None
        dh = alt_m - self.glide_demand(along)
        if p["LAND_AB_HIGH"] > 0 and dh > p["LAND_AB_HIGH"]:
            return f"{dh:.0f} m above the glide slope"
        if p["LAND_AB_LOW"] > 0 and -dh > p["LAND_AB_LOW"]:
            return f"{-dh:.0f} m below the glide slope"
        xt = self.cross(p_ne)
        if p["LAND_AB_XTRK"] > 0 and abs(xt) > p["LAND_AB_XTRK"]:
            return f"{abs(xt):.0f} m off the centreline"
        if p["LAND_AB_SPD"] > 0 and self._v_mean > self.airspeed_mps + p["LAND_AB_SPD"]:
            return f"airspeed {self._v_mean:.1f} m/s"
        return None

    def step(self, t_us: int, p_ne, alt_m: float, v_ned, airspeed_mps: float):
        p = self.params
        h = alt_m - self.alt_b - self.h_corr_m    # above the land point (rangefinder-corrected)
        sink = float(v_ned[2])
        gspd = math.hypot(float(v_ned[0]), float(v_ned[1]))
        along = self.along(p_ne)
        if self.phase == "approach":
            s_gs = self.slope * max(gspd, 1.0)        # the glide slope's sink rate
            dt = 0.0 if self._sink_us is None else (t_us - self._sink_us) * 1e-6
            self._sink_us = t_us
            self._sink_mean = sink if self._sink_mean is None else \
                self._sink_mean + (sink - self._sink_mean) * min(dt / SINK_MEAN_S, 1.0)
            if h <= p["LAND_FLARE_ALT"] or h <= s_gs * p["LAND_FLARE_SEC"]:
                # the flare law starts from the sink rate flown, its SINK_MEAN_S mean (a
                # gust's moment says nothing), the glide slope's at most: an aircraft below
                # the slope, sinking less, is not pushed down to it
                self._sink_app = max(min(s_gs, self._sink_mean), p["TECS_LAND_SINK"])
                self.phase = "flare"
                self.flare_us = t_us
                self.flare_info = (h, sink, airspeed_mps, self.length - along)
        if self.phase == "flare" and h < p["LAND_FLARE_ALT"]:
            if sink < 0.5 * p["TECS_LAND_SINK"]:
                if self._slow_since is None:
                    self._slow_since = t_us
                if (t_us - self._slow_since) * 1e-6 >= TOUCH_S:
                    self.phase = "rollout"
                    self.touch_us = t_us
            else:
                self._slow_since = None
        if self.phase in ("flare", "rollout") and gspd < STOP_GSPD and h < p["LAND_FLARE_ALT"]:
            self.phase = "ground"
            self.landed_us = t_us
        if self.phase == "approach":
            return self.glide_demand(along), None
        # the flare steered to the land point: the time constant that brings the height
        # flown to the ground at B at the ground speed flown, within FLARE_TAU_MIN..MAX
        # of LAND_FLARE_SEC; past B, TECS_LAND_SRC more sink per metre (ArduPlane's)
        tau0, s_td = p["LAND_FLARE_SEC"], p["TECS_LAND_SINK"]
        to_go = self.length - along
        gs_along = max(float(v_ned[0]) * self.u[0] + float(v_ned[1]) * self.u[1], 1.0)
        if to_go > 0.0:
            tau = flare_tau(max(h, 0.0), to_go / gs_along, s_td, FLARE_TAU_MIN * tau0, FLARE_TAU_MAX * tau0)
        else:
            tau = FLARE_TAU_MIN * tau0
        self.flare_tau_s = tau
        # the law read LAND_FLR_LAG ahead (the height the aircraft will be at when its
        # sink rate has followed the demand): a lead against that lag
        h_lead = max(h - (self._s_dem if self._s_dem is not None else sink) * p["LAND_FLR_LAG"], 0.0)
        # the cap tracks the distance too: the sink that brings the height flown down to
        # the glide slope's ground point (``shift_m`` short of B, where a flare flown from
        # the slope lands on B) at the ground speed flown, when that is more than the
        # approach's mean sink, at most FLARE_CAP_MAX times the slope's own: a flare begun
        # from a slow sink (an updraft just above the flare height lowered the mean) or
        # high on the slope would otherwise glide its first metres at the slow sink and
        # float tens of metres past B; below the slope it stays at the mean
        s_gs = self.slope * max(gs_along, 1.0)
        to_aim = to_go - self.shift_m
        s_req = h * gs_along / to_aim if to_aim > h * gs_along / (FLARE_CAP_MAX * s_gs) \
            else FLARE_CAP_MAX * s_gs
        s_cap = max(self._sink_app, min(s_req, FLARE_CAP_MAX * s_gs))
        self.flare_cap_mps = s_cap
        s_dem = min(s_cap, h_lead / tau + s_td + p["TECS_LAND_SRC"] * max(-to_go, 0.0))
        self._s_dem = s_dem
        return self.alt_b + self.h_corr_m, -s_dem
