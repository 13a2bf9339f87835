"""Where a mission starts: the launch pose both programs take from a mission file.

The simulator places the vehicle there (``sim-bridge --mission``, ``sitl run``) and the
benchmark flies from it; the autopilot itself sets home at arming from its navigation
solution (docs/design-decisions.md, "Home").
"""
from __future__ import annotations

import math

from .items import POSITION_COMMANDS, Mission


def mission_home(mission: Mission) -> tuple[float, float, float, float]:
    """(lat_deg, lon_deg, alt_m, heading_deg): item 0's position, heading towards the
    first later item with a position of its own (the launch direction), else north.
    Items at lat/lon 0 (here) do not count."""
    h = mission.home
    heading = 0.0
    for it in list(mission)[1:]:
        if it.command in POSITION_COMMANDS and (it.x_lat_deg, it.y_lon_deg) != (h.x_lat_deg, h.y_lon_deg):
            if it.x_lat_deg == 0 and it.y_lon_deg == 0:
                continue
            # initial great-circle bearing from home to the item
            lat1, lat2 = math.radians(h.x_lat_deg), math.radians(it.x_lat_deg)
            dlon = math.radians(it.y_lon_deg - h.y_lon_deg)
            y = math.sin(dlon) * math.cos(lat2)
            x = math.cos(lat1) * math.sin(lat2) - math.sin(lat1) * math.cos(lat2) * math.cos(dlon)
            heading = math.degrees(math.atan2(y, x)) % 360.0
            break
    return h.x_lat_deg, h.y_lon_deg, h.z_alt_m, heading
