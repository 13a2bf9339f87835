"""What a vehicle does with its geofence each step: the breach check on the navigation
solution, the FENCE_ACTION taken, the STATUSTEXTs. Shared by both vehicle loops, through
``autopilot.vehicle_api.VehicleApi`` only (``set_mode``, ``set_guided_target``,
``notice``) plus the vehicle's ``geofence``.
"""
from __future__ import annotations

import math

SEV_CRITICAL, SEV_WARNING, SEV_INFO = 2, 4, 6


def home_ll(v) -> tuple[float, float, float] | None:
    """Home as (lat_deg, lon_deg, alt_m MSL), or None before it is set."""
    hf = v.home_frame
    if hf is None:
        return None
    return (math.degrees(hf.lat0_rad), math.degrees(hf.lon0_rad), hf.alt0_m)


def fence_watching(g) -> bool:
    """Whether ``fence_step`` has anything to do with geofence ``g``: a fence enabled, or
    a breach still to clear. (A vehicle asks this first, every step, and leaves out the
    arguments it would have worked out for ``fence_step``.)"""
    return bool(g.breached) or g.params["FENCE_ENABLE"] >= 1


def fence_step(v, t_us: int, flying: bool, landing: bool = False) -> None:
    """Check the fence on ``v.nav_state``; on a breach take the action, on its end say so."""
    g = v.geofence
    if not fence_watching(g):
        return                                   # (off: nothing to do, every step)
    nav = v.nav_state
    home = home_ll(v)
    if nav is None or (home is None and not g.breached):
        return
    lat, lon = math.degrees(nav.lat_rad), math.degrees(nav.lon_rad)
    h = nav.alt_m - home[2] if home is not None else 0.0
    ev = g.update(t_us, lat, lon, h, home[:2] if home is not None else None, flying, landing)
    t_s = t_us * 1e-6
    if ev == "breach":
        action = take_action(v, g.action, t_us)
        g.note_action(action)
        v.notice(t_s, SEV_CRITICAL, f"Fence breach: {g.type_name(g.breached)}, {action}")
    elif ev == "clear":
        v.notice(t_s, SEV_INFO, "Fence breach cleared")


def take_action(v, action: str, t_us: int) -> str:
    """FENCE_ACTION: RTL (or LAND where RTL is refused), LAND, GUIDED to the fence return
    point (home without one, at the current altitude when the point gives none).
    Returns what was done ("report" when nothing could be)."""
    if action == "report":
        return "report"
    if action == "GUIDED":
        mode = v.modes.__members__.get("GUIDED")
        h = home_ll(v)
        rp = v.geofence.return_point(h[2]) if h is not None else None
        if rp is None and h is not None:
            rp = (h[0], h[1], math.nan)
        nav = v.nav_state
        if mode is not None and rp is not None and (v.mode == mode or v.set_mode(mode, t_us) is None):
            alt = nav.alt_m if math.isnan(rp[2]) else rp[2]
            if v.set_guided_target(math.radians(rp[0]), math.radians(rp[1]), alt, t_us) is None:
                return "GUIDED"
        action = "RTL"
    for name in (("RTL", "LAND") if action == "RTL" else ("LAND", "RTL")):
        mode = v.modes.__members__.get(name)
        if mode is None or mode not in v.implemented_modes:
            continue
        if v.mode == mode or v.set_mode(mode, t_us) is None:
            return name
    return "report"
