"""Throttle fault detection and identification for the fixed wing: the thrust balance
(course text ch. 8 sec. 2.2.3, eqs 2.18-2.24, the same two stages as :mod:`.actuator`
and :mod:`.lateral`).

Stage 1: the thrust the aircraft flies with, from the accelerometer's body-x specific
force and the aerodynamic force of the airframe's model (Beard & McLain 2012, eqs 4.18-
4.19: body-x force = T + qbar S (C_L sin(alpha) - C_D cos(alpha)); C_L from the measured
normal specific force, ``C_L ~ -m f_z / (qbar S)``, alpha from that lift and the
commanded elevator through the lift curve (the wind estimate, still settling in the
climb-out, gave alpha errors of a few hundredths of a radian: 0.3 of full throttle); C_D the quadratic polar
``C_D0 + k (C_L0 + C_La alpha)^2``, eq 4.11), then the throttle that thrust means by the
airframe's thrust curve ``T = throttle (a + b V) + c + d V`` (:class:`ThrustModel`).
z - throttle_cmd is the residual, tested as the surfaces' (window chi-square, its offset
learnt online on ``[1, V / V_ref - 1]``, its variance learnt FIT_DELAY_S late).

The thrust curve is the shipped aircraft's (its JSBSim electric motor, 1000 W, and the
APC 18x8 propeller table), measured as a thrust stand in a wind tunnel would: the plant
trimmed in level flight at 18, 21, ... 33 m/s, the throttle set to 0, 0.1, ... 1 and
held 1.5 s, the engine's thrust read; the curve's least-squares fit to those 66 points
is within 0.26 N rms (at cruise a tenth of the throttle is 2.8 N of the aircraft's
11 N of drag). The thrust follows the command with the motor's and propeller's lag,
first order, ``tau_s`` = 0.5 s: the plant's thrust after throttle steps (0 -> 1, 0 -> 0.5,
0.2 -> 0.8, 0.4 -> 0.8, 0.8 -> 0.3, 1 -> 0 at 25 m/s) reached 63 % in 0.45-0.68 s. With
the rotor's numbers (``prop_ixx``, ...) that lag is the rotor's speed instead
(:meth:`ThrustModel.rotor_step`): the same time constant about the steady speeds, but at
idle the unpowered propeller slows below the speed at which it gives any thrust, and a
throttle opened after an idle descent gives none until the motor has spun it up again.
The command goes through it before the low-pass, as the thrust it asks for.

The thrust estimated in flight carries the drag polar's errors as well: on fault-free
default flights its residual has a standard deviation of about 0.1 of
full throttle, so a throttle stuck near the command is seen only once the command moves
away from it, while one stuck at full is 0.6 above the cruise command at once.

The rotor's speed measured (ESC telemetry, ``measure_rpm``: sim_bridge/sensors/rpm.py,
ESC_TELEMETRY_1_TO_4; as ArduPilot's RPM library and PX4's ``esc_status`` read it), the
thrust balance gives way to the rotor's own. z is the throttle whose power the
propeller takes at the measured speed (:meth:`ThrustModel.prop_throttle`: JSBSim's
propeller, ``P = C_P(J) rho n^3 D^5`` with the propeller file's tables, over the
motor's full power), the throttle the motor delivers once the rotor has settled; the
inflow is the true airspeed along the propeller's axis, ``V cos(alpha)`` (alpha from the
lift, as in :meth:`ThrustModel.thrust`: in a 45 deg turn at 22 m/s V alone read the
throttle 0.03 low, a false alarm), the density the standard atmosphere's at the height
flown. It is compared with the command through the same rotor
(:meth:`ThrustModel.prop_step`: ``I dw/dt`` the motor's torque, capped by the speed
controller, less the propeller's), both low-passed over ``RPM_TAU_S`` (the telemetry's
noise) instead of BAL_TAU_S. z - that is the residual, tested and identified as the
thrust balance's (the same window test, false-alarm budget and stage 2); its offset
learnt on ``[1, V / V_ref - 1, throttle]`` (a gain term besides: the rotor model's
error grows with the power), its deviation about that fit as the lateral balance's
(:class:`.lateral._Axis` with a prior, floor RPM_RES_FLOOR), and tested once that fit
has started (before it, the thrust balance's). No drag polar and no accelerometer
force: on fault-free default flights the low-passed residual's deviation is 0.004-0.007
of full throttle in cruise against the thrust balance's 0.1, so a throttle stuck a
tenth from the command is seen at once, and its stuck position read within a few
hundredths (2 s after the detection, RPM_IDENT_S: the rotor's spin-up or down settled).
The linear rpm fit ``rpm`` of :meth:`rotor_speed` (98 rpm rms off the plant, 0.04 of
full throttle, and wrong in idle descents, where the propeller runs past the J of any
thrust) is not used here: its residual alarmed on 2 of 10 flights before the onset.
With no reading for RPM_TIMEOUT_S (none fitted, lost, or FDI_THR_RPM 0) the thrust
balance's residual is tested, exactly as before; it runs, and learns, all along.

A piston engine (the c172p: :data:`C172P_THRUST`, :class:`PistonEngine`; its rpm from
the engine's tachometer, sim_bridge/sensors/rpm.py). Its power is not the throttle
times a constant: the throttle sets the manifold pressure, and the power goes with the
manifold pressure, the rpm and the air. FGPiston's manifold pressure is the ram
pressure over ``1 + rpm (map_a + map_b (1 - u)^2)``, the constants from the IO-320
file's minmp / maxmp at idlerpm / maxrpm (:meth:`PistonEngine.map_constants`; within
0.7 % rms of the plant's settled MAP), lagging by one second. Its shaft power was
measured on the plant as on a dynamometer: trimmed level at 30-65 m/s (equivalent),
100-1100 m above a 500 m home, each throttle 0, 0.1, ... 1 (and 0.95) held 6 s, the
engine's power, MAP and rpm read (540 points); the form FGPiston's is built of (the
charge ``rpm MAP`` per the air's density and the mixture's richness at the ambient
pressure, the pumping loss, friction rising with the piston speed) fitted to it
within 208 W rms (a constant MAP coefficient left 0.04-0.06 of throttle at full at
1400-1600 m). The fixed-pitch propeller's speed depends on the airspeed: its power
``C_P(J) k_M rho n^3 D^5`` (the 75 in propeller's C_POWER table, k_M its CP_MACH
factor: at full throttle and 60 m/s the tip runs at Mach 0.88, 12 % more power) and
thrust ``C_T(J) k_M rho n^2 D^4`` (C_THRUST, CT_MACH; within 3 N of the plant's).
z is the throttle whose steady manifold pressure makes the engine give, at the measured
rpm, the power the propeller takes there (:meth:`ThrustModel.piston_throttle`, the
two relations inverted in closed form): within 0.02 (0.002-0.007 rms) of the
throttle set on the plant's settled grid points, 600-1600 m. Near full the manifold pressure hardly
moves with the throttle (``(1 - u)^2``), so a 0.5 % power error reads 0.02 of throttle
there, and the reading's noise (0.5 % of the rpm) 0.04: the speeds are low-passed
(RPM_TAU_S) before z is read from them, not z after (clipped at 1, the noise read a
stuck full throttle 0.02-0.04 low). The model rotor on the command: the manifold
pressure's lag, then ``I dw/dt = (P_engine - P_propeller) / w`` with the propeller
file's inertia (:meth:`ThrustModel.piston_step`; within 0.01 of the plant's through
throttle steps). No offset is learnt (the fit extrapolated to the 60 m/s of a throttle
stuck at full read it 0.03 low), and the residual is tested from the first rpm second,
the take-off roll included: the thrust balance, the accelerometer on the runway, is
only the fallback. The thrust curve (:meth:`ThrustModel.thrust_at`, for that balance
and the reaction) is the steady thrust of the engine and propeller models, tabled once
over the throttle and airspeed at 800 m. The onset's transient (the manifold pressure
and the 2.3 kg m^2 propeller) is ``ident_s`` = 4 s long: the first identification then,
the stuck-or-weakened test after it (:meth:`ThrottleIdentifier.identified`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from autopilot.jit import kernel, preload

from .actuator import (BAL_PERIOD_US, FIT_WARMUP_S, IDENT_WIN_S, LP_ON, LP_T, LP_T0,
                       MAX_DEFLECTION_RAD, RSS_STUCK, SETTLE_S, identify_hist, lowpass_advance, lowpass_state)
from .lateral import NO_FORCE, TEST_DIV, V_REF, _Axis
from .stats import family_alpha

RHO0 = 1.225
G0 = 9.80665
THR_RES_FLOOR = 0.05            # floor of the residual standard deviation [full throttle]
THR_OFFSET_SD = 0.1             # prior standard deviation of the learnt offset [full throttle]
THR_FIT_NOISE = 0.1             # each 10 Hz fit sample's weight against that prior
RPM_TAU_S = 0.25                # low-pass of the measured rotor's throttle and the model's [s]
RPM_TIMEOUT_S = 0.5             # no rotor speed this long: the thrust balance is tested
RPM_RES_FLOOR = 0.005           # floor of the rotor residual's deviation [full throttle]
RPM_RES_PRIOR = 0.03            # its deviation before any sample is learnt [full throttle]
RPM_RES_PRIOR_N = 10            # the warm-up's mean square as a prior worth these samples
RPM_IDENT_S = 2.0               # on the rotor's speed: the first identification this long
                                # after the detection, the stuck position the last second's
                                # mean (the rotor's spin-up or down, 0.5 s, and RPM_TAU_S settled)
RPM_RSS_STUCK = 0.1             # on the rotor's speed: stuck where the stuck fit's residual sum
                                # of squares is under this share of the weakened fit's (the
                                # surfaces' RSS_STUCK 0.05; docstring of identified)
PISTON_RSS_STUCK = 0.5          # ... a piston's (docstring of identified)

P_STD = 101325.0                # the standard sea-level pressure [Pa]
T0_K = 288.15                   # ... and temperature [K]
INHG_PA = 3386.389              # [Pa/inHg]
THRUST_GRID_V = tuple(float(v) for v in range(15, 81, 5))   # a piston's thrust table [m/s, equivalent]
THRUST_GRID_ALT_M = 800.0       # ... flown at this height of the standard atmosphere [m]


@dataclass(frozen=True)
class PistonEngine:
    """A normally aspirated piston engine as JSBSim's FGPiston runs it (module docstring).

    The manifold pressure: ``p_ram / MAP = 1 + rpm (map_a + map_b (1 - u)^2)``, the engine's
    impedance (the mean piston speed) over the air box's and the throttle plate's, whose
    constants FGPiston derives from the engine file: ``maxmp`` at ``maxrpm`` full open,
    ``minmp`` at ``idlerpm`` closed (:meth:`map_constants`). ``p_ram`` the ambient pressure
    plus ``ram`` times the dynamic pressure. MAP lags that steady value by ``map_tau_s``.

    The shaft power [W], in the form FGPiston's is built of and fitted on the plant as a
    dynamometer would (:attr:`k`)::

        P = rpm [g (k1 MAP + k2 p) + g s (k3 MAP + k4 p) + k5 (MAP - p) + k6 + k7 rpm] + k8

    the fuel burnt, ``rpm MAP``, less the charge the exhaust's back pressure keeps out
    (``p``), per the air's density and the mixture's richness at the ambient pressure p
    and temperature T (``g = p0 T0 / (p T)``, ``s = p0 / p``: the fixed mixture richens
    as the air thins); the pumping loss ``(MAP - p) rpm``; the friction's, rising with the
    piston speed (``k6``, ``k7``); and a static friction."""

    map_a: float               # [1/rpm]
    map_b: float               # [1/rpm]
    k: tuple                   # (k1 .. k8) of the power (class docstring) [W, Pa, rpm]
    map_tau_s: float = 1.0     # the manifold pressure's lag [s]
    ram: float = 1.0           # the share of the dynamic pressure the intake recovers

    @staticmethod
    def map_constants(minmp_inhg: float, maxmp_inhg: float, idle_rpm: float, max_rpm: float) -> tuple:
        """(map_a, map_b) from the engine file's numbers, as FGPiston derives its air box's
        and throttle's impedances: full open, ``maxmp`` at ``maxrpm``; closed, ``minmp``
        at ``idlerpm`` (standard sea-level pressure at the intake)."""
        a = (P_STD / (maxmp_inhg * INHG_PA) - 1.0) / max_rpm
        return a, (P_STD / (minmp_inhg * INHG_PA) - 1.0) / idle_rpm - a

    def map_steady(self, throttle: float, rpm: float, p_ram: float) -> float:
        """The manifold pressure [Pa] the throttle settles to at that rpm."""
        x = 1.0 - throttle
        return p_ram / (1.0 + rpm * (self.map_a + self.map_b * x * x))

    def _terms(self, p_amb: float, t_amb: float) -> tuple[float, float]:
        """The power's factor on MAP and its other terms but rpm's, per rpm."""
        k1, k2, k3, k4, k5, k6, _k7, _k8 = self.k
        g = P_STD * T0_K / (p_amb * t_amb)
        gs = g * P_STD / p_amb
        return g * k1 + gs * k3 + k5, (g * k2 + gs * k4 - k5) * p_amb + k6

    def power(self, map_pa: float, rpm: float, p_amb: float, t_amb: float) -> float:
        """The shaft power [W] at that manifold pressure, rpm, ambient pressure [Pa] and
        temperature [K]."""
        c_map, c_0 = self._terms(p_amb, t_amb)
        return rpm * (c_map * map_pa + c_0 + self.k[6] * rpm) + self.k[7]

    def throttle(self, power_w: float, rpm: float, p_amb: float, t_amb: float, p_ram: float) -> float:
        """The throttle (0..1) whose steady manifold pressure gives ``power_w`` at that rpm:
        :meth:`power` and :meth:`map_steady` inverted."""
        if rpm <= 0.0:
            return 0.0
        c_map, c_0 = self._terms(p_amb, t_amb)
        m = ((power_w - self.k[7]) / rpm - c_0 - self.k[6] * rpm) / c_map
        if m <= 0.0:
            return 0.0
        x2 = ((p_ram / m - 1.0) / rpm - self.map_a) / self.map_b
        if x2 <= 0.0:
            return 1.0
        if x2 >= 1.0:
            return 0.0
        return 1.0 - math.sqrt(x2)


@dataclass(frozen=True)
class ThrustModel:
    """Drag polar and thrust curve of an airframe (module docstring)."""

    name: str
    mass_kg: float
    wing_area_m2: float
    CL0: float
    CLa: float
    CLde: float
    CD0: float
    k_CD: float                # C_D = CD0 + k_CD (CL0 + CLa alpha)^2
    a: float                   # T = throttle (a + b V) + c + d V   [N, V in m/s]
    b: float
    c: float
    d: float
    CY_b: float = 0.0          # side force per sideslip (its body-x part in gusts)
    tau_s: float = 0.0         # the thrust's lag behind the command (motor and propeller) [s]
    # the rotor (propeller, hub and motor) whose speed the thrust follows (:meth:`rotor_step`;
    # prop_ixx 0: the first-order lag tau_s instead)
    prop_ixx: float = 0.0      # its rotating inertia [kg m^2]
    p_max_w: float = 0.0       # the motor's shaft power at full throttle [W]
    q_max_nm: float = 0.0      # the speed controller's torque limit [N m]
    rpm: tuple = (0.0, 0.0, 0.0, 0.0)   # steady rpm ~ a + b throttle + c V + d throttle V
    k_idle: float = 0.0        # unpowered propeller's drag torque k omega^2 [N m s^2]
    # the propeller's power coefficient (its JSBSim file; :meth:`prop_throttle`): diameter,
    # C_P against the advance ratio J, and its factor against the rpm
    prop_d_m: float = 0.0
    cp_j: tuple = ()
    cp: tuple = ()
    cp_rpm: tuple = ()
    cp_rpm_k: tuple = ()
    # a piston engine (:class:`PistonEngine`; None: the electric motor above) and what
    # its fixed-pitch propeller adds: C_T against J and both coefficients' factors
    # against the helical tip Mach number (the propeller file's CT_MACH, CP_MACH)
    engine: PistonEngine | None = None
    ct_j: tuple = ()
    ct: tuple = ()
    cp_mach: tuple = ()
    cp_mach_k: tuple = ()
    ct_mach: tuple = ()
    ct_mach_k: tuple = ()
    v_cruise: float = 25.0     # the airspeed the throttle-out reaction searches down from [m/s]
    ident_s: float = 2.0       # on the rotor's speed: the first identification this long after
                               # the detection (RPM_IDENT_S; the last second's mean)
    rpm_res_floor: float = RPM_RES_FLOOR   # floor of the rotor residual's deviation [full throttle]

    def thrust(self, V: float, f_x: float, f_z: float, elevator_rad: float,
               var_fz: float = 0.0, var_fy: float = 0.0) -> float:
        """The thrust [N] the measured specific force (body FRD, m/s^2) means, with the
        elevator's deflection (autopilot convention, nose up positive) [rad].

        ``var_fz``, ``var_fy``: the variances of the normal and lateral specific force
        about the low-passed values passed in [m^2/s^4]. The aerodynamic force turns
        with the angle of attack and the sideslip, so its body-x part is quadratic in
        them, and the mean of a square is the square of the mean plus the variance:
        ``L sin(alpha)`` adds ``qbar S C_La var(alpha)`` and the side force
        ``-Y sin(beta)`` adds ``qbar S |C_Yb| var(beta)``, both forward, with
        ``var(alpha) = var(C_L) / C_La^2``, ``var(beta) = var(C_Y) / C_Yb^2`` from the
        forces measured. Gusts faster than the low-pass (near the ground: MIL-F-8785C's
        vertical scale length is the height) made them 4-7 N, a third of full throttle."""
        qS = 0.5 * RHO0 * V * V * self.wing_area_m2
        CL = -self.mass_kg * f_z / qS
        # alpha from the lift: C_L = C_L0 + C_La alpha + C_Lde de, de = -elevator
        alpha = (CL - self.CL0 + self.CLde * elevator_rad) / self.CLa
        CLl = self.CL0 + self.CLa * alpha
        CD = self.CD0 + self.k_CD * CLl * CLl
        k = self.mass_kg / qS
        fwd = k * k * var_fz / self.CLa
        if self.CY_b != 0.0:
            fwd += k * k * var_fy / abs(self.CY_b)
        return self.mass_kg * f_x - qS * (CL * math.sin(alpha) - CD * math.cos(alpha) + fwd)

    def throttle_for(self, thrust: float, V: float) -> float:
        """The throttle that gives ``thrust`` at airspeed V (the curve inverted)."""
        if self.engine is not None:
            return self._table_throttle(thrust, V)
        return (thrust - self.c - self.d * V) / (self.a + self.b * V)

    def thrust_at(self, throttle: float, V: float) -> float:
        if self.engine is not None:
            return self._table_thrust(throttle, V)
        return throttle * (self.a + self.b * V) + self.c + self.d * V

    # ---- the piston engine and its fixed-pitch propeller (module docstring) ----
    def _prop_coef(self, w: float, V: float, a_snd: float, j_tab: tuple, c_tab: tuple,
                   mach_tab: tuple, mach_k: tuple) -> tuple[float, float]:
        """(n [rev/s], the coefficient of ``c_tab`` against J = V / (n D), times its
        factor ``mach_k`` at the helical tip Mach number ``sqrt((pi D n)^2 + V^2) / a``);
        n = 0 where the propeller does not turn forward."""
        n = w / (2.0 * math.pi)
        if n <= 0.0:
            return 0.0, 0.0
        D = self.prop_d_m
        c = _interp(V / (n * D), j_tab, c_tab)
        if mach_tab:
            c *= _interp(math.hypot(math.pi * D * n, V) / a_snd, mach_tab, mach_k)
        return n, c

    def shaft_power(self, w: float, V: float, rho: float, a_snd: float) -> float:
        """The power [W] the propeller takes at speed ``w`` [rad/s], true axial airspeed
        V [m/s], density rho and speed of sound a_snd [m/s]: ``C_P(J) k_M rho n^3 D^5``
        (JSBSim's FGPropeller, power required), k_M the CP_MACH factor."""
        n, cp = self._prop_coef(w, V, a_snd, self.cp_j, self.cp, self.cp_mach, self.cp_mach_k)
        return cp * rho * n * n * n * self.prop_d_m ** 5 if n > 0.0 else 0.0

    def prop_thrust(self, w: float, V: float, rho: float, a_snd: float) -> float:
        """The propeller's thrust [N]: ``C_T(J) k_M rho n^2 D^4`` (CT_MACH's k_M)."""
        n, ct = self._prop_coef(w, V, a_snd, self.ct_j, self.ct, self.ct_mach, self.ct_mach_k)
        return ct * rho * n * n * self.prop_d_m ** 4 if n > 0.0 else 0.0

    def piston_throttle(self, w: float, V: float, alt_m: float, qbar: float) -> float:
        """The throttle whose engine gives, at the rotor's speed ``w`` [rad/s], the power
        the propeller takes there (:meth:`shaft_power`, :meth:`PistonEngine.throttle`):
        in steady flight the throttle the engine runs at. V the true axial airspeed,
        the atmosphere the standard one at ``alt_m``, qbar the ram pressure [Pa]."""
        rho, p, a_snd, t = _isa(alt_m)
        rpm = w * (30.0 / math.pi)
        return self.engine.throttle(self.shaft_power(w, V, rho, a_snd), rpm, p, t, p + self.engine.ram * qbar)

    def piston_step(self, w: float, map_pa: float, throttle: float, V: float, alt_m: float,
                    qbar: float, dt: float) -> tuple[float, float]:
        """The rotor's speed [rad/s] and the manifold pressure [Pa] after ``dt`` seconds at
        ``throttle``: the manifold pressure lags its steady value by ``map_tau_s``
        (FGPiston's one-second lag), and ``I dw/dt = (P_engine - P_propeller) / w``."""
        e = self.engine
        rho, p, a_snd, t = _isa(alt_m)
        rpm = w * (30.0 / math.pi)
        u = 0.0 if 0.0 > throttle else 1.0 if 1.0 < throttle else throttle
        target = e.map_steady(u, rpm, p + e.ram * qbar)
        map_pa += dt / (e.map_tau_s + dt) * (target - map_pa)
        wq = 1.0 if 1.0 > w else w
        w = w + dt * (e.power(map_pa, rpm, p, t) - self.shaft_power(w, V, rho, a_snd)) / (self.prop_ixx * wq)
        return (0.0 if 0.0 > w else w), map_pa

    def piston_steady(self, throttle: float, V: float, alt_m: float, qbar: float) -> float:
        """The rotor's steady speed [rad/s] at ``throttle``, true axial airspeed V, the
        standard atmosphere at ``alt_m`` and ram pressure qbar: where the engine's power at
        its steady manifold pressure meets the propeller's (bisection)."""
        e = self.engine
        rho, p, a_snd, t = _isa(alt_m)
        p_ram = p + e.ram * qbar
        lo, hi = 1.0, 400.0
        for _ in range(50):
            w = 0.5 * (lo + hi)
            rpm = w * (30.0 / math.pi)
            if e.power(e.map_steady(throttle, rpm, p_ram), rpm, p, t) > self.shaft_power(w, V, rho, a_snd):
                lo = w
            else:
                hi = w
        return 0.5 * (lo + hi)

    @cached_property
    def _thrust_grid(self) -> tuple:
        """The steady thrust [N] over throttle 0, 0.05, ... 1 and equivalent airspeed
        THRUST_GRID_V, level at the standard atmosphere's ``THRUST_GRID_ALT_M`` (alpha 0:
        the axial airspeed the true one), computed once from the engine and propeller."""
        us = tuple(i / 20.0 for i in range(21))
        rho, p, a_snd, _t = _isa(THRUST_GRID_ALT_M)
        rows = []
        for u in us:
            row = []
            for v in THRUST_GRID_V:
                vt = v * math.sqrt(RHO0 / rho)
                w = self.piston_steady(u, vt, THRUST_GRID_ALT_M, 0.5 * RHO0 * v * v)
                row.append(self.prop_thrust(w, vt, rho, a_snd))
            rows.append(tuple(row))
        return us, tuple(rows)

    def _thrusts_at(self, V: float) -> tuple:
        us, rows = self._thrust_grid
        return us, [_interp(V, THRUST_GRID_V, r) for r in rows]

    def _table_thrust(self, throttle: float, V: float) -> float:
        us, ts = self._thrusts_at(V)
        return _interp(throttle, us, ts)

    def _table_throttle(self, thrust: float, V: float) -> float:
        """The table inverted at V (the thrust rises with the throttle), extrapolated
        linearly past its ends as the electric motor's straight curve is."""
        us, ts = self._thrusts_at(V)
        i = 1
        while i < len(us) - 1 and ts[i] < thrust:
            i += 1
        t0, t1 = ts[i - 1], ts[i]
        return us[i - 1] + (us[i] - us[i - 1]) * (thrust - t0) / (t1 - t0 if t1 != t0 else 1e-9)

    @cached_property
    def _rotor(self) -> np.ndarray:
        """The electric rotor's numbers as its kernels take them (the indices ``_P_MAX`` ... ``_D5``),
        then the airframe's that throttle_front takes (``_MASS`` ... ``_TAU``)."""
        a, b, c, d = self.rpm
        return np.array((self.p_max_w, self.q_max_nm, self.prop_ixx, self.k_idle, a, b, c, d,
                         self.prop_d_m, self.prop_d_m ** 5, self.mass_kg, self.wing_area_m2, self.CL0,
                         self.CLde, self.CLa, self.tau_s), dtype=float)

    @cached_property
    def _cp_tables(self) -> tuple:
        """The propeller's C_P(J) and CP_RPM_FACTOR tables as arrays (:func:`_prop_throttle`)."""
        return tuple(np.array(t, dtype=float) for t in (self.cp_j, self.cp, self.cp_rpm, self.cp_rpm_k))

    def rotor_speed(self, throttle: float, V: float) -> float:
        """The rotor's steady speed at that throttle and airspeed [rad/s]."""
        return _rotor_speed(throttle, V, self._rotor)

    def rotor_step(self, w: float, throttle: float, V: float, dt: float) -> float:
        """The rotor's speed ``w`` [rad/s] after ``dt`` seconds at ``throttle``
        (:func:`_rotor_step`)."""
        return _rotor_step(w, throttle, V, dt, self._rotor)

    def rotor_throttle(self, w: float, V: float) -> float:
        """The throttle whose steady rotor speed is ``w`` (0..1): the one whose thrust
        the rotor gives now."""
        return _rotor_throttle(w, V, self._rotor)

    def prop_throttle(self, w: float, V: float, rho: float = RHO0) -> float:
        """The throttle whose shaft power the propeller takes at speed ``w`` [rad/s], true
        axial airspeed V [m/s] and air density rho [kg/m^3] (:func:`_prop_throttle`)."""
        return _prop_throttle(w, V, rho, self._rotor, *self._cp_tables)

    def prop_step(self, w: float, throttle: float, V: float, rho: float, dt: float) -> float:
        """The rotor's speed ``w`` [rad/s] after ``dt`` seconds at ``throttle``, the
        plant's own rotor (:func:`_prop_step`)."""
        return _prop_step(w, throttle, V, rho, dt, self._rotor, *self._cp_tables)

    def level_drag(self, V: float) -> float:
        """The drag of level, unaccelerated flight at airspeed V [N]."""
        qS = 0.5 * RHO0 * V * V * self.wing_area_m2
        CL = self.mass_kg * G0 / qS
        return qS * (self.CD0 + self.k_CD * CL * CL)


# the Aerosonde (sim_bridge/aircraft/aerosonde/aerosonde.xml: CL-linear, CD-alpha; the
# thrust curve fitted as the module docstring says)
AEROSONDE_THRUST = ThrustModel("aerosonde", mass_kg=13.5, wing_area_m2=0.55, CL0=0.28, CLa=3.45,
                               CLde=-0.36, CD0=0.0437, k_CD=0.0232,
                               a=46.979, b=-0.778, c=4.465, d=-0.177, CY_b=-0.98, tau_s=0.5,
                               # the rotor: inertia and rpm fit as airframe.AEROSONDE's; the
                               # motor's 1000 W and the speed controller's 2.5 N m current
                               # limit; k_idle from the unpowered propeller's slowing on the
                               # plant (1/rpm rising 1.25e-5 per second, 5500 to 1500 rpm)
                               prop_ixx=3.0e-3, p_max_w=1000.0, q_max_nm=2.5,
                               rpm=(728.6, 4696.3, 201.04, -93.43), k_idle=3.6e-7,
                               # the APC 18x8E's (sim_bridge/aircraft/engine/APC_18x8E.xml)
                               prop_d_m=18 * 0.0254,
                               cp_j=(0, 0.0202, 0.0405, 0.0607, 0.0809, 0.1012, 0.1214, 0.1416,
                                     0.1619, 0.1821, 0.2023, 0.2226, 0.2428, 0.263, 0.2833,
                                     0.3035, 0.3237, 0.344, 0.3642, 0.3844, 0.4047, 0.4249,
                                     0.4451, 0.4654, 0.4856, 0.5058, 0.526, 0.5463, 0.5665, 0.5867),
                               cp=(0.025, 0.0253, 0.0255, 0.0257, 0.0258, 0.0259, 0.0259, 0.0259,
                                   0.0258, 0.0257, 0.0254, 0.0251, 0.0247, 0.0242, 0.0236, 0.0229,
                                   0.0222, 0.0213, 0.0203, 0.0192, 0.0181, 0.0168, 0.0155, 0.0141,
                                   0.0126, 0.011, 0.0093, 0.0076, 0.0058, 0.004),
                               cp_rpm=(1000, 2000, 3000, 4000, 5000, 6000, 7000, 8000, 9000,
                                       10000, 11000, 12000, 13000),
                               cp_rpm_k=(1.132, 1.036, 0.996, 0.972, 0.964, 0.96, 0.964, 0.972,
                                         0.984, 1, 1.04, 1.16, 1.396))

# JSBSim's Cessna 172P (the jsbsim package's aircraft/c172p/c172p.xml, its engine
# engine/eng_io320.xml and propeller engine/prop_75in2f.xml; tests/test_monitor_throttle_c172p.py
# reads them and checks these numbers): the mass, wing, lift and elevator as airframe.C172P
# (CLde per the autopilot's rad: 0.43 times the surface's 1.147 rad per rad), the drag
# polar fitted to CDo + CDwbh over alpha -0.05..0.12 (within 2e-4), the side force per
# sideslip as lateral.C172P_LAT. The engine: the IO-320's manifold pressure from its file
# (minmp 10 inHg at idlerpm 550, maxmp 28.5 at maxrpm 2700), its power fitted on the plant
# (module docstring); the 75 in two-blade fixed-pitch propeller's tables and inertia.
_C172P_MAP = PistonEngine.map_constants(10.0, 28.5, 550.0, 2700.0)
C172P_THRUST = ThrustModel("c172p", mass_kg=1880 * 0.45359237, wing_area_m2=174 * 0.09290304,
                           CL0=0.25, CLa=(0.73 - 0.25) / 0.09, CLde=0.43 * 23.0 * 0.01745 / 0.35,
                           CD0=0.0269, k_CD=0.0868, a=0.0, b=0.0, c=0.0, d=0.0,
                           CY_b=-0.137 / 0.349, tau_s=1.5,
                           prop_ixx=1.67 * 1.3558179, prop_d_m=75 * 0.0254,
                           engine=PistonEngine(_C172P_MAP[0], _C172P_MAP[1],
                                               k=(1.013930e-02, 3.976266e-02, -4.818017e-03,
                                                  -2.652506e-03, -4.516146e-03, -4.230567e+03,
                                                  -2.956126e-03, -1.091892e+03)),
                           cp_j=(0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0, 1.1, 1.2,
                                 1.3, 1.4, 1.5, 1.6, 1.7, 1.8, 1.9, 2.0, 2.1, 2.2, 2.3, 2.4, 5.0),
                           cp=(0.066, 0.07, 0.07, 0.066, 0.06, 0.053, 0.0501, 0.0469, 0.0426,
                               0.036, 0.0282, 0.0191, 0.0155, 0.0191, 0.0282, 0.036, 0.0426,
                               0.0469, 0.0501, 0.0516, 0.0525, 0.0525, 0.0522, 0.0511, 0.0504, 0.0493),
                           ct_j=(0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0, 1.1, 1.2,
                                 1.3, 1.4, 1.5, 1.6, 1.7, 1.8, 1.9, 2.0, 2.1, 2.2, 2.3, 5.0),
                           ct=(0.073, 0.073, 0.072, 0.071, 0.069, 0.066, 0.062, 0.055, 0.045, 0.034,
                               0.024, 0.013, -0.006, -0.013, -0.024, -0.034, -0.045, -0.055,
                               -0.062, -0.066, -0.069, -0.071, -0.072, -0.073, -0.073),
                           cp_mach=(0.85, 1.05, 2.0), cp_mach_k=(1.0, 1.8, 1.4),
                           ct_mach=(0.85, 1.05), ct_mach_k=(1.0, 0.8),
                           v_cruise=45.0, ident_s=4.0,
                           # the piston's response to a throttle ramp towards full is
                           # modelled to within 0.02-0.04 for a second or two (its manifold
                           # pressure and heavy propeller), ten times the cruise residual's
                           # deviation (0.002-0.005): at the electric motor's floor a fault-free
                           # circuit in moderate turbulence alarmed (false_alarms_c172p.toml
                           # trial 59, 1.006 of the threshold in a full-throttle turn; p95
                           # over 60 circuits 0.476)
                           rpm_res_floor=0.01)

THRUST_MODELS = {1: AEROSONDE_THRUST, 2: C172P_THRUST}


def _isa_rho(alt_m: float) -> float:
    """The standard atmosphere's density at ``alt_m`` (ICAO Doc 7488 troposphere:
    ``rho / rho0 = (1 - 2.25577e-5 h)^4.25588``; the plant's is JSBSim's standard one)."""
    r = 1.0 - 2.25577e-5 * alt_m
    return RHO0 * (0.1 if 0.1 > r else r) ** 4.25588


def _isa(alt_m: float) -> tuple[float, float, float, float]:
    """The standard atmosphere at ``alt_m`` (troposphere): density [kg/m^3], pressure [Pa],
    the speed of sound [m/s] (``sqrt(1.4 R T)``, R 287.05 J/(kg K): JSBSim's) and the
    temperature [K]."""
    r = 1.0 - 2.25577e-5 * alt_m
    r = 0.1 if 0.1 > r else r
    t = T0_K * r
    return RHO0 * r ** 4.25588, P_STD * r ** 5.25588, math.sqrt(1.4 * 287.05 * t), t


def _interp(x, xs, ys):
    """Linear interpolation in a table, held at its ends (as JSBSim's tables); the
    interval found as ``bisect_right`` finds it. ``xs``, ``ys``: tuples (the piston
    engine's tables, run by the interpreter) or arrays (:func:`_table`, this function
    compiled for the electric rotor's kernels): one law, one text."""
    n = len(xs)
    if x <= xs[0]:
        return ys[0]
    if x >= xs[n - 1]:
        return ys[n - 1]
    lo, hi = 0, n
    while lo < hi:
        mid = (lo + hi) // 2
        if x < xs[mid]:
            hi = mid
        else:
            lo = mid + 1
    x0, x1 = xs[lo - 1], xs[lo]
    return ys[lo - 1] + (ys[lo] - ys[lo - 1]) * (x - x0) / (x1 - x0)


def _inflow_tas(V: float, fz: float, elevator_cmd: float, rho: float, mass_kg: float, wing_area_m2: float,
                CL0: float, CLde: float, CLa: float) -> float:
    """The propeller's axial inflow [m/s]: the true airspeed times cos(alpha), alpha from
    the lift the normal specific force ``fz`` says (as ThrustModel.thrust), within 0.3
    rad. In a 45 deg turn at 22 m/s (alpha about 0.2) V alone read the rotor's throttle
    0.03 low. Called by the piston's step (Python) and, compiled, by throttle_front."""
    qS = 0.5 * RHO0 * V * V * wing_area_m2
    alpha = (-mass_kg * fz / qS - CL0 + CLde * elevator_cmd * MAX_DEFLECTION_RAD) / CLa
    alpha = -0.3 if -0.3 > alpha else 0.3 if 0.3 < alpha else alpha
    return V * math.sqrt(RHO0 / rho) * math.cos(alpha)


_table = kernel(_interp)      # the same law, compiled (the electric rotor's kernels call it)
_isa_rho_k = kernel(_isa_rho)   # (and throttle_front these two)
_inflow_tas_k = kernel(_inflow_tas)


# ---- the electric rotor's laws (ThrustModel.rotor_*, prop_*), compiled: the throttle
# balance runs them at 50 Hz. ``rotor`` is ThrustModel._rotor: p_max_w, q_max_nm,
# prop_ixx, k_idle, the rpm fit's a, b, c, d, prop_d_m and prop_d_m ** 5, at these indices
_P_MAX, _Q_MAX, _IXX, _K_IDLE, _RPM_A, _RPM_B, _RPM_C, _RPM_D, _D, _D5 = range(10)
_MASS, _AREA, _CL0, _CLDE, _CLA, _TAU = range(10, 16)     # the airframe's (throttle_front)


@kernel
def _rpm_line(V, rotor):
    """The steady rotor speed at zero throttle and its rise per unit of throttle at
    airspeed V [rad/s] (the rpm fit ``a + b throttle + c V + d throttle V``)."""
    k = 2.0 * math.pi / 60.0
    return (rotor[_RPM_A] + rotor[_RPM_C] * V) * k, (rotor[_RPM_B] + rotor[_RPM_D] * V) * k


@kernel
def _rotor_speed(throttle, V, rotor):
    """The rotor's steady speed at that throttle and airspeed [rad/s]."""
    w0, s = _rpm_line(V, rotor)
    w = w0 + s * throttle
    return 0.0 if 0.0 > w else w


@kernel
def _rotor_step(w, throttle, V, dt, rotor):
    """The rotor's speed ``w`` [rad/s] after ``dt`` seconds at ``throttle``:
    ``I dw/dt = Q_motor - Q_prop``. The motor gives ``throttle p_max / w``, at most
    the speed controller's ``q_max``; the propeller takes the power the steady speeds
    say it takes at ``w`` (the throttle whose steady speed is ``w``, times p_max: the
    steady state is the measured one, and about it the time constant is
    ``I s w / p_max``, 0.5 s, the thrust's lag measured after throttle steps), and
    at least the unpowered propeller's drag ``k_idle w^2``: at idle the propeller
    slows below the speed where it gives thrust (on the plant from 6000 to 1500 rpm in
    40 s of an idle descent), and a throttle opened then gives no thrust until the
    motor has spun it up again (1.7 s at 0.55 from 1500 rpm at 27 m/s: with the
    first-order lag alone the throttle read 0.27 low, a false throttle alarm)."""
    w0, s = _rpm_line(V, rotor)
    p_max, q_max = rotor[_P_MAX], rotor[_Q_MAX]
    wq = 1.0 if 1.0 > w else w
    q_m = p_max * (0.0 if 0.0 > throttle else throttle) / wq
    q_m = q_m if q_m < q_max else q_max
    q_p = p_max * (0.0 if 0.0 > w - w0 else w - w0) / s / wq
    q_idle = rotor[_K_IDLE] * w * w
    q_p = q_idle if q_idle > q_p else q_p
    w = w + dt * (q_m - q_p) / rotor[_IXX]
    return 0.0 if 0.0 > w else w


@kernel
def _rotor_throttle(w, V, rotor):
    """The throttle whose steady rotor speed is ``w`` (0..1)."""
    w0, s = _rpm_line(V, rotor)
    u = (w - w0) / s
    u = 0.0 if 0.0 > u else u
    return 1.0 if 1.0 < u else u


@kernel
def _prop_throttle(w, V, rho, rotor, cp_j, cp, cp_rpm, cp_rpm_k):
    """The throttle whose shaft power the propeller takes at speed ``w`` [rad/s], true
    axial airspeed V [m/s] and air density rho [kg/m^3]: ``P = C_P(J) k(rpm) rho n^3
    D^5`` over ``p_max_w``, n in rev/s, ``J = V / (n D)`` (JSBSim's FGPropeller,
    "power required", with the propeller file's C_POWER and CP_RPM_FACTOR tables,
    held at their ends as JSBSim's tables are). The motor gives ``throttle p_max``
    (FGElectric), so in steady flight this is the throttle the motor delivers."""
    n = w / (2.0 * math.pi)
    if n <= 0.0:
        return 0.0
    c = _table(V / (n * rotor[_D]), cp_j, cp)
    k = _table(n * 60.0, cp_rpm, cp_rpm_k)
    return c * k * rho * n * n * n * rotor[_D5] / rotor[_P_MAX]


@kernel
def _prop_step(w, throttle, V, rho, dt, rotor, cp_j, cp, cp_rpm, cp_rpm_k):
    """The rotor's speed ``w`` [rad/s] after ``dt`` seconds at ``throttle``, the
    plant's own rotor: ``I dw/dt = Q_motor - Q_prop``, the motor's torque
    ``throttle p_max / w`` capped by the speed controller at ``q_max`` (the FCS's
    esc-power-limit-norm), the propeller's ``P / w`` (:func:`_prop_throttle`)."""
    p_max, q_max = rotor[_P_MAX], rotor[_Q_MAX]
    wq = 1.0 if 1.0 > w else w
    q_m = p_max * (0.0 if 0.0 > throttle else throttle) / wq
    q_m = q_max if q_max < q_m else q_m
    q_p = p_max * _prop_throttle(w, V, rho, rotor, cp_j, cp, cp_rpm, cp_rpm_k) / wq
    w = w + dt * (q_m - q_p) / rotor[_IXX]
    return 0.0 if 0.0 > w else w


@kernel
def _rotor_advance(w, throttle, V, dt, rotor):
    """The rotor's speed after ``dt`` seconds at ``throttle`` (:func:`_rotor_step`; not
    moved where dt <= 0) and the throttle whose steady speed that is
    (:func:`_rotor_throttle`): (w, throttle)."""
    if dt > 0.0:
        w = _rotor_step(w, throttle, V, dt, rotor)
    return w, _rotor_throttle(w, V, rotor)


@kernel
def _prop_advance(w_model, l_meas, l_model, throttle, w_meas, V, rho, dt, rotor, cp_j, cp, cp_rpm, cp_rpm_k):
    """One step of the rotor's residual on its measured speed (ThrottleIdentifier.step):
    the model rotor ``w_model`` advanced ``dt`` seconds on the command ``throttle``
    (:func:`_prop_step`), and the first-order low-passes over RPM_TAU_S of the
    propeller's throttle (:func:`_prop_throttle`) at the measured speed (``l_meas``)
    and at the model's (``l_model``): the three new values."""
    w_model = _prop_step(w_model, throttle, V, rho, dt, rotor, cp_j, cp, cp_rpm, cp_rpm_k)
    a = dt / (RPM_TAU_S + dt)
    l_meas += a * (_prop_throttle(w_meas, V, rho, rotor, cp_j, cp, cp_rpm, cp_rpm_k) - l_meas)
    l_model += a * (_prop_throttle(w_model, V, rho, rotor, cp_j, cp, cp_rpm, cp_rpm_k) - l_model)
    return w_model, l_meas, l_model


@kernel
def _rotors_advance(w, throttle, V, dt, w_model, l_meas, l_model, w_meas, vt, rho, rotor, cp_j, cp, cp_rpm,
                    cp_rpm_k):
    """:func:`_rotor_advance` (the thrust's rotor, airspeed V) and :func:`_prop_advance`
    (the rotor residual's, true axial airspeed vt) on the same command and step, in one
    call (ThrottleIdentifier.step: a kernel's call costs more than their work):
    (w, throttle, w_model, l_meas, l_model)."""
    w, thr = _rotor_advance(w, throttle, V, dt, rotor)
    w_model, l_meas, l_model = _prop_advance(w_model, l_meas, l_model, throttle, w_meas, vt, rho, dt, rotor,
                                             cp_j, cp, cp_rpm, cp_rpm_k)
    return w, thr, w_model, l_meas, l_model


# ThrottleIdentifier's state past the balance's low-passes (actuator.lowpass_advance): in
# ``lp``, before the signals, the rotor's speed (ThrustModel.rotor_step) and the model rotor's of the residual on
# the measured speed [rad/s], that residual's two low-passed throttles (measured, model's),
# the command through the thrust's lag (tau_s), the measured speed [rad/s]; in ``st`` the
# residual held (1) or not, the speed's time (-1: none yet) and the residual's start [us]
_W, _WR, _LPR0, _LPR1, _LAG, _RPM = range(8, 14)
_LPR_ON, _RPM_US, _RPM_START = range(5, 8)
# how the throttle enters the thrust balance: as given (the command, or a piston's through
# its lag, ThrottleIdentifier._piston), through the electric rotor, through tau_s
_GIVEN, _ROTOR, _LAGGED = range(3)


@kernel
def throttle_front(lp, st, t_us, V, flying, f_b, elevator, throttle, alt_m, mode, rotor, cp_j, cp, cp_rpm,
                   cp_rpm_k):
    """The thrust balance's signals (the specific force ``f_b``, the elevator command
    [rad], V, the throttle the thrust asks for, the lateral and normal forces' squares)
    low-passed (actuator.lowpass_advance), with the rotor's residual on its measured speed
    advanced, flying at 10 m/s or more (else both start again, -1): 1 where a balance
    sample is due (ThrottleIdentifier.step), else 0."""
    if not flying or V < 10.0:
        st[LP_ON] = 0
        st[_LPR_ON] = 0
        return -1
    fx, fy, fz = f_b[0], f_b[1], f_b[2]
    thr = throttle
    if mode == _ROTOR:
        # the rotor's speed measured: the throttle its propeller takes, against the
        # model rotor's (prop_step) on the command, on the true airspeed and the
        # density of the standard atmosphere at the height flown
        rpm_on = st[_RPM_US] >= 0 and t_us - st[_RPM_US] <= RPM_TIMEOUT_S * 1e6
        rho = vt = 0.0
        if not rpm_on:
            st[_LPR_ON] = 0
        else:
            rho = _isa_rho_k(alt_m)
            vt = _inflow_tas_k(V, fz, elevator, rho, rotor[_MASS], rotor[_AREA], rotor[_CL0], rotor[_CLDE],
                               rotor[_CLA])
        # the thrust follows the rotor's speed (ThrustModel.rotor_step): the throttle
        # whose steady speed the rotor has now, as the thrust it asks for
        if st[LP_ON] == 0:
            lp[_W] = _rotor_speed(thr, V, rotor)
            thr = _rotor_throttle(lp[_W], V, rotor)
        else:
            dt = (t_us - st[LP_T]) * 1e-6
            if st[_LPR_ON] != 0 and dt > 0.0:
                # and the model rotor on the same command
                lp[_W], thr, lp[_WR], lp[_LPR0], lp[_LPR1] = _rotors_advance(
                    lp[_W], thr, V, dt, lp[_WR], lp[_LPR0], lp[_LPR1], lp[_RPM], vt, rho, rotor,
                    cp_j, cp, cp_rpm, cp_rpm_k)
            else:
                lp[_W], thr = _rotor_advance(lp[_W], thr, V, dt, rotor)
        if rpm_on and (st[_LPR_ON] == 0 or st[LP_ON] == 0):
            lp[_WR] = lp[_RPM]          # the model rotor starts where it is measured
            z0 = _prop_throttle(lp[_RPM], vt, rho, rotor, cp_j, cp, cp_rpm, cp_rpm_k)
            lp[_LPR0] = z0
            lp[_LPR1] = z0
            st[_LPR_ON] = 1
            st[_RPM_START] = t_us
    elif mode == _LAGGED and st[LP_ON] != 0:
        # the thrust follows the command with the motor's and propeller's lag
        # (ThrustModel.tau_s): the command through it, as the thrust it asks for
        dt = (t_us - st[LP_T]) * 1e-6
        if dt > 0.0:
            lp[_LAG] += dt / (rotor[_TAU] + dt) * (thr - lp[_LAG])
        thr = lp[_LAG]
    if st[LP_ON] == 0:
        lp[_LAG] = thr
    x = lp[14:]
    x[0], x[1], x[2], x[3], x[4], x[5], x[6], x[7] = (fx, fz, elevator * MAX_DEFLECTION_RAD, V, thr, fy,
                                                      fz * fz, fy * fy)
    return 1 if lowpass_advance(lp, st, 8, t_us) else 0


class ThrottleIdentifier:
    """Throttle fault detection and identification (module docstring); the same
    interface as :class:`.lateral.LateralIdentifier` with the one axis "throttle"."""

    def __init__(self, model: ThrustModel, alpha: float = 1e-4, window: int = 10, p_fa: float = 0.01):
        self.model = model
        tests_per_hour = 3600e6 / (BAL_PERIOD_US * TEST_DIV)
        a_det = family_alpha(p_fa, tests_per_hour)
        # the thrust balance's residual, and the rotor's when its speed is measured: one
        # of them is tested at a time (``axes["throttle"]``), so one budget
        self._thrust_axis = _Axis("throttle", window, alpha, a_det, floor=THR_RES_FLOOR,
                                  offset_sd=THR_OFFSET_SD, fit_noise=THR_FIT_NOISE)
        self._rotor_axis = _Axis("throttle", window, alpha, a_det, floor=model.rpm_res_floor,
                                 offset_sd=THR_OFFSET_SD, fit_noise=THR_FIT_NOISE,
                                 prior=RPM_RES_PRIOR, prior_n=RPM_RES_PRIOR_N, n_phi=3)
        self.axes = {"throttle": self._thrust_axis}
        self._lp = np.zeros(22)        # the signals low-passed, the rotor's, the signals (throttle_front)
        self._st = np.concatenate((lowpass_state(), (0, -1, 0)))
        self._mode = (_GIVEN if model.engine is not None else _ROTOR if model.prop_ixx > 0.0
                      else _LAGGED if model.tau_s > 0.0 else _GIVEN)
        self._thr_lag = 0.0            # a piston's command through its lag (tau_s; _piston)
        self._map = 0.0                # ... its manifold pressure [Pa]
        self._w_lp = [0.0, 0.0]        # ... its measured and model rotor speeds, low-passed
        self._k = 0
        self.frozen = False
        self.suspended = False
        self._fault_us = None
        self._model_arrays = (model._rotor, *model._cp_tables)     # (throttle_front's)
        # (autopilot.jit.preload: the balance's kernel loaded now, not on leaving the ground)
        preload(throttle_front, self._lp.copy(), self._st.copy(), 0, 20.0, True, NO_FORCE, 0.0, 0.5, 100.0,
                self._mode, *self._model_arrays)
        # (the electric rotor's kernels are compiled into throttle_front's: none of them
        # is called from Python in flight, none preloaded)

    def freeze(self, t_us: int) -> None:
        self.frozen = True
        self._thrust_axis.drop_waiting()
        self._rotor_axis.drop_waiting()
        self._fault_us = t_us - 1_000_000

    def suspend(self, on: bool) -> None:
        if on and not self.suspended:
            self._thrust_axis.drop_waiting()
            self._rotor_axis.drop_waiting()
        self.suspended = on

    def measure_rpm(self, t_us: int, rpm: float) -> None:
        """The rotor's speed measured at ``t_us`` [rpm] (ESC telemetry)."""
        self._lp[_RPM] = rpm * (2.0 * math.pi / 60.0)
        self._st[_RPM_US] = t_us

    @property
    def first_ident_s(self) -> float:
        """The monitor's first identification this long after the detection [s]."""
        return self.model.ident_s if self.rotor_measured else 1.0

    @property
    def rotor_measured(self) -> bool:
        """The rotor's residual is the one tested (a speed measured recently)."""
        return self.axes["throttle"] is self._rotor_axis

    def step(self, t_us: int, nav, controls: tuple, flying: bool, f_b) -> bool:
        """True where ``axes["throttle"].ratio`` may have changed: its window test ran
        (2 Hz) or the residual tested changed (the rotor's, the thrust balance's)."""
        V = nav.airspeed_mps
        st = self._st
        tested = self.axes["throttle"]
        flying = flying and f_b is not None
        thr = self.throttle_in(t_us, nav, controls, flying, f_b)
        # (the height only for the rotor's residual: where a speed was ever measured)
        due = throttle_front(self._lp, st, t_us, V, flying, NO_FORCE if f_b is None else f_b, controls[1], thr,
                             nav.alt_m if st[_RPM_US] >= 0 else 0.0, self._mode, *self._model_arrays)
        if due < 0:
            return False              # not flying: nothing moved
        return self.sample(t_us, tested, due > 0)

    def sample(self, t_us: int, tested, due: bool) -> bool:
        """After :func:`throttle_front` stepped, flying (``due``: a balance sample due;
        ``tested`` the axis tested before it): the axis tested now, and the balance's
        sample. As :meth:`step`."""
        st = self._st
        if self._mode == _ROTOR:
            # tested once its offset is learnt (before, the thrust balance's)
            self.axes["throttle"] = (self._rotor_axis if st[_LPR_ON] and self._rotor_axis.fitting
                                     else self._thrust_axis)
        switched = self.axes["throttle"] is not tested
        if not due:
            return switched
        m = self.model
        lp = self._lp.tolist()
        # the forces' variances about their low-passed values, over the same filter
        var_fz = max(lp[6] - lp[1] * lp[1], 0.0)
        var_fy = max(lp[7] - lp[5] * lp[5], 0.0)
        z = m.throttle_for(m.thrust(lp[3], lp[0], lp[1], lp[2], var_fz, var_fy), lp[3])
        self._k += 1
        k_test = self._k >= TEST_DIV
        if k_test:
            self._k = 0
        v_rel = lp[3] / V_REF - 1.0            # the offsets' regressor (1, v_rel[, z_rotor])
        learn = (None if self.frozen or self.suspended
                 else t_us - int(st[LP_T0]) >= FIT_WARMUP_S * 1e6)
        self._thrust_axis.step(t_us, v_rel, 0.0, z, lp[4], learn, k_test)
        if st[_LPR_ON] and t_us - int(st[_RPM_START]) >= 3.0 * RPM_TAU_S * 1e6:
            # its offset also on the throttle (a gain): the rotor model's error grows with
            # the power (the propeller's inflow along its axis, V cos(alpha), and JSBSim's
            # corrections not modelled: 0.02-0.04 of full throttle low at full)
            # (a piston's: no offset learnt, the variance only; module docstring)
            self._rotor_axis.step(t_us, v_rel, lp[_LPR1], lp[_LPR0], lp[_LPR1],
                                  learn and m.engine is None if learn is not None else None, k_test)
        return k_test or switched

    def throttle_in(self, t_us: int, nav, controls: tuple, flying: bool, f_b) -> float:
        """The throttle the thrust balance takes (``flying``: with a specific force
        ``f_b``): the command, or with a piston engine at 10 m/s or faster the engine's
        step (:meth:`_piston`)."""
        if self.model.engine is not None and flying and not nav.airspeed_mps < 10.0:
            return self._piston(t_us, nav, controls, float(f_b[2]))
        return controls[3]

    def _piston(self, t_us: int, nav, controls: tuple, fz: float) -> float:
        """A piston engine's step (module docstring): the rotor's residual from the
        measured rpm, tested from its first second (:meth:`step`); the command through
        ``tau_s`` returned for the thrust balance."""
        m = self.model
        lp, st = self._lp, self._st
        thr = float(controls[3])
        V = nav.airspeed_mps
        dt = 0.0 if not st[LP_ON] else (t_us - int(st[LP_T])) * 1e-6
        if not st[LP_ON]:
            self._thr_lag = thr
        elif dt > 0.0:
            self._thr_lag += dt / (m.tau_s + dt) * (thr - self._thr_lag)
        rpm_on = st[_RPM_US] >= 0 and t_us - int(st[_RPM_US]) <= RPM_TIMEOUT_S * 1e6
        if not rpm_on:
            st[_LPR_ON] = 0
        else:
            alt = nav.alt_m
            rho = _isa_rho(alt)
            rpm = float(lp[_RPM])
            vt = _inflow_tas(V, fz, float(controls[1]), rho, m.mass_kg, m.wing_area_m2, m.CL0, m.CLde, m.CLa)
            qbar = 0.5 * RHO0 * V * V
            if not st[_LPR_ON] or not st[LP_ON]:
                # the model rotor starts where it is measured, its manifold pressure the
                # one that gives the power its propeller takes there
                lp[_WR] = rpm
                z0 = m.piston_throttle(rpm, vt, alt, qbar)
                _rho, p_amb, _a, _t = _isa(alt)
                self._map = m.engine.map_steady(z0, rpm * (30.0 / math.pi), p_amb + m.engine.ram * qbar)
                lp[_LPR0] = lp[_LPR1] = z0
                st[_LPR_ON] = 1
                self._w_lp = [rpm, rpm]
                st[_RPM_START] = t_us
            elif dt > 0.0:
                wr, self._map = m.piston_step(float(lp[_WR]), self._map, thr, vt, alt, qbar, dt)
                lp[_WR] = wr
                # the speeds low-passed before the throttle is read from them: near full
                # throttle the manifold pressure hardly moves with the throttle, the
                # reading's noise (0.5 % of the rpm) is 0.04 of throttle there, and its
                # clipping at 1 read a stuck full throttle 0.02-0.04 low
                a = dt / (RPM_TAU_S + dt)
                wl = self._w_lp
                wl[0] += a * (rpm - wl[0])
                wl[1] += a * (wr - wl[1])
                lp[_LPR0] = m.piston_throttle(wl[0], vt, alt, qbar)
                lp[_LPR1] = m.piston_throttle(wl[1], vt, alt, qbar)
        # the rotor's residual tested whenever the speed is measured (the engine's and the
        # propeller's model from their files, not learnt: no warm-up on the thrust balance)
        self.axes["throttle"] = self._rotor_axis if st[_LPR_ON] else self._thrust_axis
        return self._thr_lag

    def worst(self) -> tuple[str, float]:
        return "throttle", self.axes["throttle"].ratio

    def identified(self, name: str = "throttle", stuck: bool = False) -> dict | None:
        """Stuck or weakened (:func:`.actuator.identify_hist`), the stuck position a
        fraction of full throttle.

        On the rotor's speed the two fits' residual sums of squares are compared at
        RPM_RSS_STUCK, not the surfaces' RSS_STUCK. The weakened hypothesis z = k d
        passes through zero, and the throttle is flown far from zero (0.3-0.9): where
        the command moves by a tenth of its level, k d is nearly a constant as well, and
        a stuck throttle's ratio of the two is about sigma^2 mean(d^2) / (s^2 var(d)),
        the residual's deviation sigma over the stuck position s, magnified by the
        command's mean square over its variance. Stuck at 0.3 from 60 s (default
        mission), seed 10: the command 0.48-0.76 over the 10 s after the onset (the
        airspeed over its demand at first), where the other nine seeds' ramped up
        towards full; its ratio after the onset's transient 0.69-0.99 to 7 s after the
        onset, then 0.19, 0.088, 0.059: read "effectiveness 0.572" 10 s after the onset
        at 0.05 (the nine read stuck by then, their ratios 0.009-0.10, or the command
        saturated, or k over K_MAX). A weakened throttle (0.3, 0.5, 0.7 from 60 s, seeds
        1-3: nine flights) read 3.2 at least after the transient, 0.52 over the whole
        window, at every reading to 10 s after the onset: on the rotor's clean residual
        (a deviation of 0.005, not the surfaces' balance, whose model errors go with the
        command) the two hypotheses stand apart by more than the factor 20, and 0.1
        keeps 30 and 5 times from those. On the thrust balance (no speed measured: a
        residual of 0.1, systematic) the surfaces' share.

        A piston (the c172p): its manifold pressure's lag and its heavy propeller make the
        onset's transient ``ident_s`` (4 s) long, and the late test starts there. A stuck
        throttle under what level flight needs pins the command at full within seconds,
        and a command that hardly moves leaves the two hypotheses apart by the reading's
        noise alone (z flat within 0.003): the share is PISTON_RSS_STUCK, 0.5, and the
        command's saturation is counted in that late window. Stuck at 0.3 from 100 s,
        seed 5, the command at 0.89-0.97 for 3 s before it stayed at full, read
        "effectiveness 0.398" 10 s after the onset at 0.1, stuck at 0.302 at 0.5. A
        weakened throttle (0.7, seeds 1 and 2) still reads weakened (0.742, 0.741) while
        its command moves; 0.5, whose command is at full at once, reads stuck at 0.50, the
        thrust it gives (as the Aerosonde's final readings)."""
        if self._fault_us is None:
            return None
        # the stuck position over the last IDENT_WIN_S; on the rotor's speed, which follows
        # the throttle within a second, over the last second
        rotor = self.rotor_measured
        win = self.model.ident_s - 1.0 if rotor else IDENT_WIN_S
        recent = None if self._st[LP_T0] < 0 else int(self._st[LP_T]) - int(win * 1e6)
        # (a piston's: the onset's transient its manifold pressure's and rotor's, ident_s
        # long, and the command's saturation counted after it, when the command has run
        # up to full: stuck at 0.3, seed 1, z flat at 0.30 from 5 s after the onset and
        # the command at full from 6.6 s read "effectiveness 0.41" 10 s after it with
        # the surfaces' 3 s and the whole window's saturation)
        piston = rotor and self.model.engine is not None
        r = identify_hist(self.axes["throttle"].hist, self._fault_us, stuck, recent, d_max=1.0,
                          rss_share=(PISTON_RSS_STUCK if piston else RPM_RSS_STUCK) if rotor else RSS_STUCK,
                          sat_late=piston, settle_s=self.model.ident_s if piston else SETTLE_S)
        if r is not None and "stuck_rad" in r:
            # the throttle is no angle: its stuck position as a fraction of full, clipped
            return {"stuck": round(min(max(r["stuck_rad"], 0.0), 1.0), 3)}
        return r
