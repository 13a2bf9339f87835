"""What the ground-station service (autopilot/gcs) may ask of a vehicle loop.

Both vehicle loops (``autopilot.vehicle.PlaneVehicle`` and the quadrotor's) implement
this protocol, so the MAVLink side never asks which airframe it serves; what of it does
not depend on the airframe is written once, in ``autopilot.vehicle_base.VehicleBase``.
The GCS calls these between lockstep steps (never from another thread), and every call
takes the simulation time ``t_us`` for its log entries.
"""
from __future__ import annotations

from enum import IntEnum
from typing import Protocol

from .geo import LocalFrame
from .messages import NavState
from .mission.items import Mission
from .params import ParamStore


class VehicleApi(Protocol):
    # --- identity -----------------------------------------------------------------
    mav_type: int                    # MAV_TYPE_FIXED_WING / MAV_TYPE_QUADROTOR
    modes: type[IntEnum]             # ArduPlane / ArduCopter custom_mode numbering
    implemented_modes: frozenset     # the members a ground station may select

    # --- state (read-only for the GCS) ---------------------------------------------
    params: ParamStore               # the PARAM table (PARAM_SET goes through set_param)
    armed: bool
    mode: IntEnum
    nav_state: NavState | None       # latest navigation solution (None before the first)
    home_frame: LocalFrame | None    # home (set at arming, or by DO_SET_HOME)
    mission: Mission | None          # the active mission (item 0 = home)
    gps_fix_type: int
    landed: bool                     # on the ground (EXTENDED_SYS_STATE landed_state)
    notices: list                    # (t_s, MAV_SEVERITY, text) the vehicle announces (STATUSTEXT)

    def current_seq(self) -> int: ...              # MISSION_CURRENT seq
    def reached_events(self) -> list[tuple[int, int]]: ...  # (t_us, seq), every item reached so far

    # --- commands (each returns None on success, else a reason for STATUSTEXT) ---------
    def arm_checks(self) -> str | None: ...        # the PreArm reason, or None
    def arm(self, t_us: int, truth=None) -> str | None: ...
    def disarm(self, t_us: int, force: bool = False) -> str | None: ...
    def set_mode(self, mode: IntEnum, t_us: int) -> str | None: ...
    def set_mission(self, mission: Mission, t_us: int) -> str | None: ...  # replaces atomically
    def set_current(self, seq: int, t_us: int) -> str | None: ...
    def set_home(self, lat_rad: float, lon_rad: float, alt_m: float, t_us: int) -> str | None: ...
    def set_param(self, name: str, value: float) -> str | None: ...  # refusal leaves it unchanged

    # --- geofence and rally points (autopilot/fence), optional: without ``geofence``
    # the mission service answers fence and rally requests MAV_MISSION_UNSUPPORTED ---
    # geofence: autopilot.fence.Geofence
    # def set_fence(self, items, t_us: int) -> str | None: ...   # () clears; refusal keeps the old
    # def set_rally(self, items, t_us: int) -> str | None: ...
