"""Geofence and rally points: the zones, the breach check and its actions' targets.

``geofence.py`` holds the geometry (polygon and circle zones, the altitude band), the
checks of uploaded fence and rally items, and :class:`Geofence`, the per-vehicle state
that both vehicle loops consult each step. ``files.py`` reads MAVProxy's fence and
rally files. The ground-station side (MAV_MISSION_TYPE_FENCE / _RALLY over the mission
protocol) is ``autopilot/gcs/mission.py``.
"""
from .geofence import (BREACH_TYPE_NAMES, FENCE_PARAMS, RALLY_PARAMS, Geofence, FenceSet, RallySet,
                       fence_items_problem, rally_items_problem)

__all__ = ["BREACH_TYPE_NAMES", "FENCE_PARAMS", "RALLY_PARAMS", "Geofence", "FenceSet", "RallySet",
           "fence_items_problem", "rally_items_problem"]
