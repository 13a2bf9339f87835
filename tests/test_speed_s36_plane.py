"""The fixed-wing loops' kernel (autopilot/control/fixed_wing.py ``_loops``, with
control/pid.py's ``pid_update``) against the Python it replaced, kept here as it was
(``_ReferenceController``, ``Pid``), bit for bit over random steps through every branch:
the overrides of the take-off, flare and ground roll, and the reactions to a stuck
elevator, aileron, rudder or throttle."""
import math
import random

import numpy as np
import pytest

from autopilot.control.fixed_wing import (EOUT_BANK_MIN_DEG, G, LAT_DEFLECTION_RAD,
                                          FixedWingController)
from autopilot.geo import quat_to_euler
from autopilot.messages import NavState
from autopilot.params import ParamStore
from autopilot.vehicle import plane_param_declarations


# ------------------------------------------------ the Python the kernel replaced --
class Pid:
    __slots__ = ("kp", "ki", "kd", "out_min", "out_max", "i_max", "integ")

    def __init__(self, kp: float, ki: float = 0.0, kd: float = 0.0,
                 out_min: float = -1.0, out_max: float = 1.0, i_max: float | None = None):
        self.kp, self.ki, self.kd = kp, ki, kd
        self.out_min, self.out_max = out_min, out_max
        self.i_max = i_max if i_max is not None else max(abs(out_min), abs(out_max))
        self.integ = 0.0

    def reset(self, integ: float = 0.0) -> None:
        self.integ = integ

    def update(self, setpoint: float, measurement: float, dt: float, rate: float,
               feedforward: float = 0.0, scale: float = 1.0) -> float:
        """``rate`` is d(measurement)/dt as measured (e.g. a gyro; 0.0 where the loop has
        no derivative term). ``scale`` multiplies the feedback terms (gain scheduling,
        e.g. with dynamic pressure). The arguments by position: the loops call this
        every step, and keywords cost the call more than its integrator."""
        err = setpoint - measurement
        unsat = feedforward + scale * (self.kp * err + self.integ - self.kd * rate)
        # min(max(unsat, lo), hi) spelt out, here and below: the same comparisons and
        # result, without the builtins' argument tuple and iterator (they cost more than
        # the rest of this call)
        lo, hi = self.out_min, self.out_max
        out = lo if lo > unsat else unsat
        out = hi if hi < out else out
        # anti-windup: integrate unless saturated and the error pushes further out
        if self.ki > 0.0 and dt > 0.0:
            pushing_out = (unsat >= hi and err > 0) or (unsat <= lo and err < 0)
            if not pushing_out:
                integ, i_max = self.integ + self.ki * err * dt, self.i_max
                integ = -i_max if -i_max > integ else integ
                self.integ = i_max if i_max < integ else integ
        return out


class _ReferenceController:
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


# ---------------------------------------------------------------------- the tests --
def _nav(rng):
    return NavState(0, np.zeros(3), np.array([rng.uniform(-30, 30), rng.uniform(-30, 30), rng.uniform(-6, 6)]),
                    np.array([1.0, 0.0, 0.0, 0.0]),
                    np.array([rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1)]), 0.0, 0.0,
                    rng.uniform(80.0, 160.0), rng.choice((rng.uniform(0.0, 45.0), 3.0, 25.0)))


def _reactions(rng, case):
    """(elevator out, its trim, its bank, full throttle, surface_out, throttle_out)"""
    eout = case in ("eout", "eout_trim", "eout_full")
    trim = rng.uniform(18.0, 30.0) if case in ("eout_trim", "eout_full") else None
    bank = rng.uniform(0.05, 0.6) if case in ("eout_trim", "eout_full") else None
    so = None
    if case in ("aileron", "rudder"):
        so = {"surface": case, "stuck_rad": 0.1, "counter_rad": rng.uniform(-0.3, 0.3),
              "roll_gain": rng.uniform(0.5, 3.0), "authority": 0.5}
    tout = None
    if case.startswith("tout"):
        tout = {"stuck": 0.5, "level": case != "tout_glide", "v_glide": rng.uniform(15.0, 25.0),
                "v_fly": rng.uniform(18.0, 32.0), "v_top": rng.uniform(25.0, 45.0)}
    return eout, trim, bank, case == "eout_full", so, tout


@pytest.mark.parametrize("case", ["none", "eout", "eout_trim", "eout_full", "aileron", "rudder",
                                  "tout_level", "tout_high", "tout_glide"])
def test_the_loops_kernel_flies_as_the_python_it_replaced(case):
    rng = random.Random(case)
    values = {}
    if case == "tout_level":
        values["TOUT_ARSPD_MAX"] = 0.0
    p = ParamStore(plane_param_declarations())
    for k, v in values.items():
        p.set(k, v)
    new, ref = FixedWingController(p), _ReferenceController(p)
    eout, trim, bank, full, so, tout = _reactions(rng, case)
    for c in (new, ref):
        c.set_elevator_out(eout)
        if eout:
            c.set_elevator_trim(trim, bank, full)
        c.surface_out, c.throttle_out = so, tout
    assert new.roll_limit_rad() == ref.roll_limit_rad()
    assert new.reaction_bank_limit_rad() == ref.reaction_bank_limit_rad()
    branches = set()
    for step in range(3000):
        if step % 500 == 0:
            new.reset(), ref.reset()
        if so is not None and step % 300 == 150:
            # the monitor refines a stuck surface's reading in its dict, in place
            so.update(counter_rad=rng.uniform(-0.3, 0.3), stuck_rad=rng.uniform(-0.2, 0.2))
        if step == 2500 and case != "none":
            # the reactions ended (the elevator's by its method, the others' dicts dropped)
            for c in (new, ref):
                c.set_elevator_out(False)
                c.surface_out = c.throttle_out = None
        nav = _nav(rng)
        euler = (rng.uniform(-1.2, 1.2), rng.uniform(-0.6, 0.6), 0.0) if step % 7 else None
        kw = {}
        if rng.random() < 0.3:
            k = rng.choice(("takeoff", "flare", "ground", "pitch"))
            branches.add(k)
            if k == "takeoff":
                kw = dict(pitch_min_rad=0.2, throttle_override=rng.uniform(0.0, 1.0))
            elif k == "flare":
                kw = dict(throttle_override=0.0, climb_override=rng.uniform(-4.0, 1.0),
                          pitch_min_rad=-0.05, pitch_max_rad=0.15, climb_kp=0.1)
            elif k == "ground":
                kw = dict(pitch_min_rad=0.2, throttle_override=1.0, rudder_override=rng.uniform(-1, 1))
            else:
                kw = dict(pitch_max_rad=rng.uniform(-0.1, 0.3), spd_weight=rng.uniform(0.0, 1.0))
        dt = rng.choice((0.01, 0.01, 0.004, 0.0))
        args = (nav, dt, rng.uniform(-1.2, 1.2), rng.uniform(60.0, 180.0), rng.uniform(0.0, 40.0))
        want = ref.update(*args, euler=euler, **kw)
        got = new.update(*args, euler=euler, **kw)
        assert got == want, (step, kw)
        assert new.commands() == [ref.alt_dem_m, ref.roll_cmd_rad, ref.pitch_cmd_rad, ref.climb_cmd_mps]
        assert new._x[:5].tolist() == [ref.roll_pid.integ, ref.pitch_pid.integ, ref.climb_pid.integ,
                                       ref.speed_pid.integ, ref.eout_pid.integ]
    assert branches == {"takeoff", "flare", "ground", "pitch"}


def test_a_parameter_change_reaches_the_kernel_with_the_integrators_kept():
    p = ParamStore(plane_param_declarations())
    new, ref = FixedWingController(p), _ReferenceController(p)
    rng = random.Random(5)
    for step in range(400):
        if step == 200:
            for name, v in (("RLL_KP", 2.0), ("SPD_KI", 0.1), ("THR_MAX", 0.8), ("CLMB_MAX", 4.0),
                            ("PTCH_LIM_MIN_DEG", -5.0), ("EOUT_THR_KP", 0.05)):
                p.set(name, v)
            new.configure_gains(), ref.configure_gains()
        args = (_nav(rng), 0.01, rng.uniform(-1, 1), rng.uniform(60, 180), rng.uniform(15, 35))
        assert new.update(*args) == ref.update(*args)
