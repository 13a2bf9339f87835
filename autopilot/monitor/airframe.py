"""The airframe as the fault monitor knows it: the pitch-axis coefficients of the
shipped aircraft, and the moment balance (B) of :mod:`.actuator` they predict.

The elevator identifier learns its balance online; with the airframe's own model as the
prior it is armed from launch instead of after a minute and a half of healthy flight.
The coefficients are those of the aircraft's JSBSim file (the Aerosonde of Beard &
McLain, Small Unmanned Aircraft, 2012, table E.2, in
``sim_bridge/aircraft/aerosonde/aerosonde.xml``; JSBSim's Cessna 172P, the jsbsim
package's ``aircraft/c172p/c172p.xml``: :data:`C172P`; tests/test_monitor_airframe.py
reads the files and checks they agree). The autopilot does not read the simulator's file: a
real aircraft's autopilot carries its airframe's model, it does not open the wind
tunnel's.

Derivation (book sign convention: ``de > 0`` trailing edge down, nose down; the
autopilot's elevator is nose-up positive, ``delta = -de``). Quasi-steady pitch (q ~ 0,
q_dot ~ 0) and lift in the linear range::

    Cm0 + Cma alpha + Cmde de = -(thrust moment) / (qbar S cbar)
    CL0 + CLa alpha + CLde de = CL_req = n m g / (qbar S)

Eliminating alpha, with ``qbar = rho0 V^2 / 2`` (V the equivalent airspeed) so that
``CL_req = CL_ref n (V_ref / V)^2``, ``CL_ref = m g / (qbar_ref S)``::

    delta = [Cm0 + (Cma / CLa) (CL_req - CL0) + C_T] / (Cmde - Cma CLde / CLa)

which is (B), ``delta = c_0 + c_L (n (V_ref / V)^2 - 1) + c_t throttle (V_ref / V)^2``,
with::

    c_0 = [Cm0 + (Cma / CLa) (CL_ref - CL0)] / D,    c_L = (Cma / CLa) CL_ref / D,
    c_t = T_max z_T / (qbar_ref S cbar) / D,         D = Cmde - Cma CLde / CLa

(z_T: the thrust line's distance below the CG; a thrust T_max at full throttle,
``throttle (V_ref / V)^2`` approximating the thrust over the dynamic pressure). The
Aerosonde's thrust line passes through its CG (z_T = 0): c_t = 0, learnt online if the
aircraft disagrees.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from autopilot.jit import kernel

G0 = 9.80665          # [m/s^2]
RHO0 = 1.225          # sea-level ISA density [kg/m^3]

# a propeller's numbers as the balances' kernels take them (PitchAero.gyro_coefs,
# lateral.LateralAero.prop_coefs): its rpm fit's a, b, c, d and e (the throttle's square),
# prop_sense * prop_ixx, and the pitch model's wing area, chord and D
_RPM_A, _RPM_B, _RPM_C, _RPM_D, _RPM_E, _SENSE_IXX, _AREA, _CHORD, _DEN = range(9)


@kernel
def prop_momentum(c, throttle, v_mps):
    """The propeller's angular momentum H [N m s] at that throttle and airspeed,
    ``prop_sense prop_ixx omega``, omega from the rpm fit
    ``a + b throttle + c V + d throttle V (+ e throttle^2)``, at least 0; 0 without a
    rotating inertia."""
    if c[_SENSE_IXX] == 0.0:
        return 0.0
    rpm = c[_RPM_A] + c[_RPM_B] * throttle + c[_RPM_C] * v_mps + c[_RPM_D] * throttle * v_mps
    if c[_RPM_E] != 0.0:
        rpm = rpm + c[_RPM_E] * throttle * throttle
    rpm = 0.0 if 0.0 > rpm else rpm               # max(rpm, 0) (control/pid.py)
    return c[_SENSE_IXX] * rpm * (2.0 * math.pi / 60.0)


@kernel
def gyro_elevator(c, r, throttle, v_mps):
    """The elevator the propeller's gyroscopic moment ``H r`` takes off the pitch
    balance (PitchAero.gyro_elevator): ``H r / (qbar S cbar) / D``."""
    if c[_SENSE_IXX] == 0.0:
        return 0.0
    H = prop_momentum(c, throttle, v_mps)
    qbar = 0.5 * RHO0 * v_mps * v_mps
    # Cm0 + Cma alpha + Cmde de = m_dyn - H r / (qbar S cbar): as dynamic_elevator
    return (H * r / (qbar * c[_AREA] * c[_CHORD])) / c[_DEN]


@dataclass(frozen=True)
class PitchAero:
    """Pitch-axis model of an airframe (book sign convention, per rad)."""

    name: str
    mass_kg: float
    wing_area_m2: float
    chord_m: float
    Cm0: float
    Cma: float
    Cmde: float
    CL0: float
    CLa: float
    CLde: float
    Iyy: float = 0.0               # pitch moment of inertia [kg m^2]
    Cmq: float = 0.0               # pitch damping [1/rad]
    thrust_max_n: float = 0.0      # static thrust at full throttle [N]
    thrust_z_m: float = 0.0        # thrust line below the CG [m]
    v_level_min_mps: float = 0.0   # slowest level flight (stall) [m/s, equivalent]
    v_level_max_mps: float = 1e9   # fastest level flight at full throttle [m/s, equivalent]
    prop_ixx: float = 0.0          # rotating inertia of propeller, hub and motor rotor [kg m^2]
    prop_sense: float = 1.0        # its spin about body x (the engine file's <sense>)
    rpm: tuple = (0.0, 0.0, 0.0, 0.0)   # propeller rpm ~ a + b throttle + c V + d throttle V
    wash: float = 1.0              # the elevator's dynamic pressure over the free stream's
                                   # (the propeller's slipstream over the tail)
    de_per_rad: float = 1.0        # the surface's deflection per autopilot radian (the
                                   # normalised command times MAX_DEFLECTION_RAD)

    @cached_property
    def D(self) -> float:
        """The elevator's moment per autopilot radian less its lift's through alpha,
        ``Cmde wash g - (Cma / CLa) CLde g`` (g = :attr:`de_per_rad`)."""
        g = self.de_per_rad
        return self.Cmde * self.wash * g - self.Cma / self.CLa * (self.CLde * g)

    def balance(self, v_ref: float) -> np.ndarray:
        """[c_0, c_L, c_t] of the balance (B) at the reference airspeed (module doc)."""
        qbar = 0.5 * RHO0 * v_ref * v_ref
        cl_ref = self.mass_kg * G0 / (qbar * self.wing_area_m2)
        k = self.Cma / self.CLa
        D = self.D
        c0 = (self.Cm0 + k * (cl_ref - self.CL0)) / D
        cL = k * cl_ref / D
        ct = self.thrust_max_n * self.thrust_z_m / (qbar * self.wing_area_m2 * self.chord_m) / D
        return np.array([c0, cL, ct])

    def dynamic_elevator(self, q: float, q_dot: float, v_mps: float) -> float:
        """The elevator (nose-up positive, rad) a pitch rate q and pitch acceleration
        q_dot add to the quasi-steady balance: the pitch moment equation with its
        inertia and damping terms, ``Cm0 + Cma alpha + Cmde de = Iyy q_dot / (qbar S
        cbar) - Cmq cbar q / (2 V)``, through the same elimination of alpha (the lift
        of the pull-up is in the measured load factor already)."""
        if self.Iyy <= 0.0:
            return 0.0
        qbar = 0.5 * RHO0 * v_mps * v_mps
        m_dyn = (self.Iyy * q_dot / (qbar * self.wing_area_m2 * self.chord_m)
                 - self.Cmq * self.chord_m * q / (2.0 * v_mps))
        return -m_dyn / self.D

    @cached_property
    def gyro_coefs(self) -> np.ndarray:
        """The propeller's and the pitch balance's numbers as :func:`prop_momentum` and
        :func:`gyro_elevator` take them."""
        a, b, c, d = self.rpm
        return np.array((a, b, c, d, 0.0, self.prop_sense * self.prop_ixx if self.prop_ixx > 0.0 else 0.0,
                         self.wing_area_m2, self.chord_m, self.D))

    def prop_momentum(self, throttle: float, v_mps: float) -> float:
        """The propeller's angular momentum H [N m s] at that throttle and airspeed
        (``prop_ixx`` times its speed from :attr:`rpm`); its gyroscopic moments on the
        airframe are ``H r`` in pitch and ``-H q`` in yaw (:meth:`gyro_elevator`)."""
        return prop_momentum(self.gyro_coefs, throttle, v_mps)

    def gyro_elevator(self, r: float, throttle: float, v_mps: float) -> float:
        """The elevator (nose-up positive, rad) the propeller's gyroscopic moment takes
        off the balance at yaw rate r [rad/s]: a rotor of angular momentum H along body
        x pitches the airframe by ``H r`` (the reaction to turning its spin axis; JSBSim
        applies it as ``moments/m-prop``), nose up in a right turn for a propeller turning
        clockwise seen from behind. ``H = prop_ixx * omega``, the speed from the rpm the
        throttle and airspeed give (:attr:`rpm`, measured on the plant). In the Aerosonde's
        turns (r 0.1-0.3 rad/s, about 7000 rpm: H 2.2 N m s) it is 0.2-0.7 N m, 0.01-0.02
        rad of elevator: the error the stuck readings had in turns (:func:`gyro_elevator`)."""
        return gyro_elevator(self.gyro_coefs, r, throttle, v_mps)

    def trim_airspeed(self, delta: float, n: float = 1.0, v_ref: float = 25.0) -> float | None:
        """The equivalent airspeed at which an elevator held at ``delta`` (nose-up
        positive, rad) balances load factor n (c_t = 0: the throttle does not enter);
        None where no airspeed does (the lift would have to be negative)."""
        c = self.balance(v_ref)
        r2 = (delta - c[0] + c[1]) / (c[1] * n)     # (V_ref / V)^2
        if r2 <= 0.0:
            return None
        return v_ref / r2 ** 0.5

    def elevator_for(self, n: float, v_mps: float, throttle: float = 0.0) -> float:
        """Elevator (nose-up positive, rad) that balances load factor n at airspeed V
        (and the thrust's moment at that throttle, where the thrust line is off the CG)."""
        c = self.balance(v_mps)
        if throttle:
            return float(c[0] + c[1] * (n - 1.0) + c[2] * throttle)
        return float(c[0] + c[1] * (n - 1.0))


# the Aerosonde (sim_bridge/aircraft/aerosonde/aerosonde.xml: metrics, mass_balance,
# aero/aerosonde/CL-linear, lift-elevator, pitch-basic, pitch-elevator; the thruster at
# z = 0 with the CG)
AEROSONDE = PitchAero("aerosonde", mass_kg=13.5, wing_area_m2=0.55, chord_m=0.18994,
                      Cm0=-0.02338, Cma=-0.38, Cmde=-0.5, CL0=0.28, CLa=3.45, CLde=-0.36,
                      Iyy=1.135, Cmq=-3.6,
                      v_level_min_mps=15.3, v_level_max_mps=34.5,
                      # sim_bridge/aircraft/engine/APC_18x8E.xml <ixx>, the thruster's <sense>;
                      # rpm fitted to the plant trimmed at 18-33 m/s, throttle 0-1 held 1.5 s
                      # (36 points, 98 rpm rms, 205 at most)
                      prop_ixx=3.0e-3, prop_sense=1.0, rpm=(728.6, 4696.3, 201.04, -93.43))

# JSBSim's Cessna 172P (the jsbsim package's aircraft/c172p/c172p.xml; the simulator
# flies that file, the autopilot carries these numbers, tests/test_monitor_airframe.py
# reads the file and checks them). Feet, slugs and pounds converted once, here.
#
# * Mass: the empty weight 1500 lb, the pilot's point mass 180 lb and the two tanks'
#   100 lb each (the other point masses weigh nothing): 1880 lb. CG at x 42.12 in,
#   z 37.74 in (structural frame, x aft, z up); Iyy 1384.3 slug ft^2 with the point
#   masses and the fuel (JSBSim's inertia/iyy-slugs_ft2).
# * metrics: wing area 174 ft^2, chord 4.9 ft.
# * Lift: the CLwbh table's linear range, 0.25 at alpha 0 and 0.73 at 0.09 rad (CL0
#   0.25, CLa 5.333); CLDe 0.43 on the free stream's dynamic pressure.
# * Pitch: Cmo 0.1, Cmalpha -1.8 about the aerodynamic reference point (AERORP, x
#   43.2 in, z 59.4 in), moved to the CG: the lift acts 1.08 in behind it (nose down)
#   and the drag 21.7 in above it (nose up), ``Cm_cg = Cmo + Cmalpha alpha - (x_a /
#   cbar)(CL cos alpha + CD sin alpha) + (z_a / cbar)(CD cos alpha - CL sin alpha)``,
#   a line through alpha 0..0.09 of the tables (CDo 0.027 + CDwbh): Cm0 0.1085, Cma
#   -2.001 (within 0.0013 of the curve). Cmq -12.4 (ci2vel, as the model's cbar q / 2V).
#   Cmadot (-7.27) is left out: in the quasi-steady balance alpha does not change.
# * The elevator, Cmde -1.122, acts on ``aero/function/qbar-induced-psf``: the dynamic
#   pressure of the free stream plus the propeller's slipstream, which by JSBSim's
#   momentum theory (u + 2 v_i)^2 = u^2 + 2 T / (rho A) is ``qbar + T / A`` (A the
#   75 in disc). The wash 1.245 is that ratio at the cruise trim (45 m/s equivalent,
#   0.65 throttle); in level flight it is 1 + S C_D / A (1.20 at 65 m/s, 1.40 at 35), at
#   full throttle in the climb-out 1.6-2.0. It multiplies the elevator's moment, and the
#   balance (B) is linear: there the model reads the surface 0.005-0.011 rad off, and
#   in slow flight at full throttle (25-30 m/s) about twice a nose-up deflection
#   (docs/monitor.md).
# * The autopilot's elevator: +1 nose up is fcs/elevator-cmd-norm -1, which the FCS
#   maps to -28 deg, and -1 nose down to +23 deg; the monitor counts 0.35 rad per
#   normalised command (its rad for the c172p, as the fault scenarios' value_rad). The
#   balance is linear in one gain: 23 deg per 0.35 rad, 1.147, the side the c172p flies
#   on from 38 m/s up; nose up the surface moves 22 % more than that.
# * Thrust: the thruster at z 26.6 in, 11.1 in (0.283 m) below the CG, a nose-up
#   moment; the full-throttle thrust measured on the plant, 2000-2250 N at 25-65 m/s
#   (800 m).
# * Level flight from 24 m/s (equivalent: the stall) to 69 m/s (full throttle), the
#   plant's trims 300 m above a 500 m home.
C172P = PitchAero("c172p", mass_kg=1880 * 0.45359237, wing_area_m2=174 * 0.09290304,
                  chord_m=4.9 * 0.3048, Cm0=0.1085, Cma=-2.001, Cmde=-1.122,
                  CL0=0.25, CLa=(0.73 - 0.25) / 0.09, CLde=0.43,
                  Iyy=1384.3 * 1.3558179, Cmq=-12.4,
                  thrust_max_n=2200.0, thrust_z_m=(37.74 - 26.6) * 0.0254,
                  v_level_min_mps=24.0, v_level_max_mps=69.0,
                  wash=1.245, de_per_rad=23.0 * 0.01745 / 0.35)

# FDI_EL_MODEL -> the airframe whose model is the elevator identifier's prior (0: none,
# the balance is learnt in flight from nothing)
MODELS = {1: AEROSONDE, 2: C172P}
