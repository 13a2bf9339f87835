"""JSBSim fixed-wing plant: the project's Aerosonde (or JSBSim's stock c172p).

The aircraft is a JSBSim model; this class is the only place that talks to JSBSim.
Feet, slugs, pounds and Rankine are converted to SI once, where they are read;
everything leaving the class follows ``sim_bridge.plants.base`` (SI, radians, NED,
FRD, ``q_nb`` scalar-first Hamilton body->NED, longitude wrapped to (-pi, pi]).

Airframes
    ``"aerosonde"``  Beard & McLain (2012) Appendix E, ``sim_bridge/aircraft/aerosonde``.
    ``"c172p"``      JSBSim's Cessna 172P, from the jsbsim package.

Start and launch
    *Aerosonde, catapult.* The aircraft starts at rest on a launcher at home: a rail
    ``LAUNCHER_HEIGHT_M`` above the ground, pointing along the home heading. The deck is
    modelled as raised terrain under the cradle shoes, so the aircraft truly rests on
    it (``on_ground`` True, specific force (0, 0, -g), zero rates apart from the
    Earth's rotation) about 4 deg nose up; the launcher's release latch (an external
    force cancelling the thrust) and the shoes' friction hold it against the running
    propeller. The catapult fires when ``launch()`` is called, or by itself once
    the throttle command has stayed above ``AUTO_LAUNCH_THROTTLE`` for ``SPIN_UP_S``
    (the propeller reaches power first, as on a real launcher). It pushes with
    ``CATAPULT_FORCE_N`` along body x for ``RAIL_LENGTH_M`` (0.29 s, about 8 g); the
    aircraft leaves the rail at 21.9 m/s, 1.4 times its minimum level-flight speed
    (14.9 m/s at sea level, 15.3 m/s at 500 m, where the elevator runs out at
    alpha 23 deg), the launcher is removed (terrain back at home altitude) and the
    autopilot climbs out at full throttle (steady climb 4.0 m/s at 20 m/s, pitch
    22 deg, alpha 10.5 deg).
    *c172p, runway.* The aircraft starts at rest on its wheels at home with the
    brakes set; the brakes are released by ``launch()`` or when the throttle command
    first exceeds ``AUTO_LAUNCH_THROTTLE``, and the autopilot takes off on the wheels.
    After the start, any ground contact (terrain at home altitude, or the terrain
    model's height under the aircraft, ``terrain``) ends at rest: the
    Aerosonde's contact points (cradle shoes, nose, tail, wing tips, top) slide with
    friction and keep it above ground at any attitude, whatever the impact.

Controls (``PlaneControls``, as documented in base.py) map to JSBSim commands:
aileron +1 -> fcs/aileron-cmd-norm +1 (roll right); elevator +1 (nose up) ->
fcs/elevator-cmd-norm -1 (JSBSim's positive elevator is stick forward, nose down);
rudder +1 (nose right) -> fcs/rudder-cmd-norm -1 (JSBSim's positive rudder deflection
yaws the nose left in both airframes), and the nose wheel with it, rudder +1 ->
fcs/steer-cmd-norm +1 (nose right, as the c172p's pedals steer it; the Aerosonde's
contacts do not steer, so it has none); throttle 0..1 -> fcs/throttle-cmd-norm.
Table E.2 makes the Aerosonde's rudder a stronger roll than yaw effector
(C_ldr 0.105, C_ndr -0.032): rudder +1 yaws the nose right but also rolls left.

Wind: ``wind_ned`` is the velocity of the air over ground (wind from the west is
+east). Turbulence is MIL-F-8785C Dryden turbulence at the specification's 20 ft wind
speeds (light 15 kt, moderate 30 kt, severe 45 kt), computed by
``sim_bridge.wind.DrydenGusts`` from the injected ``numpy.random.Generator`` and fed to
JSBSim's gust input. JSBSim's own MIL-F-8785C turbulence (``atmosphere/turb-type`` 3/4)
is not used: its filters take the airspeed *including* the turbulence, and when the
gust dominates the airspeed (a slow, tumbling or crashed aircraft) that feedback
diverges; gusts of over 100 m/s were measured after a spin into the ground in severe
turbulence. The gust model takes the airspeed relative to the steady wind instead.

JSBSim's own trim cannot trim the Aerosonde (its one-control-per-axis iteration does
not converge with Table E.2's strong aileron-yaw and rudder-roll coupling), so
``trim()`` solves all six body accelerations at once by Newton's method.
"""
from __future__ import annotations

import math
import os
import warnings
from dataclasses import dataclass
from operator import add
from pathlib import Path

import jsbsim
import numpy as np

from sim_bridge.plants.base import PlantState, PlaneControls
from sim_bridge.wind import TURBULENCE_W20_KT, DrydenGusts, gust_advance

AIRCRAFT_DIR = Path(__file__).resolve().parent.parent / "aircraft"

# Unit conversions, applied once where JSBSim values are read or written.
FT_M = 0.3048                       # [m/ft]
LBF_N = 4.4482216152605             # [N/lbf]
SLUGFT3_KGM3 = 515.378818           # [(kg/m^3)/(slug/ft^3)]
PSF_PA = 47.880258888889            # [Pa/psf]
RANKINE_K = 5.0 / 9.0               # [K/R]
KT_MPS = 1852.0 / 3600.0            # [(m/s)/kt]

# Aerosonde launcher.
LAUNCHER_HEIGHT_M = 1.5             # rail deck above the ground at home [m]
RAIL_LENGTH_M = 3.0                 # catapult stroke [m]
CATAPULT_FORCE_N = 1000.0           # catapult push along body x [N]
AUTO_LAUNCH_THROTTLE = 0.5          # throttle command that arms the launch
SPIN_UP_S = 1.0                     # propeller spin-up before an automatic release [s]

# JSBSim's ground reactions (every contact point's height over the terrain, each JSBSim
# step) are a third of its step; clear of the ground their forces are zero, so they are
# switched off while no contact can reach the ground within a step() call: above
# CONTACT_REACH_M plus MAX_SPEED_MPS times the call's time (the contacts' distance from
# the CG at any attitude with a margin; a speed no airframe here reaches).
CONTACT_REACH_M = 10.0              # [m]
MAX_SPEED_MPS = 150.0               # [m/s]

_HELD, _FIRING, _FREE = "held", "firing", "free"
_ZERO6 = (0.0,) * 6
# a property node's value, unbound: map(_read, nodes) reads a tuple of nodes from C, no
# Python frame or bound method per read
_read = jsbsim.FGPropertyNode.get_double_value
_TWO_PI = 2.0 * math.pi


@dataclass(frozen=True, slots=True)
class _Airframe:
    """What differs between the airframes this plant can fly."""

    model: str
    own_files: bool                 # shipped in sim_bridge/aircraft (else JSBSim's)
    catapult: bool                  # starts on the catapult (else on its wheels)
    brakes: tuple[str, ...]         # brake commands that hold it at the start
    steers: bool                    # a nose wheel steered with the rudder
    bogeys: tuple[int, ...]         # gear units it rests on (front one = largest x)
    has_esc: bool                   # FCS has fcs/esc-limit-off (see aerosonde.xml)
    settle_s: float                 # time to come to rest at the start [s]


_AIRFRAMES = {
    "aerosonde": _Airframe("aerosonde", True, True, (), False,
                           (0, 1, 2), True, 1.0),
    "c172p": _Airframe("c172p", False, False,
                       ("fcs/left-brake-cmd-norm", "fcs/right-brake-cmd-norm"), True,
                       (0, 1, 2), False, 6.0),
}


class JSBSimPlane:
    """A fixed-wing aircraft flown by JSBSim, behind the ``Plant`` protocol."""

    def __init__(
        self,
        airframe: str = "aerosonde",
        home: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0),
        dt_s: float = 1.0 / 200.0,
        wind_ned=(0.0, 0.0, 0.0),
        turbulence: str = "none",
        rng: np.random.Generator | None = None,
    ) -> None:
        if airframe not in _AIRFRAMES:
            raise ValueError(f"unknown airframe {airframe!r}; known: {sorted(_AIRFRAMES)}")
        self._af = _AIRFRAMES[airframe]
        self.airframe = airframe
        lat_deg, lon_deg, alt_m, heading_deg = home
        self.home = (float(lat_deg), float(lon_deg), float(alt_m), float(heading_deg))
        self._dt_us = int(round(dt_s * 1e6))
        if self._dt_us <= 0:
            raise ValueError("dt_s must be at least 1 us")
        self.dt_s = self._dt_us * 1e-6
        self._t_us = 0
        rng = rng if rng is not None else np.random.default_rng(0)

        jsbsim.FGJSBBase().debug_lvl = 0          # no banner, no load chatter
        fdm = jsbsim.FGFDMExec(None)
        if self._af.own_files:
            fdm.set_aircraft_path(str(AIRCRAFT_DIR))
            fdm.set_engine_path(str(AIRCRAFT_DIR / "engine"))
            fdm.set_systems_path(str(AIRCRAFT_DIR))
        if not fdm.load_model(self._af.model):
            raise RuntimeError(f"JSBSim could not load {self._af.model}")
        self._silence_outputs(fdm)
        fdm.set_dt(self.dt_s)
        self._fdm = fdm
        self._bind_nodes()

        self._wind_ned = np.zeros(3)
        self._turbulence = "none"
        self._gusts = DrydenGusts(rng, self.dt_s)
        self._gust_wind = (0.0, 0.0, 0.0)         # the gusts' steady wind, NED floats [m/s]
        self._phase = _HELD
        self._armed_us: int | None = None
        self._rail_start_ecef_ft = (0.0, 0.0, 0.0)
        self._controls = PlaneControls()
        # the ground's height [m MSL] under the aircraft once it is free: a callable
        # (lat_deg, lon_deg) -> metres or None (autopilot.geo.terrain); None: flat at home
        self.terrain = None
        self._set_wind_values(wind_ned, turbulence)
        self._place_at_start()

    # ------------------------------------------------------------------ public API

    @property
    def t_us(self) -> int:
        """Simulation time [us], exact (integer steps of dt)."""
        return self._t_us

    @property
    def on_launcher(self) -> bool:
        """True until the catapult has fired (or the brakes are released)."""
        return self._phase != _FREE

    # ``step`` reports the body rates and specific force as their mean over its last
    # ``imu_mean_steps`` steps (the HIL bridge sets its period: an IMU integrates over
    # its sample interval). On the ground at full throttle JSBSim's contact springs
    # chatter at the step rate, +-1.7 m/s^2 and +-0.7 deg/s from one step to the next:
    # a point sample every second step reads that as a steady lateral force and roll
    # rate the aircraft does not have; the mean is right.
    imu_mean_steps = 1

    def state(self) -> PlantState:
        """The true state now, in SI units (see base.PlantState)."""
        return self._readout(_ZERO6, 1)

    def _readout(self, imu_sums: tuple, n_mean: int) -> PlantState:
        """The state now, its body rates and specific force the means over ``n_mean``
        steps: this one's and the earlier ones' sums ``imu_sums`` (p, q, r, ax, ay, az
        in JSBSim's units; with ``n_mean`` 1, this step's values as read)."""
        (lat, lon, alt, vn, ve, vd, phi, theta, psi, p, q, r, ax, ay, az, wn, we, wd,
         vt, alpha, beta, fx_gear, fz_gear, rho, pressure, temperature, rpm, agl) = map(
            _read, self._state_nodes)
        if n_mean > 1:
            sum_p, sum_q, sum_r, sum_ax, sum_ay, sum_az = imu_sums
            p, q, r = (sum_p + p) / n_mean, (sum_q + q) / n_mean, (sum_r + r) / n_mean
            ax, ay, az = (sum_ax + ax) / n_mean, (sum_ay + ay) / n_mean, (sum_az + az) / n_mean
        cr, sr = math.cos(0.5 * phi), math.sin(0.5 * phi)
        cp, sp = math.cos(0.5 * theta), math.sin(0.5 * theta)
        cy, sy = math.cos(0.5 * psi), math.sin(0.5 * psi)
        # q_nb: Euler 3-2-1 (yaw, pitch, roll) -> body->NED quaternion, scalar first:
        # cr cp cy + sr sp sy, sr cp cy - cr sp sy, cr sp cy + sr cp sy, cr cp sy - sr sp cy
        # (each product of three taken as its roll-pitch pair times the yaw term)
        crcp, srsp, srcp, crsp = cr * cp, sr * sp, sr * cp, cr * sp
        q_nb = (crcp * cy + srsp * sy, srcp * cy - crsp * sy,
                crsp * cy + srcp * sy, crcp * sy - srsp * cy)
        lon = math.remainder(lon, _TWO_PI)       # wrapped to (-pi, pi]
        if lon == -math.pi:
            lon = math.pi
        # kept for the next step's gust and contacts: JSBSim's state does not change in
        # between (the places that set it, the start and trim, read it again)
        self._v_ned = v_ned = (vn * FT_M, ve * FT_M, vd * FT_M)
        self._agl_m = agl * FT_M
        return PlantState.make(                   # (positional: no keyword dict built)
            self._t_us, lat, lon, alt,
            v_ned, q_nb, (p, q, r),               # v_ned q_nb omega_b
            (ax * FT_M, ay * FT_M, az * FT_M), (wn * FT_M, we * FT_M, wd * FT_M),   # f_b wind_ned
            vt * FT_M, alpha, beta,               # airspeed_mps, alpha_rad, beta_rad
            abs(fz_gear) + abs(fx_gear) > 1e-9,   # on_ground
            rho * SLUGFT3_KGM3, pressure * PSF_PA, temperature * RANKINE_K, rpm)

    def step(self, controls: PlaneControls, n_steps: int = 1) -> PlantState:
        """Hold ``controls`` for ``n_steps`` JSBSim steps and return the new state."""
        self._apply_controls(controls)
        run = self._fdm.run
        # the gust advances once per call, over the n steps (its correlation lengths are
        # tens to hundreds of metres: 0.25 m of flight per JSBSim step changes nothing)
        gusts = self._gusts
        if gusts.active and not (self._phase == _HELD and self._af.catapult):
            # over the height above the terrain, at the speed through the steady wind
            vn, ve, vd = self._v_ned
            wn, we, wd = self._gust_wind
            du, dv, dw = vn - wn, ve - we, vd - wd
            row = gusts.next_row()                # (before the noise is read: it may draw)
            self._write_gust(gust_advance(gusts.s, row, self._agl_m,
                                          math.sqrt(du * du + dv * dv + dw * dw), n_steps))
        # (a terrain model moves the ground under the aircraft: the contacts stay on.
        # Free of the launcher, its latch and catapult pushed nothing at the last JSBSim
        # step, the release's, nor will again.)
        held = self._phase != _FREE
        self._set_reactions(held or self.terrain is not None
                            or self._agl_m <= CONTACT_REACH_M + MAX_SPEED_MPS * n_steps * self.dt_s,
                            held)
        if self.terrain is not None and self._phase == _FREE:
            fdm = self._fdm
            h = self.terrain(fdm["position/lat-geod-deg"], fdm["position/long-gc-deg"])
            fdm["position/terrain-elevation-asl-ft"] = (self.home[2] if h is None else h) / FT_M
        imu = self._imu_nodes
        n_mean = self.imu_mean_steps
        n_mean = n_steps if n_steps < n_mean else n_mean    # min() (autopilot/control/pid.py)
        # the means' earlier steps summed here; the last step's read with the state
        first, last = n_steps - n_mean, n_steps - 1
        acc = _ZERO6                              # sums of p, q, r, ax, ay, az
        for k in range(n_steps):
            if self._phase != _FREE:
                self._launcher_logic(controls.throttle)
            run()
            self._t_us += self._dt_us
            if first <= k < last:
                acc = tuple(map(add, acc, map(_read, imu)))
        return self._readout(acc, n_mean)

    def set_wind(self, wind_ned, turbulence: str = "none") -> None:
        """Steady wind, the air's velocity over ground NED [m/s], and turbulence level."""
        self._set_wind_values(wind_ned, turbulence)
        self._apply_wind()

    def launch(self) -> None:
        """Fire the catapult now (Aerosonde) or release the brakes (c172p)."""
        if self._phase != _HELD:
            return
        for brake in self._af.brakes:
            self._fdm[brake] = 0.0
        if not self._af.catapult:
            self._phase = _FREE
            return
        n = self._n
        self._rail_start_ecef_ft = (n["ecef_x"](), n["ecef_y"](), n["ecef_z"]())
        self._fdm["fcs/launcher-latch"] = 0.0
        self._fdm["fcs/catapult-force-lbs"] = CATAPULT_FORCE_N / LBF_N
        self._phase = _FIRING
        self._apply_wind()

    def trim(self, airspeed_mps: float = 22.0, height_m: float = 100.0) -> PlaneControls:
        """Restart in trimmed wings-level flight and return the controls that hold it.

        The aircraft is placed ``height_m`` above home, at the home position and
        heading, flying level at true airspeed ``airspeed_mps`` relative to the air
        mass (the current wind is added to its ground velocity); the launcher is
        removed. In still air the six body accelerations are driven to zero with
        alpha, beta, throttle, elevator, aileron and rudder (bank and flight path angle
        zero, no rotation) by Newton's method on JSBSim's own accelerations. The clock
        runs on (``t_us`` is not reset). Raises RuntimeError if no trim exists (the
        aircraft is then put back at rest on its launcher or runway).
        """
        fdm = self._fdm
        self._phase = _FREE
        if self._af.catapult:
            fdm["fcs/catapult-force-lbs"] = 0.0
            fdm["fcs/launcher-latch"] = 0.0
        for brake in self._af.brakes:
            fdm[brake] = 0.0
        for name in ("fcs/pitch-trim-cmd-norm", "fcs/roll-trim-cmd-norm",
                     "fcs/yaw-trim-cmd-norm"):
            fdm[name] = 0.0
        self._gusts.reset()                       # trim in still air
        self._write_gust((0.0, 0.0, 0.0))
        fdm.get_propulsion().init_running(-1)

        def residual(x: np.ndarray) -> np.ndarray:
            self._set_flight_ic(height_m, airspeed_mps, x)
            fdm.run_ic()
            fdm.get_propulsion().get_steady_state()
            fdm.run_ic()
            return np.array([
                fdm["accelerations/udot-ft_sec2"] * FT_M,
                fdm["accelerations/vdot-ft_sec2"] * FT_M,
                fdm["accelerations/wdot-ft_sec2"] * FT_M,
                fdm["accelerations/pdot-rad_sec2"],
                fdm["accelerations/qdot-rad_sec2"],
                fdm["accelerations/rdot-rad_sec2"],
            ])

        # unknowns: alpha, beta [rad]; JSBSim throttle, elevator, aileron, rudder cmds
        lower = np.array([-0.3, -0.3, 0.0, -1.0, -1.0, -1.0])
        upper = np.array([0.4, 0.3, 1.0, 1.0, 1.0, 1.0])
        delta = np.array([1e-4, 1e-4, 1e-3, 1e-3, 1e-3, 1e-3])
        x = np.array([0.05, 0.0, 0.5, 0.0, 0.0, 0.0])
        # JSBSim's propeller steady-state search marches in 0.5 s steps and diverges
        # from a stopped propeller: spin it up in real time first (run_ic() keeps the
        # propeller speed, so where the airframe goes meanwhile does not matter).
        self._set_flight_ic(height_m, airspeed_mps, x)
        fdm.run_ic()
        for _ in range(int(round(2.0e6 / self._dt_us))):
            fdm.run()
        if self._af.has_esc:
            fdm["fcs/esc-limit-off"] = 1.0
        r = residual(x)
        for _ in range(40):
            if not np.all(np.isfinite(r)) or np.max(np.abs(r)) < 1e-5:
                break
            jac = np.empty((6, 6))
            for j in range(6):
                xj = x.copy()
                xj[j] += delta[j]
                jac[:, j] = (residual(xj) - r) / delta[j]
            dx = np.linalg.lstsq(jac, -r, rcond=None)[0]
            # damped step: at most 0.1 in any unknown per iteration
            dx *= min(1.0, 0.1 / max(np.max(np.abs(dx)), 1e-12))
            x = np.clip(x + dx, lower, upper)
            r = residual(x)
        if self._af.has_esc:
            fdm["fcs/esc-limit-off"] = 0.0
        if not np.all(np.isfinite(r)) or np.max(np.abs(r)) > 1e-3:
            self._place_at_start()
            raise RuntimeError(
                f"no trim at {airspeed_mps} m/s: residual {np.array2string(r, precision=4)}")

        # Restart from the trimmed state with the wind added to the ground velocity.
        theta, psi = fdm["attitude/theta-rad"], fdm["attitude/psi-rad"]
        uvw_air = np.array((fdm["velocities/u-fps"], fdm["velocities/v-fps"],
                            fdm["velocities/w-fps"]))
        self._set_flight_ic(height_m, airspeed_mps, x)
        wind_fps = self._wind_ned / FT_M
        fdm["ic/vw-mag-fps"] = math.hypot(wind_fps[0], wind_fps[1])
        fdm["ic/vw-dir-deg"] = math.degrees(math.atan2(wind_fps[1], wind_fps[0]))
        fdm["ic/phi-rad"] = 0.0
        fdm["ic/theta-rad"] = theta
        fdm["ic/psi-true-rad"] = psi
        ct, st, cp, sp = math.cos(theta), math.sin(theta), math.cos(psi), math.sin(psi)
        r_bn = np.array(((ct * cp, ct * sp, -st),          # NED -> body at zero bank
                         (-sp, cp, 0.0),
                         (st * cp, st * sp, ct)))
        uvw = uvw_air + r_bn @ wind_fps
        fdm["ic/u-fps"], fdm["ic/v-fps"], fdm["ic/w-fps"] = (float(v) for v in uvw)
        fdm.run_ic()
        self._apply_wind()
        self._refresh()
        self.state()                              # (its readout keeps the velocity: step)
        controls = PlaneControls(aileron=float(x[4]), elevator=float(-x[3]),
                                 rudder=float(-x[5]), throttle=float(x[2]))
        self._apply_controls(controls)
        return controls

    def _set_flight_ic(self, height_m: float, airspeed_mps: float, x: np.ndarray) -> None:
        """Initial condition for trim: level, wings level, in still air, at home."""
        fdm = self._fdm
        lat_deg, lon_deg, alt_m, heading_deg = self.home
        fdm["ic/lat-geod-deg"] = lat_deg
        fdm["ic/long-gc-deg"] = lon_deg
        fdm["ic/terrain-elevation-ft"] = alt_m / FT_M
        fdm["ic/h-sl-ft"] = (alt_m + height_m) / FT_M
        fdm["ic/vw-mag-fps"] = 0.0
        fdm["ic/psi-true-deg"] = heading_deg
        fdm["ic/phi-rad"] = 0.0
        fdm["ic/gamma-rad"] = 0.0
        fdm["ic/vt-fps"] = airspeed_mps / FT_M
        fdm["ic/alpha-rad"] = x[0]
        fdm["ic/beta-rad"] = x[1]
        fdm["ic/p-rad_sec"] = 0.0
        fdm["ic/q-rad_sec"] = 0.0
        fdm["ic/r-rad_sec"] = 0.0
        fdm["fcs/throttle-cmd-norm"] = x[2]
        fdm["fcs/elevator-cmd-norm"] = x[3]
        fdm["fcs/aileron-cmd-norm"] = x[4]
        fdm["fcs/rudder-cmd-norm"] = x[5]
        self._controls = None                     # the commands now differ from ours
        self._set_reactions(True, True)

    # ------------------------------------------------------------------ internals

    @staticmethod
    def _silence_outputs(fdm) -> None:
        """Send any <output> an aircraft file declares to the null device, then stop it.

        Some stock aircraft (c172x) write a CSV into the working directory at run_ic().
        """
        index = 0
        while index < 16 and fdm.get_output_filename(index):
            fdm.set_output_filename(index, os.devnull)
            index += 1
        fdm.disable_output()

    def _bind_nodes(self) -> None:
        """Cache the property getters read every step (a node read costs ~0.1 us)."""
        pm = self._fdm.get_property_manager()

        def getter(path: str):
            node = pm.get_node(path)
            if node is None:
                raise RuntimeError(f"JSBSim property {path} not found")
            return node.get_double_value

        def setter(path: str):
            node = pm.get_node(path, True)
            return node.set_double_value

        self._n = {
            "lat": getter("position/lat-geod-rad"),
            "lon": getter("position/long-gc-rad"),
            "alt": getter("position/h-sl-meters"),
            "vn": getter("velocities/v-north-fps"),
            "ve": getter("velocities/v-east-fps"),
            "vd": getter("velocities/v-down-fps"),
            "phi": getter("attitude/phi-rad"),
            "theta": getter("attitude/theta-rad"),
            "psi": getter("attitude/psi-rad"),
            "p": getter("velocities/pi-rad_sec"),
            "q": getter("velocities/qi-rad_sec"),
            "r": getter("velocities/ri-rad_sec"),
            "ax": getter("accelerations/a-pilot-x-ft_sec2"),
            "ay": getter("accelerations/a-pilot-y-ft_sec2"),
            "az": getter("accelerations/a-pilot-z-ft_sec2"),
            "wn": getter("atmosphere/total-wind-north-fps"),
            "we": getter("atmosphere/total-wind-east-fps"),
            "wd": getter("atmosphere/total-wind-down-fps"),
            "vt": getter("velocities/vt-fps"),
            "agl": getter("position/h-agl-ft"),
            "alpha": getter("aero/alpha-rad"),
            "beta": getter("aero/beta-rad"),
            "fx_gear": getter("forces/fbx-gear-lbs"),
            "fz_gear": getter("forces/fbz-gear-lbs"),
            "rho": getter("atmosphere/rho-slugs_ft3"),
            "pressure": getter("atmosphere/P-psf"),
            "temperature": getter("atmosphere/T-R"),
            # the propeller's speed (its engine's: the Aerosonde's electric motor drives
            # it directly), for the ESC telemetry (sensors/rpm.py)
            "rpm": getter("propulsion/engine/propeller-rpm"),
            "ecef_x": getter("position/ecef-x-ft"),
            "ecef_y": getter("position/ecef-y-ft"),
            "ecef_z": getter("position/ecef-z-ft"),
        }
        names = ("lat", "lon", "alt", "vn", "ve", "vd", "phi", "theta", "psi", "p", "q", "r",
                 "ax", "ay", "az", "wn", "we", "wd", "vt", "alpha", "beta", "fx_gear",
                 "fz_gear", "rho", "pressure", "temperature", "rpm", "agl")
        imu = ("p", "q", "r", "ax", "ay", "az")
        # the nodes read together every step (map(_read, ...))
        node = {name: get.__self__ for name, get in self._n.items()}
        self._state_nodes = tuple(node[name] for name in names)
        self._imu_nodes = tuple(node[name] for name in imu)
        self._ground_node = setter("simulation/models/FGGroundReactions/enabled")
        self._launcher_node = setter("simulation/models/FGExternalReactions/enabled")
        self._ground_on = self._launcher_on = True
        self._set_aileron = setter("fcs/aileron-cmd-norm")
        self._set_elevator = setter("fcs/elevator-cmd-norm")
        self._set_rudder = setter("fcs/rudder-cmd-norm")
        # (none for an airframe without a steered wheel: JSBSim would ignore it)
        self._set_steer = setter("fcs/steer-cmd-norm") if self._af.steers else None
        self._set_throttle = setter("fcs/throttle-cmd-norm")
        self._set_gust = (setter("atmosphere/gust-north-fps"),
                          setter("atmosphere/gust-east-fps"),
                          setter("atmosphere/gust-down-fps"))

    def _set_reactions(self, ground: bool, launcher: bool) -> None:
        """JSBSim's ground reactions (CONTACT_REACH_M) and external reactions (the
        launcher's latch and catapult) on or off, each written on a change."""
        if ground != self._ground_on:
            self._ground_on = ground
            self._ground_node(1.0 if ground else 0.0)
        if launcher != self._launcher_on:
            self._launcher_on = launcher
            self._launcher_node(1.0 if launcher else 0.0)

    def _apply_controls(self, controls: PlaneControls) -> None:
        # written at every call: in flight the commands change every step (comparing
        # them first cost more than it saved), and writing a value again changes nothing
        self._controls = controls
        self._set_aileron(controls.aileron)
        self._set_elevator(-controls.elevator)
        self._set_rudder(-controls.rudder)
        if self._set_steer is not None:
            self._set_steer(controls.rudder)
        self._set_throttle(controls.throttle)

    def _refresh(self) -> None:
        """Recompute every derived value (airspeed, alpha, ...) without advancing time."""
        fdm = self._fdm
        fdm.suspend_integration()
        fdm.run()
        fdm.resume_integration()

    def _set_wind_values(self, wind_ned, turbulence: str) -> None:
        if turbulence not in TURBULENCE_W20_KT:
            raise ValueError(f"turbulence must be one of {sorted(TURBULENCE_W20_KT)}")
        wind = np.asarray(wind_ned, dtype=float).reshape(3)
        if not np.all(np.isfinite(wind)):
            raise ValueError("wind_ned must be finite")
        self._wind_ned = wind.copy()
        self._turbulence = turbulence

    def _apply_wind(self) -> None:
        """Write the steady wind into JSBSim (run_ic() resets it) and set the gusts.

        While the Aerosonde is held on its launcher the rail constrains it completely,
        so the air is kept still there: otherwise a crosswind weathervanes and rolls the
        airframe on its shoes before launch. The wind starts blowing at release."""
        fdm = self._fdm
        held = self._af.catapult and self._phase == _HELD
        wind = (0.0, 0.0, 0.0) if held else self._wind_ned
        fdm["atmosphere/turb-type"] = 0           # JSBSim's own turbulence stays off
        fdm["atmosphere/wind-north-fps"] = wind[0] / FT_M
        fdm["atmosphere/wind-east-fps"] = wind[1] / FT_M
        fdm["atmosphere/wind-down-fps"] = wind[2] / FT_M
        self._gusts.configure(TURBULENCE_W20_KT[self._turbulence] * KT_MPS, self._wind_ned)
        self._gust_wind = tuple(float(v) for v in self._wind_ned)    # (not numpy scalars)
        self._write_gust(self._gusts.gust_ned)

    def _write_gust(self, gust_ned: tuple) -> None:
        """The gust (NED, m/s) into JSBSim's gust input."""
        gust_n, gust_e, gust_d = gust_ned
        set_n, set_e, set_d = self._set_gust
        set_n(gust_n / FT_M)
        set_e(gust_e / FT_M)
        set_d(gust_d / FT_M)

    def _rest_pose(self) -> tuple[float, float]:
        """Pitch [rad] and CG height above the ground [m] resting on the bogeys.

        From the gear locations (structural frame: x aft, z up, inches): the front
        unit and the mean of the others must touch a flat surface at zero bank.
        """
        fdm = self._fdm
        fdm.run_ic()                              # the CG is computed at run_ic()
        gear = fdm.get_ground_reactions()
        with warnings.catch_warnings():          # the binding returns numpy.matrix
            warnings.simplefilter("ignore", PendingDeprecationWarning)
            cg = np.asarray(fdm.get_mass_balance().get_xyz_cg()).ravel()
            locations = [np.asarray(gear.get_gear_unit(i).get_location()).ravel()
                         for i in self._af.bogeys]
        pts = []
        for s in locations:
            d = (s - cg) * 0.0254
            pts.append((-d[0], -d[2]))           # body x forward, z down [m]
        pts.sort(reverse=True)
        x_f, z_f = pts[0]
        x_r = sum(p[0] for p in pts[1:]) / (len(pts) - 1)
        z_r = sum(p[1] for p in pts[1:]) / (len(pts) - 1)
        theta = math.atan2(z_f - z_r, x_f - x_r)
        depth = z_f * math.cos(theta) - x_f * math.sin(theta)
        return theta, depth

    def _place_at_start(self) -> None:
        """Put the aircraft at rest at home (on the launcher or the runway)."""
        fdm = self._fdm
        lat_deg, lon_deg, alt_m, heading_deg = self.home
        deck_m = alt_m + (LAUNCHER_HEIGHT_M if self._af.catapult else 0.0)
        theta, depth = self._rest_pose()
        fdm["ic/lat-geod-deg"] = lat_deg
        fdm["ic/long-gc-deg"] = lon_deg
        fdm["ic/terrain-elevation-ft"] = deck_m / FT_M
        fdm["ic/h-sl-ft"] = (deck_m + depth + 0.005) / FT_M
        fdm["ic/vw-mag-fps"] = 0.0
        fdm["ic/psi-true-deg"] = heading_deg
        fdm["ic/theta-rad"] = theta
        fdm["ic/phi-rad"] = 0.0
        for name in ("ic/u-fps", "ic/v-fps", "ic/w-fps",
                     "ic/p-rad_sec", "ic/q-rad_sec", "ic/r-rad_sec"):
            fdm[name] = 0.0
        self._set_reactions(True, True)
        fdm.reset_to_initial_conditions(0)        # every model afresh, then run_ic()
        self._gusts.reset()
        for brake in self._af.brakes:
            fdm[brake] = 1.0
        if self._af.catapult:
            fdm["fcs/catapult-force-lbs"] = 0.0
            fdm["fcs/launcher-latch"] = 1.0
        else:
            fdm["fcs/mixture-cmd-norm"] = 1.0
        self._apply_controls(PlaneControls())
        fdm.get_propulsion().init_running(-1)
        fdm["position/terrain-elevation-asl-ft"] = deck_m / FT_M
        self._phase = _HELD
        self._apply_wind()
        for _ in range(int(round(self._af.settle_s * 1e6 / self._dt_us))):
            fdm.run()
        self._armed_us = None
        self.state()                              # (its readout keeps the velocity: step)

    def _launcher_logic(self, throttle: float) -> None:
        """Automatic release on the launcher and the end of the catapult stroke."""
        if self._phase == _HELD:
            if throttle <= AUTO_LAUNCH_THROTTLE:
                self._armed_us = None
            elif not self._af.catapult:
                self.launch()
            elif self._armed_us is None:
                self._armed_us = self._t_us
            elif self._t_us - self._armed_us >= int(SPIN_UP_S * 1e6):
                self.launch()
            return
        # firing: stop pushing at the end of the rail, then remove the launcher
        n = self._n
        x0, y0, z0 = self._rail_start_ecef_ft
        travelled_m = math.sqrt((n["ecef_x"]() - x0) ** 2 + (n["ecef_y"]() - y0) ** 2
                                + (n["ecef_z"]() - z0) ** 2) * FT_M
        if travelled_m >= RAIL_LENGTH_M:
            fdm = self._fdm
            fdm["fcs/catapult-force-lbs"] = 0.0
            fdm["position/terrain-elevation-asl-ft"] = self.home[2] / FT_M
            self._phase = _FREE
