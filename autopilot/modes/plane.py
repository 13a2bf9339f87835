"""Fixed-wing flight modes, numbered as ArduPlane numbers them (HEARTBEAT custom_mode),
so that MAVProxy's ``mode AUTO``, MAVSDK's flight_mode and QGroundControl's mode list
agree with what the vehicle does. Only the modes listed here are implemented; a ground
station asking for another gets MAV_RESULT_UNSUPPORTED."""
from __future__ import annotations

from enum import IntEnum


class PlaneMode(IntEnum):
    MANUAL = 0      # on the ground / disarmed: surfaces neutral, throttle off
    AUTO = 10       # fly the mission
    RTL = 11        # return to home and loiter over it
    LOITER = 12     # circle where the mode was entered (LOITER_RAD), at that height
    GUIDED = 15     # circle the ground station's target (DO_REPOSITION / SET_POSITION_TARGET)


IMPLEMENTED_PLANE_MODES = frozenset({PlaneMode.MANUAL, PlaneMode.AUTO, PlaneMode.RTL,
                                     PlaneMode.LOITER, PlaneMode.GUIDED})
