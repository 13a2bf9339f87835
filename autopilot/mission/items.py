"""Mission items: the MAVLink MISSION_ITEM_INT contract with float degrees, and its checks.

A `MissionItem` carries exactly the fields of MISSION_ITEM_INT (less the target ids),
except that x / y are float degrees (`x_lat_deg`, `y_lon_deg`) instead of degE7
integers; `from_int` / `to_int` convert at the link boundary. `z_alt_m` is metres,
above mean sea level for MAV_FRAME_GLOBAL(_INT), above home for
MAV_FRAME_GLOBAL_RELATIVE_ALT(_INT), above the terrain for MAV_FRAME_GLOBAL_TERRAIN_ALT(_INT).

Item 0 of a mission is home (the ArduPilot convention that MAVProxy, MAVSDK and
QGroundControl expect): a NAV_WAYPOINT in an absolute-altitude global frame.

`validate_item` and `validate_mission` answer with MAV_MISSION_RESULT names, so the
ground-station mission handler can put them straight into MISSION_ACK.

Which commands a vehicle flies (``VEHICLE_COMMANDS``, ``vehicle_problem``): a command one
vehicle cannot fly yet is refused for it at upload and at load (MAV_MISSION_UNSUPPORTED,
named), never accepted and skipped. ``validate_mission`` also refuses a mission that
cannot be flown at all: DO_JUMP targets that do not exist, a chain of DO items and jumps
that loops for ever without a navigation item (an infinite DO_JUMP whose loop holds no
navigation command), and a mission with items but no navigation command.
"""

from __future__ import annotations

import math
import operator
from dataclasses import dataclass, fields
from typing import Any, Iterable, Iterator

from pymavlink.dialects.v20 import ardupilotmega as mavlink2

# --- commands we fly (MAV_CMD) ---------------------------------------------------------
NAV_WAYPOINT = mavlink2.MAV_CMD_NAV_WAYPOINT  # 16
NAV_LOITER_UNLIM = mavlink2.MAV_CMD_NAV_LOITER_UNLIM  # 17
NAV_LOITER_TURNS = mavlink2.MAV_CMD_NAV_LOITER_TURNS  # 18
NAV_LOITER_TIME = mavlink2.MAV_CMD_NAV_LOITER_TIME  # 19
NAV_RETURN_TO_LAUNCH = mavlink2.MAV_CMD_NAV_RETURN_TO_LAUNCH  # 20
NAV_LAND = mavlink2.MAV_CMD_NAV_LAND  # 21
NAV_TAKEOFF = mavlink2.MAV_CMD_NAV_TAKEOFF  # 22
DO_JUMP = mavlink2.MAV_CMD_DO_JUMP  # 177
DO_CHANGE_SPEED = mavlink2.MAV_CMD_DO_CHANGE_SPEED  # 178
DO_SET_HOME = mavlink2.MAV_CMD_DO_SET_HOME  # 179
NAV_LOITER_TO_ALT = mavlink2.MAV_CMD_NAV_LOITER_TO_ALT  # 31
NAV_DELAY = mavlink2.MAV_CMD_NAV_DELAY  # 93
CONDITION_DELAY = mavlink2.MAV_CMD_CONDITION_DELAY  # 112
CONDITION_DISTANCE = mavlink2.MAV_CMD_CONDITION_DISTANCE  # 114
CONDITION_YAW = mavlink2.MAV_CMD_CONDITION_YAW  # 115
NAV_SPLINE_WAYPOINT = mavlink2.MAV_CMD_NAV_SPLINE_WAYPOINT  # 82
DO_SET_ROI_LOCATION = mavlink2.MAV_CMD_DO_SET_ROI_LOCATION  # 195
DO_SET_ROI_NONE = mavlink2.MAV_CMD_DO_SET_ROI_NONE  # 197
DO_SET_ROI_WPNEXT_OFFSET = mavlink2.MAV_CMD_DO_SET_ROI_WPNEXT_OFFSET  # 196 (structure scans)
DO_SET_ROI = mavlink2.MAV_CMD_DO_SET_ROI  # 201 (deprecated form; QGroundControl still writes it)
DO_DIGICAM_CONTROL = mavlink2.MAV_CMD_DO_DIGICAM_CONTROL  # 203
DO_SET_CAM_TRIGG_DIST = mavlink2.MAV_CMD_DO_SET_CAM_TRIGG_DIST  # 206
IMAGE_START_CAPTURE = mavlink2.MAV_CMD_IMAGE_START_CAPTURE  # 2000
IMAGE_STOP_CAPTURE = mavlink2.MAV_CMD_IMAGE_STOP_CAPTURE  # 2001
DO_LAND_START = mavlink2.MAV_CMD_DO_LAND_START  # 189: marks a landing sequence
DO_GO_AROUND = mavlink2.MAV_CMD_DO_GO_AROUND  # 191: COMMAND_LONG only, never a mission item

# The same values under their full MAVLink names.
MAV_CMD_NAV_WAYPOINT = NAV_WAYPOINT
MAV_CMD_NAV_LOITER_UNLIM = NAV_LOITER_UNLIM
MAV_CMD_NAV_LOITER_TURNS = NAV_LOITER_TURNS
MAV_CMD_NAV_LOITER_TIME = NAV_LOITER_TIME
MAV_CMD_NAV_RETURN_TO_LAUNCH = NAV_RETURN_TO_LAUNCH
MAV_CMD_NAV_LAND = NAV_LAND
MAV_CMD_NAV_TAKEOFF = NAV_TAKEOFF
MAV_CMD_DO_JUMP = DO_JUMP
MAV_CMD_DO_CHANGE_SPEED = DO_CHANGE_SPEED
MAV_CMD_DO_SET_HOME = DO_SET_HOME
MAV_CMD_NAV_LOITER_TO_ALT = NAV_LOITER_TO_ALT
MAV_CMD_NAV_DELAY = NAV_DELAY
MAV_CMD_CONDITION_DELAY = CONDITION_DELAY
MAV_CMD_CONDITION_DISTANCE = CONDITION_DISTANCE
MAV_CMD_CONDITION_YAW = CONDITION_YAW
MAV_CMD_NAV_SPLINE_WAYPOINT = NAV_SPLINE_WAYPOINT
MAV_CMD_DO_SET_ROI_LOCATION = DO_SET_ROI_LOCATION
MAV_CMD_DO_SET_ROI_NONE = DO_SET_ROI_NONE
MAV_CMD_DO_SET_ROI_WPNEXT_OFFSET = DO_SET_ROI_WPNEXT_OFFSET
MAV_CMD_DO_SET_ROI = DO_SET_ROI
MAV_CMD_DO_LAND_START = DO_LAND_START
MAV_CMD_DO_GO_AROUND = DO_GO_AROUND

COMMAND_NAMES: dict[int, str] = {
    NAV_WAYPOINT: "NAV_WAYPOINT",
    NAV_LOITER_UNLIM: "NAV_LOITER_UNLIM",
    NAV_LOITER_TURNS: "NAV_LOITER_TURNS",
    NAV_LOITER_TIME: "NAV_LOITER_TIME",
    NAV_RETURN_TO_LAUNCH: "NAV_RETURN_TO_LAUNCH",
    NAV_LAND: "NAV_LAND",
    NAV_TAKEOFF: "NAV_TAKEOFF",
    DO_JUMP: "DO_JUMP",
    DO_CHANGE_SPEED: "DO_CHANGE_SPEED",
    DO_SET_HOME: "DO_SET_HOME",
    NAV_LOITER_TO_ALT: "NAV_LOITER_TO_ALT",
    NAV_DELAY: "NAV_DELAY",
    CONDITION_DELAY: "CONDITION_DELAY",
    CONDITION_DISTANCE: "CONDITION_DISTANCE",
    CONDITION_YAW: "CONDITION_YAW",
    NAV_SPLINE_WAYPOINT: "NAV_SPLINE_WAYPOINT",
    DO_SET_ROI_LOCATION: "DO_SET_ROI_LOCATION",
    DO_SET_ROI_NONE: "DO_SET_ROI_NONE",
    DO_SET_ROI_WPNEXT_OFFSET: "DO_SET_ROI_WPNEXT_OFFSET",
    DO_SET_ROI: "DO_SET_ROI",
    DO_DIGICAM_CONTROL: "DO_DIGICAM_CONTROL",
    DO_SET_CAM_TRIGG_DIST: "DO_SET_CAM_TRIGG_DIST",
    IMAGE_START_CAPTURE: "IMAGE_START_CAPTURE",
    IMAGE_STOP_CAPTURE: "IMAGE_STOP_CAPTURE",
    DO_LAND_START: "DO_LAND_START",
}
# Camera commands (what QGroundControl's surveys and corridor scans put between their
# waypoints): accepted and noted by both vehicles, which carry no camera (said once).
CAMERA_COMMANDS = frozenset({DO_DIGICAM_CONTROL, DO_SET_CAM_TRIGG_DIST, IMAGE_START_CAPTURE,
                             IMAGE_STOP_CAPTURE})
SUPPORTED_COMMANDS = frozenset(COMMAND_NAMES)

# Commands whose x / y / z are a place to fly to (DO_SET_HOME only when param1 == 0).
POSITION_COMMANDS = frozenset(
    {NAV_WAYPOINT, NAV_LOITER_UNLIM, NAV_LOITER_TURNS, NAV_LOITER_TIME, NAV_LAND, NAV_TAKEOFF,
     NAV_LOITER_TO_ALT, NAV_SPLINE_WAYPOINT}
)
# Commands whose x / y / z are a place to look at (region of interest); DO_SET_ROI at
# latitude and longitude 0 clears it, as ArduPilot reads it.
ROI_COMMANDS = frozenset({DO_SET_ROI_LOCATION, DO_SET_ROI})
# Position commands whose altitude may be NaN: "the current altitude" (MAVLink's
# "NaN: use the current / no change" for param7; QGroundControl writes it null, e.g. the
# altitude of a loiter in its ArduPlane SITL test plan). A takeoff needs its altitude;
# DO_SET_HOME a place to move home to.
NAN_ALT_COMMANDS = frozenset({NAV_WAYPOINT, NAV_LOITER_UNLIM, NAV_LOITER_TURNS, NAV_LOITER_TIME,
                              NAV_LAND, NAV_LOITER_TO_ALT, NAV_SPLINE_WAYPOINT}) | ROI_COMMANDS
# Navigation commands (ArduPilot's "NAV" ids, < 95): the vehicle flies one at a time.
NAV_COMMANDS = POSITION_COMMANDS | {NAV_RETURN_TO_LAUNCH, NAV_DELAY}
# Conditions gate the DO items after them, never a navigation command (AP_Mission).
CONDITION_COMMANDS = frozenset({CONDITION_DELAY, CONDITION_DISTANCE, CONDITION_YAW})

# What each vehicle flies. The quadrotor flies every command above but DO_LAND_START
# (guidance/multirotor.py); the fixed-wing (guidance/mission.py) the ones listed, and
# `_plane_problem` names what it does not fly yet within those.
VEHICLE_COMMANDS: dict[str, frozenset[int]] = {
    "quad": SUPPORTED_COMMANDS - {DO_LAND_START},
    "plane": frozenset({NAV_WAYPOINT, NAV_LOITER_UNLIM, NAV_LOITER_TURNS, NAV_LOITER_TIME,
                        NAV_LOITER_TO_ALT, NAV_DELAY, NAV_RETURN_TO_LAUNCH, NAV_TAKEOFF,
                        NAV_LAND, DO_LAND_START,
                        DO_JUMP, DO_CHANGE_SPEED, DO_SET_HOME, CONDITION_DELAY,
                        CONDITION_DISTANCE, CONDITION_YAW, NAV_SPLINE_WAYPOINT,
                        DO_SET_ROI_LOCATION, DO_SET_ROI_NONE, DO_SET_ROI,
                        DO_SET_ROI_WPNEXT_OFFSET}) | CAMERA_COMMANDS,
}
VEHICLE_NAMES = {"plane": "the fixed-wing", "quad": "the quadrotor"}
# DO_CHANGE_SPEED speed types (MAV_SPEED_TYPE)
SPEED_TYPE_NAMES = {0: "airspeed", 1: "ground speed", 2: "climb speed", 3: "descent speed"}

# --- frames (MAV_FRAME) ----------------------------------------------------------------
FRAME_GLOBAL = mavlink2.MAV_FRAME_GLOBAL  # 0, alt above MSL
FRAME_MISSION = mavlink2.MAV_FRAME_MISSION  # 2, no position (DO_ commands)
FRAME_GLOBAL_RELATIVE_ALT = mavlink2.MAV_FRAME_GLOBAL_RELATIVE_ALT  # 3, alt above home
FRAME_GLOBAL_INT = mavlink2.MAV_FRAME_GLOBAL_INT  # 5, same meaning as 0
FRAME_GLOBAL_RELATIVE_ALT_INT = mavlink2.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT  # 6, as 3
FRAME_GLOBAL_TERRAIN_ALT = mavlink2.MAV_FRAME_GLOBAL_TERRAIN_ALT  # 10, alt above the terrain
FRAME_GLOBAL_TERRAIN_ALT_INT = mavlink2.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT  # 11, as 10

SUPPORTED_FRAMES = frozenset(
    {FRAME_GLOBAL, FRAME_MISSION, FRAME_GLOBAL_RELATIVE_ALT, FRAME_GLOBAL_INT,
     FRAME_GLOBAL_RELATIVE_ALT_INT, FRAME_GLOBAL_TERRAIN_ALT, FRAME_GLOBAL_TERRAIN_ALT_INT}
)
GLOBAL_FRAMES = frozenset(
    {FRAME_GLOBAL, FRAME_GLOBAL_RELATIVE_ALT, FRAME_GLOBAL_INT, FRAME_GLOBAL_RELATIVE_ALT_INT,
     FRAME_GLOBAL_TERRAIN_ALT, FRAME_GLOBAL_TERRAIN_ALT_INT}
)
TERRAIN_FRAMES = frozenset({FRAME_GLOBAL_TERRAIN_ALT, FRAME_GLOBAL_TERRAIN_ALT_INT})
ABSOLUTE_ALT_FRAMES = frozenset({FRAME_GLOBAL, FRAME_GLOBAL_INT})
RELATIVE_ALT_FRAMES = frozenset({FRAME_GLOBAL_RELATIVE_ALT, FRAME_GLOBAL_RELATIVE_ALT_INT})

MISSION_TYPE_MISSION = mavlink2.MAV_MISSION_TYPE_MISSION  # 0

# Altitudes outside this band are taken for a unit or sign mistake.
ALT_MIN_M = -1000.0
ALT_MAX_M = 50000.0
# DO_CHANGE_SPEED: more than this is not a speed for the vehicles we fly.
SPEED_MAX_M_S = 100.0

_E7 = 1e7
_INT32_MIN = -(2**31)
_INT32_MAX = 2**31 - 1
_UNUSED_XY_MAX = 214.0  # |x|, |y| that still fit a degE7 int32

# One NaN object for every NaN parameter, so that items with NaN ("use default")
# parameters compare equal field by field (tuple comparison checks identity first).
_NAN = float("nan")

_INT_FIELDS = ("seq", "frame", "command", "current", "autocontinue", "mission_type")
_FLOAT_FIELDS = ("param1", "param2", "param3", "param4", "x_lat_deg", "y_lon_deg", "z_alt_m")


def deg_to_e7(deg: float) -> int:
    """Float degrees -> MAVLink degE7 integer (rounded); ValueError if it won't fit int32."""
    value = round(deg * _E7)
    if not _INT32_MIN <= value <= _INT32_MAX:
        raise ValueError(f"{deg!r} deg does not fit a degE7 int32")
    return value


def _e7_or_zero(deg: float) -> int:
    """degE7 of an x / y; NaN (an unused field left "default") is sent as 0, the only
    integer that means "not given" to ArduPilot (latitude and longitude 0 = here)."""
    return 0 if math.isnan(deg) else deg_to_e7(deg)


def e7_to_deg(value_e7: int) -> float:
    """MAVLink degE7 integer -> float degrees."""
    return value_e7 / _E7


@dataclass(frozen=True)
class MissionItem:
    """One mission item, MISSION_ITEM_INT semantics, degrees as floats."""

    seq: int  # index in the mission, 0 = home
    frame: int  # MAV_FRAME
    command: int  # MAV_CMD
    current: int  # 1 if this is the current item, else 0
    autocontinue: int  # 1 to go on to the next item when this one completes
    param1: float  # meaning depends on command (NaN = default)
    param2: float
    param3: float
    param4: float
    x_lat_deg: float  # PARAM5: latitude [deg] in global frames
    y_lon_deg: float  # PARAM6: longitude [deg] in global frames
    z_alt_m: float  # PARAM7: altitude [m], MSL or above home by frame
    mission_type: int = MISSION_TYPE_MISSION  # MAV_MISSION_TYPE

    def __post_init__(self) -> None:
        for name in _INT_FIELDS:
            value = getattr(self, name)
            if isinstance(value, bool):
                value = int(value)
            object.__setattr__(self, name, operator.index(value))
        for name in _FLOAT_FIELDS:
            value = float(getattr(self, name))
            object.__setattr__(self, name, _NAN if math.isnan(value) else value)

    @property
    def params(self) -> tuple[float, float, float, float, float, float, float]:
        """PARAM1..PARAM7 in order, as a .plan file and a MISSION_ITEM list them."""
        return (self.param1, self.param2, self.param3, self.param4,
                self.x_lat_deg, self.y_lon_deg, self.z_alt_m)

    @property
    def command_name(self) -> str:
        return COMMAND_NAMES.get(self.command, f"MAV_CMD {self.command}")

    @classmethod
    def from_int(cls, msg: Any) -> MissionItem:
        """From a MISSION_ITEM_INT (a pymavlink message or anything with its field names).

        x / y are degE7 for every frame we support; ArduPilot applies the same scale to
        MAV_FRAME_MISSION, and our DO_ commands do not use x / y.
        """
        return cls(
            seq=msg.seq, frame=msg.frame, command=msg.command, current=msg.current,
            autocontinue=msg.autocontinue, param1=msg.param1, param2=msg.param2,
            param3=msg.param3, param4=msg.param4, x_lat_deg=e7_to_deg(msg.x),
            y_lon_deg=e7_to_deg(msg.y), z_alt_m=msg.z,
            mission_type=getattr(msg, "mission_type", MISSION_TYPE_MISSION),
        )

    def to_int(self) -> dict[str, int | float]:
        """MISSION_ITEM_INT fields by their pymavlink names, for
        `mav.mission_item_int_send(target_system, target_component, **item.to_int())`."""
        return {
            "seq": self.seq, "frame": self.frame, "command": self.command,
            "current": self.current, "autocontinue": self.autocontinue,
            "param1": self.param1, "param2": self.param2, "param3": self.param3,
            "param4": self.param4, "x": _e7_or_zero(self.x_lat_deg),
            "y": _e7_or_zero(self.y_lon_deg), "z": self.z_alt_m,
            "mission_type": self.mission_type,
        }

    @classmethod
    def from_float(cls, msg: Any) -> MissionItem:
        """From a (deprecated) MISSION_ITEM, whose x / y are already float degrees."""
        return cls(
            seq=msg.seq, frame=msg.frame, command=msg.command, current=msg.current,
            autocontinue=msg.autocontinue, param1=msg.param1, param2=msg.param2,
            param3=msg.param3, param4=msg.param4, x_lat_deg=msg.x, y_lon_deg=msg.y,
            z_alt_m=msg.z, mission_type=getattr(msg, "mission_type", MISSION_TYPE_MISSION),
        )

    def replace(self, **changes: Any) -> MissionItem:
        values = {f.name: getattr(self, f.name) for f in fields(self)}
        values.update(changes)
        return MissionItem(**values)


@dataclass(frozen=True)
class Problem:
    """Why an item or a mission is refused."""

    seq: int  # the offending item
    code: str  # MAV_MISSION_RESULT name, e.g. "MAV_MISSION_INVALID_PARAM5_X"
    text: str  # for a person

    def __str__(self) -> str:
        return f"{self.text} ({self.code})"


def vehicle_kind(mav_type: int) -> str:
    """'plane' or 'quad' for a HEARTBEAT MAV_TYPE (what `VEHICLE_COMMANDS` is keyed by)."""
    return "plane" if mav_type == mavlink2.MAV_TYPE_FIXED_WING else "quad"


def _uses_position(item: MissionItem) -> bool:
    if item.command in POSITION_COMMANDS or item.command in ROI_COMMANDS:
        return True
    return item.command == DO_SET_HOME and item.param1 == 0.0


def _is_whole(value: float) -> bool:
    return math.isfinite(value) and value == int(value)


def item_problem(item: MissionItem, vehicle: str | None = None) -> Problem | None:
    """The first thing wrong with one item on its own, or None; with ``vehicle``
    ('plane' / 'quad') also what that vehicle cannot fly (`vehicle_problem`)."""
    problem = _item_problem(item)
    if problem is None and vehicle is not None:
        problem = vehicle_problem(item, vehicle)
    return problem


def _item_problem(item: MissionItem) -> Problem | None:
    seq = item.seq

    def bad(code: str, text: str) -> Problem:
        return Problem(seq, f"MAV_MISSION_{code}", text)

    if item.seq < 0:
        return bad("INVALID_SEQUENCE", f"negative seq {item.seq}")
    if item.mission_type != MISSION_TYPE_MISSION:
        return bad("UNSUPPORTED", f"mission_type {item.mission_type} (only plain missions)")
    if item.command not in SUPPORTED_COMMANDS:
        known = mavlink2.enums["MAV_CMD"].get(item.command)
        if known is None:
            return bad("UNSUPPORTED", f"unknown command {item.command}")
        return bad("UNSUPPORTED", f"{known.name.removeprefix('MAV_CMD_')} ({item.command}) "
                                  "is not supported")
    if item.frame not in SUPPORTED_FRAMES:
        return bad("UNSUPPORTED_FRAME", f"unsupported frame {item.frame}")
    if item.current not in (0, 1):
        return bad("INVALID", f"current must be 0 or 1, got {item.current}")
    if item.autocontinue not in (0, 1):
        return bad("INVALID", f"autocontinue must be 0 or 1, got {item.autocontinue}")

    name = item.command_name
    if _uses_position(item):
        if item.frame not in GLOBAL_FRAMES:
            return bad("UNSUPPORTED_FRAME", f"{name} needs a global frame, got frame {item.frame}")
        if not (math.isfinite(item.x_lat_deg) and -90.0 <= item.x_lat_deg <= 90.0):
            return bad("INVALID_PARAM5_X", f"latitude {item.x_lat_deg} outside [-90, 90]")
        if not (math.isfinite(item.y_lon_deg) and -180.0 <= item.y_lon_deg <= 180.0):
            return bad("INVALID_PARAM6_Y", f"longitude {item.y_lon_deg} outside [-180, 180]")
        if math.isnan(item.z_alt_m) and item.command in NAN_ALT_COMMANDS:
            pass   # NaN altitude: the current altitude (MAVLink's "no change")
        elif not (math.isfinite(item.z_alt_m) and ALT_MIN_M <= item.z_alt_m <= ALT_MAX_M):
            return bad("INVALID_PARAM7",
                       f"altitude {item.z_alt_m} m outside [{ALT_MIN_M:g}, {ALT_MAX_M:g}]")
    else:
        # x / y / z are unused; they must still be numbers that fit MISSION_ITEM_INT.
        # NaN ("unused", as QGroundControl writes null) is sent as 0 in x / y (`to_int`).
        for code, value, limit in (("INVALID_PARAM5_X", item.x_lat_deg, _UNUSED_XY_MAX),
                                   ("INVALID_PARAM6_Y", item.y_lon_deg, _UNUSED_XY_MAX),
                                   ("INVALID_PARAM7", item.z_alt_m, math.inf)):
            if math.isnan(value):
                continue
            if not (math.isfinite(value) and abs(value) <= limit):
                return bad(code, f"{name}: unused x/y/z value {value} does not fit the INT message")

    if item.command == NAV_TAKEOFF:
        if not (math.isnan(item.param1) or -90.0 <= item.param1 <= 90.0):
            return bad("INVALID_PARAM1", f"takeoff pitch {item.param1} deg outside [-90, 90]")
    elif item.command == NAV_LOITER_TURNS:
        if not (math.isfinite(item.param1) and item.param1 > 0.0):
            return bad("INVALID_PARAM1", f"loiter turns {item.param1} must be > 0")
        if not (math.isnan(item.param3) or abs(item.param3) <= 10000.0):
            return bad("INVALID_PARAM3", f"loiter radius {item.param3} m is absurd")
    elif item.command == NAV_LOITER_TIME:
        if not (math.isfinite(item.param1) and item.param1 >= 0.0):
            return bad("INVALID_PARAM1", f"loiter time {item.param1} s must be >= 0")
    elif item.command == NAV_LOITER_UNLIM:
        if not (math.isnan(item.param3) or abs(item.param3) <= 10000.0):
            return bad("INVALID_PARAM3", f"loiter radius {item.param3} m is absurd")
    elif item.command == DO_JUMP:
        if not (_is_whole(item.param1) and item.param1 >= 1.0):
            return bad("INVALID_PARAM1", f"DO_JUMP target {item.param1:g} is not a seq >= 1")
        if item.param1 == item.seq:
            return bad("INVALID_PARAM1", f"DO_JUMP to itself (seq {item.seq})")
        if not (_is_whole(item.param2) and item.param2 >= -1.0):
            return bad("INVALID_PARAM2",
                       f"DO_JUMP repeat {item.param2:g} is not a count >= 0 or -1 (for ever)")
    elif item.command == DO_CHANGE_SPEED:
        if item.param1 not in (0.0, 1.0, 2.0, 3.0):
            return bad("INVALID_PARAM1", f"speed type {item.param1} not in 0..3")
        if not (item.param2 in (-1.0, -2.0) or (0.0 <= item.param2 <= SPEED_MAX_M_S)):
            return bad("INVALID_PARAM2", f"speed {item.param2} m/s not -1 (no change), "
                                         f"-2 (default) or in [0, {SPEED_MAX_M_S:g}]")
        if not (math.isnan(item.param3) or item.param3 == -1.0 or 0.0 <= item.param3 <= 100.0):
            return bad("INVALID_PARAM3", f"throttle {item.param3} % not -1 or in [0, 100]")
    elif item.command == DO_SET_HOME:
        if item.param1 not in (0.0, 1.0):
            return bad("INVALID_PARAM1", f"DO_SET_HOME use-current {item.param1} not 0 or 1")
    elif item.command == NAV_LOITER_TO_ALT:
        if not (math.isnan(item.param2) or abs(item.param2) <= 10000.0):
            return bad("INVALID_PARAM2", f"loiter radius {item.param2} m is absurd")
    elif item.command == NAV_DELAY:
        if not (math.isfinite(item.param1) and item.param1 >= -1.0):
            return bad("INVALID_PARAM1", f"NAV_DELAY {item.param1} s must be >= 0 (or -1)")
        if item.param1 < 0.0:
            return bad("UNSUPPORTED", "NAV_DELAY until a time of day (param1 -1) is not "
                                      "supported: give the delay in seconds")
    elif item.command in (CONDITION_DELAY, CONDITION_DISTANCE):
        if not (math.isfinite(item.param1) and item.param1 >= 0.0):
            unit = "s" if item.command == CONDITION_DELAY else "m"
            return bad("INVALID_PARAM1", f"{name} {item.param1} {unit} must be >= 0")
    elif item.command == CONDITION_YAW:
        # (relative turns of more than a circle are flown: ArduCopter's autotest turns 640 deg)
        if not (math.isfinite(item.param1) and 0.0 <= item.param1 <= 3600.0):
            return bad("INVALID_PARAM1", f"CONDITION_YAW angle {item.param1} deg not in [0, 3600]")
        if not (math.isnan(item.param2) or 0.0 <= item.param2 <= 360.0):
            return bad("INVALID_PARAM2", f"CONDITION_YAW rate {item.param2} deg/s not in [0, 360]")
        if item.param3 not in (-1.0, 0.0, 1.0):
            return bad("INVALID_PARAM3", f"CONDITION_YAW direction {item.param3} not -1, 0 or 1")
        if item.param4 not in (0.0, 1.0):
            return bad("INVALID_PARAM4", f"CONDITION_YAW relative {item.param4} not 0 or 1")
    return None


def _plane_problem(item: MissionItem) -> str | None:
    """What the fixed-wing does not fly yet within the commands it flies, or None."""
    if item.command == DO_CHANGE_SPEED and math.isfinite(item.param3) and item.param3 > 0.0:
        # (ArduPlane sets its cruise throttle; here the airspeed loop sets the throttle)
        return f"DO_CHANGE_SPEED throttle {item.param3:g} %"
    if item.command == NAV_LAND and item.x_lat_deg == 0 and item.y_lon_deg == 0:
        # (a landing needs its point: the approach is the leg from the previous waypoint)
        return "NAV_LAND at latitude/longitude 0 (here)"
    return None


def vehicle_problem(item: MissionItem, vehicle: str) -> Problem | None:
    """Why ``vehicle`` ('plane' / 'quad') cannot fly this (otherwise valid) item, or None.
    Item 0 (home) is not flown and never refused here."""
    if item.seq == 0:
        return None
    who = VEHICLE_NAMES.get(vehicle, vehicle)
    if item.command not in VEHICLE_COMMANDS[vehicle]:
        return Problem(item.seq, "MAV_MISSION_UNSUPPORTED",
                       f"{item.command_name} is not flown by {who}")
    if vehicle == "plane":
        what = _plane_problem(item)
        if what is not None:
            return Problem(item.seq, "MAV_MISSION_UNSUPPORTED", f"{what} is not flown by {who}")
    return None


def terrain_problem(mission, terrain) -> str | None:
    """Why a mission cannot be armed for: a terrain-frame item with a place of its own
    where ``terrain`` (a callable (lat_deg, lon_deg) -> metres or None) has no data, as
    ArduPilot refuses to arm until its terrain data covers the mission. None if every
    such item has data, or if there is no terrain source (flat: data everywhere)."""
    if mission is None or terrain is None:
        return None
    for it in mission.items[1:]:
        if it.frame in TERRAIN_FRAMES and (it.command in POSITION_COMMANDS) \
                and not (it.x_lat_deg == 0.0 and it.y_lon_deg == 0.0):
            if terrain(it.x_lat_deg, it.y_lon_deg) is None:
                # (one STATUSTEXT: 50 characters with "PreArm: ")
                return f"terrain data missing for item {it.seq}"
    return None


def validate_item(item: MissionItem, vehicle: str | None = None) -> str | None:
    """None if the item is acceptable on its own, else a MAV_MISSION_RESULT name."""
    problem = item_problem(item, vehicle)
    return None if problem is None else problem.code


def validate_mission(items: Iterable[MissionItem], vehicle: str | None = None) -> Problem | None:
    """The first thing wrong with a whole mission (item 0 = home), or None.

    Checks: at least the home item; seq == index; home is a NAV_WAYPOINT at an
    absolute altitude; every item passes `item_problem` (for ``vehicle`` if given);
    DO_JUMP targets exist and are not home; the mission can be flown (`_flight_problem`).
    """
    items = tuple(items)
    if not items:
        return Problem(0, "MAV_MISSION_INVALID", "empty mission (no home item)")
    for index, item in enumerate(items):
        if item.seq != index:
            return Problem(index, "MAV_MISSION_INVALID_SEQUENCE",
                           f"expected seq {index}, got {item.seq}")
    home = items[0]
    if home.command != NAV_WAYPOINT:
        return Problem(0, "MAV_MISSION_INVALID",
                       f"item 0 (home) must be NAV_WAYPOINT, got {home.command_name}")
    if home.frame not in ABSOLUTE_ALT_FRAMES:
        return Problem(0, "MAV_MISSION_UNSUPPORTED_FRAME",
                       f"item 0 (home) needs an absolute-altitude frame (0 or 5), got {home.frame}")
    for item in items:
        problem = item_problem(item, vehicle)
        if problem is not None:
            return problem
        if item.command == DO_JUMP and not 1 <= int(item.param1) < len(items):
            return Problem(item.seq, "MAV_MISSION_INVALID_PARAM1",
                           f"DO_JUMP to missing item {int(item.param1)} "
                           f"(mission has items 1..{len(items) - 1})")
    return _flight_problem(items)


def _flight_problem(items: tuple[MissionItem, ...]) -> Problem | None:
    """A mission that cannot be flown at all: items but no navigation command, or DO
    items and jumps that loop for ever without one.

    From a DO item the sequencer goes on to the next item, or, from a DO_JUMP repeated
    for ever (param2 -1), to its target; a jump repeated a finite number of times falls
    through in the end. These moves form a functional graph on the DO items; a cycle in
    it is a loop the vehicle never leaves (ArduPilot stops such a mission in flight)."""
    if len(items) > 1 and not any(it.command in NAV_COMMANDS for it in items[1:]):
        return Problem(1, "MAV_MISSION_INVALID", "no navigation command in the mission "
                                                 "(nothing to fly)")

    def after(it: MissionItem) -> int:
        if it.command == DO_JUMP and it.param2 < 0:
            return int(it.param1)
        return it.seq + 1

    done: set[int] = set()
    for start in range(1, len(items)):
        path: list[int] = []
        seq = start
        while (seq < len(items) and seq not in done and items[seq].command not in NAV_COMMANDS
               and seq not in path):
            path.append(seq)
            seq = after(items[seq])
        if seq in path:
            jumps = [s for s in path[path.index(seq):] if items[s].command == DO_JUMP]
            j = jumps[0] if jumps else seq
            return Problem(j, "MAV_MISSION_INVALID_PARAM1",
                           f"DO_JUMP {j} loops for ever through items "
                           f"{min(path[path.index(seq):])}..{max(path[path.index(seq):])} "
                           "with no navigation command in the loop")
        done.update(path)
    return None


@dataclass(frozen=True)
class Mission:
    """An immutable, valid mission: item 0 is home. Raises ValueError if invalid."""

    items: tuple[MissionItem, ...]

    def __post_init__(self) -> None:
        object.__setattr__(self, "items", tuple(self.items))
        problem = validate_mission(self.items)
        if problem is not None:
            raise ValueError(f"item {problem.seq}: {problem}")

    @property
    def home(self) -> MissionItem:
        return self.items[0]

    def __len__(self) -> int:
        return len(self.items)

    def __iter__(self) -> Iterator[MissionItem]:
        return iter(self.items)

    def __getitem__(self, seq: int) -> MissionItem:
        return self.items[seq]
