"""Flight invariants and the cross-track error against the mission as written.

Both are computed from a finished run's flight log (truth in home's NED frame), its
mission and the vehicle's reached events (``reached_events()``: (t_us, seq) of every
item the sequencer counted, DO_ items and taken DO_JUMPs included).

The mission's lines (``mission_legs``)
    The mission as written is resolved into the items it executes
    (``tools.missions_random.resolve_order``: DO_JUMPs taken as many times as their
    repeat count). Its navigation items in that order, starting from the take-off point
    (the NAV_TAKEOFF's position for the fixed-wing when it has one, else home; the quad
    takes off where it stands, as ArduCopter ignores the take-off's position), give
    the lines: from each point to the next (a loiter's centre is its point; RTL goes
    home; latitude and longitude 0 mean "where the previous item was"). Lines shorter
    than 1 m (duplicates, a landing "here") are left out.

Cross-track against them (``xtrack_mission``)
    Each line is scored over its leg: from the sequencer's counting of the item before
    it (the take-off, for the first; its last counting where a go-around flew the pass
    again) to its own counting, the k-th visit of an item
    matched to the k-th reached event of that item. For a fixed-wing loiter the leg ends
    earlier, where the vehicle reaches the circle (the radius it flew, which is wider
    than the one written where that is under the minimum turn radius; LOITER_RAD for 0;
    plus ``CAPTURE_M``). As for the flown legs (tools/summary.py), a leg counts from its
    capture: its first sample within ``CAPTURE_M`` of the line between the two items
    (the segment, not its extension: a loop that crosses the line's extension far beyond
    either item is not on the line the user drew) flying along it (true ground velocity
    less than 90 degrees from the line's direction); from there the error is the
    distance from the line through the two items. The direction
    matters for the mission's lines as it does not for the legs guidance draws: after a
    reversal the aircraft is at the new line's start, but flying the other way, and the
    turn back is the join, not tracking. An item never counted has its leg run to the
    end of the log. The approach to a fixed-wing NAV_LAND is scored from where the
    vehicle leaves the last circling the landing commands (the descent circle of an
    approach started too high, guidance/landing.py; the turn-in's arcs) onto the
    approach line.

``xtrack_mission_worst_leg`` names the line with the largest error (the items at its two
ends, ``from_seq`` null for the take-off point) with its own rms and max;
``xtrack_mission_legs`` lists every line so (rms and max null for a line never captured),
e.g. each transect of a survey.

The invariants (``check_invariants``): each ``{"passed": bool, "figure": number}`` and,
where a bound applies, ``"limit"`` (``mission_order`` and ``no_orbit`` also name the item
concerned, ``"seq"``, or null):

* ``mission_order``: the navigation items reached are exactly those of the resolved
  order (``expected_order``), and the end of the mission was flown (the sequencer
  finished: the fixed-wing's loiter over home established, the quad landed; not crashed). Figure: the
  number of expected visits not matched in order (the first mismatch onwards). A
  fixed-wing go-around (an aborted approach, guidance/landing.py) flies its landing
  sequence again from its DO_LAND_START: the passes it abandoned are not counted.
* ``time_bound``: done (completed) within ``TIME_FACTOR`` x the mission's time estimate
  at the worst-wind ground speed (``missions_random.estimate_time_s`` with every speed
  scaled by (lowest airspeed - wind) / cruise airspeed for the fixed-wing; the quad flies
  its ground speed) plus ``TIME_SLACK_S``. Figure: seconds from arming to done (to the
  end of the run if not done).
* ``no_orbit``: over each stretch of the log flying one item that is not a loiter (and
  not the loiter over home that ends a fixed-wing mission), the range of the
  accumulated course change of the true ground velocity (above ``ORBIT_MIN_GS`` m/s)
  is at most two full turns; on a NAV_LAND, the circling the landing itself commands
  (its descent circle, kind "loiter", guidance/landing.py ``descend``) is left out.
  Figure: the largest number of turns.
* ``waypoints_passed``: every NAV_WAYPOINT with a position of its own (a line of the
  mission ends at it) is passed within its acceptance radius (its param2, else
  WP_RADIUS / WPNAV_RADIUS) plus ``PASS_MARGIN_M`` (the navigation's error), on the
  true track between the counting of the item before it (the launch, after a take-off:
  one inside the climb-out is passed before the take-off counts; the counting of the
  one before that where the item before lies within its radius: a cluster, passed on
  one turn in either order) and the next counting,
  after its own, of an item elsewhere (one whose acceptance circle, 0 for an item
  other than a NAV_WAYPOINT, does not overlap this one's: a turn counted where it
  starts passes the waypoint after the counting, and a cluster's items, or one
  counted at once with it, count on the same turn, as the vehicle enters each one's
  circle):
  a waypoint the sequencer counts is one the vehicle went to, as ArduPlane's is (its
  turn anticipation is capped at WP_RADIUS). Figure: the largest closest approach
  beyond the item's radius [m] (negative: every one within it), ``seq`` the item.
* ``no_ground_contact``: from ``LAUNCH_GRACE_S`` after the take-off begins, and the
  aircraft ``LIFTOFF_M`` above home (a runway take-off's ground roll is longer than the
  grace), to the start of a landing (the quad's land phase), the true height above home
  stays above
  ``CONTACT_M``, and the run did not end in a crash (the runner's ``crashed``: the
  fixed-wing's crash detection, or back on the ground). Figure: the lowest true height
  in that span (from the launch, for a crash before its end) [m].
* ``height_floor``: from the end of the climb-out (the take-off counted) to the start of
  a landing, the true height above home (above the terrain in a ``--terrain`` run)
  stays at or above the floor: ``HEIGHT_FLOOR_M``
  of the vehicle, or half the lowest height commanded after the take-off if that is lower.
  Figure: the lowest true height [m].
* ``attitude_limits``: fixed-wing bank within ROLL_LIMIT_DEG and pitch within
  PTCH_LIM_MIN_DEG..PTCH_LIM_MAX_DEG, quad tilt within ANGLE_MAX_DEG, each plus
  ``ATTITUDE_MARGIN_DEG`` (gusts), while flying. Figure: the largest bank (tilt) [deg].
* ``finite_log``: no NaN or inf in the flight log, but in the columns that are NaN by
  design (truth on rows without truth, GPS on rows without a fix, filter sigmas on
  truth navigation). Figure: the number of non-finite values.
* ``no_unexpected_mode``: in a run with no fault injected, no geofence breach and no
  ground station, no mode change after the first AUTO, no failsafe or crash event, no
  fixed-wing disarm (it only disarms on a crash). Figure: their number (always counted; passes
  regardless in other runs). The fault monitor's false alarms that change no mode are
  the summary's ``false_alarms``.
"""
from __future__ import annotations

import math

import numpy as np

from autopilot.geo import LocalFrame
from autopilot.mission.items import (DO_LAND_START, NAV_LAND, NAV_LOITER_TIME, NAV_LOITER_TO_ALT,
                                     NAV_LOITER_TURNS, NAV_LOITER_UNLIM, NAV_RETURN_TO_LAUNCH,
                                     NAV_TAKEOFF, NAV_WAYPOINT, Mission)

from .missions_random import NAV_FLOWN, estimate_time_s, item_ne_h, resolve_order

CAPTURE_M = 10.0
TIME_FACTOR = 1.5
TIME_SLACK_S = 60.0
ORBIT_MIN_GS = {"plane": 2.0, "quad": 1.0}
ORBIT_MAX_TURNS = 2.0
LAUNCH_GRACE_S = 5.0
LIFTOFF_M = 1.0          # off the ground: this high above home (tools/runner.py's LEFT_GROUND_M)
CONTACT_M = {"plane": 0.5, "quad": 0.2}
HEIGHT_FLOOR_M = {"plane": 20.0, "quad": 1.5}
ATTITUDE_MARGIN_DEG = {"plane": 10.0, "quad": 5.0}
PASS_MARGIN_M = {"plane": 10.0, "quad": 1.0}   # navigation error over a waypoint's radius
KIND_LOITER = 3    # autopilot/vehicle.py KIND_CODES["loiter"]
LOITERS = (NAV_LOITER_TURNS, NAV_LOITER_TIME, NAV_LOITER_UNLIM, NAV_LOITER_TO_ALT)
QUAD_KIND_LAND = 4
# flight-log columns that are NaN by design on some rows
NAN_BY_DESIGN_PREFIXES = ("truth_", "gps_", "sig_")


# --- the mission's lines -------------------------------------------------------------

def mission_legs(mission: Mission, frame: LocalFrame, vehicle: str, params=None,
                 loiter_radii=()) -> list[dict]:
    """The lines of the mission as written, in the order they are flown: dicts with
    ``visit`` (index into the navigation items flown), ``seq`` (the item at the line's
    end), ``prev_seq``, ``a`` / ``b`` (north, east) and ``loiter_r`` (fixed-wing loiter
    radius flown, else 0). ``loiter_radii``: the sequencer's (seq, radius flown) of
    every loiter in the order flown (a radius under the minimum turn radius is flown
    wider); a visit it does not cover takes the radius as written (LOITER_RAD for 0)."""
    order = [s for s in resolve_order(mission) if mission[s].command in NAV_FLOWN]
    flown: dict[int, list[float]] = {}
    for seq, r in loiter_radii:
        flown.setdefault(int(seq), []).append(float(r))
    legs: list[dict] = []
    point = (0.0, 0.0)
    prev_seq = None
    for visit, seq in enumerate(order):
        it = mission[seq]
        p = item_ne_h(mission, seq, frame)
        if it.command == NAV_TAKEOFF:
            if vehicle == "plane" and p is not None:
                point = (p[0], p[1])
            prev_seq = seq
            continue
        if it.command == NAV_RETURN_TO_LAUNCH:
            b = (0.0, 0.0)
        else:
            b = point if p is None else (p[0], p[1])
        r = 0.0
        if vehicle == "plane" and it.command in LOITERS:
            if flown.get(seq):
                r = flown[seq].pop(0)
            else:
                written = it.param2 if it.command == NAV_LOITER_TO_ALT else it.param3
                r = abs(written) if abs(written) > 1.0 else \
                    (params["LOITER_RAD"] if params is not None else 80.0)
        if math.hypot(b[0] - point[0], b[1] - point[1]) >= 1.0:
            legs.append({"visit": visit, "seq": seq, "prev_seq": prev_seq, "a": point, "b": b,
                         "loiter_r": r})
        point, prev_seq = b, seq
    return legs


def _nav_events(mission: Mission, events) -> list[tuple[float, int]]:
    return [(t_us * 1e-6, seq) for t_us, seq in events
            if 0 < seq < len(mission) and mission[seq].command in NAV_FLOWN]


def leg_windows(mission: Mission, legs: list[dict], events, t_end: float) -> list[tuple[float, float] | None]:
    """(t_start, t_end] of each leg from the reached events (None: its start never came)."""
    order = [s for s in resolve_order(mission) if mission[s].command in NAV_FLOWN]
    nav = _nav_events(mission, events)
    # match the expected visits to the reached events in order
    times: list[float | None] = []
    j = 0
    for seq in order:
        k = j
        while k < len(nav) and nav[k][1] != seq:
            k += 1
        if k < len(nav):
            times.append(nav[k][0])
            j = k + 1
        else:
            times.append(None)
    out = []
    for leg in legs:
        v = leg["visit"]
        start = times[v - 1] if v >= 1 else None
        if start is None:
            out.append(None)
            continue
        end = times[v] if times[v] is not None else t_end
        # a pass flown again before the leg's end came (a go-around's second approach
        # through its landing sequence): the leg is scored on the last pass, not across
        # the go-around's climb-out and circuit
        again = [t for t, q in nav if q == order[v - 1] and start < t < end]
        if again:
            start = again[-1]
        out.append((start, end))
    return out


def xtrack_mission(a: dict, mission: Mission, frame: LocalFrame, vehicle: str, events,
                   params=None, loiter_radii=()) -> tuple[float | None, float | None, list[dict]]:
    """(rms, max) of the true cross-track error against the mission's lines, and the
    legs with their figures (module docstring)."""
    legs = mission_legs(mission, frame, vehicle, params, loiter_radii)
    t = a["t_s"]
    if not len(t):
        return None, None, legs
    windows = leg_windows(mission, legs, events, float(t[-1]))
    tn, te = a["truth_n_m"], a["truth_e_m"]
    parts = []
    for leg, win in zip(legs, windows):
        leg["xtrack_rms_m"] = leg["xtrack_max_m"] = None
        if win is None:
            continue
        m = (t > win[0]) & (t <= win[1]) & np.isfinite(tn)
        idx = np.flatnonzero(m)
        if idx.size and "kind" in a and mission[leg["seq"]].command == NAV_LAND:
            # the circling the landing itself commands (its descent circle, and the
            # turn-in's arcs, kind "loiter") is not the line: scored from where the
            # vehicle leaves the last of it onto the approach
            circ = np.flatnonzero(a["kind"][idx] == KIND_LOITER)
            if circ.size:
                idx = idx[circ[-1] + 1:]
        if not idx.size:
            continue
        (an, ae), (bn, be) = leg["a"], leg["b"]
        length = math.hypot(bn - an, be - ae)
        un, ue = (bn - an) / length, (be - ae) / length
        xt = (tn[idx] - an) * (-ue) + (te[idx] - ae) * un
        along = (tn[idx] - an) * un + (te[idx] - ae) * ue
        along_v = a["truth_vn_mps"][idx] * un + a["truth_ve_mps"][idx] * ue
        if leg["loiter_r"] > 0.0:
            near = np.flatnonzero(np.hypot(tn[idx] - bn, te[idx] - be) <= leg["loiter_r"] + CAPTURE_M)
            if near.size:
                xt, along, along_v = xt[:near[0]], along[:near[0]], along_v[:near[0]]
        # captured on the line between the two items (within CAPTURE_M of the segment),
        # flying along it
        cap = np.flatnonzero((np.abs(xt) <= CAPTURE_M) & (along_v > 0.0)
                             & (along >= -CAPTURE_M) & (along <= length + CAPTURE_M))
        if not cap.size:
            continue
        xt = xt[cap[0]:]
        leg["xtrack_rms_m"] = float(np.sqrt(np.mean(xt ** 2)))
        leg["xtrack_max_m"] = float(np.max(np.abs(xt)))
        parts.append(xt)
    if not parts:
        return None, None, legs
    allx = np.concatenate(parts)
    return float(np.sqrt(np.mean(allx ** 2))), float(np.max(np.abs(allx))), legs


# --- invariants ------------------------------------------------------------------------

def passed_figure(a: dict, mission: Mission, vehicle: str, events, params,
                  frame: LocalFrame) -> tuple[float | None, int | None]:
    """The largest closest approach of the true track to a NAV_WAYPOINT beyond its
    acceptance radius, over the span from the counting of the item before it to the
    counting of the next item whose acceptance circle does not overlap its own, and that
    item (``waypoints_passed``); (None, None)
    where no waypoint was flown to."""
    legs = mission_legs(mission, frame, vehicle, params)
    t = a["t_s"]
    windows = leg_windows(mission, legs, events, float(t[-1]))
    tn, te = a["truth_n_m"], a["truth_e_m"]
    default = float(params["WP_RADIUS"] if vehicle == "plane" else params["WPNAV_RADIUS"])
    worst, at = None, None
    for i, (leg, win) in enumerate(zip(legs, windows)):
        it = mission[leg["seq"]]
        if win is None or it.command != NAV_WAYPOINT:
            continue
        accept = _accept_of(it, default)
        # to the counting of the next item elsewhere: the items of a cluster, whose
        # acceptance circles overlap this one's, count on the same turn, before or
        # after it (an arc that turns past the cluster counts them as it enters their
        # circles, and may pass this one after)
        end = next((w[1] for g, w in zip(legs[i + 1:], windows[i + 1:]) if w is not None
                    and w[1] > win[1]
                    and math.hypot(g["b"][0] - leg["b"][0], g["b"][1] - leg["b"][1])
                    > accept + _accept_of(mission[g["seq"]], default)),
                   float(t[-1]))
        # a waypoint after the take-off may be passed in the climb-out, before the
        # take-off counts (one inside the climb-out, or at home)
        after_takeoff = leg["prev_seq"] is not None and mission[leg["prev_seq"]].command == NAV_TAKEOFF
        start = -math.inf if after_takeoff else win[0]
        # ... or while the item before it flew, where that item's point lies within its
        # radius (a cluster, passed on one turn in either order; a loiter's centre)
        if i > 0 and windows[i - 1] is not None and leg["prev_seq"] == legs[i - 1]["seq"] \
                and math.dist(legs[i - 1]["b"], leg["b"]) <= accept:
            start = min(start, windows[i - 1][0])
        m = (t > start) & (t <= max(end, win[1])) & np.isfinite(tn)
        if not m.any():
            continue
        d = float(np.min(np.hypot(tn[m] - leg["b"][0], te[m] - leg["b"][1]))) - accept
        if worst is None or d > worst:
            worst, at = d, leg["seq"]
    return worst, at


def _accept_of(item, default: float) -> float:
    """A NAV_WAYPOINT's acceptance radius (its own, else the default); 0 for any
    other item."""
    if item.command != NAV_WAYPOINT:
        return 0.0
    return item.param2 if item.param2 > 0 else default


def _inv(passed: bool, figure, limit=None) -> dict:
    out = {"passed": bool(passed), "figure": None if figure is None else float(figure)}
    if limit is not None:
        out["limit"] = float(limit)
    return out


def expected_order(mission: Mission) -> list[int]:
    """The navigation items in the order they are flown (DO_JUMPs resolved). DO_ and
    CONDITION_ items are left out: a condition may hold back the DO items after it past
    the start of the next navigation item, or drop them, as AP_Mission does."""
    return [s for s in resolve_order(mission) if mission[s].command in NAV_FLOWN]


def order_figure(mission: Mission, events) -> tuple[int, int | None]:
    """Expected visits not matched in order (from the first mismatch on), and the
    expected item at the first mismatch (None if all matched)."""
    expected = expected_order(mission)
    actual = _without_abandoned_approaches(
        mission, [seq for _t, seq in events if 0 < seq < len(mission) and mission[seq].command in NAV_FLOWN])
    n = 0
    for e, g in zip(expected, actual):
        if e != g:
            break
        n += 1
    missing = len(expected) - n
    extra = 0 if len(actual) <= len(expected) or missing else len(actual) - len(expected)
    return missing + extra, (expected[n] if missing else None)


def _without_abandoned_approaches(mission: Mission, actual: list[int]) -> list[int]:
    """The visits less the passes through a landing sequence (the items after a
    DO_LAND_START, up to its NAV_LAND) that a go-around abandoned: a visit that goes back
    within the same sequence drops the earlier pass from that item on."""
    seq_of: dict[int, int] = {}          # item -> the DO_LAND_START of its sequence
    start = None
    for it in mission.items[1:]:
        if it.command == DO_LAND_START:
            start = it.seq
        elif start is not None:
            seq_of[it.seq] = start
            if it.command == NAV_LAND:
                start = None
    out: list[int] = []
    for s in actual:
        ls = seq_of.get(s)
        if ls is not None and out and seq_of.get(out[-1]) == ls and out[-1] >= s:
            while out and seq_of.get(out[-1]) == ls and out[-1] >= s:
                out.pop()
        out.append(s)
    return out


def time_bound_s(mission: Mission, vehicle: str, wind_mps: float, params) -> float:
    if vehicle == "plane":
        v_lo = float(params["ARSPD_FBW_MIN"]) if params is not None else 20.0
        v_trim = float(params["TRIM_ARSPD"]) if params is not None else 25.0
        k = max(v_lo - wind_mps, 0.2 * v_lo) / v_trim
    else:
        k = 1.0
    return TIME_FACTOR * estimate_time_s(mission, vehicle, ground_speed_factor=k) + TIME_SLACK_S


def orbit_turns(a: dict, mission: Mission, vehicle: str) -> tuple[float, int | None]:
    """Largest range of accumulated course change [turns] over a stretch flying one
    item that commands no loiter, and that item."""
    armed = a["armed"] > 0
    seq = a["seq"]
    vn, ve = a["truth_vn_mps"], a["truth_ve_mps"]
    gs = np.hypot(vn, ve)
    chi = np.arctan2(ve, vn)
    ok = armed & np.isfinite(gs) & (gs > ORBIT_MIN_GS[vehicle])
    worst, worst_seq = 0.0, None
    n = len(seq)
    i = 0
    while i < n:
        j = i
        while j + 1 < n and seq[j + 1] == seq[i] and armed[j + 1] == armed[i]:
            j += 1
        s = int(seq[i])
        loiter = s >= len(mission) or (s > 0 and mission[s].command in LOITERS)
        if armed[i] and not loiter:
            here = ok[i:j + 1]
            if s > 0 and mission[s].command == NAV_LAND and "kind" in a:
                here = here & (a["kind"][i:j + 1] != KIND_LOITER)   # the descent circle
            idx = np.flatnonzero(here) + i
            if idx.size > 1:
                d = np.diff(chi[idx])
                d = (d + np.pi) % (2 * np.pi) - np.pi
                # a gap in the gated samples (slow flight) breaks the accumulation
                d[np.diff(idx) > 5] = 0.0
                cum = np.concatenate([[0.0], np.cumsum(d)])
                turns = float((cum.max() - cum.min()) / (2 * np.pi))
                if turns > worst:
                    worst, worst_seq = turns, s
        i = j + 1
    return worst, worst_seq


def _land_start(a: dict, vehicle: str, after_t: float, mission: Mission | None = None) -> float:
    """When the landing began: the quad's land phase; the fixed-wing's approach to a
    NAV_LAND (the first row flying that item); inf without one."""
    t = a["t_s"]
    if vehicle == "quad":
        idx = np.flatnonzero((a["kind"] == QUAD_KIND_LAND) & (a["armed"] > 0) & (t > after_t))
        return float(t[idx[0]]) if idx.size else math.inf
    if mission is None:
        return math.inf
    lands = [it.seq for it in mission.items[1:] if it.command == NAV_LAND]
    if not lands:
        return math.inf
    idx = np.flatnonzero(np.isin(a["seq"], lands) & (a["armed"] > 0) & (t > after_t))
    return float(t[idx[0]]) if idx.size else math.inf


def _lowest_commanded_height(mission: Mission) -> float:
    hs = []
    takeoff = next((it.seq for it in mission.items[1:] if it.command == NAV_TAKEOFF), 0)
    for it in mission.items[takeoff + 1:]:
        if it.command in NAV_FLOWN and it.command not in (NAV_LAND, NAV_RETURN_TO_LAUNCH):
            rel = it.frame in (3, 6, 10, 11)
            if (rel and it.z_alt_m == 0.0) or math.isnan(it.z_alt_m):
                continue   # "the current altitude"
            hs.append(it.z_alt_m if rel else it.z_alt_m - mission.home.z_alt_m)
    return min(hs) if hs else math.inf


def check_invariants(a: dict, mission: Mission, vehicle: str, events, *, completed: bool,
                     done_t_s: float | None, home_truth_alt_m: float | None, params,
                     wind_mps: float, fault_free: bool, log_events=(), crashed: bool = False,
                     ground_m: np.ndarray | None = None, frame: LocalFrame | None = None) -> dict:
    """The invariants of one run (module docstring). ``ground_m``: the terrain's height
    under each row (a ``--terrain`` run); the heights are then above that ground (less
    the vehicle's height above it at home), not above home."""
    inv: dict = {}
    t = a["t_s"]
    armed = a["armed"] > 0
    # order
    miss, at = order_figure(mission, events)
    inv["mission_order"] = _inv(miss == 0 and completed, miss)
    inv["mission_order"]["seq"] = at
    # time
    bound = time_bound_s(mission, vehicle, wind_mps, params)
    t_arm = float(t[np.flatnonzero(armed)[0]]) if armed.any() else 0.0
    t_done = (done_t_s if (completed and done_t_s is not None) else (float(t[-1]) if len(t) else 0.0)) - t_arm
    inv["time_bound"] = _inv(completed and t_done <= bound, t_done, bound)
    # orbits
    turns, at = orbit_turns(a, mission, vehicle) if len(t) else (0.0, None)
    inv["no_orbit"] = _inv(turns <= ORBIT_MAX_TURNS, turns, ORBIT_MAX_TURNS)
    inv["no_orbit"]["seq"] = at
    worst, at = passed_figure(a, mission, vehicle, events, params, frame) if len(t) and frame is not None \
        else (None, None)
    inv["waypoints_passed"] = _inv(worst is None or worst <= PASS_MARGIN_M[vehicle], worst,
                                   PASS_MARGIN_M[vehicle])
    inv["waypoints_passed"]["seq"] = at
    # heights
    if home_truth_alt_m is not None and armed.any():
        h = a["truth_alt_m"] - home_truth_alt_m
        if ground_m is not None and len(ground_m) and np.isfinite(ground_m[0]):
            h = h - (ground_m - ground_m[np.flatnonzero(armed)[0]])
        takeoff_t = [tu * 1e-6 for tu, s in events if 0 < s < len(mission) and mission[s].command == NAV_TAKEOFF]
        climbed = takeoff_t[0] if takeoff_t else math.inf
        t_land = _land_start(a, vehicle, climbed if takeoff_t else t_arm, mission)
        flying = (a["kind"] != 0) & armed
        t_launch = float(t[np.flatnonzero(flying)[0]]) if flying.any() else math.inf
        # armed or not: an aircraft disarmed by its crash detection is on the ground
        after = (t >= t_launch) & (t < t_land) & np.isfinite(h)
        # a runway take-off rolls on its wheels far longer than a catapult shot takes to
        # climb away: the span starts once the aircraft has also left the ground
        up = np.flatnonzero(after & (h >= LIFTOFF_M))
        t_up = float(t[up[0]]) if up.size else math.inf
        span = after & (t >= max(t_launch + LAUNCH_GRACE_S, t_up))
        if not span.any() and crashed:
            span = after                     # never got going: from the launch on
        low = float(np.min(h[span])) if span.any() else None
        inv["no_ground_contact"] = _inv(not crashed and (low is None or low > CONTACT_M[vehicle]),
                                        low, CONTACT_M[vehicle])
        floor = min(HEIGHT_FLOOR_M[vehicle], 0.5 * _lowest_commanded_height(mission))
        span = armed & (t >= climbed) & (t < t_land) & np.isfinite(h)
        low = float(np.min(h[span])) if span.any() else None
        inv["height_floor"] = _inv(low is None or low >= floor, low, floor)
    else:
        inv["no_ground_contact"] = _inv(True, None)
        inv["height_floor"] = _inv(True, None)
    # attitude
    fly = armed & (a["kind"] != 0) & np.isfinite(a["truth_roll_rad"])
    roll, pitch = a["truth_roll_rad"], a["truth_pitch_rad"]
    margin = ATTITUDE_MARGIN_DEG[vehicle]
    if not fly.any():
        inv["attitude_limits"] = _inv(True, None)
    elif vehicle == "plane":
        bank = float(np.degrees(np.max(np.abs(roll[fly]))))
        p_hi = float(np.degrees(np.max(pitch[fly])))
        p_lo = float(np.degrees(np.min(pitch[fly])))
        lim = float(params["ROLL_LIMIT_DEG"]) + margin
        ok = bank <= lim and p_hi <= float(params["PTCH_LIM_MAX_DEG"]) + margin \
            and p_lo >= float(params["PTCH_LIM_MIN_DEG"]) - margin
        inv["attitude_limits"] = _inv(ok, bank, lim)
    else:
        c = np.cos(roll[fly]) * np.cos(pitch[fly])
        tilt = float(np.degrees(np.max(np.arccos(np.clip(c, -1.0, 1.0)))))
        lim = float(params["ANGLE_MAX_DEG"]) + margin
        inv["attitude_limits"] = _inv(tilt <= lim, tilt, lim)
    # finite
    bad = 0
    for k, v in a.items():
        if k.startswith(NAN_BY_DESIGN_PREFIXES) or k.startswith("event") or \
                not isinstance(v, np.ndarray) or v.dtype.kind != "f":
            continue
        bad += int(np.count_nonzero(~np.isfinite(v)))
    inv["finite_log"] = _inv(bad == 0, bad)
    # unasked-for mode changes and failsafes
    n = 0
    seen_auto = False
    # a fixed-wing that has landed disarms (and drops to MANUAL): asked for by its NAV_LAND
    t_landed = _land_start(a, vehicle, -math.inf, mission) if vehicle == "plane" else math.inf
    for _t, text in log_events:
        if _t >= t_landed and text in ("disarmed", "mode MANUAL"):
            continue
        if text.startswith("mode "):
            if text == "mode AUTO" and not seen_auto:
                seen_auto = True
                continue
            n += 1
        elif "failsafe" in text.lower() or "crash" in text.lower() \
                or (vehicle == "plane" and text == "disarmed"):
            n += 1
    inv["no_unexpected_mode"] = _inv(n == 0 or not fault_free, n)
    return inv


def run_invariants(session, summary: dict, a: dict) -> tuple[dict, dict]:
    """(extra summary figures, invariants) of a finished in-process session."""
    v = session.vehicle
    vehicle = session.cfg.vehicle
    mission = v.mission if v.mission is not None else session.mission
    events = v.reached_events()
    figs: dict = {"xtrack_mission_rms_m": None, "xtrack_mission_max_m": None,
                  "xtrack_mission_worst_leg": None, "xtrack_mission_legs": []}
    if v.home_frame is not None:
        radii = getattr(v.sequencer, "loiter_radii", ()) if vehicle == "plane" else ()
        rms, mx, legs = xtrack_mission(a, mission, v.home_frame, vehicle, events, session.params,
                                       radii)
        figs["xtrack_mission_rms_m"], figs["xtrack_mission_max_m"] = rms, mx
        # (a run with no log rows leaves its lines unscored)
        scored = [g for g in legs if g.get("xtrack_max_m") is not None]
        # every line's own figures (a survey's transects), null where never captured
        figs["xtrack_mission_legs"] = [
            {"from_seq": g["prev_seq"], "to_seq": g["seq"], "rms_m": g.get("xtrack_rms_m"),
             "max_m": g.get("xtrack_max_m")} for g in legs]
        if scored:
            w = max(scored, key=lambda g: g["xtrack_max_m"])
            figs["xtrack_mission_worst_leg"] = {"from_seq": w["prev_seq"], "to_seq": w["seq"],
                                                "rms_m": w["xtrack_rms_m"], "max_m": w["xtrack_max_m"]}
    # a geofence breach (autopilot/fence) explains its action's mode change as a fault does
    fault_free = (not session.bridge.fault_log and session.gcs is None
                  and not getattr(getattr(v, "geofence", None), "breaches", ()))
    # the end of the mission flown (the fixed-wing's loiter over home established, the
    # quad landed), not crashed; which items were reached is mission_order's to judge
    # (the summary's `completed` also counts DO items, which a condition may drop)
    seq = v.sequencer
    ended = bool(seq is not None and seq.finished and not session.crashed
                 and (seq.rtl_established or getattr(seq, "land_complete", False)))
    inv = check_invariants(a, mission, vehicle, events, completed=ended,
                           done_t_s=session.t_s, home_truth_alt_m=v.home_truth_alt_m,
                           params=session.params, wind_mps=float(session.wind.speed_mps),
                           fault_free=fault_free, log_events=session.log.events,
                           crashed=bool(session.crashed), ground_m=_ground_under(session, a),
                           frame=v.home_frame)
    return figs, inv


def _ground_under(session, a: dict) -> np.ndarray | None:
    """The terrain's height under every row of a ``--terrain`` run (NaN where no data;
    the home ground there), else None."""
    terrain = getattr(session, "terrain", None)
    frame = session.vehicle.home_frame
    if terrain is None or frame is None or not len(a["t_s"]):
        return None
    out = np.empty(len(a["t_s"]))
    for i, (n, e) in enumerate(zip(a["truth_n_m"], a["truth_e_m"])):
        lat, lon, _ = frame.to_geodetic_fast((n, e, 0.0))
        h = terrain(math.degrees(lat), math.degrees(lon)) if math.isfinite(n) else None
        out[i] = np.nan if h is None else h
    home = terrain(math.degrees(frame.lat0_rad), math.degrees(frame.lon0_rad))
    return np.where(np.isfinite(out), out, home if home is not None else np.nan)
