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

Every PID has explicit saturation and anti-windup (control/pid.py). The loops of a step
are one compiled kernel (``_loops``, autopilot/jit.py): their integrators and the
altitude demand in a state it advances in place, the gains and the parameters it reads
written when a parameter or a fault's reaction changes, the three in one array. The
course loop is L1 guidance (guidance/l1.py), which commands the bank angle directly.

Normalised outputs, as HIL_ACTUATOR_CONTROLS carries them: aileron +1 rolls right,
elevator +1 pitches the nose up, rudder +1 yaws the nose right, throttle 0..1. The
gains are per unit of normalised deflection (a full deflection is about 0.35 rad on
the default airframe).
"""
from __future__ import annotations

import math

import numpy as np

from ..geo import quat_to_euler
from ..jit import kernel, preload
from ..messages import NavState
from ..params import Param
from .pid import I_MAX, KD, KI, KP, OUT_MIN, clamp, max2, min2, pid_update

G = 9.80665
# elevator out: the bank limit never under this, so that the aircraft can still turn back
# to its mission where the model has no level turn (a 10 deg turn costs 1.5 % of the lift)
EOUT_BANK_MIN_DEG = 10.0
LAT_DEFLECTION_RAD = 0.35   # aileron and rudder deflection at a normalised command of 1 [rad]
_EOUT_BANK_MIN_RAD = math.radians(EOUT_BANK_MIN_DEG)

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


# the loops: their rows of ``gains`` and their integrators' places in the state array
ROLL, PITCH, CLIMB, SPEED, EOUT = range(5)
# ... which holds after them the altitude demand (NaN: none yet) and the step's commands
# (``commands``, for the log), and the airspeed low-passed while the elevator is out
# (NaN: none yet)
ALT_DEM, ROLL_CMD, PITCH_CMD, CLIMB_CMD, V_MEAN = range(5, 10)
# the parameters the loops read (``FixedWingController.configure_gains``) and the fault
# reactions in force (NaN or 0: none), in the kernel's array ``c``
(C_SINK_MAX, C_CLMB_MAX, C_DEM_UP, C_DEM_DOWN, C_ALT_KP, C_SPD_PRIO, C_SPD_PRIO_DB,
 C_TRIM_ARSPD, C_TURN_FF, C_ALPHA_TRIM, C_THR_TRIM, C_THR_CLMB_FF, C_ELEV_TRIM, C_YAW_KD,
 C_ROLL_LIM, C_THR_MAX, C_ARSPD_MIN, C_ARSPD_MAX, C_TOUT_ARSPD_MAX, C_EOUT_DEM_RATE,
 C_EOUT_SPD_TAU, C_EOUT_SPD_KP, C_SQUARE,
 C_EOUT_ON, C_EOUT_TRIM, C_EOUT_BANK, C_EOUT_FULL,
 C_SO, C_SO_COUNTER, C_SO_ROLL_GAIN,
 C_TOUT, C_TOUT_LEVEL, C_TOUT_V_FLY, C_TOUT_V_GLIDE) = range(34)
SO_AILERON, SO_RUDDER = 1.0, 2.0            # c[C_SO]: which surface is out (0: none)
# the gains (5 x 6), the state (10), the parameters (34) and the step's optional
# demands (6) in one array, the kernel's first argument: numba's dispatch costs about
# 0.1 us an array argument, more than the loops' arithmetic with each
_X0, _C0, _O0, _BUF_N = 30, 40, 74, 80
# the step's optional demands (NaN: none), the kernel's ``ovr``
O_PITCH_MIN, O_THROTTLE, O_CLIMB, O_PITCH_MAX, O_CLIMB_KP, O_RUDDER = range(6)
_NO_LIMITS = (None, None)                   # ``reaction_limits`` without a reaction


@kernel
def _roll_limit(roll_lim, eout_bank_rad, counter_rad):
    """The bank limit in force (``FixedWingController.roll_limit_rad``): ROLL_LIMIT_DEG
    ``roll_lim``, the elevator out's steepest level turn ``eout_bank_rad`` and the
    stuck aileron's or rudder's counter deflection ``counter_rad`` (NaN: none)."""
    if not math.isnan(eout_bank_rad):
        roll_lim = min2(roll_lim, max2(eout_bank_rad, _EOUT_BANK_MIN_RAD))
    if not math.isnan(counter_rad):
        share = 1.0 - abs(counter_rad) / LAT_DEFLECTION_RAD
        roll_lim = min2(roll_lim, max2(roll_lim * share, _EOUT_BANK_MIN_RAD))
    return roll_lim


@kernel
def _loops(buf, roll, pitch, omega, v_ned, alt_m, airspeed_mps, dt,
           bank_cmd_rad, alt_cmd_m, airspeed_cmd_mps, spd_weight):
    """One step of every loop (module docstring; ``FixedWingController.update``): the
    controls (aileron, elevator, rudder, throttle), the state ``x`` advanced in place.
    ``buf``: the gains, the state, the parameters and the step's optional demands
    (``_X0``, ``_C0``, ``_O0``). The squares
    are the C library's pow (``c[C_SQUARE]`` = 2.0, which LLVM cannot fold into x * x:
    that differs from Python's ** 2 in the last bit of 0.1 % of values)."""
    gains, x, c, ovr = buf[:_X0].reshape((5, 6)), buf[_X0:_C0], buf[_C0:_O0], buf[_O0:]
    two = c[C_SQUARE]
    v_air = max2(airspeed_mps, 5.0)
    eout_on = c[C_EOUT_ON] > 0.0
    roll_lim = _roll_limit(c[C_ROLL_LIM], c[C_EOUT_BANK] if eout_on else math.nan,
                           c[C_SO_COUNTER])
    phi_c = clamp(bank_cmd_rad, -roll_lim, roll_lim)
    throttle_override, climb_override = ovr[O_THROTTLE], ovr[O_CLIMB]
    thr_over = not math.isnan(throttle_override)
    climb_over = not math.isnan(climb_override)

    # altitude to climb rate (outer), climb rate to pitch (middle)
    hdot = -v_ned[2]
    if math.isnan(x[ALT_DEM]) or thr_over:
        x[ALT_DEM] = alt_m   # (takeoff: the demand starts from where we are)
    sink_max, clmb_max = c[C_SINK_MAX], c[C_CLMB_MAX]
    up, down = c[C_DEM_UP], c[C_DEM_DOWN]
    if eout_on:
        up, down = min2(up, c[C_EOUT_DEM_RATE]), min2(down, c[C_EOUT_DEM_RATE])
    hdot_dem = clamp((alt_cmd_m - x[ALT_DEM]) / dt, -down, up) if dt > 0 else 0.0
    x[ALT_DEM] += hdot_dem * dt
    if thr_over:
        hdot_dem, alt_err = 0.0, alt_cmd_m - alt_m
    else:
        alt_err = x[ALT_DEM] - alt_m
    hdot_c = clamp(hdot_dem + c[C_ALT_KP] * alt_err, -sink_max, clmb_max)
    if climb_over:
        x[ALT_DEM] = alt_m
        hdot_c = clamp(climb_override, -sink_max, clmb_max)
    dv = airspeed_cmd_mps - v_air
    db = c[C_SPD_PRIO_DB]
    eout = eout_on and not thr_over
    if eout:
        # elevator out: the airspeed is the stuck trim's, not a demand; only its limits
        # (should the surface work again) trade height for speed
        dv = max2(c[C_ARSPD_MIN] - v_air, min2(0.0, c[C_ARSPD_MAX] - v_air))
    spd_prio = c[C_SPD_PRIO]
    if c[C_TOUT] > 0.0 and not climb_over:
        # throttle out: where the stuck throttle holds level flight the height demand
        # acts, the airspeed bounding it as TECS does; else (or TOUT_ARSPD_MAX 0) the
        # airspeed on the pitch alone, and where no level flight the height is given
        # up: the glide at the best lift-to-drag airspeed, not under ARSPD_FBW_MIN
        v_lo = c[C_ARSPD_MIN]
        if c[C_TOUT_LEVEL] > 0.0 and c[C_TOUT_ARSPD_MAX] > 0.0:
            # the stuck thrust holds level flight: the height held on the pitch (TECS's
            # height priority), the airspeed left to float to where that thrust meets
            # the drag (at full throttle the airframe's top speed, stuck low slower than
            # the cruise). The airspeed bounds the climb and the descent: the climb at
            # most SPD_PRIO times the airspeed over ARSPD_FBW_MIN, the descent at most
            # SPD_PRIO times its margin under TOUT_ARSPD_MAX (a climb the stuck thrust
            # cannot give is flown just over ARSPD_FBW_MIN, not traded down to the
            # stall; out of the two the pitch gives height for airspeed)
            v_hi = max2(c[C_TOUT_ARSPD_MAX], v_lo)
            hdot_c = clamp(hdot_c, -spd_prio * (v_hi - v_air), spd_prio * (v_air - v_lo))
            hdot_c = clamp(hdot_c, -sink_max, 2.0 * clmb_max)
        elif c[C_TOUT_LEVEL] > 0.0:
            # the airspeed the model says the stuck thrust holds level, if slower
            # than the demand; the height is what the excess thrust gives, the climb
            # free up to twice CLMB_MAX (a throttle stuck at full climbs at 3 m/s at
            # the cruise airspeed; flying faster to climb less was tried: the pitch
            # loop could not hold the steeper climb a slowing down needs, and the
            # airspeed went 3 m/s over ARSPD_FBW_MAX)
            v_t = min2(airspeed_cmd_mps, c[C_TOUT_V_FLY])
            hdot_c = clamp(-spd_prio * (v_t - v_air), -sink_max, 2.0 * clmb_max)
        else:
            v_t = max2(c[C_TOUT_V_GLIDE], v_lo)
            hdot_c = clamp(-spd_prio * (v_t - v_air), -sink_max, clmb_max)
    elif abs(dv) > db and not climb_over:
        hdot_c -= spd_weight * spd_prio * (dv - math.copysign(db, dv))
        hdot_c = clamp(hdot_c, -sink_max, clmb_max)
    trim_arspd = c[C_TRIM_ARSPD]
    q_ratio = (trim_arspd / v_air) ** two
    scale = clamp(q_ratio, 0.5, 2.0)
    turn_ff = c[C_TURN_FF] * (1.0 / max2(math.cos(roll), 0.5) - 1.0)
    gamma_c = math.asin(clamp(hdot_c / v_air, -0.5, 0.5))
    # trim angle of attack at the *commanded* airspeed: using the measured one would
    # raise the nose further as the aircraft slows (positive feedback towards stall)
    alpha_ff = c[C_ALPHA_TRIM] * min2((trim_arspd / max2(airspeed_cmd_mps, 5.0)) ** two, 2.0)
    kp = ovr[O_CLIMB_KP]
    if math.isnan(kp):
        kp = gains[CLIMB, KP]
    # (rate 0.0: no derivative term)
    theta_c = pid_update(gains, x, CLIMB, kp, hdot_c, hdot, dt, 0.0, alpha_ff + gamma_c + turn_ff, 1.0)
    if not math.isnan(ovr[O_PITCH_MAX]):
        theta_c = min2(theta_c, ovr[O_PITCH_MAX])
    if not math.isnan(ovr[O_PITCH_MIN]):
        theta_c = max2(theta_c, ovr[O_PITCH_MIN])

    # airspeed from throttle (with the climb feed-forward)
    if thr_over:
        thr = throttle_override          # (the airspeed's integrator held)
    elif eout:
        # elevator out: throttle from the height error, plus the airspeed's deviation
        # below its own slow mean (the speed the stuck elevator trims to)
        if math.isnan(x[V_MEAN]):
            x[V_MEAN] = v_air
        x[V_MEAN] += (v_air - x[V_MEAN]) * min2(dt / c[C_EOUT_SPD_TAU], 1.0)
        if not math.isnan(c[C_EOUT_TRIM]):
            x[V_MEAN] = c[C_EOUT_TRIM]
        thr = pid_update(gains, x, EOUT, gains[EOUT, KP], x[ALT_DEM], alt_m, dt, 0.0,
                         c[C_THR_TRIM] + c[C_EOUT_SPD_KP] * (x[V_MEAN] - v_air), 1.0)
        if c[C_EOUT_FULL] > 0.0 and alt_m < x[ALT_DEM]:
            thr = c[C_THR_MAX]     # no level trim: the least height loss
    else:
        thr = pid_update(gains, x, SPEED, gains[SPEED, KP], airspeed_cmd_mps, v_air, dt, 0.0,
                         c[C_THR_TRIM] + c[C_THR_CLMB_FF] * hdot_c, 1.0)

    # inner loops
    da = pid_update(gains, x, ROLL, gains[ROLL, KP], phi_c, roll, dt, omega[0], 0.0, scale)
    rudder_override = ovr[O_RUDDER]
    if not math.isnan(rudder_override):
        x[ROLL] = 0.0
    de_ff = c[C_ELEV_TRIM] * min2(q_ratio, 2.0)
    de = pid_update(gains, x, PITCH, gains[PITCH, KP], theta_c, pitch, dt, omega[1], de_ff, scale)
    r_c = G * math.tan(roll) * math.cos(pitch) / v_air
    dr = clamp(c[C_YAW_KD] * (r_c - omega[2]), -1.0, 1.0)
    if not math.isnan(rudder_override):
        dr = rudder_override
    so = c[C_SO]
    if so > 0.0:
        # aileron or rudder out: the other surface at the deflection that holds the
        # wings level against it (the airframe's model), the roll loop on top of it;
        # a stuck aileron's roll loop acts through the rudder, scaled by the ratio of
        # their rolling moments (the Aerosonde's rudder rolls more than it yaws)
        ff = c[C_SO_COUNTER] / LAT_DEFLECTION_RAD
        if so == SO_AILERON:
            dr = clamp(ff + c[C_SO_ROLL_GAIN] * da, -1.0, 1.0)
        else:
            da = clamp(da + ff, -1.0, 1.0)

    x[ROLL_CMD], x[PITCH_CMD], x[CLIMB_CMD] = phi_c, theta_c, hdot_c
    return da, de, dr, thr


class FixedWingController:
    """Attitude, altitude and airspeed loops; ``update`` returns the 4 normalised
    controls (aileron, elevator, rudder, throttle)."""

    def __init__(self, params):
        self.params = params
        self.configure()
        # (the kernels flown, loaded now: autopilot.jit.preload; _roll_limit is called from
        # Python once a reaction limits the bank)
        preload(_loops, self._buf.copy(), 0.0, 0.0, np.zeros(3),
                np.zeros(3), 100.0, 25.0, 0.01, 0.0, 100.0, 25.0, 1.0)
        preload(_roll_limit, 0.5, math.nan, 0.1)

    def configure_gains(self) -> None:
        """Re-read the gains and the parameters the loops read every step, after a
        parameter change (integrators kept)."""
        p = self.params
        g = self._gains
        for j, kp, ki, kd in ((ROLL, "RLL_KP", "RLL_KI", "RLL_KD"),
                              (PITCH, "PTCH_KP", "PTCH_KI", "PTCH_KD"),
                              (CLIMB, "CLMB_KP", "CLMB_KI", None),
                              (SPEED, "SPD_KP", "SPD_KI", None),
                              (EOUT, "EOUT_THR_KP", "EOUT_THR_KI", None)):
            g[j, KP], g[j, KI] = p[kp], p[ki]
            g[j, KD] = p[kd] if kd is not None else 0.0
        # (out_min, out_max, i_max)
        g[ROLL, OUT_MIN:] = g[PITCH, OUT_MIN:] = (-1.0, 1.0, 0.3)
        g[PITCH, I_MAX] = 0.4
        g[CLIMB, OUT_MIN:] = (math.radians(p["PTCH_LIM_MIN_DEG"]), math.radians(p["PTCH_LIM_MAX_DEG"]),
                              math.radians(5.0))
        g[SPEED, OUT_MIN:] = (0.0, p["THR_MAX"], 0.4)
        g[EOUT, OUT_MIN:] = (0.0, p["THR_MAX"], 0.5)
        c = self._c
        c[C_SINK_MAX], c[C_CLMB_MAX] = p["SINK_MAX"], p["CLMB_MAX"]
        c[C_DEM_UP], c[C_DEM_DOWN] = p["DEM_CLMB_FRAC"] * p["CLMB_MAX"], p["DEM_CLMB_FRAC"] * p["SINK_MAX"]
        c[C_ALT_KP], c[C_SPD_PRIO], c[C_SPD_PRIO_DB] = p["ALT_KP"], p["SPD_PRIO"], p["SPD_PRIO_DB"]
        c[C_TRIM_ARSPD], c[C_TURN_FF] = p["TRIM_ARSPD"], p["PTCH_TURN_FF"]
        c[C_ALPHA_TRIM] = math.radians(p["PTCH_TRIM_DEG"])
        c[C_THR_TRIM], c[C_THR_CLMB_FF] = p["THR_TRIM"], p["THR_CLMB_FF"]
        c[C_ELEV_TRIM], c[C_YAW_KD] = p["ELEV_TRIM"], p["YAW_KD"]
        self._roll_lim_rad = c[C_ROLL_LIM] = math.radians(p["ROLL_LIMIT_DEG"])
        c[C_THR_MAX], c[C_ARSPD_MIN], c[C_ARSPD_MAX] = p["THR_MAX"], p["ARSPD_FBW_MIN"], p["ARSPD_FBW_MAX"]
        c[C_TOUT_ARSPD_MAX], c[C_EOUT_DEM_RATE] = p["TOUT_ARSPD_MAX"], p["EOUT_DEM_RATE"]
        c[C_EOUT_SPD_TAU], c[C_EOUT_SPD_KP] = p["EOUT_SPD_TAU"], p["EOUT_SPD_KP"]
        c[C_SQUARE] = 2.0                      # (the squares' exponent: _loops)

    def configure(self) -> None:
        self._buf = np.zeros(_BUF_N)            # (the kernel's one array: _loops)
        self._gains = self._buf[:_X0].reshape(5, 6)
        self._x = self._buf[_X0:_C0]            # the loops' state (ROLL .. V_MEAN)
        self._x[ALT_DEM] = self._x[V_MEAN] = math.nan
        self._cmd = self._x[ALT_DEM:V_MEAN]     # (commands(): the view made once)
        self._c = self._buf[_C0:_O0]
        self._ovr = self._buf[_O0:]             # the step's optional demands (NaN: none) ...
        self._ovr[:] = math.nan
        self._overriding = False                # ... and whether any is set
        self.elevator_out = False
        self.eout_trim_mps: float | None = None  # the stuck elevator's trim airspeed (model)
        self.eout_bank_max_rad: float | None = None  # its steepest level turn (model)
        self.eout_full_throttle = False          # the model has no level trim for it
        self.surface_out: dict | None = None     # a stuck aileron or rudder (monitor's surface_out)
        self.throttle_out: dict | None = None    # a stuck throttle (monitor's throttle_out)
        self.configure_gains()
        self._load_reactions()

    def commands(self) -> list[float]:
        """[altitude demand (NaN before the first step), roll, pitch, climb-rate
        command] of the last step, for the log."""
        return self._cmd.tolist()

    def _load_reactions(self) -> None:
        """The fault reactions in force into the kernel's parameters (NaN or 0: none);
        ``update`` calls it every step while ``surface_out`` or ``throttle_out`` is set,
        and once more when neither is (the monitor refines a reaction's dict in place:
        a stuck surface's position as its reading settles)."""
        c, nan = self._c, math.nan
        c[C_EOUT_ON] = 1.0 if self.elevator_out else 0.0
        c[C_EOUT_TRIM] = nan if self.eout_trim_mps is None else self.eout_trim_mps
        c[C_EOUT_BANK] = nan if self.eout_bank_max_rad is None else self.eout_bank_max_rad
        c[C_EOUT_FULL] = 1.0 if self.eout_full_throttle else 0.0
        so = self.surface_out
        c[C_SO] = 0.0 if so is None else SO_AILERON if so["surface"] == "aileron" else SO_RUDDER
        c[C_SO_COUNTER] = nan if so is None else so["counter_rad"]
        c[C_SO_ROLL_GAIN] = nan if so is None else so.get("roll_gain", nan)
        tout = self.throttle_out
        c[C_TOUT] = 0.0 if tout is None else 1.0
        c[C_TOUT_LEVEL] = 1.0 if tout is not None and tout["level"] else 0.0
        c[C_TOUT_V_FLY] = nan if tout is None else tout.get("v_fly", nan)
        c[C_TOUT_V_GLIDE] = nan if tout is None else tout.get("v_glide", nan)
        self._reacting = so is not None or tout is not None

    def set_elevator_out(self, out: bool) -> None:
        """Elevator out (stuck): the height on the throttle (module docstring)."""
        if out and not self.elevator_out:
            self._x[EOUT] = 0.0
            self._x[V_MEAN] = math.nan
        if not out:
            self.eout_trim_mps = self.eout_bank_max_rad = None
            self.eout_full_throttle = False
        self.elevator_out = out
        self._load_reactions()

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
        self._load_reactions()

    def roll_limit_rad(self) -> float:
        """The bank limit in force [rad]: ROLL_LIMIT_DEG, or less under a fault's
        reaction: the elevator out, the steepest level turn of its trim (not under
        EOUT_BANK_MIN_DEG); an aileron or rudder out, the share of the other surface's
        travel left after countering it (monitor.py, _lateral_reaction), not under
        EOUT_BANK_MIN_DEG either. With an aileron or rudder out the mission's turns are
        planned at it (guidance/mission.py, ``reaction_limits``)."""
        eout_bank = self.eout_bank_max_rad if self.elevator_out else None
        so = self.surface_out
        return _roll_limit(self._roll_lim_rad, math.nan if eout_bank is None else eout_bank,
                           math.nan if so is None else so["counter_rad"])

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

    def reaction_limits(self) -> tuple[float | None, float | None]:
        """(``reaction_bank_limit_rad()``, ``reaction_airspeed_mps()``): what the mission
        asks when it plans a turn (the vehicle hands it this method: guidance/mission.py,
        ``reaction_limits``); (None, None) without a reaction."""
        if self.surface_out is None and self.throttle_out is None:
            return _NO_LIMITS
        return self.reaction_bank_limit_rad(), self.reaction_airspeed_mps()

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
        x = self._x
        x[ROLL] = x[PITCH] = x[CLIMB] = x[SPEED] = 0.0
        x[ALT_DEM] = math.nan

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
        the lift-off). The loops are the kernel ``_loops``; the vehicle passes every
        argument by position (keywords cost the call a name lookup each)."""
        roll, pitch, _ = euler if euler is not None else quat_to_euler(nav.q_nb.tolist())
        if self.surface_out is not None or self.throttle_out is not None or self._reacting:
            self._load_reactions()
        if pitch_min_rad is not None or throttle_override is not None or climb_override is not None \
                or pitch_max_rad is not None or climb_kp is not None or rudder_override is not None:
            self._ovr[:] = [math.nan if v is None else v for v in (
                pitch_min_rad, throttle_override, climb_override, pitch_max_rad, climb_kp, rudder_override)]
            self._overriding = True
        elif self._overriding:
            self._ovr[:] = math.nan             # (cleared once, on the step that has none)
            self._overriding = False
        return _loops(self._buf, roll, pitch, nav.omega_b, nav.v_ned,
                      nav.alt_m, nav.airspeed_mps, dt, bank_cmd_rad, alt_cmd_m, airspeed_cmd_mps, spd_weight)
