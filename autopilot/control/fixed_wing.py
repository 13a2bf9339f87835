"""Fixed-wing inner and outer loops (successive loop closure, Beard & McLain 2012 ch. 6).

Loops are named by what they close:

* roll from aileron:      da = kp (phi_c - phi) + ki int(...) - kd p
* pitch from elevator:    de = s (kp (theta_c - theta) + ki int(...) - kd q) + de_trim (V_t/V)^2
* climb rate from pitch:  theta_c = alpha_trim (V_t/V_c)^2 + asin(hdot_c / V)
                          + kp (hdot_c - hdot) + ki int(...)
                          + the turn compensation (1/cos(phi) - 1) * PTCH_TURN_FF
* altitude demand:        h_dem follows the guidance altitude h_c, slew-limited to
                          DEM_CLMB_FRAC of the climb and sink limits (as TECS shapes its
                          height demand), so a step in h_c becomes a ramp the aircraft
                          can fly; its rate hdot_dem is fed forward
* altitude to climb rate: hdot_c = clamp(hdot_dem + ALT_KP (h_dem - h), -SINK_MAX, CLMB_MAX)
* speed priority:         hdot_c -= SPD_PRIO * dead(V_c - V, SPD_PRIO_DB): with the throttle
                          unable to hold airspeed (a climb beyond the aircraft's excess
                          power, or a dive at idle), trade height for speed rather than
                          stall or overspeed; the idea of TECS (Lambregts 1983) in its
                          simplest form. Weighted (``spd_weight``) on a landing approach,
                          down to 0 at the land point (TECS_LAND_SPDWGT, as ArduPlane's
                          TECS): there the glide slope comes first
* airspeed from throttle: dt = THR_TRIM + kp (V_c - V) + ki int(...) + THR_CLMB_FF hdot_c
* yaw damper / turn coordination from rudder: dr = kd (r_c - r), r_c = g tan(phi) cos(theta) / V
* elevator out:           once the fault monitor has found an elevator actuator fault
                          (``set_elevator_out``, EOUT_ENABLE), the airspeed is no longer
                          the throttle's: with the elevator stuck the angle of attack is
                          nearly fixed, so the airspeed is whatever that trim gives and the
                          throttle sets the flight-path angle instead (the principle of
                          propulsion-controlled aircraft, Burcham et al., NASA TP-3627):
                          dt = THR_TRIM + EOUT_THR_KP (h_dem - h) + EOUT_THR_KI int(...)
                          + EOUT_SPD_KP (V_mean - V), with V_mean the airspeed low-passed over
                          EOUT_SPD_TAU (phugoid damping: thrust against the speed swing),
                          and the height demand slewed at EOUT_DEM_RATE. It engages at the
                          detection, before the monitor has told a stuck surface from a
                          weakened one (seconds, tens of seconds in turbulence). From the
                          detection on, V_mean is the airspeed the airframe's model says
                          the deflection flown (once identified, the stuck one) trims to
                          (``set_elevator_trim``), the bank is limited to the steepest
                          level turn of that trim (not under EOUT_BANK_MIN_DEG), and where
                          the model has no level trim the throttle is full while under the
                          height demand: the low-passed mean lags the speed change
                          the fault starts, and a nose-down stuck elevator's dive then read
                          as a speed swing to damp with less throttle, where the least height
                          loss needs the most (with the angle of attack fixed, the flight-
                          path angle grows with the thrust at that speed). Where the
                          elevator still acts (weakened, or working again after ``ok``) the
                          pitch loop holds the height as before and the speed priority,
                          now only outside ARSPD_FBW_MIN..MAX, guards the airspeed.
                          The gains are low on purpose: the throttle's own pitching moment
                          (a cut pitches the nose up on the default airframe) and the
                          lightly damped phugoid turn faster throttle loops, and a climb-
                          rate feedback, into growing pitch oscillations. Without this the
                          airspeed loop, asking for a speed a nose-up stuck elevator cannot
                          give, holds full throttle and the aircraft climbs away, and with
                          the elevator stuck nose-down it flies into the ground
                          (missions/fault_elevator_stuck_down.toml).

The feed-forwards follow from the lift and pitching-moment balance: the trim angle of
attack and the trim elevator both grow as 1/V^2 about their values at TRIM_ARSPD, and
the flight-path angle for a commanded climb rate is asin(hdot_c / V); the loops only
correct what the feed-forwards miss. The surface loops are scaled by
s = clamp((TRIM_ARSPD / V)^2, 0.5, 2) because control power grows with dynamic pressure.

Every PID has explicit saturation and anti-windup (control/pid.py). The course loop is
L1 guidance (guidance/l1.py), which commands the bank angle directly.

Normalised outputs, as HIL_ACTUATOR_CONTROLS carries them: aileron +1 rolls right,
elevator +1 pitches the nose up, rudder +1 yaws the nose right, throttle 0..1. The
gains are per unit of normalised deflection (a full deflection is about 0.35 rad on
the default airframe).
"""
from __future__ import annotations

import math

from ..geo import quat_to_euler
from ..messages import NavState
from ..params import Param
from .pid import Pid

G = 9.80665
# elevator out: the bank limit never under this, so that the aircraft can still turn back
# to its mission where the model has no level turn (a 10 deg turn costs 1.5 % of the lift)
EOUT_BANK_MIN_DEG = 10.0
LAT_DEFLECTION_RAD = 0.35   # aileron and rudder deflection at a normalised command of 1 [rad]

FW_PARAMS = (
    Param("RLL_KP", 1.2, 0.0, 10.0, "1/rad", "roll angle to aileron, proportional"),
    Param("RLL_KI", 0.2, 0.0, 5.0, "1/(rad s)", "roll angle to aileron, integral"),
    Param("RLL_KD", 0.12, 0.0, 5.0, "s/rad", "roll rate damping to aileron"),
    Param("PTCH_KP", 2.0, 0.0, 10.0, "1/rad", "pitch angle to elevator, proportional"),
    Param("PTCH_KI", 0.5, 0.0, 5.0, "1/(rad s)", "pitch angle to elevator, integral"),
    Param("PTCH_KD", 0.5, 0.0, 5.0, "s/rad", "pitch rate damping to elevator"),
    Param("PTCH_TRIM_DEG", 5.7, -10.0, 15.0, "deg", "pitch attitude (= angle of attack) in level flight at TRIM_ARSPD"),
    Param("ELEV_TRIM", 0.35, -1.0, 1.0, "", "elevator in level flight at TRIM_ARSPD"),
    Param("PTCH_TURN_FF", 0.12, 0.0, 1.0, "rad", "extra pitch per (1/cos(bank) - 1) in turns"),
    Param("PTCH_LIM_MAX_DEG", 20.0, 0.0, 45.0, "deg", "maximum pitch command"),
    Param("PTCH_LIM_MIN_DEG", -15.0, -45.0, 0.0, "deg", "minimum pitch command"),
    Param("ALT_KP", 0.3, 0.0, 5.0, "1/s", "altitude error to climb-rate command"),
    Param("CLMB_KP", 0.03, 0.0, 2.0, "rad s/m", "climb-rate error to pitch, proportional"),
    Param("CLMB_KI", 0.01, 0.0, 2.0, "rad/m", "climb-rate error to pitch, integral"),
    Param("CLMB_MAX", 2.5, 0.5, 15.0, "m/s", "maximum climb rate"),
    Param("SINK_MAX", 3.0, 0.5, 15.0, "m/s", "maximum sink rate"),
    Param("DEM_CLMB_FRAC", 0.7, 0.1, 1.0, "", "altitude demand slews at this fraction of CLMB_MAX / SINK_MAX"),
    Param("SPD_PRIO", 1.0, 0.0, 5.0, "", "climb-rate given up per m/s of airspeed error beyond the dead band"),
    Param("SPD_PRIO_DB", 1.5, 0.0, 10.0, "m/s", "airspeed error dead band of the speed priority"),
    Param("THR_TRIM", 0.38, 0.0, 1.0, "", "throttle in level cruise at TRIM_ARSPD"),
    Param("THR_MAX", 1.0, 0.0, 1.0, "", "maximum throttle"),
    Param("THR_CLMB_FF", 0.06, 0.0, 1.0, "s/m", "throttle per m/s of commanded climb"),
    Param("SPD_KP", 0.08, 0.0, 2.0, "s/m", "airspeed error to throttle, proportional"),
    Param("SPD_KI", 0.03, 0.0, 2.0, "1/m", "airspeed error to throttle, integral"),
    Param("YAW_KD", 0.3, 0.0, 5.0, "s/rad", "yaw-rate error (vs coordinated turn) to rudder"),
    Param("ROLL_LIMIT_DEG", 45.0, 5.0, 65.0, "deg", "maximum bank angle"),
    Param("TRIM_ARSPD", 25.0, 10.0, 80.0, "m/s", "cruise airspeed"),
    Param("ARSPD_FBW_MIN", 20.0, 8.0, 80.0, "m/s", "minimum airspeed command"),
    Param("ARSPD_FBW_MAX", 30.0, 10.0, 100.0, "m/s", "maximum airspeed command"),
    Param("LOUT_ENABLE", 1.0, 0.0, 1.0, "", "aileron or rudder out: once the fault monitor finds one stuck, counter it with the other surface and fly the roll on what is left (0: off)"),
    Param("TOUT_ENABLE", 1.0, 0.0, 1.0, "", "throttle out: once the fault monitor finds the throttle stuck, fly the airspeed on the pitch and let the height be what the thrust gives (0: off)"),
    Param("TOUT_ARSPD_MAX", 40.0, 0.0, 100.0, "m/s", "throttle out where the stuck thrust holds level flight: the height held on the pitch, the airspeed left to float between ARSPD_FBW_MIN and this (out of it the pitch trades height for airspeed); 0: the airspeed flown on the pitch, the height free"),
    Param("EOUT_ENABLE", 1.0, 0.0, 1.0, "", "elevator out: fly the height on the throttle once the fault monitor finds an elevator actuator fault (0: off)"),
    Param("EOUT_THR_KP", 0.015, 0.0, 0.2, "1/m", "elevator out: height error to throttle, proportional"),
    Param("EOUT_THR_KI", 0.0008, 0.0, 0.05, "1/(m s)", "elevator out: height error to throttle, integral"),
    Param("EOUT_SPD_KP", 0.08, 0.0, 1.0, "s/m", "elevator out: airspeed below its own mean to throttle (phugoid damping)"),
    Param("EOUT_SPD_TAU", 20.0, 1.0, 200.0, "s", "elevator out: time constant of that mean airspeed"),
    Param("EOUT_DEM_RATE", 1.0, 0.1, 10.0, "m/s", "elevator out: slew rate of the altitude demand"),
)


class FixedWingController:
    """Attitude, altitude and airspeed loops; ``update`` returns the 4 normalised
    controls (aileron, elevator, rudder, throttle)."""

    def __init__(self, params):
        self.params = params
        self.configure()

    def configure_gains(self) -> None:
        """Re-read the gains and the parameters the loops read every step, after a
        parameter change (integrators kept)."""
        p = self.params
        for pid, (kp, ki, kd) in ((self.roll_pid, ("RLL_KP", "RLL_KI", "RLL_KD")),
                                  (self.pitch_pid, ("PTCH_KP", "PTCH_KI", "PTCH_KD")),
                                  (self.climb_pid, ("CLMB_KP", "CLMB_KI", None)),
                                  (self.speed_pid, ("SPD_KP", "SPD_KI", None))):
            pid.kp, pid.ki = p[kp], p[ki]
            if kd is not None:
                pid.kd = p[kd]
        self.speed_pid.out_max = p["THR_MAX"]
        self.eout_pid.kp, self.eout_pid.ki, self.eout_pid.out_max = p["EOUT_THR_KP"], p["EOUT_THR_KI"], p["THR_MAX"]
        self.climb_pid.out_min = math.radians(p["PTCH_LIM_MIN_DEG"])
        self.climb_pid.out_max = math.radians(p["PTCH_LIM_MAX_DEG"])
        # the parameters every step reads, read here (a change reaches them as it does
        # the gains): a parameter's lookup cost as much as the arithmetic it feeds
        self._sink_max, self._clmb_max = p["SINK_MAX"], p["CLMB_MAX"]
        self._dem_up, self._dem_down = p["DEM_CLMB_FRAC"] * p["CLMB_MAX"], p["DEM_CLMB_FRAC"] * p["SINK_MAX"]
        self._alt_kp, self._spd_prio, self._spd_prio_db = p["ALT_KP"], p["SPD_PRIO"], p["SPD_PRIO_DB"]
        self._trim_arspd, self._turn_ff = p["TRIM_ARSPD"], p["PTCH_TURN_FF"]
        self._alpha_trim_rad = math.radians(p["PTCH_TRIM_DEG"])
        self._thr_trim, self._thr_clmb_ff = p["THR_TRIM"], p["THR_CLMB_FF"]
        self._elev_trim, self._yaw_kd = p["ELEV_TRIM"], p["YAW_KD"]
        self._roll_lim_rad = math.radians(p["ROLL_LIMIT_DEG"])

    def configure(self) -> None:
        p = self.params
        self.roll_pid = Pid(p["RLL_KP"], p["RLL_KI"], p["RLL_KD"], -1.0, 1.0, i_max=0.3)
        self.pitch_pid = Pid(p["PTCH_KP"], p["PTCH_KI"], p["PTCH_KD"], -1.0, 1.0, i_max=0.4)
        self.climb_pid = Pid(p["CLMB_KP"], p["CLMB_KI"], 0.0,
                             math.radians(p["PTCH_LIM_MIN_DEG"]), math.radians(p["PTCH_LIM_MAX_DEG"]),
                             i_max=math.radians(5.0))
        self.speed_pid = Pid(p["SPD_KP"], p["SPD_KI"], 0.0, 0.0, p["THR_MAX"], i_max=0.4)
        self.last = (0.0, 0.0, 0.0, 0.0)
        self.roll_cmd_rad = 0.0
        self.pitch_cmd_rad = 0.0
        self.climb_cmd_mps = 0.0
        self.alt_dem_m: float | None = None
        self.elevator_out = False
        self.eout_pid = Pid(p["EOUT_THR_KP"], p["EOUT_THR_KI"], 0.0, 0.0, p["THR_MAX"], i_max=0.5)
        self._eout_v_mean: float | None = None  # airspeed low-passed while the elevator is out
        self.eout_trim_mps: float | None = None  # the stuck elevator's trim airspeed (model)
        self.eout_bank_max_rad: float | None = None  # its steepest level turn (model)
        self.eout_full_throttle = False          # the model has no level trim for it
        self.surface_out: dict | None = None     # a stuck aileron or rudder (monitor's surface_out)
        self.throttle_out: dict | None = None    # a stuck throttle (monitor's throttle_out)
        self.configure_gains()

    def set_elevator_out(self, out: bool) -> None:
        """Elevator out (stuck): the height on the throttle (module docstring)."""
        if out and not self.elevator_out:
            self.eout_pid.reset()
            self._eout_v_mean = None
        if not out:
            self.eout_trim_mps = self.eout_bank_max_rad = None
            self.eout_full_throttle = False
        self.elevator_out = out

    def set_elevator_trim(self, trim_mps: float | None, bank_max_rad: float | None = None,
                          full_throttle: bool = False) -> None:
        """The airspeed the airframe's model says the stuck elevator trims to (level
        flight): the phugoid damping acts about it instead of about the low-passed
        airspeed, which lags the speed change the fault starts (module docstring); the
        steepest bank of a level turn at that trim (not under EOUT_BANK_MIN_DEG); and
        whether the model has no level trim for it, when the throttle is full while the
        aircraft is under its height demand."""
        self.eout_trim_mps = trim_mps
        self.eout_bank_max_rad = bank_max_rad
        self.eout_full_throttle = full_throttle

    def roll_limit_rad(self) -> float:
        """The bank limit in force [rad]: ROLL_LIMIT_DEG, or less under a fault's
        reaction: the elevator out, the steepest level turn of its trim (not under
        EOUT_BANK_MIN_DEG); an aileron or rudder out, the share of the other surface's
        travel left after countering it (monitor.py, _lateral_reaction), not under
        EOUT_BANK_MIN_DEG either. With an aileron or rudder out the mission's turns are
        planned at it (guidance/mission.py, ``bank_limit_rad``)."""
        roll_lim = self._roll_lim_rad
        if self.elevator_out and self.eout_bank_max_rad is not None:
            roll_lim = min(roll_lim, max(self.eout_bank_max_rad, math.radians(EOUT_BANK_MIN_DEG)))
        so = self.surface_out
        if so is not None:
            share = 1.0 - abs(so["counter_rad"]) / LAT_DEFLECTION_RAD
            roll_lim = min(roll_lim, max(roll_lim * share, math.radians(EOUT_BANK_MIN_DEG)))
        return roll_lim

    def reaction_bank_limit_rad(self) -> float | None:
        """The bank limit an aileron's or rudder's reaction imposes below ROLL_LIMIT_DEG
        [rad], None where there is none. Not the elevator out's: with the elevator stuck
        the height is what matters, and a turn replanned wider may turn the other way,
        where the propeller's gyroscopic moment pitches the nose down with nothing to
        answer it (fault_elevator_stuck_launch.toml trial 2, 0.051 rad from 119 m:
        replanned, it turned left and hit the ground, 68 m lost turning right before;
        over the 200 trials 4 lost and 2 saved)."""
        if self.surface_out is None:
            return None
        lim = self.roll_limit_rad()
        return lim if lim < self._roll_lim_rad else None

    def reaction_airspeed_mps(self) -> float | None:
        """The airspeed a fault's reaction flies instead of the commanded one [m/s], None
        where there is none: a stuck throttle whose thrust holds level flight, the speed
        it floats to (the model's top level speed, under TOUT_ARSPD_MAX). The mission's
        turns are sized for it where it is faster (guidance/mission.py,
        ``reaction_airspeed_mps``). Not a stuck elevator's trim, for the reason of
        :meth:`reaction_bank_limit_rad`."""
        tout = self.throttle_out
        p = self.params
        if tout is not None and tout["level"] and p["TOUT_ARSPD_MAX"] > 0.0:
            v_hi = max(p["TOUT_ARSPD_MAX"], p["ARSPD_FBW_MIN"])
            v_top = tout.get("v_top")
            return v_hi if v_top is None or v_top > v_hi else v_top
        return None

    def reset(self) -> None:
        self.alt_dem_m = None
        for pid in (self.roll_pid, self.pitch_pid, self.climb_pid, self.speed_pid):
            pid.reset()

    def update(self, nav: NavState, dt: float, bank_cmd_rad: float, alt_cmd_m: float,
               airspeed_cmd_mps: float, pitch_min_rad: float | None = None,
               throttle_override: float | None = None,
               euler: tuple[float, float, float] | None = None,
               climb_override: float | None = None,
               pitch_max_rad: float | None = None,
               climb_kp: float | None = None,
               spd_weight: float = 1.0,
               rudder_override: float | None = None) -> tuple[float, float, float, float]:
        """``climb_override``: fly this climb rate [m/s] instead of the altitude (the
        landing flare: height, not airspeed, is what matters then, so no speed
        priority), with the proportional gain ``climb_kp`` if given;
        ``pitch_max_rad``: a pitch ceiling below PTCH_LIM_MAX_DEG; ``spd_weight``
        scales the speed priority (0 on a landing's short final: the pitch holds the glide
        slope, the throttle the airspeed; guidance/landing.py TECS_LAND_SPDWGT);
        ``rudder_override``: on the wheels (a runway's take-off roll), the rudder the
        ground steering asks, and the roll loop's integrator held at zero (the wings
        cannot roll on the gear: it would wind up against it and roll the aircraft at
        the lift-off)."""
        # (every min(max(x, lo), hi) of the steps flown in every step is spelt out, as in
        # control/pid.py: the builtins cost more than the rest of the line)
        p = self.params
        roll, pitch, _ = euler if euler is not None else quat_to_euler(nav.q_nb.tolist())
        omega = nav.omega_b.tolist()
        v_air = nav.airspeed_mps
        v_air = 5.0 if 5.0 > v_air else v_air                        # max(V, 5)
        roll_lim = self.roll_limit_rad()
        so = self.surface_out
        phi_c = -roll_lim if -roll_lim > bank_cmd_rad else bank_cmd_rad
        phi_c = roll_lim if roll_lim < phi_c else phi_c

        # altitude to climb rate (outer), climb rate to pitch (middle)
        hdot = -nav.v_ned.item(2)
        if self.alt_dem_m is None or throttle_override is not None:
            self.alt_dem_m = nav.alt_m   # (takeoff: the demand starts from where we are)
        sink_max, clmb_max = self._sink_max, self._clmb_max
        up, down = self._dem_up, self._dem_down
        if self.elevator_out:
            up, down = min(up, p["EOUT_DEM_RATE"]), min(down, p["EOUT_DEM_RATE"])
        if dt > 0:
            hdot_dem = (alt_cmd_m - self.alt_dem_m) / dt
            hdot_dem = -down if -down > hdot_dem else hdot_dem
            hdot_dem = up if up < hdot_dem else hdot_dem
        else:
            hdot_dem = 0.0
        self.alt_dem_m += hdot_dem * dt
        if throttle_override is not None:
            hdot_dem, alt_err = 0.0, alt_cmd_m - nav.alt_m
        else:
            alt_err = self.alt_dem_m - nav.alt_m
        hdot_c = hdot_dem + self._alt_kp * alt_err
        hdot_c = -sink_max if -sink_max > hdot_c else hdot_c
        hdot_c = clmb_max if clmb_max < hdot_c else hdot_c
        if climb_override is not None:
            self.alt_dem_m = nav.alt_m
            hdot_c = min(max(climb_override, -p["SINK_MAX"]), p["CLMB_MAX"])
        dv = airspeed_cmd_mps - v_air
        db = self._spd_prio_db
        eout = self.elevator_out and throttle_override is None
        if eout:
            # elevator out: the airspeed is the stuck trim's, not a demand; only its limits
            # (should the surface work again) trade height for speed
            dv = max(p["ARSPD_FBW_MIN"] - v_air, min(0.0, p["ARSPD_FBW_MAX"] - v_air))
        tout = self.throttle_out
        if tout is not None and climb_override is None:
            # throttle out: where the stuck throttle holds level flight the height demand
            # acts, the airspeed bounding it as TECS does; else (or TOUT_ARSPD_MAX 0) the
            # airspeed on the pitch alone, and where no level flight the height is given
            # up: the glide at the best lift-to-drag airspeed, not under ARSPD_FBW_MIN
            if tout["level"] and p["TOUT_ARSPD_MAX"] > 0.0:
                # the stuck thrust holds level flight: the height held on the pitch (TECS's
                # height priority), the airspeed left to float to where that thrust meets
                # the drag (at full throttle the airframe's top speed, stuck low slower than
                # the cruise). The airspeed bounds the climb and the descent: the climb at
                # most SPD_PRIO times the airspeed over ARSPD_FBW_MIN, the descent at most
                # SPD_PRIO times its margin under TOUT_ARSPD_MAX (a climb the stuck thrust
                # cannot give is flown just over ARSPD_FBW_MIN, not traded down to the
                # stall; out of the two the pitch gives height for airspeed)
                v_lo = p["ARSPD_FBW_MIN"]
                v_hi = max(p["TOUT_ARSPD_MAX"], v_lo)
                hdot_c = min(max(hdot_c, -p["SPD_PRIO"] * (v_hi - v_air)), p["SPD_PRIO"] * (v_air - v_lo))
                hdot_c = min(max(hdot_c, -p["SINK_MAX"]), 2.0 * p["CLMB_MAX"])
            elif tout["level"]:
                # the airspeed the model says the stuck thrust holds level, if slower
                # than the demand; the height is what the excess thrust gives, the climb
                # free up to twice CLMB_MAX (a throttle stuck at full climbs at 3 m/s at
                # the cruise airspeed; flying faster to climb less was tried: the pitch
                # loop could not hold the steeper climb a slowing down needs, and the
                # airspeed went 3 m/s over ARSPD_FBW_MAX)
                v_t = min(airspeed_cmd_mps, tout["v_fly"])
                hdot_c = min(max(-p["SPD_PRIO"] * (v_t - v_air), -p["SINK_MAX"]), 2.0 * p["CLMB_MAX"])
            else:
                v_t = max(tout["v_glide"], p["ARSPD_FBW_MIN"])
                hdot_c = min(max(-p["SPD_PRIO"] * (v_t - v_air), -p["SINK_MAX"]), p["CLMB_MAX"])
        elif abs(dv) > db and climb_override is None:
            hdot_c -= spd_weight * self._spd_prio * (dv - math.copysign(db, dv))
            hdot_c = -sink_max if -sink_max > hdot_c else hdot_c
            hdot_c = clmb_max if clmb_max < hdot_c else hdot_c
        trim_arspd = self._trim_arspd
        q_ratio = (trim_arspd / v_air) ** 2
        scale = 0.5 if 0.5 > q_ratio else q_ratio
        scale = 2.0 if 2.0 < scale else scale
        cos_roll = math.cos(roll)
        turn_ff = self._turn_ff * (1.0 / (0.5 if 0.5 > cos_roll else cos_roll) - 1.0)
        sin_gamma = hdot_c / v_air
        sin_gamma = -0.5 if -0.5 > sin_gamma else sin_gamma
        gamma_c = math.asin(0.5 if 0.5 < sin_gamma else sin_gamma)
        # trim angle of attack at the *commanded* airspeed: using the measured one would
        # raise the nose further as the aircraft slows (positive feedback towards stall)
        v_c = 5.0 if 5.0 > airspeed_cmd_mps else airspeed_cmd_mps
        alpha_ratio = (trim_arspd / v_c) ** 2
        alpha_ff = self._alpha_trim_rad * (2.0 if 2.0 < alpha_ratio else alpha_ratio)
        climb_pid = self.climb_pid
        kp = climb_pid.kp
        if climb_kp is not None:
            climb_pid.kp = climb_kp
        # (the loops' Pid.update arguments by position: setpoint, measurement, dt, rate,
        # feed-forward, scale; rate 0.0: no derivative term)
        theta_c = climb_pid.update(hdot_c, hdot, dt, 0.0, alpha_ff + gamma_c + turn_ff)
        climb_pid.kp = kp
        if pitch_max_rad is not None:
            theta_c = pitch_max_rad if pitch_max_rad < theta_c else theta_c     # min()
        if pitch_min_rad is not None:
            theta_c = pitch_min_rad if pitch_min_rad > theta_c else theta_c     # max()

        # airspeed from throttle (with the climb feed-forward)
        if throttle_override is not None:
            thr = throttle_override
            self.speed_pid.reset(self.speed_pid.integ)
        elif eout:
            # elevator out: throttle from the height error, plus the airspeed's deviation
            # below its own slow mean (the speed the stuck elevator trims to)
            if self._eout_v_mean is None:
                self._eout_v_mean = v_air
            self._eout_v_mean += (v_air - self._eout_v_mean) * min(dt / p["EOUT_SPD_TAU"], 1.0)
            if self.eout_trim_mps is not None:
                self._eout_v_mean = self.eout_trim_mps
            thr = self.eout_pid.update(self.alt_dem_m, nav.alt_m, dt, 0.0,
                                       p["THR_TRIM"] + p["EOUT_SPD_KP"] * (self._eout_v_mean - v_air))
            if self.eout_full_throttle and nav.alt_m < self.alt_dem_m:
                thr = p["THR_MAX"]     # no level trim: the least height loss
        else:
            thr = self.speed_pid.update(airspeed_cmd_mps, v_air, dt, 0.0,
                                        self._thr_trim + self._thr_clmb_ff * hdot_c)

        # inner loops
        da = self.roll_pid.update(phi_c, roll, dt, omega[0], 0.0, scale)
        if rudder_override is not None:
            self.roll_pid.integ = 0.0
        de_ff = self._elev_trim * (2.0 if 2.0 < q_ratio else q_ratio)
        de = self.pitch_pid.update(theta_c, pitch, dt, omega[1], de_ff, scale)
        r_c = G * math.tan(roll) * math.cos(pitch) / v_air
        dr = self._yaw_kd * (r_c - omega[2])
        dr = -1.0 if -1.0 > dr else dr
        dr = 1.0 if 1.0 < dr else dr
        if rudder_override is not None:
            dr = rudder_override
        if so is not None:
            # aileron or rudder out: the other surface at the deflection that holds the
            # wings level against it (the airframe's model), the roll loop on top of it;
            # a stuck aileron's roll loop acts through the rudder, scaled by the ratio of
            # their rolling moments (the Aerosonde's rudder rolls more than it yaws)
            ff = so["counter_rad"] / LAT_DEFLECTION_RAD
            if so["surface"] == "aileron":
                dr = min(max(ff + so["roll_gain"] * da, -1.0), 1.0)
            else:
                da = min(max(da + ff, -1.0), 1.0)

        self.roll_cmd_rad, self.pitch_cmd_rad, self.climb_cmd_mps = phi_c, theta_c, hdot_c
        self.last = (da, de, dr, thr)
        return self.last
