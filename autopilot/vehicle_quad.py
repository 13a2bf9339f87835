"""The quadrotor vehicle loop: one visible, synchronous pipeline per lockstep step.

    sensors -> navigation -> modes -> guidance -> reference angles / altitude
            -> PDD attitude -> mixer -> motors

``QuadVehicle.step(frame, truth)`` runs once per HIL_SENSOR (250 Hz: the HIL period of
the quadrotor is 4 ms) on simulation time only; truth is logged for scoring and used to
fly only with ``--nav truth``. It implements ``autopilot.vehicle_api.VehicleApi``.

Navigation rate. The inner (attitude) loop runs at every step. The INS/GPS filter
(``InsGpsEkf(vehicle="quad")``) runs every QD_NAV_DIV-th step on the IMU samples
averaged over its interval (coning and sculling are negligible at these rates and
rotation speeds), with the magnetometer, barometer and GPS samples of the interval; in
between, an output predictor (as PX4's EKF2 has) carries the latest estimate forward
with each bias-corrected IMU sample: q <- q (x) Exp(omega dt), v <- v + (R f + g) dt,
p <- p + v dt. The attitude loop thus sees a fresh attitude and the raw gyro rate at
every step. QD_NAV_DIV = 1 runs the filter at the full rate. The filter predicts its
covariance over as many of its steps as fit in 40 ms, and before every fusion
(``InsGpsEkf(cov_div=...)``: 2 at 250 Hz with QD_NAV_DIV = 4).

Frames: the filter's origin is its first GPS fix; home is set at arming from the
navigation solution (as ArduPilot does) and guidance works in the NED frame of home,
``p_home = p_nav - p_nav(home)`` (the two tangent frames are metres apart).

Ground handling: armed on the ground, the motors idle at QD_SPIN_ARM and the loops are
held; a takeoff starts them, with the integrators frozen until the vehicle is 0.5 m up.
The land detector (as ArduCopter's): while landing, a thrust demand below 75 % of the
weight with a vertical speed under 0.3 m/s for LAND_DET_S seconds is a touchdown; the
motors stop and the vehicle disarms.
"""
from __future__ import annotations

import math

import numpy as np

from .control.multirotor import (MULTIROTOR_PARAMS, X_N as CTRL_N, Y_EULER, Y_N, Y_Q, Y_V, Y_W,
                                 MultirotorController, track_mix)
from .fence.actions import fence_step, fence_watching, home_ll
from .fence.geofence import Geofence
from .geo import LocalFrame, wrap_pi
from .geo.rotations import euler_321, quat_dcm, quat_step
from .guidance.multirotor import (PHASE_KIND, COPTER_GUIDANCE_PARAMS, REF_END, REF_START,
                                  TRAJ_N, CopterMissionSequencer, CopterNavigator, CopterTarget,
                                  guidance_step)
from .jit import kernel, preload
from .link.codec import MAV
from .log.flightlog import FlightLog, RowSchedule
from .messages import ActuatorOutputs, BaroSample, ImuSample, MagSample, NavState, SensorFrame
from .mission.items import Mission
from .modes.copter import IMPLEMENTED_COPTER_MODES, POSITION_MODES, CopterMode
from .monitor import FDI_PARAMS
from .monitor.motors import MOTOR_PARAMS, MotorMonitor
from .nav.strapdown import X_BA as NOM_BA, X_BG as NOM_BG
from .params import Param, ParamStore
from .vehicle_base import NAV_COLUMNS, TRUTH_COLUMNS, TruthNav, VehicleBase, shared_param_declarations

RHO0 = 1.225
R_AIR = 287.05287

QUAD_VEHICLE_PARAMS = (
    Param("ARM_SETTLE_S", 3.0, 0.0, 60.0, "s", "headless: seconds of healthy navigation before arming"),
    Param("QD_NAV_DIV", 4, 1, 10, "", "run the navigation filter every Nth step (output predictor between)",
          is_int=True, at_start=True),
    Param("QD_NAV_AUX_HZ", 25.0, 1.0, 250.0, "Hz", "fuse magnetometer / barometer (averaged) at most this often",
          at_start=True),
    Param("QD_LOG_DIV", 4, 1, 100, "", "flight log: one row every Nth step (and at every GPS fix)", is_int=True),
    Param("LAND_DET_S", 0.5, 0.1, 5.0, "s", "land detector: conditions held this long"),
    Param("PILOT_THR_HOV", 0.41, 0.1, 0.9, "", "STABILIZE: collective command without a pilot"),
    Param("PILOT_SPEED_UP", 2.5, 0.1, 10.0, "m/s", "ALT_HOLD: climb rate at full stick"),
)

LOG_COLUMNS = (
    "t_s", "armed", "mode", "seq", "leg_id", "kind", "hold", "landed",
) + TRUTH_COLUMNS + (
    "est_n_m", "est_e_m", "est_alt_m", "est_roll_rad", "est_pitch_rad", "est_yaw_rad",
    "est_vn_mps", "est_ve_mps", "est_vd_mps",
    # the reference trajectory (home NED: tgt_alt_m is MSL like the plane's)
    "tgt_n_m", "tgt_e_m", "tgt_alt_m", "tgt_vn_mps", "tgt_ve_mps", "tgt_vd_mps",
    "goal_n_m", "goal_e_m", "leg_a_n_m", "leg_a_e_m",
    # reference angles and thrust (eqs 3.37-3.41) and the effective inputs of eq 3.30
    "cmd_roll_rad", "cmd_pitch_rad", "cmd_yaw_rad", "cmd_thrust_n",
    "u_roll_n", "u_pitch_n", "u_yaw_n",
    "motor_1", "motor_2", "motor_3", "motor_4",
) + NAV_COLUMNS + (
    # motor fault monitor (autopilot/monitor/motors.py): detection and isolation
    # statistics over their thresholds, rotor effectiveness estimates, fading factor
    "fdi_motor_det", "fdi_motor_iso", "fdi_gamma_1", "fdi_gamma_2", "fdi_gamma_3",
    "fdi_gamma_4", "fdi_motor_lam",
)
# the modes the loop tests at every step, read once here (an enum class's attribute
# costs several times a module global's)
_LAND, _AUTO, _STABILIZE = CopterMode.LAND, CopterMode.AUTO, CopterMode.STABILIZE
_PILOT_MODES = (CopterMode.STABILIZE, CopterMode.ALT_HOLD)
KIND_CODES = {"ground": 0, "takeoff": 1, "move": 2, "hold": 3, "land": 4, "idle": 5, "manual": 6}


_QUAD_FDI = ("FDI_ENABLE", "FDI_ALPHA", "FDI_PFA", "FDI_WIN", "FDI_CLR_T")


def quad_param_declarations() -> list[Param]:
    decls = list(MULTIROTOR_PARAMS) + list(COPTER_GUIDANCE_PARAMS) + list(QUAD_VEHICLE_PARAMS)
    decls += [p for p in FDI_PARAMS if p.name in _QUAD_FDI] + list(MOTOR_PARAMS)
    return decls + shared_param_declarations("quad")


class PilotInput:
    """Stick inputs of STABILIZE / ALT_HOLD (the ground-station service writes them from
    RC_CHANNELS_OVERRIDE / MANUAL_CONTROL). Neutral sticks by default."""

    __slots__ = ("roll_rad", "pitch_rad", "yaw_rate_rps", "throttle")

    def __init__(self, throttle: float | None = None):
        self.roll_rad = 0.0
        self.pitch_rad = 0.0
        self.yaw_rate_rps = 0.0
        self.throttle = throttle      # 0..1; None: PILOT_THR_HOV (STABILIZE), centre (ALT_HOLD)


class DecimatedNav:
    """The navigation filter every ``div`` steps, an output predictor in between
    (module docstring). Magnetometer and barometer samples are averaged and handed to
    the filter at most ``aux_hz`` times a second (each fusion costs several predictions;
    the average keeps the information of every sample). ``update(frame) -> (nav_state,
    p, euler)`` with p the predicted position (floats, nav origin NED) and euler the
    predicted attitude's (roll, pitch, yaw); the velocity, q_nb, the bias-corrected rate
    of this step and the angles are written in its array ``y``, where the loops and the
    vehicle read them (control.multirotor.Y_*). ``x``: where the predictor's array
    (X_N floats, zeros; ``y`` its part from X_Y) lives, if not its own."""

    def __init__(self, filt, div: int, aux_hz: float = 25.0, x=None):
        self.filt = filt
        self.output_sigmas9 = filt.output_sigmas9     # the filter's own (no call around it)
        self.div = max(1, int(div))
        self._aux_us = int(1e6 / aux_hz) if aux_hz > 0 else 0
        self._k = 0
        self._m = [0.0, 0.0, 0.0]
        self._nm = 0
        self._b = [0.0, 0.0, 0.0]       # pressure, altitude, temperature sums
        self._nb = 0
        self._aux_t: int | None = None
        self._gps = self._air = None
        self.nav: NavState | None = None
        # the output predictor's state (predict_output), its output y the part from X_Y
        self._x = np.zeros(X_N) if x is None else x
        self._last_t: int | None = None
        self.f_raw = (0.0, 0.0, 0.0)    # this step's specific-force sample as floats
        self.ba_z = 0.0                 # the accelerometer's z bias estimate (x's, as a float)
        self.y = self._x[X_Y:]

    @property
    def P(self):
        return self.filt.P

    def _aux(self, t: int):
        """The averaged magnetometer and barometer samples, if due."""
        if self._aux_t is not None and t - self._aux_t < self._aux_us:
            return None, None
        mag = baro = None
        if self._nm:
            n = 1.0 / self._nm
            m = self._m
            mag = MagSample.make(t, (m[0] * n, m[1] * n, m[2] * n))
            m[0] = m[1] = m[2] = 0.0
            self._nm = 0
        if self._nb:
            n = 1.0 / self._nb
            b = self._b
            baro = BaroSample.make(t, b[0] * n, b[1] * n, b[2] * n)
            b[0] = b[1] = b[2] = 0.0
            self._nb = 0
        if mag is not None or baro is not None:
            self._aux_t = t
        return mag, baro

    def update(self, frame: SensorFrame):
        imu = frame.imu
        fx, fy, fz = self.f_raw = imu.f_b
        wx, wy, wz = imu.omega_b
        t = frame.t_us
        dt = 0.0 if self._last_t is None else (t - self._last_t) * 1e-6
        self._last_t = t
        if frame.mag is not None:
            mx, my, mz = frame.mag.m_b
            m = self._m
            m[0] += mx; m[1] += my; m[2] += mz
            self._nm += 1
        if frame.baro is not None:
            bs = frame.baro
            b = self._b
            b[0] += bs.pressure_pa; b[1] += bs.alt_m; b[2] += bs.temperature_k
            self._nb += 1
        if frame.gps is not None:
            self._gps = frame.gps
        if frame.airspeed is not None:
            self._air = frame.airspeed
        self._k += 1
        if self._k >= self.div or self.nav is None or not self.nav.aligned:
            mag, baro = self._aux(t)
            if self._k == 1:
                imu_f = imu
            else:
                # the samples of the predictor's steps since the last update, summed in
                # x by predict_output, and this one
                f0, f1, f2, w0, w1, w2 = self._x[X_SUMS:X_Y].tolist()
                n = 1.0 / self._k
                imu_f = ImuSample.make(t, ((f0 + fx) * n, (f1 + fy) * n, (f2 + fz) * n),
                                       ((w0 + wx) * n, (w1 + wy) * n, (w2 + wz) * n))
            fr = SensorFrame.make(t, imu_f, mag, baro, self._air, self._gps)
            self._k = 0
            self._gps = self._air = None
            filt = self.filt
            nav = filt.update(fr)
            self.nav = nav
            x = self._x
            p, euler = restart_output(x, nav.p_ned, nav.v_ned, nav.q_nb, filt.nom.x, filt._g,
                                      wx, wy, wz)
            self.ba_z = x.item(X_BA + 2)
            return nav, p, euler
        p, euler = predict_output(self._x, fx, fy, fz, wx, wy, wz, dt)
        return self.nav, p, euler


COV_PERIOD_S = 0.04   # EKF covariance predicted at least this often (and before fusions)


def make_quad_nav(source: str, params: ParamStore, dt_s: float = 0.004, x=None):
    """The navigation of ``source``; ``x``: where the output predictor's array lives
    (DecimatedNav)."""
    if source == "truth":
        return TruthNav()
    values = {n: v for n, v in params.items()}
    div = int(params["QD_NAV_DIV"])
    if source == "ekf":
        from .nav.ekf import InsGpsEkf
        # the covariance over as many filter steps as fit in COV_PERIOD_S (the aux
        # sensors' fusion period): 2 at 250 Hz / 4 (autopilot/nav/ekf.py)
        cov_div = max(1, int(COV_PERIOD_S / (max(div, 1) * dt_s) + 1e-9))
        return DecimatedNav(InsGpsEkf(values, vehicle="quad", cov_div=cov_div), div,
                            params["QD_NAV_AUX_HZ"], x)
    if source == "ukf":
        from .nav.ukf import InsGpsUkf
        return DecimatedNav(InsGpsUkf(values, vehicle="quad"), div, params["QD_NAV_AUX_HZ"], x)
    raise ValueError(f"unknown navigation source {source!r} (truth, ekf, ukf)")


class QuadVehicle(VehicleBase):
    """The quadrotor autopilot's loop. ``autostart``: arm and fly AUTO by itself once
    navigation is healthy (headless runs); otherwise wait for a ground station. Its
    airframe-independent half is ``autopilot.vehicle_base.VehicleBase``."""

    vehicle_kind = "quad"
    mav_type = MAV.MAV_TYPE_QUADROTOR
    modes = CopterMode
    implemented_modes = IMPLEMENTED_COPTER_MODES

    def __init__(self, params: ParamStore, mission: Mission | None, nav_source: str = "ekf",
                 autostart: bool = True, log: FlightLog | None = None, dt_s: float = 0.004):
        self.params = params
        self.mission = mission
        self.nav_source = nav_source
        # the loops' array, the reference trajectory's and the output predictor's, parts
        # of one (guide_track's one argument for the three: LOOPS_*)
        self._loops = np.zeros(LOOPS_N)
        self.nav = make_quad_nav(nav_source, params, dt_s, self._loops[LOOPS_NAV:])
        # the navigation output the loops read (control.multirotor.Y_*): the output
        # predictor's (its y), or (truth) the same part of the array, which the step writes
        self.y = self._loops[LOOPS_NAV + X_Y:]
        self.autostart = autostart
        self.log = log if log is not None else FlightLog(LOG_COLUMNS)
        self.dt_nominal = dt_s
        self.ctrl = MultirotorController(params, dt_s, self._loops[:LOOPS_TRAJ])
        self.navigator = CopterNavigator(params, self._loops[LOOPS_TRAJ:LOOPS_NAV])
        self.pilot = PilotInput()
        self.mode = CopterMode.STABILIZE
        self.armed = False
        self.home_frame: LocalFrame | None = None
        self.home_truth_alt_m: float | None = None
        self._home_nav_p = (0.0, 0.0, 0.0)      # home in the navigation frame
        self.sequencer: CopterMissionSequencer | None = None
        self.nav_state: NavState | None = None
        self._target: CopterTarget | None = None   # (the property ``target``)
        self._target_of: tuple | None = None        # (seq, hold) it is built from
        self.on_ground = True                   # the land detector's state
        self.flying = False                     # airborne far enough for the integrators
        self.mission_landed = False             # a landing (mission, RTL or LAND) ended
        self.healthy_since_us: int | None = None
        self.gps_fix_type = 0
        self.last_t_us: int | None = None
        self.steps = 0
        self._gps_this_step = None
        self._land_since_us: int | None = None
        self.log_rows = RowSchedule(params["QD_LOG_DIV"])
        self._alt_ref = 0.0                     # ALT_HOLD height reference (home frame, up)
        self._yaw_hold = 0.0
        self.euler = (0.0, 0.0, 0.0)
        self.p_home = (0.0, 0.0, 0.0)
        # motor fault monitor on the rotor force / moment balance (none on truth nav)
        self.monitor = (MotorMonitor(params, dt_s, div=2) if params["FDI_ENABLE"] >= 1
                        and params["FDI_MOT_ENABLE"] >= 1 else None)
        self._fdi_events = 0
        self._motors = (0.0, 0.0, 0.0, 0.0)     # the commands flown since the last step
        self.notices: list[tuple[float, int, str]] = []   # (t_s, MAV_SEVERITY, text): STATUSTEXT
        self.geofence = Geofence(params, "quad")  # fence and rally points (autopilot/fence)
        self.navigator.rally_source = self._rally_dest   # every RTL, the mission's too
        # (autopilot.jit.preload: the loops' kernel loaded now, not at the take-off; on a
        # copy of the array it writes, a unit attitude in it)
        loops = self._loops.copy()
        loops[LOOPS_NAV + X_Y + Y_Q] = 1.0
        preload(guide_track, loops, False, np.zeros((1, 7)), dt_s, 0.0, 0.0, 0.0, 8.0, 0.0,
                math.nan, 0.01, False)
        # (and the angles' kernel, which the log's truth rows call from Python in flight:
        # the output predictor's restart calls it inside its own kernel)
        preload(euler_321, 1.0, 0.0, 0.0, 0.0)

    # ------------------------------------------------------------------ arming ---
    def _mission_needed(self) -> bool:
        return self.mode == CopterMode.AUTO      # a copter arms without one outside AUTO

    _home_alt_format = ".2f"

    def _arming(self, nav: NavState) -> None:
        """At arming: guidance in home's frame from here, on the ground."""
        self._home_nav_p = tuple(float(c) for c in nav.p_ned)
        self.p_home = (0.0, 0.0, 0.0)
        if self.mission is not None:
            self.sequencer = CopterMissionSequencer(self.mission, self.home_frame, self.params,
                                                    self.navigator)
        self.ctrl.reset()
        self.navigator.init((0.0, 0.0, 0.0), self.euler[2])
        self.navigator.speed_mps = None
        self.navigator.speed_up_mps = self.navigator.speed_dn_mps = None
        self.on_ground = True
        self.flying = False
        self.mission_landed = False

    def set_mode(self, mode, t_us: int) -> str | None:
        try:
            mode = CopterMode(int(mode))
        except ValueError:
            return f"mode {int(mode)} not implemented"
        if mode not in self.implemented_modes:
            return f"mode {int(mode)} not implemented"
        if mode in POSITION_MODES and (self.nav_state is None or not self.nav_state.healthy):
            return f"{mode.name} needs a healthy position estimate"
        if mode == self.mode:
            return None
        prev = self.mode
        self.mode = mode
        self.log.event(t_us * 1e-6, f"mode {mode.name}")
        self._enter_mode(prev, mode)
        return None

    def _enter_mode(self, prev: CopterMode, mode: CopterMode) -> None:
        nv = self.navigator
        nv.release_yaw()                         # a mission's CONDITION_YAW ends with AUTO
        if prev not in POSITION_MODES or nv.phase in ("idle", "landed") and not self.on_ground:
            nv.init(self.p_home, self.euler[2])
        if not self.armed or self.on_ground:
            if mode == CopterMode.AUTO and self.sequencer is not None:
                self.sequencer.set_current(self.sequencer.current)
            return
        if mode == CopterMode.AUTO and self.sequencer is not None:
            self.sequencer.set_current(self.sequencer.current)
        elif mode in (CopterMode.GUIDED, CopterMode.LOITER):
            nv.hold(None)
        elif mode == CopterMode.RTL:
            nv.rtl(self.p_home)
        elif mode == CopterMode.LAND:
            nv.land(None)
        elif mode == CopterMode.ALT_HOLD:
            self._alt_ref = -self.p_home[2]
        self._yaw_hold = self.euler[2]

    def _rally_dest(self):
        """RTL's rally point in home's NED (north, east, height above home), or None
        for home (autopilot/fence: the nearest, when nearer than home)."""
        nav, home = self.nav_state, home_ll(self)
        if nav is None or home is None:
            return None
        r = self.geofence.rally_for_rtl(math.degrees(nav.lat_rad), math.degrees(nav.lon_rad), home)
        if r is None:
            return None
        p = self.home_frame.to_ned_fast(math.radians(r[0]), math.radians(r[1]), r[2])
        return (float(p[0]), float(p[1]), -float(p[2]))

    @property
    def landed(self) -> bool:
        return not self.armed or self.on_ground

    def _load_mission(self, mission: Mission) -> None:
        """Armed without a mission (outside AUTO), a new one gets its sequencer now."""
        if self.sequencer is not None:
            self.sequencer.load(mission)
        elif self.home_frame is not None:
            self.sequencer = CopterMissionSequencer(mission, self.home_frame, self.params, self.navigator)

    def set_home(self, lat_rad: float, lon_rad: float, alt_m: float, t_us: int) -> str | None:
        """Move home: guidance positions shift to the new frame."""
        if self.home_frame is None or self.nav_state is None:
            self.home_frame = LocalFrame(lat_rad, lon_rad, alt_m)
            return None
        old = self.home_frame
        d = old.to_ned_fast(lat_rad, lon_rad, alt_m)
        self._home_nav_p = (self._home_nav_p[0] + d[0], self._home_nav_p[1] + d[1],
                            self._home_nav_p[2] + d[2])
        self.home_frame = LocalFrame(lat_rad, lon_rad, alt_m)
        shift = (-float(d[0]), -float(d[1]), -float(d[2]))
        if self.sequencer is not None:
            self.sequencer.frame = self.home_frame
            self.sequencer.home_alt_m = alt_m
            self.sequencer.shift(shift)
        self.navigator.shift(shift)          # the reference flies on, in the new frame
        self.log.event(t_us * 1e-6, "home moved")
        return None

    def _param_changed(self, name: str) -> None:
        """Reconfigure what depends on parameter ``name``, at once: the loops and the
        mixer, the reference model, the log's rate, the motor monitor's settings; the
        navigation filter follows in ``_param_follow`` (what they are built from is
        ``at_start``). The rest is read from the store where it is used."""
        self.ctrl.configure()
        self.navigator.traj.w = self.params["WPNAV_SMOOTH"]
        self.log_rows.div = max(1, int(self.params["QD_LOG_DIV"]))
        if self.monitor is not None:
            self.monitor.configure(self.params)

    def _param_follow(self, name: str, value: float) -> None:
        filt = getattr(self.nav, "filt", None)      # (DecimatedNav's filter; none on truth)
        if filt is not None:
            filt.set_param(name, value)

    def set_guided_target(self, lat_rad: float, lon_rad: float, alt_m: float,
                          t_us: int) -> str | None:
        """GUIDED: fly to (lat, lon, alt MSL) and hold there."""
        if self.mode != CopterMode.GUIDED or self.home_frame is None or not self.armed:
            return "not in GUIDED flight"
        p = self.home_frame.to_ned_fast(lat_rad, lon_rad, alt_m)
        self.navigator.goto((float(p[0]), float(p[1]), float(p[2])))
        self.log.event(t_us * 1e-6, "guided target")
        return None

    def guided_takeoff(self, height_m: float, t_us: int) -> str | None:
        """GUIDED on the ground (MAV_CMD_NAV_TAKEOFF): climb to ``height_m`` above home."""
        if self.mode != CopterMode.GUIDED or not self.armed:
            return "takeoff needs GUIDED and armed"
        if not self.on_ground:
            return "already flying"
        self.navigator.takeoff(self.p_home, max(height_m, 0.5))
        self.log.event(t_us * 1e-6, f"guided takeoff to {height_m:.1f} m")
        return None

    # -------------------------------------------------------------------- loop ---
    def step(self, frame: SensorFrame, truth=None) -> ActuatorOutputs:
        t_us = frame.t_us
        dt = self.dt_nominal if self.last_t_us is None else (t_us - self.last_t_us) * 1e-6
        dt = 1e-4 if 1e-4 > dt else dt           # max(dt, 1e-4) (control/pid.py)
        self.last_t_us = t_us
        self.steps += 1
        gps = frame.gps
        if gps is not None:
            self._gps_this_step = gps           # logged with the next row
            self.gps_fix_type = gps.fix_type
        baro = frame.baro
        if baro is not None and baro.temperature_k > 150.0:
            # air density for the thrust model (thrust at full command ~ rho)
            self.ctrl.mixer.set_density_ratio(
                baro.pressure_pa / (R_AIR * baro.temperature_k) / RHO0)

        # sensors -> navigation
        if self.nav_source == "truth":
            nav = self.nav.update(frame, truth)
            if nav is None:
                return ActuatorOutputs(t_us, (0.0, 0.0, 0.0, 0.0), False)
            p_nav = nav.p_ned.tolist()
            q = nav.q_nb.tolist()
            euler = euler_321(*q)
            self.y[:] = (*nav.v_ned.tolist(), *q, *nav.omega_b.tolist(), *euler)
        else:
            nav, p_nav, euler = self.nav.update(frame)
        self.nav_state = nav
        hp = self._home_nav_p
        self.p_home = (p_nav[0] - hp[0], p_nav[1] - hp[1], p_nav[2] - hp[2])
        self.euler = euler

        # modes
        if not self.armed and self.autostart and not self.mission_landed:
            if nav.aligned and nav.healthy and self.gps_fix_type >= 3:
                if self.healthy_since_us is None:
                    self.healthy_since_us = t_us
                if (t_us - self.healthy_since_us) * 1e-6 >= self.params["ARM_SETTLE_S"]:
                    self.mode = CopterMode.AUTO
                    if self.arm(t_us, truth) is None:
                        self.log.event(t_us * 1e-6, "mode AUTO")
            else:
                self.healthy_since_us = None

        # navigation -> motor fault monitor
        mon = self.monitor
        if mon is not None and mon.due():
            self._monitor(mon, frame, t_us)

        if fence_watching(self.geofence):        # (else no arguments worked out)
            fence_step(self, t_us, self.armed and not self.on_ground,
                       landing=self.mode is _LAND or self.navigator.phase.startswith("land"))
        motors = (0.0, 0.0, 0.0, 0.0)
        if self.armed:
            motors = self._fly(dt, t_us)
        self._motors = motors
        if truth is not None and self.armed and self.home_truth_alt_m is None:
            self.home_truth_alt_m = truth.alt_m   # armed on a step without truth (scoring)
        if self.log_rows.take(self.steps, truth is not None, gps is not None):
            self._log(t_us, nav, truth, motors)
        return ActuatorOutputs.make(t_us, motors, self.armed)

    def _fly(self, dt: float, t_us: int) -> tuple:
        p = self.params
        ctrl = self.ctrl
        mode = self.mode
        roll, pitch, yaw = self.euler
        pos = self.p_home
        if self.on_ground:
            self._yaw_hold = yaw
        if mode in _PILOT_MODES:
            self._target = self._target_of = None
            y = self.y.tolist()
            q, omega = y[Y_Q:Y_Q + 4], y[Y_W:Y_W + 3]
            pl = self.pilot
            lim = math.radians(p["ANGLE_MAX_DEG"])
            r_d = max(-lim, min(lim, pl.roll_rad))
            p_d = max(-lim, min(lim, pl.pitch_rad))
            self._yaw_hold = wrap_pi(self._yaw_hold + pl.yaw_rate_rps * dt)
            if mode == _STABILIZE:
                thr = pl.throttle if pl.throttle is not None else p["PILOT_THR_HOV"]
                if self.on_ground and thr <= p["QD_SPIN_ARM"] + 0.02:
                    return ctrl.idle(p["QD_SPIN_ARM"])
                u_z = 4.0 * ctrl.mixer.thrust_of(thr)
                self._update_ground_state(u_z, t_us, landing=thr < 0.3)
                return ctrl.attitude(q, omega, r_d, p_d, self._yaw_hold, u_z)
            stick = 0.5 if pl.throttle is None else pl.throttle
            climb = (stick - 0.5) * 2.0 * p["PILOT_SPEED_UP"] if abs(stick - 0.5) > 0.05 else 0.0
            h = -pos[2]
            if self.on_ground and climb <= 0.0:
                self._alt_ref = h
                return ctrl.idle(p["QD_SPIN_ARM"])
            self._alt_ref += climb * dt
            u_z = ctrl.altitude(self._alt_ref, climb, 0.0, h, -y[Y_V + 2], roll, pitch, dt,
                                not self.flying)
            self._update_ground_state(u_z, t_us, landing=climb < 0.0)
            return ctrl.attitude(q, omega, r_d, p_d, self._yaw_hold, u_z)

        # position modes: guidance -> reference trajectory
        nv = self.navigator
        touchdown = self._touchdown_pending
        self._touchdown_pending = False
        seq, hold = 0, False
        sq = self._sequencer               # (read without the property: vehicle_base.py)
        if mode == _AUTO and sq is not None:
            seq, hold = sq.advance(t_us, pos, touchdown, yaw)
            if sq.home_request is not None:
                self._mission_set_home(sq, t_us)
            if sq.notices:
                for t_s, severity, text in sq.notices:
                    self.notice(t_s, severity, text)
                sq.notices.clear()
            if sq.landed and not self.mission_landed:
                self._landed_end(t_us)
        elif touchdown and nv.phase == "land_descend":
            nv.touchdown()
            self._landed_end(t_us)
        # the navigator's step (nv.update in two halves: its phase, then its kernel's)
        step = nv.step_inputs(dt, pos)
        self._target, self._target_of = None, (seq, hold)
        kind = PHASE_KIND[nv.phase]
        # waiting on the ground (or a hold / landing asked while landed)
        idle = self.on_ground and (kind in ("idle", "hold", "land")
                                   or nv.phase in ("idle", "landed"))
        tr = nv.traj
        if self.armed and not idle and nv.terrain_leg is None:
            # the reference's step and the loops on it in one call (guide_track); the
            # navigator's record kept as its update() keeps it, the controller's as its
            # track() does (a method to share that would cost the formation's loops,
            # which call track() every quad-step, 0.3 % of their instructions)
            tr.arrived, nv.yaw_ref, ctrl.roll_d, ctrl.pitch_d, ctrl.u, motors = guide_track(
                self._loops, not self.flying, *step)
            ctrl.yaw_d = nv.yaw_ref
            ctrl.motors = motors
        else:
            tr.arrived, nv.yaw_ref = guidance_step(tr.x, *step)
            if not self.armed:
                return (0.0, 0.0, 0.0, 0.0)
            if idle:
                # the target of this step, then the reference reset to where the vehicle is
                self._target = self._make_target(seq, hold)
                nv.init(pos, yaw)
                return ctrl.idle(p["QD_SPIN_ARM"])
            # a terrain-frame leg: the loops' reference depth follows the ground (as the
            # target's, CopterNavigator.target) under the reference after its step
            hold_i = not self.flying
            motors = ctrl.track(self.y, pos, tr.ref, nv.yaw_ref, dt, hold_i, hold_i,
                                nv.terrain_offset(*tr.p[:2]))
        # (the ground state after the loops: in these modes it changes none of their inputs)
        self._update_ground_state(ctrl.u[0], t_us, landing=kind == "land")
        return motors

    @property
    def v_ned(self) -> tuple:
        """The velocity estimate (NED) of the last step: the navigation output's (``y``)."""
        return tuple(self.y[Y_V:Y_V + 3].tolist())

    @property
    def target(self) -> CopterTarget | None:
        """What guidance asked of the loops at the last step (None in the pilot modes),
        built when asked (the log's rows): the loops read the trajectory's own array."""
        t = self._target
        if t is None and self._target_of is not None:
            t = self._target = self._make_target(*self._target_of)
        return t

    def _make_target(self, seq: int, hold: bool) -> CopterTarget:
        return self.navigator.target(seq, hold)

    _touchdown_pending = False

    def _mission_set_home(self, sq: CopterMissionSequencer, t_us: int) -> None:
        """A mission's DO_SET_HOME: here (the navigation solution) or the item's place."""
        req = sq.home_request
        sq.home_request = None
        nav = self.nav_state
        if req == "here":
            req = (nav.lat_rad, nav.lon_rad, nav.alt_m)
        self.set_home(*req, t_us)
        self.notice(t_us * 1e-6, 6, f"Mission: home set to {math.degrees(req[0]):.7f} "
                                    f"{math.degrees(req[1]):.7f} {req[2]:.1f} m")

    def _monitor(self, mon: MotorMonitor, frame: SensorFrame, t_us: int) -> None:
        """The motor fault monitor on this step's IMU sample (less the filter's bias
        estimates) and the commands of the last step, on the steps it is due
        (``mon.due()``, asked by the caller); its events to the log, its failsafe to the
        modes."""
        nav = self.nav
        # (truth navigation: no bias estimate)
        f_z = nav.f_raw[2] - nav.ba_z if isinstance(nav, DecimatedNav) else frame.imu.f_b[2]
        # free flight only: not on the ground nor within FDI_MOT_HAGL of home's height
        # (ground contact and ground effect; the estimated height drifts by decimetres)
        flying = (self.armed and self.flying and not self.on_ground
                  and self.p_home[2] < -self.params["FDI_MOT_HAGL"])
        if not mon.update(t_us, flying, self._motors, f_z, self.y, self.ctrl.mixer.k):
            return                      # (its stage did not run: nothing of it changed)
        self._forward_events(mon)
        if mon.accommodation != self.ctrl.mixer.eff:
            self.ctrl.mixer.set_effectiveness(mon.accommodation)
        if mon.failsafe == "LAND":
            mon.failsafe = None
            if self.armed and self.mode != CopterMode.LAND:
                self.set_mode(CopterMode.LAND, t_us)

    def _update_ground_state(self, u_z: float, t_us: int, landing: bool) -> None:
        """Leaving the ground, and the land detector (module docstring)."""
        h = -self.p_home[2]
        if self.on_ground:
            if u_z > 0.8 * self.ctrl.hover_thrust():
                self.on_ground = False
                self._land_since_us = None
            return
        if not self.flying and h > 0.5:
            self.flying = True
        if landing and u_z < 0.75 * self.ctrl.hover_thrust() and abs(self.y[Y_V + 2]) < 0.3:
            if self._land_since_us is None:
                self._land_since_us = t_us
            elif (t_us - self._land_since_us) * 1e-6 >= self.params["LAND_DET_S"]:
                self.on_ground = True
                self.flying = False
                self._touchdown_pending = True
                self.log.event(t_us * 1e-6, "touchdown")
                if self.mode in (CopterMode.STABILIZE, CopterMode.ALT_HOLD):
                    self.ctrl.reset()
        else:
            self._land_since_us = None

    def _landed_end(self, t_us: int) -> None:
        """A landing ended (mission, RTL or LAND): motors off, disarm."""
        self.mission_landed = True
        self.ctrl.reset()
        self.disarm(t_us, force=True)

    def _log(self, t_us: int, nav: NavState, truth, motors) -> None:
        gps = self._gps_this_step
        self._gps_this_step = None
        hf = self.home_frame
        if hf is None:
            return
        p = self.p_home
        er, ep, ey = self.euler
        tgt = self.target
        c = self.ctrl
        alt0 = hf.alt0_m
        if tgt is None:
            kind = 6.0 if self.armed and not self.on_ground else 0.0
            tgt_row = (p[0], p[1], alt0 - p[2], 0.0, 0.0, 0.0, p[0], p[1], p[0], p[1])
            hold = 0.0
        else:
            kind = 0 if self.on_ground and tgt.kind != "takeoff" else KIND_CODES[tgt.kind]
            tp_ = tgt.p_ned
            tgt_row = (tp_[0], tp_[1], alt0 - tp_[2], *tgt.v_ned, *tgt.goal_ne, *tgt.leg_a)
            hold = tgt.hold
        seq = tgt.seq if tgt is not None else 0
        leg = tgt.leg_id if tgt is not None else 0
        # one tuple display (not a chain of tuple sums, each a copy of the row so far;
        # whole vectors starred, not element by element); flags and codes as they are:
        # the log makes floats of its rows once, when it is saved (FlightLog.arrays), as
        # the fixed-wing's log does; the mode as its number (a row of numbers only is
        # left alone by the cyclic garbage collector after its first pass, as the
        # fixed-wing's _log says)
        self.log.append((
            t_us * 1e-6, self.armed, int(self.mode), seq, leg, kind, hold, self.on_ground,
            *self._truth_row(hf, truth),
            p[0], p[1], alt0 - p[2], er, ep, ey, *self.y[Y_V:Y_V + 3].tolist(),
            *tgt_row,
            c.roll_d, c.pitch_d, c.yaw_d, *c.u, *motors,
            *self._nav_row(hf, nav, gps), *self._fdi_row()))

    def _fdi_row(self) -> tuple:
        mon = self.monitor
        if mon is None:
            return (0.0, 0.0, 1.0, 1.0, 1.0, 1.0, 1.0)
        return (mon.ratio, mon.iso_ratio, *mon.gamma.tolist(), mon.lam)


@kernel
def guide_track(loops, hold, poly, dt, pn, pe, pd, leash, yaw_ref, goal, yaw_step, follow):
    """The navigator's step (:func:`~.guidance.multirotor.guidance_step` on the
    trajectory's array ``tx`` and the arguments ``CopterNavigator.step_inputs`` gives) and
    the loops on the reference it leaves in ``tx`` (:func:`~.control.multirotor.track_mix`
    on the controller's array ``cx`` and the navigation output ``y``, the integrators
    held with ``hold``), in one call where nothing comes between them (no terrain-frame
    leg); ``cx``, ``tx`` and ``y`` are parts of ``loops`` (QuadVehicle._loops, LOOPS_*).
    Returns guidance_step's (arrived, yaw_ref), then track_mix's (phi_d, theta_d, u,
    motors)."""
    cx, tx = loops[:LOOPS_TRAJ], loops[LOOPS_TRAJ:LOOPS_NAV]
    y = loops[LOOPS_NAV + X_Y:]
    arrived, yaw_ref = guidance_step(tx, poly, dt, pn, pe, pd, leash, yaw_ref, goal, yaw_step,
                                     follow)
    roll_d, pitch_d, u, motors = track_mix(cx, tx[REF_START:REF_END], y, pn, pe, pd, 0.0,
                                           yaw_ref, dt, hold, hold)
    return arrived, yaw_ref, roll_d, pitch_d, u, motors


# predict_output's x: p, v, q_nb, the accelerometer and gyro biases, g, the sums of the
# samples, then its output y (the loops' array: DecimatedNav.y, a view; one array, one
# argument)
X_BA, X_BG, X_G, X_SUMS, X_Y = 10, 13, 16, 17, 23
X_N = X_Y + Y_N
# QuadVehicle._loops: the controller's array (control.multirotor.X_*), the reference
# trajectory's (guidance.multirotor's), the output predictor's (X_* above)
LOOPS_TRAJ = CTRL_N
LOOPS_NAV = LOOPS_TRAJ + TRAJ_N
LOOPS_N = LOOPS_NAV + X_N


@kernel
def restart_output(x, p, v, q, nom, g, wx, wy, wz):
    """The output predictor started from the filter's update: ``x`` from its output's
    p, v, q, the nominal state's (``nom``: nav.strapdown's X_*) accelerometer and gyro
    biases and g, the sums of the samples at zero; its ``y`` (from X_Y) as
    predict_output writes it, on this step's raw rate (wx, wy, wz) less the gyro bias.
    Returns p and the angles, as predict_output does."""
    for i in range(3):
        x[i] = p[i]
        x[3 + i] = v[i]
        x[X_BA + i] = nom[NOM_BA + i]
        x[X_BG + i] = nom[NOM_BG + i]
    for i in range(4):
        x[6 + i] = q[i]
    x[X_G] = g
    x[X_SUMS:X_Y] = 0.0
    roll, pitch, yaw = euler_321(q[0], q[1], q[2], q[3])
    y = x[X_Y:]
    y[Y_V], y[Y_V + 1], y[Y_V + 2] = v[0], v[1], v[2]
    y[Y_Q], y[Y_Q + 1], y[Y_Q + 2], y[Y_Q + 3] = q[0], q[1], q[2], q[3]
    y[Y_W], y[Y_W + 1], y[Y_W + 2] = wx - x[X_BG], wy - x[X_BG + 1], wz - x[X_BG + 2]
    y[Y_EULER], y[Y_EULER + 1], y[Y_EULER + 2] = roll, pitch, yaw
    return (p[0], p[1], p[2]), (roll, pitch, yaw)


@kernel
def predict_output(x, fx, fy, fz, wx, wy, wz, dt):
    """The output predictor (module docstring) over one IMU sample: ``x`` = (p, v, q_nb,
    accelerometer bias, gyro bias, g, the sums of the samples f and omega since the
    filter's update: X_SUMS, y: X_Y), its p, v, q and sums updated in place;
    q <- q (x) Exp(omega dt), v <- v + (R f + g) dt, p <- p + (v + v') dt / 2 with f and
    omega the bias-corrected specific force and rate. Writes v, q, omega and q's (roll,
    pitch, yaw) in its ``y`` (the loops' array, Y_*, where the vehicle reads them too) and
    returns the new p and the angles, two tuples of floats (the caller's values without
    reading them back out of ``x`` or ``y``; the angles here rather than in a call of
    their own)."""
    # the raw sample summed for the filter's next update (DecimatedNav.update)
    x[X_SUMS] += fx
    x[X_SUMS + 1] += fy
    x[X_SUMS + 2] += fz
    x[X_SUMS + 3] += wx
    x[X_SUMS + 4] += wy
    x[X_SUMS + 5] += wz
    wx -= x[X_BG]
    wy -= x[X_BG + 1]
    wz -= x[X_BG + 2]
    fx -= x[X_BA]
    fy -= x[X_BA + 1]
    fz -= x[X_BA + 2]
    qw, qx, qy, qz = x[6], x[7], x[8], x[9]
    r = quat_dcm(qw, qx, qy, qz)
    an = r[0] * fx + r[1] * fy + r[2] * fz
    ae = r[3] * fx + r[4] * fy + r[5] * fz
    ad = r[6] * fx + r[7] * fy + r[8] * fz + x[X_G]
    vn, ve, vd = x[3], x[4], x[5]
    vn1, ve1, vd1 = vn + an * dt, ve + ae * dt, vd + ad * dt
    x[0] += 0.5 * (vn + vn1) * dt
    x[1] += 0.5 * (ve + ve1) * dt
    x[2] += 0.5 * (vd + vd1) * dt
    x[3], x[4], x[5] = vn1, ve1, vd1
    qw, qx, qy, qz = quat_step(qw, qx, qy, qz, wx * dt, wy * dt, wz * dt)
    x[6], x[7], x[8], x[9] = qw, qx, qy, qz
    roll, pitch, yaw = euler_321(qw, qx, qy, qz)
    y = x[X_Y:]
    y[Y_V], y[Y_V + 1], y[Y_V + 2] = vn1, ve1, vd1
    y[Y_Q], y[Y_Q + 1], y[Y_Q + 2], y[Y_Q + 3] = qw, qx, qy, qz
    y[Y_W], y[Y_W + 1], y[Y_W + 2] = wx, wy, wz
    y[Y_EULER], y[Y_EULER + 1], y[Y_EULER + 2] = roll, pitch, yaw
    return (x[0], x[1], x[2]), (roll, pitch, yaw)
