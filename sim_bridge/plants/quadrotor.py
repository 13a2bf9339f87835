"""Quadrotor plant: the seed's nonlinear rigid-body model (ch. 9 sec. 3.6.2.1).

Eqs 3.23-3.26 (rebuilt from the seed's references, Hoffmann, Huang, Waslander & Tomlin,
AIAA GNC 2007, and Bayezit & Fidan, IEEE TIE 60(12) 2013)::

    F = m p''                                                    (3.23)
    M = I omega' + omega x I omega                               (3.24)
    F = -D(V_a) e_V + m g e_D + sum_j (-T_j R e_z)               (3.25)
    M = sum_j (M_j + r_j x (-T_j e_z))                           (3.26)

with the drag along the air-relative velocity, ``D(V_a) = c_lin V_a + 1/2 rho CdA V_a^2``,
each rotor's thrust following its static value through a first-order lag (eq 3.31,
discretised exactly), and the attitude quaternion propagated by
``q <- q (x) Exp(omega dt)`` and renormalised (eqs 1.13-1.14, the convention of
``autopilot.geo.rotations``). The airframe is the F450 class from JSBSim's F450 data,
flown "+" (the seed's mixer, eq 3.30)::

    channel 0  rotor 1  aft    (x = -l)   spins counter-clockwise seen from above
    channel 1  rotor 2  left   (y = -l)   clockwise
    channel 2  rotor 3  front  (x = +l)   counter-clockwise
    channel 3  rotor 4  right  (y = +l)   clockwise

    M = (l (T2 - T4), l (T3 - T1), k_M (T1 + T3 - T2 - T4)).

Ground contact: flat terrain at home altitude, or the terrain model's height under the
vehicle (``terrain``); the vehicle rests on its skids, a
touchdown stops it within the step (no sinking, no bouncing) and the IMU sees the
impulse; too fast or too tilted sets ``crashed``.

The airframe's numbers and how each is derived (static thrust, k_M, tau), the drag, and
the ground contact: docs/simulator.md, "The quadrotor plant".
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba.extending import register_jitable as jitable

from autopilot.geo import LocalFrame, gravity_m_s2
from autopilot.geo.rotations import PI, TWO_PI, quat_dcm, quat_step
from autopilot.jit import kernel
from sim_bridge.plants.base import PlantState
from sim_bridge.sensors import isa
from sim_bridge.wind import GUST_STATE_N, DrydenGusts, gust_advance

CRASH_SPEED_MPS = 3.0     # touchdown faster than this counts as a crash [m/s]
CRASH_TILT_RAD = math.radians(35.0)
LEVEL_RATE = 8.0          # a tilted vehicle on its skids levels at this rate [1/s]


@dataclass(frozen=True, slots=True)
class QuadAirframe:
    """Data of a quadrotor (SI). Defaults: the F450 of JSBSim (module docstring)."""

    name: str = "f450"
    mass_kg: float = 1.4
    ixx: float = 0.019                 # [kg m^2]
    iyy: float = 0.019
    izz: float = 0.0252
    arm_m: float = 0.1651 * math.sqrt(2.0)   # rotor distance from the CG [m]
    prop_diameter_m: float = 9.4 * 0.0254
    c_t: float = 0.1288                # static thrust coefficient C_T
    c_p: float = 0.0666                # static power coefficient C_P
    rotor_inertia: float = 6.05e-5     # propeller + rotor [kg m^2]
    motor_kv: float = 960.0            # [rpm/V]
    motor_r_ohm: float = 0.117
    motor_i0_a: float = 0.45           # no-load current [A]
    motor_v_max: float = 14.63         # voltage at full command [V]
    drag_lin: float = 0.25             # c_lin [N s/m]
    drag_area_m2: float = 0.016129     # CdA [m^2]
    gear_height_m: float = 0.1524      # CG above the skids' contact plane [m]

    # --- derived -----------------------------------------------------------------
    @property
    def kv_rad(self) -> float:
        """Speed constant [rad/s per V]; the torque constant is its inverse [N m/A]."""
        return self.motor_kv * 2.0 * math.pi / 60.0

    def c_thrust(self, rho: float) -> float:
        """T = c_thrust omega^2 [N s^2]."""
        return self.c_t * rho * self.prop_diameter_m ** 4 / (4.0 * math.pi ** 2)

    def c_torque(self, rho: float) -> float:
        """Q = c_torque omega^2 [N m s^2]."""
        return self.c_p * rho * self.prop_diameter_m ** 5 / (8.0 * math.pi ** 3)

    @property
    def k_m(self) -> float:
        """Reaction moment per newton of thrust, C_P D / (2 pi C_T) [m]."""
        return self.c_p * self.prop_diameter_m / (2.0 * math.pi * self.c_t)

    def rotor_speed(self, u: float, rho: float) -> float:
        """Steady rotor speed [rad/s] at command u (0..1): motor torque = propeller torque,
        (1/Kv) ((u V_max - omega/Kv)/R - I0) = c_Q omega^2."""
        kt = 1.0 / self.kv_rad
        drive = kt * (u * self.motor_v_max / self.motor_r_ohm - self.motor_i0_a)
        if drive <= 0.0:
            return 0.0
        a = self.c_torque(rho)
        b = kt / (self.motor_r_ohm * self.kv_rad)
        return (-b + math.sqrt(b * b + 4.0 * a * drive)) / (2.0 * a)

    def static_thrust(self, u: float, rho: float = 1.225) -> float:
        """T_ss(u): thrust of one rotor at steady command u [N]."""
        w = self.rotor_speed(min(max(u, 0.0), 1.0), rho)
        return self.c_thrust(rho) * w * w

    def hover_command(self, rho: float = 1.225, g: float = 9.80665) -> float:
        """The command at which four rotors carry the weight (bisection on T_ss)."""
        target = self.mass_kg * g / 4.0
        lo, hi = 0.0, 1.0
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            if self.static_thrust(mid, rho) < target:
                lo = mid
            else:
                hi = mid
        return 0.5 * (lo + hi)

    def thrust_time_constant(self, rho: float = 1.225, g: float = 9.80665) -> float:
        """tau = J / (d(Q_prop - Q_motor)/d omega) at hover [s] (module docstring)."""
        w = math.sqrt(self.mass_kg * g / 4.0 / self.c_thrust(rho))
        damping = 1.0 / (self.motor_r_ohm * self.kv_rad ** 2) + 2.0 * self.c_torque(rho) * w
        return self.rotor_inertia / damping


F450 = QuadAirframe()
AIRFRAMES = {"f450": F450}



# The plant's state, one array (``QuadrotorPlant._x``) that flight_step updates in place:
# p (NED from home's ground point), v, q_nb, omega_b, the specific force f_b, the wind
# of the last state() (steady + gust, NED), the rotor thrusts T; then whether it rests
# on the ground (1.0, else 0.0), which plant_advance keeps.
_P, _V, _Q, _W, _F, _WIND, _T, _GROUNDED = 0, 3, 6, 10, 13, 16, 19, 23
_NX = 24
# the conditions in the constants (``QuadrotorPlant._consts``) that change on an event,
# after its 28 constants: the rotor thrust scales (rotor_scale), the ground's depth below
# home's ground point under the vehicle (NED down; a terrain model moves it every step)
_K, _GROUND_D = 28, 32
_NC = 33
# The plant's one array (``QuadrotorPlant._a``), which the kernels called every step take
# whole (each array argument costs a compiled call 0.6-1.1 k instructions): the state
# (``_x``), the constants (``_consts``) and the gusts' state and noise (``DrydenGusts.s``),
# each a view of its part, from these offsets
_C0, _S0 = _NX, _NX + _NC
_FLYING, _ON_GROUND, _TOUCHDOWN = 0, 1, 2      # flight_step's codes


class QuadrotorPlant:
    """The quadrotor behind the ``Plant`` protocol; controls are the four rotor
    commands 0..1 (module docstring for the order)."""

    def __init__(self, home: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0),
                 airframe: QuadAirframe | str = F450, dt_s: float = 0.004,
                 wind_ned=(0.0, 0.0, 0.0), turbulence: str = "none",
                 rng: np.random.Generator | None = None):
        if isinstance(airframe, str):
            if airframe not in AIRFRAMES:
                raise ValueError(f"unknown quadrotor airframe {airframe!r}; known: {sorted(AIRFRAMES)}")
            airframe = AIRFRAMES[airframe]
        self.af = af = airframe
        lat_deg, lon_deg, alt_m, heading_deg = (float(v) for v in home)
        self.home = (lat_deg, lon_deg, alt_m, heading_deg)
        self._frame = LocalFrame.from_degrees(lat_deg, lon_deg, alt_m)
        self._dt_us = int(round(dt_s * 1e6))
        if self._dt_us <= 0:
            raise ValueError("dt_s must be at least 1 us")
        self.dt_s = self._dt_us * 1e-6
        self._t_us = 0
        rng = rng if rng is not None else np.random.default_rng(0)
        # air at the home altitude (ISA); density sets the rotor thrust
        self.rho = isa.density_kgm3(alt_m)
        self.g = gravity_m_s2(math.radians(lat_deg), alt_m)
        self.tau_s = af.thrust_time_constant(self.rho, self.g)
        self._lag = 1.0 - math.exp(-self.dt_s / self.tau_s)
        self._ct = af.c_thrust(self.rho)
        self._km = af.k_m
        self._wind = tuple(float(w) for w in wind_ned)
        self._a = np.zeros(_S0 + GUST_STATE_N)
        self._x, self._consts = self._a[:_C0], self._a[_C0:_S0]
        self._gusts = DrydenGusts(rng, self.dt_s, turbulence, self._wind, self._a[_S0:])
        # T_ss(u) in closed form (QuadAirframe.rotor_speed): omega = (sqrt(b^2 + k1 u - k0) - b) / 2a
        a = af.c_torque(self.rho)
        kt = 1.0 / af.kv_rad
        b = kt / (af.motor_r_ohm * af.kv_rad)
        self._ts = (b * b, 4.0 * a * kt * af.motor_v_max / af.motor_r_ohm,
                    4.0 * a * kt * af.motor_i0_a, b, 0.5 / a, self._ct)
        self.crashed = False
        self.touchdown_speed_mps: float | None = None
        # flight_step's constants: the step's, then static_thrust's; then (from 19)
        # plant_step's and state_readout's: the steady wind NED, the local frame at home
        # (lat0, lon0, alt0 and LocalFrame.to_geodetic_fast's bend and radii); then the
        # conditions (_K, _GROUND_D), set where they change
        f = self._frame
        self._consts[:] = ((self.dt_s, self._lag, af.mass_kg, self.g, af.drag_lin, self.rho,
                            af.drag_area_m2, af.arm_m, self._km, af.ixx, af.iyy, af.izz,
                            af.gear_height_m) + self._ts + self._wind
                           + (f.lat0_rad, f.lon0_rad, f.alt0_m, f._bend, f._rm, f._rn0)
                           + (1.0, 1.0, 1.0, 1.0, 0.0))
        self._rotor_scale = (1.0, 1.0, 1.0, 1.0)
        # the ground: flat at home, or a terrain model, a callable (lat_deg, lon_deg) ->
        # height [m MSL] or None (autopilot.geo.terrain), its depth under the vehicle
        # (_GROUND_D) updated every step()
        self.terrain = None
        self.reset()

    # ------------------------------------------------------------------- state ---
    # p, v, q, w, thrust: the state array's parts as float lists (and settable)
    p = property(lambda self: self._x[_P:_V].tolist(),
                 lambda self, val: self._x.__setitem__(slice(_P, _V), val))
    v = property(lambda self: self._x[_V:_Q].tolist(),
                 lambda self, val: self._x.__setitem__(slice(_V, _Q), val))
    q = property(lambda self: self._x[_Q:_W].tolist(),
                 lambda self, val: self._x.__setitem__(slice(_Q, _W), val))
    w = property(lambda self: self._x[_W:_F].tolist(),
                 lambda self, val: self._x.__setitem__(slice(_W, _F), val))
    thrust = property(lambda self: self._x[_T:_GROUNDED].tolist(),
                      lambda self, val: self._x.__setitem__(slice(_T, _GROUNDED), val))

    @property
    def on_ground(self) -> bool:
        """Resting on the ground (on its skids)."""
        return bool(self._x[_GROUNDED])

    @on_ground.setter
    def on_ground(self, value: bool) -> None:
        self._x[_GROUNDED] = 1.0 if value else 0.0

    @property
    def rotor_scale(self) -> tuple[float, ...]:
        """Thrust of each rotor as a share of its model's (motor faults: thrust reduced)."""
        return self._rotor_scale

    @rotor_scale.setter
    def rotor_scale(self, scales) -> None:
        self._rotor_scale = tuple(float(k) for k in scales)
        self._consts[_K:_GROUND_D] = self._rotor_scale

    def reset(self) -> None:
        """At rest on the ground at home, heading as home's, motors stopped."""
        psi = math.radians(self.home[3])
        x = self._x
        x[:] = 0.0
        x[_P + 2] = -self.af.gear_height_m         # NED from home's ground point
        x[_Q:_W] = (math.cos(0.5 * psi), 0.0, 0.0, math.sin(0.5 * psi))
        x[_F + 2] = -self.g
        self.on_ground = True
        self.crashed = False
        self._gusts.reset()

    @property
    def t_us(self) -> int:
        return self._t_us

    def set_airborne(self, height_m: float, yaw_rad: float = 0.0) -> None:
        """Put the vehicle in hover ``height_m`` above home (tests): level, still, each
        rotor at the hover thrust, its command held at the hover command."""
        airborne(self._x, height_m, yaw_rad, self.g, self.af.mass_kg * self.g / 4.0)

    def hold_airborne(self, height_m: float) -> PlantState:
        """``set_airborne(height_m)`` and the state it leaves, in one compiled call: where
        a formation holds its members every step until they are armed."""
        return PlantState.make(*airborne_readout(self._a, self._t_us, height_m, self.g,
                                                 self.af.mass_kg * self.g / 4.0))

    def state(self) -> PlantState:
        return PlantState.make(*state_readout(self._x, self._consts, self._gusts.s, self._t_us,
                                              self.on_ground))

    # ---------------------------------------------------------------- stepping ---
    def static_thrusts(self, controls) -> list[float]:
        """T_ss of each rotor for a command vector (:func:`static_thrust`)."""
        return [static_thrust(u, *self._ts) for u in controls[:4]]

    def step(self, controls, n_steps: int = 1) -> PlantState:
        """Hold the rotor commands for ``n_steps`` (at least 1) integration steps
        (:func:`plant_advance`, the last :func:`plant_step` with its readout; the ground,
        resting and touching down, in :meth:`_grounded`)."""
        u1, u2, u3, u4 = controls[:4]
        x, c = self._x, self._consts
        if self.terrain is not None:
            lat, lon, _ = self._frame.to_geodetic_fast(x[_P:_V].tolist())
            h = self.terrain(math.degrees(lat), math.degrees(lon))
            c[_GROUND_D] = 0.0 if h is None else self.home[2] - h
        gusts = self._gusts
        for _ in range(n_steps - 1):              # (only the last step's state is handed on)
            row = gusts.next_row() if gusts.active else -1    # (before the noise: it may draw)
            self._t_us += self._dt_us
            code = plant_advance(x, c, gusts.s, row, u1, u2, u3, u4)
            if code != _FLYING:
                self._grounded(code)
        row = gusts.next_row() if gusts.active else -1
        self._t_us += self._dt_us
        code, readout = plant_step(self._a, row, u1, u2, u3, u4, self._t_us)
        if code != _FLYING:                       # (the ground moved the state after its readout)
            self._grounded(code)
            readout = state_readout(x, c, gusts.s, self._t_us, True)
        return PlantState.make(*readout)

    def _grounded(self, code: int) -> None:
        """A step that ended on the ground (plant_advance's code): resting or touching down."""
        if code == _ON_GROUND:
            self._rest(self.dt_s)
        else:
            self._touchdown(self._x[_V + 2])

    def _touchdown(self, v_down: float) -> None:
        """The skids reach the ground: the vehicle stops within the step (no sinking, no
        bounce). The accelerometer sees the impulse (a one-step spike that integrates to
        the lost velocity); the attitude then levels through body rates the gyro sees."""
        x = self._x
        v_down = float(v_down)
        qw, qx, qy, qz = x[_Q:_W].tolist()
        tilt = math.acos(max(-1.0, min(1.0, 1.0 - 2.0 * (qx * qx + qy * qy))))
        self.touchdown_speed_mps = v_down
        if v_down > CRASH_SPEED_MPS or tilt > CRASH_TILT_RAD:
            self.crashed = True
        dt = self.dt_s
        vn, ve, vd = x[_V:_Q].tolist()
        # specific force over the step: (dv/dt - g_vec), dv = -v
        fn, fe, fd = -vn / dt, -ve / dt, -vd / dt - self.g
        r = quat_dcm(qw, qx, qy, qz)
        x[_F:_WIND] = (r[0] * fn + r[3] * fe + r[6] * fd,
                       r[1] * fn + r[4] * fe + r[7] * fd,
                       r[2] * fn + r[5] * fe + r[8] * fd)
        x[_P + 2] = self._consts[_GROUND_D] - self.af.gear_height_m
        x[_V:_Q] = 0.0
        x[_W:_F] = 0.0

    @staticmethod
    def _level(r) -> float:
        """Tilt of the body z axis from the vertical, as 1 - cos(tilt)."""
        return 1.0 - r[8]

    def _rest(self, dt: float) -> None:
        """On the skids: still on the ground plane; a tilted vehicle levels at
        ``LEVEL_RATE`` through body rates (seen by the gyro); the accelerometer reads
        the reaction of the ground, R^T (0, 0, -g)."""
        x = self._x
        qw, qx, qy, qz = x[_Q:_W].tolist()
        r = quat_dcm(qw, qx, qy, qz)
        roll = math.atan2(r[7], r[8])
        pitch = -math.asin(max(-1.0, min(1.0, r[6])))
        if abs(roll) + abs(pitch) > 1e-6:
            p, q = -LEVEL_RATE * roll, -LEVEL_RATE * pitch
            x[_W:_F] = (p, q, 0.0)
            qn = quat_step(qw, qx, qy, qz, p * dt, q * dt, 0.0)
            x[_Q:_W] = qn
            r = quat_dcm(*qn)
        else:
            x[_W:_F] = 0.0
        x[_P + 2] = self._consts[_GROUND_D] - self.af.gear_height_m
        x[_V:_Q] = 0.0
        g = self.g
        x[_F:_WIND] = (-r[6] * g, -r[7] * g, -r[8] * g)


@kernel
def static_thrust(u, b2, k1, k0, b, inv2a, ct):
    """T_ss(u), one rotor's static thrust at command u (clipped to 0..1), in the closed
    form of QuadAirframe.rotor_speed: omega = (sqrt(b^2 + k1 u - k0) - b) / 2a,
    T_ss = c_T omega^2 (the constants: QuadrotorPlant._ts)."""
    u = 0.0 if u < 0.0 else (1.0 if u > 1.0 else u)
    d = k1 * u - k0
    w = (math.sqrt(b2 + d) - b) * inv2a if d > 0.0 else 0.0
    return ct * w * w


@kernel
def air_data(x, wn, we, wd):
    """(airspeed, alpha, beta) of the plant's state array ``x`` in the wind (wn, we, wd)
    (steady + gust, NED), which is stored in x as the state's wind. Alpha and beta
    from the air velocity in body axes, R^T (v - w); zero below 1e-6 m/s."""
    x[16], x[17], x[18] = wn, we, wd
    ax, ay, az = x[3] - wn, x[4] - we, x[5] - wd
    airspeed = math.sqrt(ax * ax + ay * ay + az * az)
    alpha = beta = 0.0
    if airspeed > 1e-6:
        r = quat_dcm(x[6], x[7], x[8], x[9])
        ub = r[0] * ax + r[3] * ay + r[6] * az
        vb = r[1] * ax + r[4] * ay + r[7] * az
        wb = r[2] * ax + r[5] * ay + r[8] * az
        alpha = math.atan2(wb, ub)
        s = vb / airspeed
        s = s if s < 1.0 else 1.0
        beta = math.asin(s if s > -1.0 else -1.0)
    return airspeed, alpha, beta


@kernel
def plant_advance(x, c, gust, row, u1, u2, u3, u4):
    """One step of the plant on its state array ``x`` and constants ``c`` (with the
    conditions: the rotor thrust scales, the ground's depth): the Dryden gust (``gust``,
    ``sim_bridge.wind.gust_advance``, driven by row ``row`` of its noise; no gust when
    ``row`` is negative) at the height above the ground and the speed through the steady
    wind, then :func:`flight_step` in the steady wind + gust, from the ground if the
    state rests on it; the state's ground flag follows the step. Returns flight_step's
    code."""
    wn, we, wd = c[19], c[20], c[21]
    ground_d = c[_GROUND_D]
    if row >= 0:
        an0, ae0, ad0 = x[3] - wn, x[4] - we, x[5] - wd
        gn, ge, gd = gust_advance(gust, row, ground_d - x[2],
                                  math.sqrt(an0 * an0 + ae0 * ae0 + ad0 * ad0), 1)
        wn, we, wd = wn + gn, we + ge, wd + gd
    code = flight_step(x, c, u1, u2, u3, u4, c[_K], c[_K + 1], c[_K + 2], c[_K + 3], wn, we, wd,
                       x[_GROUNDED] != 0.0, ground_d)
    x[_GROUNDED] = 0.0 if code == _FLYING else 1.0      # (resting, or touched down)
    return code


@kernel
def plant_step(a, row, u1, u2, u3, u4, t_us):
    """:func:`plant_advance` on the plant's one array ``a``, then the state's readout at
    ``t_us``, the step's end (:func:`state_readout`, flying; out of date unless the
    vehicle flew: the ground then moves it, in Python): the last step of a HIL period.
    Returns the code and the readout."""
    x, c, gust = a[:_C0], a[_C0:_S0], a[_S0:]
    code = plant_advance(x, c, gust, row, u1, u2, u3, u4)
    return code, state_readout(x, c, gust, t_us, False)


@jitable
def airborne(x, height_m, yaw_rad, g, hover_thrust):
    """``x`` in hover ``height_m`` above home at heading ``yaw_rad``: level, still, the
    specific force -g, each rotor's thrust ``hover_thrust``, not on the ground.
    (Element stores where Python calls it: numpy converts a sequence of floats slowly.)"""
    x[_P:_WIND] = 0.0                                   # p, v, q, omega, f_b
    x[_P + 2] = -height_m
    x[_Q] = math.cos(0.5 * yaw_rad)
    x[_Q + 3] = math.sin(0.5 * yaw_rad)
    x[_F + 2] = -g
    x[_T:_GROUNDED] = hover_thrust
    x[_GROUNDED] = 0.0


@kernel
def airborne_readout(a, t_us, height_m, g, hover_thrust):
    """:func:`airborne` at heading north on the plant's one array ``a``, then
    :func:`state_readout` (airborne)."""
    x = a[:_C0]
    airborne(x, height_m, 0.0, g, hover_thrust)
    return state_readout(x, a[_C0:_S0], a[_S0:], t_us, False)


@kernel
def state_readout(x, c, gust, t_us, on_ground):
    """PlantState's fields, in order, at time ``t_us`` of the state array ``x``: the
    geodetic position of p (``LocalFrame.to_geodetic_fast`` of the frame at home, the
    constants ``c[22:28]``), v, q, omega, f, the wind (the steady wind ``c[19:22]`` + the
    gust ``gust[3:6]``, stored in x), the air data in it (:func:`air_data`), whether the
    vehicle rests on the ground and the air density ``c[5]``."""
    airspeed, alpha, beta = air_data(x, c[19] + gust[3], c[20] + gust[4], c[21] + gust[5])
    lat0, lon0, alt0, bend, rm, rn0 = c[22], c[23], c[24], c[25], c[26], c[27]
    e = x[1]
    lat = lat0 + (x[0] - e * e * bend) / rm
    lon = (lon0 + e / (rn0 * math.cos(lat)) + PI) % TWO_PI - PI      # wrap_pi
    return (t_us, lat, lon, alt0 - x[2], (x[3], x[4], x[5]), (x[6], x[7], x[8], x[9]),
            (x[10], x[11], x[12]), (x[13], x[14], x[15]), (x[16], x[17], x[18]),
            airspeed, alpha, beta, on_ground, c[5])


@kernel
def flight_step(x, c, u1, u2, u3, u4, k1, k2, k3, k4, wn, we, wd, on_ground, ground_d):
    """One step dt of eqs 3.23-3.26 (module docstring) on the plant's state array ``x``
    (``_P`` ... ``_T``: p NED, v, q_nb, omega_b, f_b, wind, the rotor thrusts T),
    updated in place. The rotor commands u (T_ss(u) scaled by k, the motor faults'
    share of thrust), the wind (steady + gust, NED), whether the vehicle rests on the
    ground and the ground's depth below home (NED down); ``c``: dt, the thrust lag
    1 - exp(-dt/tau), m, g, c_lin, rho, CdA, l, k_M, Ixx, Iyy, Izz, the gear height,
    then :func:`static_thrust`'s constants. Returns 0 flew, 1 rests on the ground (only
    T written), 2 touched down."""
    dt, lag, m, g, drag_lin, rho, cda, l, km, ixx, iyy, izz, gear = (
        c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7], c[8], c[9], c[10], c[11], c[12])
    b2, tk1, tk0, b, inv2a, ct = c[13], c[14], c[15], c[16], c[17], c[18]
    # each rotor's thrust follows its static value (eq 3.31, discretised exactly)
    t1 = x[19] + (static_thrust(u1, b2, tk1, tk0, b, inv2a, ct) * k1 - x[19]) * lag
    t2 = x[20] + (static_thrust(u2, b2, tk1, tk0, b, inv2a, ct) * k2 - x[20]) * lag
    t3 = x[21] + (static_thrust(u3, b2, tk1, tk0, b, inv2a, ct) * k3 - x[21]) * lag
    t4 = x[22] + (static_thrust(u4, b2, tk1, tk0, b, inv2a, ct) * k4 - x[22]) * lag
    x[19], x[20], x[21], x[22] = t1, t2, t3, t4
    total = t1 + t2 + t3 + t4
    qw, qx, qy, qz = x[6], x[7], x[8], x[9]
    r00, r01, r02, r10, r11, r12, r20, r21, r22 = quat_dcm(qw, qx, qy, qz)   # R(q_nb)
    # air-relative velocity and the body drag (3.25): -D e_V, D / V_a = c_lin + 1/2 rho CdA V_a
    vn, ve, vd = x[3], x[4], x[5]
    an, ae, ad = vn - wn, ve - we, vd - wd
    va = math.sqrt(an * an + ae * ae + ad * ad)
    dk = drag_lin + 0.5 * rho * cda * va
    dn, de, dd = -dk * an, -dk * ae, -dk * ad
    # thrust -T e_z in NED: third column of R times -total (gravity added below)
    fn = -total * r02 + dn
    fe = -total * r12 + de
    fdn = -total * r22 + dd
    if on_ground:
        if not (fdn + m * g < 0.0 and 1.0 - r22 < 0.02):   # thrust exceeds weight: lift off
            return 1
    # rotational dynamics (3.24), (3.26): I omega' = M - omega x I omega
    mx = l * (t2 - t4)
    my = l * (t3 - t1)
    mz = km * (t1 + t3 - t2 - t4)
    p, q, rr = x[10], x[11], x[12]
    pd = (mx - (izz - iyy) * q * rr) / ixx
    qd = (my - (ixx - izz) * p * rr) / iyy
    rd = (mz - (iyy - ixx) * p * q) / izz
    p1, q1, r1 = p + pd * dt, q + qd * dt, rr + rd * dt
    x[10], x[11], x[12] = p1, q1, r1
    # attitude: q <- q (x) Exp(omega_mid dt), renormalised (1.13-1.14)
    x[6], x[7], x[8], x[9] = quat_step(qw, qx, qy, qz, 0.5 * (p + p1) * dt,
                                        0.5 * (q + q1) * dt, 0.5 * (rr + r1) * dt)
    # translational dynamics (3.23), (3.25)
    a_n, a_e, a_d = fn / m, fe / m, fdn / m + g
    u_n, u_e, u_d = vn + a_n * dt, ve + a_e * dt, vd + a_d * dt
    pdn1 = x[2] + 0.5 * (vd + u_d) * dt
    x[0], x[1], x[2] = x[0] + 0.5 * (vn + u_n) * dt, x[1] + 0.5 * (ve + u_e) * dt, pdn1
    x[3], x[4], x[5] = u_n, u_e, u_d
    # specific force (accelerometer truth): non-gravitational force / m, body axes
    x[13] = (r00 * dn + r10 * de + r20 * dd) / m
    x[14] = (r01 * dn + r11 * de + r21 * dd) / m
    x[15] = (r02 * dn + r12 * de + r22 * dd - total) / m
    return 2 if pdn1 > ground_d - gear else 0
