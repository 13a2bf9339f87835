"""The fixed-wing vehicle loop: one visible, synchronous pipeline per lockstep step.

    sensors -> navigation -> modes -> guidance -> control -> actuators

``PlaneVehicle.step(frame, truth)`` runs once per HIL_SENSOR (100 Hz by default) on
simulation time only. Truth (HIL_STATE_QUATERNION) is never used to fly unless the
navigation source is explicitly ``truth`` (a debugging aid); otherwise it is only
logged for scoring.

Flight log: one row every LOG_DIV-th step (50 Hz) and at every GPS fix, on the steps
that bring truth when the simulator paces it (``autopilot.log.flightlog.RowSchedule``).

Frames: the navigation filter has its own origin (its first GPS fix). Home is set when
the vehicle arms, from the navigation solution, as ArduPilot does, and guidance works in
the local NED frame of home (``home_frame``). Mission item 0 is replaced by that home.

Crash detection (AUTO, CRASH_DETECT = 1; after ArduPlane's, which disarms an aircraft
in AUTO that is not flying when it should be): the launch is the first moment the
airspeed estimate reaches 0.75 ARSPD_FBW_MIN (ArduPlane's "moving through the air");
an aircraft not CRASH_ALT above the point where it rested at arming CRASH_LAUNCH_S
seconds later, and not climbing towards it (its climb rate, low-passed over
CRASH_LAUNCH_TAU seconds, under CRASH_LAUNCH_CLIMB: a slow climb-out in thin air or
gusts is waited for), has failed its launch, and one that, after that, stays below CRASH_GND_ALT
above that point without climbing (not above home, which DO_SET_HOME may move), or
stops (airspeed under 0.75 ARSPD_FBW_MIN and ground speed under 1.5 m/s), for
CRASH_DELAY_S seconds while no landing is flown has touched down outside a landing.
Either way the throttle is cut and the vehicle disarms, saying why (STATUSTEXT
EMERGENCY "Crash detected: ...", in ``notices``; the reason stays in ``crash``).
"""
from __future__ import annotations

import math

import numpy as np

from .control.fixed_wing import FW_PARAMS, FixedWingController
from .fence.actions import fence_step, fence_watching, home_ll
from .fence.geofence import Geofence
from .geo import LocalFrame, wrap_pi
from .geo.rotations import euler_321
from .guidance.l1 import G, L1Guidance
from .guidance.landing import LAND_PARAMS
from .guidance.rangefinder import RNGFND_PARAMS, RangefinderHeight
from .guidance.mission import MissionSequencer, NavTarget
from .log.flightlog import FlightLog, RowSchedule
from .messages import ActuatorOutputs, NavState, SensorFrame
from .mission.items import MAV_CMD_NAV_LAND, Mission
from .link.codec import MAV
from .modes.plane import IMPLEMENTED_PLANE_MODES, PlaneMode
from .monitor import FDI_PARAMS, LOG_COLUMNS as FDI_LOG_COLUMNS, SEV_WARNING, FaultMonitor
from .params import Param, ParamStore
from .vehicle_base import NAV_COLUMNS, TRUTH_COLUMNS, TruthNav, VehicleBase, shared_param_declarations

GUIDANCE_PARAMS = (
    Param("NAVL1_PERIOD", 17.0, 5.0, 60.0, "s", "L1 period: the cross-track response period"),
    Param("NAVL1_DAMPING", 0.75, 0.6, 1.0, "", "L1 damping ratio"),
    Param("WP_RADIUS", 100.0, 1.0, 500.0, "m", "waypoint acceptance radius and turn-anticipation cap"),
    Param("TURN_BANK_DEG", 28.0, 5.0, 60.0, "deg", "nominal bank of the turn arcs between legs"),
    Param("TURN_GS_FACTOR", 1.15, 0.5, 3.0, "", "ground speed / airspeed assumed when sizing turn arcs"),
    Param("LOITER_RAD", 80.0, 20.0, 2000.0, "m", "default loiter radius"),
    Param("RTL_ALT", 100.0, -1.0, 3000.0, "m", "RTL altitude above home (-1: keep current)"),
    Param("TKOFF_PITCH", 12.0, 0.0, 30.0, "deg", "takeoff climb pitch when the item gives none"),
    Param("TKOFF_ALT_TOL", 5.0, 0.0, 50.0, "m", "takeoff complete this close to its altitude"),
    Param("TKOFF_LVL_ALT", 15.0, 0.0, 100.0, "m", "bank limited to TKOFF_LVL_BANK below this height"),
    Param("TKOFF_LVL_BANK", 10.0, 0.0, 45.0, "deg", "bank limit just after launch"),
    Param("GROUND_STEER_ALT", 0.0, 0.0, 10.0, "m", "a take-off below this height above where the aircraft rested at arming is on its wheels: wings level, the rudder (nose wheel) steering the take-off heading (0: off, a catapult launch)"),
    Param("GSTEER_KP", 4.0, 0.0, 10.0, "1/rad", "ground steering: heading error to rudder"),
    Param("GSTEER_KD", 1.0, 0.0, 10.0, "s/rad", "ground steering: yaw rate to rudder"),
    Param("ARM_SETTLE_S", 3.0, 0.0, 60.0, "s", "headless: seconds of healthy navigation before arming"),
)

CRASH_PARAMS = (
    Param("CRASH_DETECT", 1, 0, 1, "", "AUTO: a failed launch or a touchdown outside a landing cuts the throttle and disarms (0: off)", is_int=True),
    Param("CRASH_LAUNCH_S", 5.0, 1.0, 60.0, "s", "airborne (CRASH_ALT) this long after the launch, else a failed launch"),
    Param("CRASH_ALT", 3.0, 0.5, 50.0, "m", "height above the arming point that counts as airborne after the launch"),
    Param("CRASH_GND_ALT", -0.5, -10.0, 20.0, "m", "below this height above the arming point and not climbing: on the ground (the Aerosonde's launcher deck is 1.5 m above the ground)"),
    Param("CRASH_DELAY_S", 1.0, 0.1, 10.0, "s", "on the ground (or stopped) this long before a crash is declared"),
)
SEV_EMERGENCY = 0        # MAV_SEVERITY_EMERGENCY (ArduPlane says "Crash detected" so)
SEV_INFO = 6             # MAV_SEVERITY_INFO
CRASH_STOP_GSPD = 1.5   # ground speed under which a stopped aircraft is not moving [m/s] (ArduPlane)
CRASH_CLIMB = 1.0       # climbing faster than this [m/s] is not resting on the ground
CRASH_LAUNCH_CLIMB = 0.5  # after the launch, climbing faster than this [m/s] is on its way up
CRASH_LAUNCH_TAU = 1.0  # ... the climb rate low-passed over this [s], through the gusts
GSTEER_LINE_M = 25.0    # ground steering: back onto the runway's line over this distance [m]

LOG_COLUMNS = (
    "t_s", "armed", "mode", "seq", "leg_id", "kind",
) + TRUTH_COLUMNS + (
    "est_n_m", "est_e_m", "est_alt_m", "est_roll_rad", "est_pitch_rad", "est_yaw_rad",
    "est_vn_mps", "est_ve_mps", "est_vd_mps", "est_airspeed_mps", "est_wind_n_mps", "est_wind_e_mps",
    # tgt_alt_m is the slew-limited altitude demand the control loops track
    "tgt_alt_m", "tgt_airspeed_mps", "cmd_roll_rad", "cmd_pitch_rad", "cmd_climb_mps",
    "leg_a_n_m", "leg_a_e_m", "leg_b_n_m", "leg_b_e_m", "loiter_c_n_m", "loiter_c_e_m",
    "loiter_r_m", "loiter_dir", "xtrack_est_m",
    "ctl_aileron", "ctl_elevator", "ctl_rudder", "ctl_throttle",
    # the downward rangefinder (guidance/rangefinder.py): its tilt-corrected height above
    # the ground (-1 when out of range or none), the correction a landing applies
    "rng_hagl_m", "rng_corr_m",
    # the propeller's speed its ESC reports (ESC_TELEMETRY_1_TO_4; -1 none delivered yet)
    "rpm",
) + NAV_COLUMNS + FDI_LOG_COLUMNS  # fault monitor statistics (autopilot/monitor/monitor.py LOG_COLUMNS)
_FDI_IDLE = (0.0, -1.0) + (0.0,) * (len(FDI_LOG_COLUMNS) - 3) + (1.0,)
KIND_CODES = {"idle": 0, "takeoff": 1, "line": 2, "loiter": 3, "direct": 4}
LOG_DIV = 2          # flight log: one row every LOG_DIV-th step (50 Hz) and at every GPS fix
NAV_COV_DIV = 4      # EKF covariance prediction every 4th step, and before every fusion (autopilot/nav/ekf.py)
# the modes as module constants for the per-step tests: reading a member off its enum
# class (PlaneMode.AUTO) costs about 0.2 us, as much as the rest of such a test
_MANUAL, _AUTO, _RTL = PlaneMode.MANUAL, PlaneMode.AUTO, PlaneMode.RTL
_HOLD_MODES = (PlaneMode.LOITER, PlaneMode.GUIDED)


def plane_param_declarations() -> list[Param]:
    decls = (list(FW_PARAMS) + list(GUIDANCE_PARAMS) + list(LAND_PARAMS) + list(RNGFND_PARAMS)
             + list(CRASH_PARAMS) + list(FDI_PARAMS))
    return decls + shared_param_declarations("plane")


def make_nav(source: str, params: ParamStore):
    if source == "truth":
        return TruthNav()
    values = {n: v for n, v in params.items()}
    if source == "ekf":
        from .nav.ekf import InsGpsEkf
        return InsGpsEkf(values, vehicle="plane", cov_div=NAV_COV_DIV)
    if source == "ukf":
        from .nav.ukf import InsGpsUkf
        return InsGpsUkf(values, vehicle="plane")
    raise ValueError(f"unknown navigation source {source!r} (truth, ekf, ukf)")


class PlaneVehicle(VehicleBase):
    """The fixed-wing autopilot's loop. ``autostart``: arm and fly AUTO by itself once
    navigation is healthy (headless runs); otherwise wait for a ground station.
    Implements ``autopilot.vehicle_api.VehicleApi`` for the ground-station service
    (its airframe-independent half in ``autopilot.vehicle_base.VehicleBase``)."""

    vehicle_kind = "plane"
    mav_type = MAV.MAV_TYPE_FIXED_WING
    modes = PlaneMode
    implemented_modes = IMPLEMENTED_PLANE_MODES

    def __init__(self, params: ParamStore, mission: Mission | None, nav_source: str = "ekf",
                 autostart: bool = True, log: FlightLog | None = None):
        self.params = params
        self.mission = mission
        self.nav_source = nav_source
        self.nav = make_nav(nav_source, params)
        # fault monitor on the filter's innovations (none on truth navigation)
        self.monitor = FaultMonitor(params, self.nav) if hasattr(self.nav, "innovations") else None
        self._fdi_events = 0
        self.autostart = autostart
        self.log = log if log is not None else FlightLog(LOG_COLUMNS)
        self.l1 = L1Guidance(params["NAVL1_PERIOD"], params["NAVL1_DAMPING"])
        self.ctrl = FixedWingController(params)
        self.mode = PlaneMode.MANUAL
        self.armed = False
        self.home_frame: LocalFrame | None = None
        self.home_truth_alt_m: float | None = None
        self.sequencer: MissionSequencer | None = None
        self.nav_state: NavState | None = None
        self.target: NavTarget | None = None
        self.hold: NavTarget | None = None      # LOITER / GUIDED: the circle to fly
        self.xtrack_m = 0.0
        self.healthy_since_us: int | None = None
        self.gps_fix_type = 0
        self.last_t_us: int | None = None
        self.steps = 0
        self._gps_this_step = None              # the GPS fix for the next log row
        self._p_home = None                     # (nav state, its position in home's NED)
        self._wind_of = self._wind_l = None     # the wind array and its list (_fly)
        self.log_rows = RowSchedule(LOG_DIV)
        self.notices: list[tuple[float, int, str]] = []   # (t_s, MAV_SEVERITY, text): STATUSTEXT
        self.crash: str | None = None           # why crash detection disarmed the vehicle
        self.terminated = False                 # flight termination (the monitor's FDI_EL_TERM)
        self._launch_us: int | None = None      # crash detection: the launch ...
        self._airborne = False                  # ... has been followed by flight
        self._launch_climb = 0.0                # ... the climb rate since, low-passed [m/s]
        self._launch_t_us: int | None = None    # ... the step it was last updated
        self._ground_since_us: int | None = None
        self._launch_alt_m: float | None = None  # where the aircraft rested at arming (MSL)
        self.geofence = Geofence(params, "plane")  # fence and rally points (autopilot/fence)
        self.rtl_hold: NavTarget | None = None  # RTL to a rally point: the loiter there
        self._launch_ground_m: float | None = None  # the terrain's height there, if known
        self.land_done = False                  # landed (NAV_LAND) and disarmed: no re-arming
        self.rangefinder = RangefinderHeight(params)   # RNGFND1_*, RNGFND_LANDING
        self.rpm = -1.0                 # the propeller's last reported speed [rpm] (-1 none)
        self._read_step_params()

    def _read_step_params(self) -> None:
        """The parameters the loop reads every step (crash detection's, the bank limit's
        near the ground), read at the start and again at every change
        (``_param_changed``): a read from the ParamStore costs about 0.4 k instructions."""
        p = self.params
        self._crash_detect = p["CRASH_DETECT"] >= 1
        self._moving_air_mps = 0.75 * p["ARSPD_FBW_MIN"]   # ArduPlane's "moving through the air"
        self._crash_gnd_alt_m = p["CRASH_GND_ALT"]
        self._level_alt_m = p["TKOFF_LVL_ALT"]
        self._trim_arspd_mps = p["TRIM_ARSPD"]   # (the airspeed flown without DO_CHANGE_SPEED)

    # ------------------------------------------------------------------ arming ---
    def _arming(self, nav: NavState) -> None:
        """At arming: the mission from its start, crash detection from the launch."""
        self.sequencer = MissionSequencer(self.mission, self.home_frame, self.params)
        # the mission's RTL item goes to the nearest rally point as RTL mode does
        self.sequencer.rally_point = lambda lat, lon: self.geofence.rally_for_rtl(lat, lon, home_ll(self))
        # the mission's turns planned at the bank a reaction leaves, at the speed it flies
        self.sequencer.reaction_limits = self.ctrl.reaction_limits
        self.ctrl.reset()
        self.crash = None
        self._launch_us = self._ground_since_us = None
        self._launch_alt_m = nav.alt_m
        self._launch_ground_m = self._ground_m(nav)
        self._airborne = False
        self._launch_climb, self._launch_t_us = 0.0, None

    def _disarming(self, t_us: int) -> None:
        self.set_mode(PlaneMode.MANUAL, t_us)

    def set_mode(self, mode: PlaneMode, t_us: int) -> str | None:
        if mode not in self.implemented_modes:
            return f"mode {int(mode)} not implemented"
        if mode == PlaneMode.RTL and self.params["RTL_AUTOLAND"] == 2 and self._autoland(t_us):
            return None                          # RTL_AUTOLAND 2: straight to the landing (AUTO)
        if mode != self.mode:
            self.log.event(t_us * 1e-6, f"mode {mode.name}")
            if mode == PlaneMode.AUTO and self.sequencer is not None:
                self.sequencer.resume()  # the current leg joined again from where we are
            if mode in (PlaneMode.LOITER, PlaneMode.GUIDED) and self.nav_state is not None:
                nav = self.nav_state  # circle where we are, at this height
                self.hold = self._hold_at(nav.lat_rad, nav.lon_rad, nav.alt_m)
            self.rtl_hold = None
            if mode == PlaneMode.RTL and self.sequencer is not None:
                self.sequencer.forget_rtl_destination()   # chosen afresh from here
            if mode == PlaneMode.RTL and self.nav_state is not None:
                # the nearest rally point when it is nearer than home: loiter there
                nav = self.nav_state
                rally = self.geofence.rally_for_rtl(math.degrees(nav.lat_rad), math.degrees(nav.lon_rad),
                                                    home_ll(self))
                if rally is not None:
                    self.rtl_hold = self._hold_at(math.radians(rally[0]), math.radians(rally[1]), rally[2])
                    self.log.event(t_us * 1e-6, f"RTL to rally point {rally[0]:.7f} {rally[1]:.7f}")
        self.mode = mode
        return None

    def _hold_at(self, lat_rad: float, lon_rad: float, alt_m: float) -> NavTarget | None:
        if self.home_frame is None:
            return None
        p = self.home_frame.to_ned_fast(lat_rad, lon_rad, alt_m)
        seq = self.sequencer
        radius = self.params["LOITER_RAD"]
        if seq is not None and self.nav_state is not None:
            # no tighter than the vehicle can hold in this wind (as a mission's loiter)
            radius = max(radius, seq.min_turn_radius_m(self.nav_state.wind_ned[:2]))
        return NavTarget("loiter", self.current_seq(), (seq.leg_id + 1) if seq else 0, alt_m,
                         seq.airspeed_mps if seq else self.params["TRIM_ARSPD"],
                         c_ne=(float(p[0]), float(p[1])), radius_m=radius, direction=1)

    def set_guided_target(self, lat_rad: float, lon_rad: float, alt_m: float, t_us: int) -> str | None:
        """GUIDED: circle (lat, lon) at alt_m MSL (ArduPlane's guided waypoint)."""
        if self.mode != PlaneMode.GUIDED or not self.armed or self.home_frame is None:
            return "not in GUIDED flight"
        self.hold = self._hold_at(lat_rad, lon_rad, alt_m)
        self.log.event(t_us * 1e-6, "guided target")
        return None

    def set_speed(self, airspeed_mps: float, t_us: int) -> str | None:
        """DO_CHANGE_SPEED: the airspeed demand, within ARSPD_FBW_MIN..MAX."""
        if self.sequencer is None:
            return "not armed"
        lo, hi = self.params["ARSPD_FBW_MIN"], self.params["ARSPD_FBW_MAX"]
        self.sequencer.airspeed_mps = min(max(airspeed_mps, lo), hi)
        if self.hold is not None:
            self.hold = self.hold._replace(airspeed_mps=self.sequencer.airspeed_mps)
        return None

    @property
    def landed(self) -> bool:
        """On the launcher or back on the ground: not armed, or armed but not yet
        launched (no mission item reached above the launcher, and below 2 m above home),
        or down and stopped at the end of a landing (guidance/landing.py)."""
        if not self.armed or self.home_frame is None or self.nav_state is None:
            return True
        land = self._sequencer.landing
        if land is not None and land.phase == "ground":
            return True   # (rollout: still sliding; ground stations see it land when it stops)
        # (launched first: from then on the height is not asked)
        return not self._sequencer.launched and self.home_frame.alt0_m - self.nav_state.alt_m > -2.0

    @property
    def landing_phase(self) -> str | None:
        """The NAV_LAND phase being flown (guidance/landing.py), or None."""
        seq = self.sequencer
        if not self.armed or seq is None or seq.landing is None:
            return None
        return seq.landing.phase

    def _load_mission(self, mission: Mission) -> None:
        """In flight a new mission starts from its item 1 (ArduPilot keeps the index; a
        fresh start is the simpler promise)."""
        if self.sequencer is not None:
            self.sequencer.load(mission)

    def set_home(self, lat_rad: float, lon_rad: float, alt_m: float, t_us: int) -> str | None:
        self.home_frame = LocalFrame(lat_rad, lon_rad, alt_m)
        if self.sequencer is not None:
            self.sequencer.move_home(self.home_frame)
        self.log.event(t_us * 1e-6, "home moved")
        return None

    def _param_changed(self, name: str) -> None:
        """Reconfigure what depends on parameter ``name``, at once: the loops' gains and
        limits, L1's design, the step's own copies, the airspeed flown; the navigation
        filter and the fault monitor follow in ``_param_follow`` (what they are built
        from is ``at_start``). The rest is read from the store where it is used."""
        if name == "TRIM_ARSPD":
            self._trim_changed(self._trim_arspd_mps, self.params[name])
        self._read_step_params()
        if name in ("NAVL1_PERIOD", "NAVL1_DAMPING"):
            self.l1.set_design(self.params["NAVL1_PERIOD"], self.params["NAVL1_DAMPING"])
        else:
            self.ctrl.configure_gains()

    def _param_follow(self, name: str, value: float) -> None:
        if hasattr(self.nav, "set_param"):       # (none on truth navigation)
            self.nav.set_param(name, value)
        if self.monitor is not None:
            self.monitor.set_param(name, value)

    def _trim_changed(self, old_mps: float, new_mps: float) -> None:
        """TRIM_ARSPD changed: the mission and the loiters fly the new cruise airspeed,
        unless a DO_CHANGE_SPEED asked for another (as ArduPlane's AIRSPEED_CRUISE)."""
        seq = self._sequencer
        if seq is not None and seq.airspeed_mps == old_mps:
            seq.airspeed_mps = new_mps
        for attr in ("hold", "rtl_hold"):
            h = getattr(self, attr)
            if h is not None and h.airspeed_mps == old_mps:
                setattr(self, attr, h._replace(airspeed_mps=new_mps))

    # -------------------------------------------------------------------- loop ---
    def step(self, frame: SensorFrame, truth=None) -> ActuatorOutputs:
        """One lockstep step: ``control_step``, then ``finish_step``."""
        out = self.control_step(frame, truth)
        self.finish_step()
        return out

    def control_step(self, frame: SensorFrame, truth=None) -> ActuatorOutputs:
        """The step up to its answer: sensors to actuators. What follows the answer and
        does not change it (the monitor's look at the controls, the log row) waits for
        ``finish_step``, so a loop on two processes can send the answer first and the
        simulator advances its plant meanwhile (autopilot/cli.py); ``step`` runs both."""
        self._finish = None
        t_us = frame.t_us
        dt = 0.01 if self.last_t_us is None else (t_us - self.last_t_us) * 1e-6
        dt = 1e-4 if 1e-4 > dt else dt           # max(dt, 1e-4) (control/pid.py)
        self.last_t_us = t_us
        self.steps += 1
        gps = frame.gps
        if gps is not None:
            self._gps_this_step = gps
            self.gps_fix_type = gps.fix_type

        # sensors -> navigation
        if self.nav_source == "truth":
            nav = self.nav.update(frame, truth)
        else:
            nav = self.nav.update(frame)
        if nav is None:
            return ActuatorOutputs(t_us, (0.0, 0.0, 0.0, 0.0), False)
        self.nav_state = nav
        self.euler = euler_321(*nav.q_nb.tolist())    # (roll, pitch, yaw), once per step
        vl = nav.v_ned.tolist()                         # the velocity [m/s], once per step

        # navigation -> fault monitor
        p = self.params
        ctrl = self.ctrl
        mon = self.monitor
        if mon is not None:
            mon.update(t_us, self._monitoring())
            self._forward_events(mon)
            eout = mon.elevator_fault_s is not None and p["EOUT_ENABLE"] > 0
            if eout != ctrl.elevator_out:
                # the elevator is faulty: height on the throttle (control/fixed_wing.py)
                ctrl.set_elevator_out(eout)
                mon.announce(t_us * 1e-6, SEV_WARNING, "elevator out: height flown on the throttle"
                              if eout else "elevator out: off")
            if eout and (mon.elevator_trim_mps, mon.elevator_bank_max_rad, mon.elevator_full_throttle) != (
                    ctrl.eout_trim_mps, ctrl.eout_bank_max_rad, ctrl.eout_full_throttle):
                # the model's trim speed, steepest level turn, and full throttle if no trim
                ctrl.set_elevator_trim(mon.elevator_trim_mps, mon.elevator_bank_max_rad,
                                       mon.elevator_full_throttle)
            so = mon.surface_out
            if so is not None and not p["LOUT_ENABLE"] > 0:
                so = None                        # (the parameter read only on a reaction)
            if so is not ctrl.surface_out:
                # a stuck aileron or rudder: countered with the other (control/fixed_wing.py)
                new = ctrl.surface_out is None
                ctrl.surface_out = so
                if new:
                    mon.announce(t_us * 1e-6, SEV_WARNING,
                                 f"{so['surface']} out: roll flown on the "
                                 f"{'rudder' if so['surface'] == 'aileron' else 'aileron'}")
            to = mon.throttle_out
            if to is not None and not p["TOUT_ENABLE"] > 0:
                to = None
            if to is not ctrl.throttle_out:
                # a stuck throttle: where it holds level flight the height held and the
                # airspeed free, else the airspeed on the pitch (control/fixed_wing.py)
                if ctrl.throttle_out is None:
                    high = to["level"] and p["TOUT_ARSPD_MAX"] > 0
                    mon.announce(t_us * 1e-6, SEV_WARNING,
                                 "throttle out: height held, airspeed free" if high
                                 else "throttle out: airspeed flown on the pitch")
                ctrl.throttle_out = to
            if mon.terminate and not self.terminated and self.armed:
                # ArduPlane's aerodynamic termination (AP_AdvancedFailsafe_Plane::
                # terminate_vehicle): throttle closed, aileron, elevator and rudder full
                self.terminated = True
                mon.announce(t_us * 1e-6, 0, "flight termination: throttle closed, surfaces full")
            if mon.failsafe == "RTL" and self.armed and self.mode != _RTL and self.mode != _MANUAL:
                mon.failsafe = None
                self.set_mode(PlaneMode.RTL, t_us)

        # modes
        if not self.armed and self.autostart and self.crash is None and not self.land_done:
            # (no re-arming after a crash or a landing)
            if nav.aligned and nav.healthy and self.gps_fix_type >= 3:
                if self.healthy_since_us is None:
                    self.healthy_since_us = t_us
                if (t_us - self.healthy_since_us) * 1e-6 >= self.params["ARM_SETTLE_S"] \
                        and self.arm(t_us, truth) is None:
                    self.set_mode(PlaneMode.AUTO, t_us)
            else:
                self.healthy_since_us = None

        if frame.rpm is not None:
            # the propeller's speed (ESC telemetry): the throttle's monitor only, no control
            self.rpm = frame.rpm.rpm
            if self.monitor is not None:
                self.monitor.observe_rpm(frame.rpm)
        if frame.range is not None and self.rangefinder.enabled:
            # the rangefinder's height, and its correction of a landing's (RNGFND_LANDING)
            land = self._rf_landing()
            note = self.rangefinder.update(t_us, frame.range, nav.q_nb,
                                           nav.alt_m - land.alt_b if land is not None else None,
                                           land is not None, self._rf_terrain(nav, land))
            if note is not None:
                self.notice(t_us * 1e-6, SEV_INFO, note)
        if self.armed and self.mode == _AUTO and self._crash_detect:
            self._crash_check(nav, t_us, vl)
        if fence_watching(self.geofence):
            fence_step(self, t_us, self.armed and not self.landed, landing=self._landing())
        controls = (0.0, 0.0, 0.0, 0.0)
        if self.armed and self.home_frame is not None and self.mode != _MANUAL:
            controls = self._fly(nav, dt, t_us, vl)
            if self.terminated:
                controls = (1.0, 1.0, 1.0, 0.0)
        seq = self._sequencer
        if self.armed and seq is not None and seq.landing is not None:
            self._land_disarm(t_us, seq.landing)
        self._finish = (t_us, nav, controls, truth, gps is not None)
        return ActuatorOutputs.make(t_us, controls, self.armed)

    _finish = None      # (t_us, nav, controls, truth, gps) of a step not yet finished

    def finish_step(self) -> None:
        """The rest of the step ``control_step`` answered (its docstring); nothing when
        that step had no navigation yet."""
        if self._finish is None:
            return
        t_us, nav, controls, truth, gps = self._finish
        self._finish = None
        mon = self.monitor
        if mon is not None:
            mon.observe_controls(t_us, nav, controls, self._monitoring())
        if self.home_truth_alt_m is None and truth is not None and self.armed:
            self.home_truth_alt_m = truth.alt_m   # armed on a step without truth (scoring)
        if self.log_rows.take(self.steps, truth is not None, gps):
            self._log(t_us, nav, truth, controls)

    def _crash_check(self, nav: NavState, t_us: int, v_ned: list) -> None:
        """Crash detection (module docstring); disarms on a crash. ``v_ned``: nav.v_ned
        as a list."""
        p = self.params
        if self._launch_alt_m is None:
            return
        # height above where the aircraft rested at arming, not above home: a home moved
        # in flight (DO_SET_HOME 'here' sets home's altitude to the current one) says
        # nothing of where the ground is
        h = nav.alt_m - self._launch_alt_m
        if self._launch_ground_m is not None:
            ground = self._ground_m(nav)
            if ground is not None:
                # over known terrain: the height above the ground under the aircraft (less
                # the launcher's height above it at arming), not above the launch point
                h = nav.alt_m - ground - (self._launch_alt_m - self._launch_ground_m)
        moving_air = nav.airspeed_mps >= self._moving_air_mps
        if self._launch_us is None:
            if moving_air:
                self._launch_us = t_us
            return
        if not self._airborne:
            if self._launch_t_us is not None:
                a = min(1.0, (t_us - self._launch_t_us) * 1e-6 / CRASH_LAUNCH_TAU)
                self._launch_climb += a * (-float(nav.v_ned[2]) - self._launch_climb)
            self._launch_t_us = t_us
            if h >= p["CRASH_ALT"]:
                self._airborne = True
            elif (t_us - self._launch_us) * 1e-6 >= p["CRASH_LAUNCH_S"] \
                    and self._launch_climb < CRASH_LAUNCH_CLIMB:
                self._crashed(t_us, f"not airborne {p['CRASH_LAUNCH_S']:g} s after launch "
                                    f"(height {h:.1f} m, climbing {self._launch_climb:.1f} m/s)")
            return
        vn, ve, vd = v_ned
        on_ground = h < self._crash_gnd_alt_m and vd > -CRASH_CLIMB
        stopped = not moving_air and math.hypot(vn, ve) < CRASH_STOP_GSPD
        if not (on_ground or stopped) or self._landing():
            # flying, or down where a landing means to be (the landing asked only then)
            self._ground_since_us = None
            return
        if self._ground_since_us is None:
            self._ground_since_us = t_us
        elif (t_us - self._ground_since_us) * 1e-6 >= p["CRASH_DELAY_S"]:
            where = f"height {h:.1f} m" if on_ground else "stopped"
            self._crashed(t_us, f"on the ground outside a landing ({where})")

    def _ground_m(self, nav: NavState) -> float | None:
        """The terrain's height under the aircraft [m MSL] from ``terrain``, or None."""
        if self.terrain is None:
            return None
        return self.terrain(math.degrees(nav.lat_rad), math.degrees(nav.lon_rad))

    def _rf_landing(self):
        """The landing whose heights the rangefinder corrects (ArduPlane's LAND flight
        stage: a NAV_LAND flown in AUTO, not its go-around), or None."""
        seq = self.sequencer
        if not self.armed or self.mode != PlaneMode.AUTO or seq is None or seq.landing is None \
                or seq.landing.phase == "go_around":
            return None
        return seq.landing

    def _rf_terrain(self, nav: NavState, land) -> float:
        """The terrain's height under the aircraft less the land point's, when a terrain
        model gives both (the rangefinder's terrain correction), else 0."""
        if land is None or self.terrain is None:
            return 0.0
        if land.ground_b_m is None:
            lat, lon, _ = self.home_frame.to_geodetic_fast(np.array((land.b_ne[0], land.b_ne[1], 0.0)))
            g = self.terrain(math.degrees(lat), math.degrees(lon))
            land.ground_b_m = math.nan if g is None else float(g)
        here = self._ground_m(nav)
        if here is None or math.isnan(land.ground_b_m):
            return 0.0
        return here - land.ground_b_m

    def _landing(self) -> bool:
        """A landing is being flown (where touching down is the plan)."""
        seq = self._sequencer
        if seq is None or seq.finished or not 0 < seq.current < len(seq.items):
            return False
        return seq.items[seq.current].command == MAV_CMD_NAV_LAND

    def _monitoring(self) -> bool:
        """The fault monitor watches the flight: armed, off the ground, and not in a
        landing's flare (idle, high angle of attack, ground effect and then the skids'
        friction: outside the models its statistics test)."""
        if self.landed:
            return False                 # (disarmed is landed; armed has a sequencer)
        land = self._sequencer.landing
        return land is None or land.phase in ("approach", "descend")

    def go_around(self, alt_m: float, t_us: int) -> str | None:
        """MAV_CMD_DO_GO_AROUND: abandon the landing being flown in AUTO (climb to
        ``alt_m`` above home, 0: the NAV_LAND's or LAND_ABORT_ALT) and fly it again."""
        if not self.armed or self.mode != PlaneMode.AUTO or self.sequencer is None:
            return "not flying a landing in AUTO"
        return self.sequencer.go_around(t_us, "commanded", alt_m if alt_m > 0 else None)

    def _autoland(self, t_us: int) -> bool:
        """RTL_AUTOLAND: fly the nearest DO_LAND_START sequence in AUTO (ArduPlane
        switches to AUTO so); False when the mission has none."""
        seq, nav = self.sequencer, self.nav_state
        if seq is None or not self.armed or nav is None or self.home_frame is None:
            return False
        p = self.home_frame.to_ned_fast(nav.lat_rad, nav.lon_rad, nav.alt_m)
        start = seq.landing_start_seq((float(p[0]), float(p[1])))
        if start is None:
            return False
        self.notice(t_us * 1e-6, SEV_INFO, f"RTL_AUTOLAND: landing sequence from item #{start}")
        seq.set_current(start)
        seq.landing = None
        if self.mode != PlaneMode.AUTO:
            self.log.event(t_us * 1e-6, "mode AUTO")
            self.mode = PlaneMode.AUTO
        return True

    def _land_disarm(self, t_us: int, land) -> None:
        """NAV_LAND: disarm LAND_DISARMDELAY after the landing ``land`` being flown is
        complete (stopped on the ground, guidance/landing.py); the mission is then over."""
        if land.landed_us is None:
            return
        seq = self._sequencer
        if (t_us - land.landed_us) * 1e-6 >= self.params["LAND_DISARMDELAY"]:
            seq.land_complete = seq.finished = True
            if seq.current < len(seq.items) and seq.current not in seq.reached_seqs:
                seq.reached.append((t_us, seq.current))     # the NAV_LAND item: done
                seq.reached_seqs.add(seq.current)
            self.land_done = True
            self.notice(t_us * 1e-6, SEV_INFO, "Landing complete: disarming")
            self.disarm(t_us, force=True)

    def _crashed(self, t_us: int, why: str) -> None:
        self.crash = why
        self.notice(t_us * 1e-6, SEV_EMERGENCY, f"Crash detected: {why}")
        self.disarm(t_us, force=True)            # throttle cut: nothing flies disarmed

    def _fly(self, nav: NavState, dt: float, t_us: int, vl: list) -> tuple:
        """The step's controls in the modes that fly; ``vl``: nav.v_ned as a list."""
        p = self.params
        # the position in home's frame and the velocities as tuples / lists: the guidance
        # reads them element by element, and a numpy element costs more than its arithmetic
        pl = self.home_frame.ned_fast(nav.lat_rad, nav.lon_rad, nav.alt_m)
        w = nav.wind_ned
        if w is not self._wind_of:
            # a new wind estimate: the filter hands the same array on until it has one
            # (a fusion), and never writes into it (autopilot/nav/base.py, _output)
            self._wind_of, self._wind_l = w, w.tolist()
        wl = self._wind_l
        yaw = self.euler[2]
        mode = self.mode
        if mode in _HOLD_MODES or (mode == _RTL and self.rtl_hold is not None):
            hold = self.rtl_hold if mode == _RTL else self.hold
            if hold is None or self.landed:
                return (0.0, 0.0, 0.0, 0.0)  # not launched: stay on the launcher
            tgt = hold
            gs = math.hypot(vl[0], vl[1])
        else:
            seq = self._sequencer
            if mode == _RTL and not seq.finished:
                seq.finished = True  # RTL mode: go straight to the home loiter
            # (no landing in the sequencer: no rangefinder landing, no correction)
            landing = seq.landing is not None and self._rf_landing() is not None
            seq.land_h_corr_m = self.rangefinder.correction_m(t_us, True) if landing else 0.0
            # (wind and airspeed by position: keywords cost the call a dict)
            tgt = seq.update(t_us, pl, vl, yaw, nav.alt_m, wl, nav.airspeed_mps)
            if mode == _RTL and seq.rtl_established and p["RTL_AUTOLAND"] == 1 \
                    and self._autoland(t_us):   # RTL_AUTOLAND 1: over home, now the landing
                tgt = seq.update(t_us, pl, vl, yaw, nav.alt_m, wl, nav.airspeed_mps)
            # what the mission asked of the vehicle this step: its warnings and notes to
            # the log and the ground stations, a new home (DO_SET_HOME)
            if seq.notices:
                for t_s, severity, text in seq.notices:
                    self.notice(t_s, severity, text)
                seq.notices.clear()
            if seq.home_request is not None:
                req, seq.home_request = seq.home_request, None
                if req == "here":
                    req = (nav.lat_rad, nav.lon_rad, nav.alt_m)
                self.set_home(*req, t_us)
            gs = seq.ground_speed_mps            # (worked out by its update this step)
        self.target = tgt
        vn, ve, _ = vl
        pn, pe, pd = pl
        self._p_home = (nav, pl, vl, wl)         # for the log row of this step
        v_ne = (vn, ve)
        p_ne = (pn, pe)
        l1 = self.l1          # (its design follows NAVL1_*: _param_changed)
        pitch_min = pitch_max = climb = None
        throttle = rudder = None
        land = tgt.land
        kind = tgt.kind
        if land == "go_around":
            pitch_min = math.radians(p["TKOFF_PITCH"]) if tgt.alt_m - nav.alt_m > p["TKOFF_ALT_TOL"] else None
        if land in ("flare", "rollout", "ground"):
            # the flare (guidance/landing.py): idle, the sink rate on the pitch
            throttle, climb = 0.0, tgt.climb_mps
            pitch_min, pitch_max = math.radians(p["LAND_PITCH_DEG"]), math.radians(p["LAND_PITCH_MAX"])
            # the trim angle of attack at the airspeed flown, not the approach speed's:
            # the speed decays at idle, and the nose must rise with it (to LAND_PITCH_MAX)
            tgt = tgt._replace(airspeed_mps=max(nav.airspeed_mps, 0.75 * p["ARSPD_FBW_MIN"]))
        if kind == "takeoff":
            # wings level on the launch heading, full throttle, climb at the takeoff pitch
            err = wrap_pi(tgt.heading_rad - yaw)
            bank = max(min(1.0 * err, math.radians(p["TKOFF_LVL_BANK"])), -math.radians(p["TKOFF_LVL_BANK"]))
            pitch_min = tgt.pitch_min_rad
            throttle = p["THR_MAX"]
            self.xtrack_m = 0.0
            if p["GROUND_STEER_ALT"] > 0.0 and self._launch_alt_m is not None \
                    and nav.alt_m - self._launch_alt_m < p["GROUND_STEER_ALT"]:
                # on the wheels (ArduPlane's ground steering, GROUND_STEER_ALT): a bank
                # asked of an aircraft on its gear rolls it at the lift-off, and only the
                # nose wheel and rudder turn it; the heading held on the rudder
                bank = 0.0
                start = self.sequencer._takeoff_start_ne if self.sequencer is not None else None
                if start is not None:
                    # back onto the runway's line (the take-off heading through where the
                    # roll began), not only parallel to it
                    h0 = tgt.heading_rad
                    xt = -(pn - start[0]) * math.sin(h0) + (pe - start[1]) * math.cos(h0)
                    err = wrap_pi(err - math.atan(xt / GSTEER_LINE_M))
                rudder = p["GSTEER_KP"] * err - p["GSTEER_KD"] * float(nav.omega_b[2])
                rudder = max(min(rudder, 1.0), -1.0)
        elif kind == "line" or kind == "direct":
            # (LateralCommand's fields: accel, bank, xtrack, ...)
            _, bank, self.xtrack_m, _, _, _ = l1.steer_line(p_ne, v_ne, gs, tgt.a_ne, tgt.b_ne, yaw,
                                                            nav.airspeed_mps)
        elif kind == "loiter":
            _, bank, self.xtrack_m, _, _, _ = l1.steer_loiter(p_ne, v_ne, gs, tgt.c_ne, tgt.radius_m,
                                                              tgt.direction, yaw, nav.airspeed_mps)
        else:
            bank = 0.0
        if kind != "takeoff" and -pd < self._level_alt_m:
            lim = math.radians(p["TKOFF_LVL_BANK"])
            bank = max(min(bank, lim), -lim)
        if land == "rollout" or land == "ground":
            bank = 0.0                           # on the skids: wings level (landing.py)
        # (by position: pitch_min_rad, throttle_override, euler, climb_override,
        # pitch_max_rad, climb_kp, spd_weight, rudder_override)
        return self.ctrl.update(nav, dt, bank, tgt.alt_m, tgt.airspeed_mps, pitch_min, throttle,
                                self.euler, climb, pitch_max,
                                p["LAND_FLR_CLMB_KP"] if climb is not None else None,
                                tgt.spd_weight, rudder)

    def _log(self, t_us: int, nav: NavState, truth, controls) -> None:
        gps = self._gps_this_step
        self._gps_this_step = None
        hf = self.home_frame
        if hf is None:
            return
        ph = self._p_home
        if ph is not None and ph[0] is nav:
            _, p_est, v, w = ph                  # computed by _fly this step
        else:
            p_est = hf.ned_fast(nav.lat_rad, nav.lon_rad, nav.alt_m)
            v = nav.v_ned.tolist()
            w = nav.wind_ned.tolist()
        er, ep, ey = self.euler
        tgt = self.target
        c = self.ctrl
        rf = self.rangefinder
        seq = self._sequencer
        mon = self.monitor
        if tgt is None:
            tgt = NavTarget("idle", 0, 0, nav.alt_m, 0.0)
        a, b, cc = tgt.a_ne, tgt.b_ne, tgt.c_ne
        alt_dem, roll_c, pitch_c, climb_c = c.commands()
        h_rf = rf.height_m
        # one tuple built from its parts at once (``*``: no intermediate tuples); the
        # flags and counts as they are (the log converts its rows once, at the end), the
        # mode as its number: a row of numbers only is left alone by the cyclic garbage
        # collector (it untracks it at its first pass), where one holding the PlaneMode
        # member stayed tracked and was walked again at every older generation's pass
        self.log.append((
            t_us * 1e-6, self.armed, int(self.mode), tgt.seq, tgt.leg_id, KIND_CODES[tgt.kind],
            *self._truth_row(hf, truth),
            p_est[0], p_est[1], nav.alt_m, er, ep, ey,
            v[0], v[1], v[2], nav.airspeed_mps, w[0], w[1],
            tgt.alt_m if math.isnan(alt_dem) else alt_dem, tgt.airspeed_mps, roll_c, pitch_c, climb_c,
            a[0], a[1], b[0], b[1], cc[0], cc[1],
            tgt.radius_m, tgt.direction, self.xtrack_m,
            controls[0], controls[1], controls[2], controls[3],
            h_rf if h_rf is not None else -1.0,
            seq.land_h_corr_m if seq is not None else 0.0,
            self.rpm,
            *self._nav_row(hf, nav, gps),
            *(mon.log_row() if mon is not None else _FDI_IDLE)))
