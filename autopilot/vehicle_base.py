"""What the two vehicle loops share: the part of ``autopilot.vehicle_api.VehicleApi`` that
does not depend on the airframe.

``PlaneVehicle`` (autopilot/vehicle.py) and ``QuadVehicle`` (autopilot/vehicle_quad.py)
both derive from ``VehicleBase``. It holds what is the same for both, written once:
the terrain handed to the mission sequencer, the pre-arm checks of navigation, GPS,
geofence and terrain, arming (home set from the navigation solution, as ArduPilot
does) and disarming, the mission, current item, fence and rally services of the
ground station, the parameter changes (with the geofence's veto on FENCE_ACTION) and
the parameters both declare, the STATUSTEXT notices, and the pieces of the flight-log
row that do not depend on the airframe (truth in home's frame, filter sigmas, the GPS
fix) with their columns. What differs stays in
each loop, reached through a few hooks named below: what arming and disarming reset,
whether arming needs a mission, how a new mission reaches the sequencer, what a
parameter change reconfigures.

A ``VehicleBase`` subclass provides ``params``, ``mission``, ``nav``, ``nav_state``,
``gps_fix_type``, ``geofence``, ``home_frame``, ``home_truth_alt_m``, ``armed``,
``landed``, ``log``, ``notices``, ``mode`` and ``sequencer`` (the airframe's mission
sequencer, None until armed).
"""
from __future__ import annotations

import math

import numpy as np

from .fence.actions import home_ll
from .fence.geofence import FENCE_PARAMS, rally_params
from .geo import LocalFrame
from .geo.rotations import euler_321
from .messages import NavState, SensorFrame
from .mission.items import Mission, terrain_problem, validate_mission
from .nav.config import NAV_PARAMS
from .params import Param

SEV_NOTICE = 5          # MAV_SEVERITY_NOTICE
_NAN3 = (math.nan, math.nan, math.nan)
_NAN9 = (math.nan,) * 9
_NAN10 = (math.nan,) * 10

# the flight-log columns of the airframe-independent row parts, in their order: truth in
# home's NED (``VehicleBase._truth_row``) ...
TRUTH_COLUMNS = (
    "truth_n_m", "truth_e_m", "truth_alt_m", "truth_roll_rad", "truth_pitch_rad", "truth_yaw_rad",
    "truth_vn_mps", "truth_ve_mps", "truth_vd_mps", "truth_airspeed_mps",
)
# ... and the navigation filter: 1-sigma of its errors (NaN on truth; attitude as a
# NED-frame rotation vector, the error state of autopilot/nav), health, and the GPS fixes
# received this step (NaN when none), for scoring the estimate and the receiver
# (``VehicleBase._nav_row``)
NAV_COLUMNS = (
    "sig_pn_m", "sig_pe_m", "sig_pd_m", "sig_vn_mps", "sig_ve_mps", "sig_vd_mps",
    "sig_att_n_rad", "sig_att_e_rad", "sig_att_d_rad", "nav_aligned", "nav_healthy",
    "gps_n_m", "gps_e_m", "gps_alt_m",
)


def shared_param_declarations(kind: str) -> list[Param]:
    """The parameters both airframes declare, after their own (the PARAM table's order):
    the geofence, the rally points (``kind``: "plane" / "quad") and the navigation
    filter's."""
    return list(FENCE_PARAMS) + list(rally_params(kind)) + list(NAV_PARAMS)


class TruthNav:
    """NavState from HIL_STATE_QUATERNION: the ``--nav truth`` debugging aid."""

    def __init__(self):
        self.origin: LocalFrame | None = None

    def update(self, frame: SensorFrame, truth) -> NavState | None:
        if truth is None:
            return None
        if self.origin is None:
            self.origin = LocalFrame(truth.lat_rad, truth.lon_rad, truth.alt_m)
        p = self.origin.to_ned_fast(truth.lat_rad, truth.lon_rad, truth.alt_m)
        return NavState(frame.t_us, p, np.array(truth.v_ned), np.array(truth.q_nb),
                        np.array(truth.omega_b),
                        truth.lat_rad, truth.lon_rad, truth.alt_m, truth.airspeed_mps,
                        source="truth")


class VehicleBase:
    """The airframe-independent half of a vehicle loop (module docstring)."""

    vehicle_kind = ""     # "plane" / "quad": the mission validator's and geofence's name

    # the terrain the autopilot reads (a callable (lat_deg, lon_deg) -> metres MSL or None:
    # the simulator's tiles, autopilot.geo.terrain); None: flat at home altitude
    terrain = None

    @property
    def sequencer(self):
        """The mission sequencer (None without a mission). The vehicles' per-step paths
        read ``_sequencer`` itself: this call costs more than the read, 15 times a step."""
        return self._sequencer

    @sequencer.setter
    def sequencer(self, seq) -> None:
        self._sequencer = seq
        if seq is not None:
            seq.terrain = self.terrain

    def terrain_problem(self) -> str | None:
        """The pre-arm reason when a terrain-frame item of the mission has no terrain
        data under it (ArduPilot refuses to arm so), else None."""
        return terrain_problem(self.mission, self.terrain)

    # ------------------------------------------------------------------ arming ---
    def _mission_needed(self) -> bool:
        """Whether arming needs a mission of at least one item besides home (hook)."""
        return True

    def arm_checks(self) -> str | None:
        """None when arming is allowed, else the PreArm reason."""
        nav = self.nav_state
        if nav is None or not nav.aligned:
            return "navigation not aligned"
        if not nav.healthy:
            return "navigation unhealthy"
        if self.gps_fix_type < 3:
            return "no 3D fix"
        if self._mission_needed() and (self.mission is None or len(self.mission) < 2):
            return "no valid mission"
        return (self.geofence.arm_problem(math.degrees(nav.lat_rad), math.degrees(nav.lon_rad))
                or self.terrain_problem())

    _home_alt_format = ".1f"    # the home altitude in the "armed" log event

    def arm(self, t_us: int, truth=None) -> str | None:
        """Arm after the pre-arm checks; home is set here from the navigation solution
        (as ArduPilot does), and the airframe prepares its loops (``_arming``)."""
        reason = self.arm_checks()
        if reason is not None:
            return reason
        nav = self.nav_state
        self.home_frame = LocalFrame(nav.lat_rad, nav.lon_rad, nav.alt_m)
        if truth is not None:
            self.home_truth_alt_m = truth.alt_m
        self._arming(nav)
        self.armed = True
        self.log.event(t_us * 1e-6, f"armed; home {math.degrees(nav.lat_rad):.7f} "
                                    f"{math.degrees(nav.lon_rad):.7f} "
                                    f"{nav.alt_m:{self._home_alt_format}} m")
        return None

    def _arming(self, nav: NavState) -> None:
        """What the airframe resets at arming, home being set (hook)."""

    def disarm(self, t_us: int, force: bool = False) -> str | None:
        """Disarm; refused in flight unless forced (a crash, a landing's end)."""
        if not self.armed:
            return None
        if not self.landed and not force:
            return "Disarm refused: flying"
        self.armed = False
        self._disarming(t_us)
        self.log.event(t_us * 1e-6, "disarmed")
        return None

    def _disarming(self, t_us: int) -> None:
        """What the airframe does on disarming, before the log says so (hook)."""

    # ------------------------------------------------------- ground station API ---
    def current_seq(self) -> int:
        if self.sequencer is None:
            return 1 if self.mission is not None and len(self.mission) > 1 else 0
        return min(self.sequencer.current, max(len(self.sequencer.items) - 1, 0))

    def reached_events(self) -> list[tuple[int, int]]:
        return list(self.sequencer.reached) if self.sequencer is not None else []

    def set_mission(self, mission: Mission, t_us: int) -> str | None:
        """Replace the mission atomically, after checking it whole (items, geofence): a
        refusal leaves the old one flying."""
        if len(mission) < 1:
            return "empty mission"
        problem = validate_mission(mission.items, self.vehicle_kind)
        if problem is not None:
            return f"item {problem.seq}: {problem.text}"
        outside = self.geofence.mission_problem(mission.items, home_ll(self))
        if outside is not None:
            return outside
        self.mission = mission
        self._load_mission(mission)
        self.log.event(t_us * 1e-6, f"mission replaced: {len(mission) - 1} items")
        return None

    def _load_mission(self, mission: Mission) -> None:
        """Hand an accepted mission to the sequencer (hook)."""
        if self.sequencer is not None:
            self.sequencer.load(mission)

    def set_current(self, seq: int, t_us: int) -> str | None:
        if self.mission is None or not 0 < seq < len(self.mission):
            return f"no mission item {seq}"
        if self.sequencer is not None:
            self.sequencer.set_current(seq)
        return None

    def set_fence(self, items, t_us: int) -> str | None:
        """A new geofence (MAV_MISSION_TYPE_FENCE items), checked whole; () clears it."""
        problem = self.geofence.set_fence(items)
        if problem is not None:
            return problem.text
        self.log.event(t_us * 1e-6, f"fence: {len(self.geofence.fence_items)} items")
        return None

    def set_rally(self, items, t_us: int) -> str | None:
        """New rally points (MAV_MISSION_TYPE_RALLY items); () clears them."""
        problem = self.geofence.set_rally(items)
        if problem is not None:
            return problem.text
        self.log.event(t_us * 1e-6, f"rally points: {len(self.geofence.rally_items)}")
        return None

    def set_param(self, name: str, value: float) -> str | None:
        """PARAM_SET: a refusal (out of range, unknown, a FENCE_ACTION the fence cannot
        take) leaves the value unchanged; an accepted one takes effect at once
        (``_param_changed``), or, for a parameter the vehicle is built from (``at_start``
        in its declaration), is stored and takes effect at the next start: a new value
        of such a parameter is announced to the ground stations (STATUSTEXT NOTICE, as
        ArduPilot's and PX4's ground stations say "reboot required")."""
        from .params import ParamError
        if name == "FENCE_ACTION":
            why = self.geofence.action_problem(value)
            if why is not None:
                return why
        # (the value before, by the dict's own lookup: a look of the parameter service,
        # not a use of the parameter; tests/test_params_inflight.py traces the uses)
        old = dict.get(self.params, name)
        try:
            v = self.params.set(name, value)
        except ParamError as e:
            return str(e)
        self._param_changed(name)
        self._param_follow(name, v)
        if self.params.declaration(name).at_start and v != old:
            t_us = getattr(self, "last_t_us", None)
            self.notice(t_us * 1e-6 if t_us is not None else 0.0, SEV_NOTICE,
                        f"{name} set: takes effect at the next start")
        return None

    def _param_changed(self, name: str) -> None:
        """Reconfigure what depends on parameter ``name`` (hook)."""

    def _param_follow(self, name: str, value: float) -> None:
        """Hand parameter ``name``'s new ``value`` to the blocks that keep their own copy
        of the parameters (the navigation filter, the fault monitor) (hook)."""

    def notice(self, t_s: float, severity: int, text: str) -> None:
        """Something to tell the ground stations (STATUSTEXT) and the flight log."""
        self.notices.append((t_s, severity, text))
        self.log.event(t_s, text)

    def _forward_events(self, mon) -> None:
        """A fault monitor's new events to the flight log."""
        if len(mon.events) > self._fdi_events:
            for t_s, _sev, text in mon.events[self._fdi_events:]:
                self.log.event(t_s, text)
            self._fdi_events = len(mon.events)

    # --------------------------------------------------------------- flight log ---
    @staticmethod
    def _truth_row(hf: LocalFrame, truth) -> tuple:
        """Truth for a log row, in TRUTH_COLUMNS' order: position in home's NED, Euler
        angles, velocity, altitude and airspeed; NaN on a step without truth."""
        if truth is None:
            return _NAN10
        p_tru = hf.ned_fast(truth.lat_rad, truth.lon_rad, truth.alt_m)
        roll, pitch, yaw = euler_321(*truth.q_nb)
        vn, ve, vd = truth.v_ned
        # (the values by name: a tuple display with ``*`` in it is built as a list)
        return (p_tru[0], p_tru[1], truth.alt_m, roll, pitch, yaw, vn, ve, vd,
                truth.airspeed_mps)

    def _nav_row(self, hf: LocalFrame, nav: NavState, gps) -> tuple:
        """The filter's part of a log row, in NAV_COLUMNS' order: its nine 1-sigma errors
        (NaN on truth navigation), health, and this step's GPS fix in home's NED (NaN
        when none)."""
        out_sig = getattr(self.nav, "output_sigmas9", None)
        sig = out_sig() if out_sig is not None else _NAN9
        if gps is None:
            return (*sig, nav.aligned, nav.healthy, *_NAN3)
        g = hf.ned_fast(gps.lat_rad, gps.lon_rad, gps.alt_m)
        return (*sig, nav.aligned, nav.healthy, g[0], g[1], gps.alt_m)
