"""Multirotor flight modes, numbered as ArduCopter numbers them (HEARTBEAT
custom_mode), so that MAVProxy's ``mode LOITER``, MAVSDK's flight_mode and
QGroundControl's mode list agree with what the vehicle does. A ground station asking
for a mode not listed in IMPLEMENTED_COPTER_MODES gets MAV_RESULT_UNSUPPORTED.

What each does (autopilot/vehicle_quad.py):

* STABILIZE  pilot roll / pitch angles, yaw rate and collective thrust (RC input;
             neutral sticks and the hover throttle without a pilot)
* ALT_HOLD   pilot roll / pitch angles and yaw rate; height held, throttle stick
             commands a climb rate
* AUTO       fly the mission
* GUIDED     fly to the ground station's target (MAV_CMD_DO_REPOSITION /
             SET_POSITION_TARGET), hold there
* LOITER     hold the position (the pilot's sticks move it)
* RTL        climb to RTL_ALT, return home, land, disarm
* LAND       land where it is, disarm
"""
from __future__ import annotations

from enum import IntEnum


class CopterMode(IntEnum):
    STABILIZE = 0
    ALT_HOLD = 2
    AUTO = 3
    GUIDED = 4
    LOITER = 5
    RTL = 6
    LAND = 9


IMPLEMENTED_COPTER_MODES = frozenset(CopterMode)
# modes that fly on the position loops (they need a healthy position estimate)
POSITION_MODES = frozenset({CopterMode.AUTO, CopterMode.GUIDED, CopterMode.LOITER,
                            CopterMode.RTL, CopterMode.LAND})
