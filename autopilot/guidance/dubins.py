"""Planned turns for a fixed-wing: Dubins-like joins onto a straight leg.

A fixed-wing cannot stop and turn on the spot, so every transition onto a leg that
does not start where and how the aircraft already flies (after a takeoff into the
wind, a loiter, a DO_JUMP, RTL, a mode change back to AUTO) is planned as a path of
bounded curvature (Dubins 1957): a turn of radius R from the current position and
course, a straight tangent, and a second turn of radius R that ends tangent to the leg
at an entry point E on it. Of the four turn-straight-turn words (RSR, LSL, RSL, LSR)
at each entry E along the leg, the path flown is the one of least cost
(``path_cost``): its length, plus what the mission's cross-track (tools/invariants.py)
would score on it once it is on the line (the squared cross-track it flies there, and
any straying beyond CAPTURE_M, weighed so that a loop costs less than a few metres of
overshoot). The shortest path is not the best: it reaches the line at a shallow angle
far down the leg and flies beside it all the way, and one that loops across the line
overshoots it by up to a turn diameter; L1 left to capture a line joined at a large
angle overshoots it by a good fraction of the turn radius.

Conventions as the rest of the guidance: horizontal (north, east) pairs in metres,
courses chi from north, clockwise positive (chi = atan2(e, n)), turn direction +1
clockwise (right), -1 counter-clockwise. A circle of direction d through the aircraft
at course chi has its centre d R (-sin chi, cos chi) from it.

Segments are plain tuples, flown by the sequencer with the L1 law:
``("arc", centre, radius, direction, angle, start)`` (angle: the course change, >= 0;
start: the point the arc begins at) and ``("line", start, end)``.
"""
from __future__ import annotations

import math

import numpy as np

from autopilot.jit import kernel

TWO_PI = 2.0 * math.pi
_MIN_ARC_RAD = math.radians(3.0)   # arcs smaller than this are flown as straight lines
_MIN_LINE_M = 1.0
CAPTURE_M = 10.0    # on the line from this close (as the mission's cross-track is scored)
STRAY_WEIGHT = 100.0  # metres of path worth one metre strayed from the line (a loop,
                      # 2 pi R, is worth less than a stray of a few metres)
XT2_WEIGHT = 0.05   # metres of path worth 1 m^3 of squared cross-track flown on the line
                    # (20 m of path beside the line at 10 m: 100 m of path)
SAMPLE_M = 5.0      # the path's sampling for its cost
LOOP_PENALTY_M = 1e5  # a path turning more than a full circle (the no-orbit invariant's half)


def _unit(chi: float) -> tuple[float, float]:
    return math.cos(chi), math.sin(chi)


def _right(chi: float) -> tuple[float, float]:
    return -math.sin(chi), math.cos(chi)


def centre_of(p, chi: float, radius: float, direction: int) -> tuple[float, float]:
    """Centre of the turn of ``direction`` through p at course chi."""
    rn = _right(chi)
    return p[0] + direction * radius * rn[0], p[1] + direction * radius * rn[1]


def _arc_angle(chi_from: float, chi_to: float, direction: int) -> float:
    a = (direction * (chi_to - chi_from)) % TWO_PI
    return 0.0 if a > TWO_PI - 1e-9 else a


def csc_words(p, chi: float, q, psi: float, radius: float):
    """Every turn-straight-turn path from pose (p, chi) to pose (q, psi) with turns of
    ``radius``: [(length, segments)] (the same-direction words always exist, the
    opposite-direction ones when the two circles are at least 2R apart)."""
    words = []
    for d1 in (1, -1):
        c1 = centre_of(p, chi, radius, d1)
        for d2 in (1, -1):
            c2 = centre_of(q, psi, radius, d2)
            vn, ve = c2[0] - c1[0], c2[1] - c1[1]
            dist = math.hypot(vn, ve)
            # tangent points t1 = c1 - d1 R rn(sigma), t2 = c2 - d2 R rn(sigma) of the
            # straight at course sigma: t2 - t1 = v + k rn(sigma) must lie along u(sigma)
            k = (d1 - d2) * radius
            if dist < abs(k) - 1e-9:
                continue
            length = math.sqrt(max(dist * dist - k * k, 0.0))
            sigma = chi if dist < 1e-9 else math.atan2(ve, vn) + math.atan2(k, length)
            a1 = _arc_angle(chi, sigma, d1)
            a2 = _arc_angle(sigma, psi, d2)
            rn = _right(sigma)
            t1 = (c1[0] - d1 * radius * rn[0], c1[1] - d1 * radius * rn[1])
            t2 = (c2[0] - d2 * radius * rn[0], c2[1] - d2 * radius * rn[1])
            segs = []
            if a1 >= _MIN_ARC_RAD:
                segs.append(("arc", c1, radius, d1, a1, (float(p[0]), float(p[1]))))
            if length >= _MIN_LINE_M:
                segs.append(("line", t1, t2))
            if a2 >= _MIN_ARC_RAD:
                segs.append(("arc", c2, radius, d2, a2, t2))
            words.append((radius * (a1 + a2) + length, segs))
    return words


def csc(p, chi: float, q, psi: float, radius: float):
    """The shortest turn-straight-turn path (length, segments), or None."""
    words = csc_words(p, chi, q, psi, radius)
    return min(words, key=lambda w: w[0]) if words else None


def samples(segments, ds: float = SAMPLE_M):
    """(north, east, course) every ``ds`` metres along the segments (their ends
    included)."""
    for sg in segments:
        if sg[0] == "line":
            _, (n0, e0), (n1, e1) = sg
            ln = math.hypot(n1 - n0, e1 - e0)
            chi = math.atan2(e1 - e0, n1 - n0)
            n = max(int(ln / ds), 1)
            for k in range(n + 1):
                yield n0 + (n1 - n0) * k / n, e0 + (e1 - e0) * k / n, chi
        else:
            _, c, r, d, ang, start = sg
            b0 = math.atan2(start[1] - c[1], start[0] - c[0])
            n = max(int(r * ang / ds), 1)
            for k in range(n + 1):
                b = b0 + d * ang * k / n
                yield c[0] + r * math.cos(b), c[1] + r * math.sin(b), b + d * 0.5 * math.pi


def side_of(p, a, u, tol_m: float) -> float:
    """Which side of the line through A along the unit vector u point p lies on: +1
    right, -1 left, 0 within ``tol_m`` of it (``path_cost``'s ``side``)."""
    xt = (p[0] - a[0]) * -u[1] + (p[1] - a[1]) * u[0]
    return 0.0 if abs(xt) < tol_m else math.copysign(1.0, xt)


def path_cost(segments, a, u, side: float, cross_tol_m: float) -> tuple[float, float]:
    """(cost beyond the path's length, metres strayed) of a join onto the line through
    A along u, as the mission's cross-track is scored: from the path's first point
    within CAPTURE_M of the line moving along it (its capture), the squared cross-track
    flown (XT2_WEIGHT per m^3) and any straying beyond CAPTURE_M again (STRAY_WEIGHT per
    metre); before it, crossing to the far side of the line by more than
    ``cross_tol_m`` (when the path starts on one side: ``side`` +-1, else 0) also counts
    as straying.

    The points are ``samples(segments)``'s, scored by :func:`_path_cost` (a join's
    planning scores a few thousand paths of a few hundred points); what depends on a
    segment only (a line's length and whether it heads along u, an arc's start bearing)
    is computed here, with Python's math as ``samples`` does."""
    psi = math.atan2(u[1], u[0])
    rows = np.empty((len(segments), 7))
    for i, sg in enumerate(segments):
        if sg[0] == "line":
            _, (n0, e0), (n1, e1) = sg
            ln = math.hypot(n1 - n0, e1 - e0)
            ahead = math.cos(math.atan2(e1 - e0, n1 - n0) - psi) > 0.0
            rows[i] = (0.0, n0, e0, n1, e1, ln, 1.0 if ahead else 0.0)
        else:
            _, c, r, d, ang, start = sg
            rows[i] = (1.0, c[0], c[1], r, ang, math.atan2(start[1] - c[1], start[0] - c[0]), d)
    return _path_cost(rows, a[0], a[1], u[0], u[1], psi, side, cross_tol_m)


@kernel
def _path_cost(rows, a0, a1, un, ue, psi, side, cross_tol_m):
    """:func:`path_cost` over the points of ``samples()``. ``rows``: one segment each,
    a line ``(0, n0, e0, n1, e1, length, 1 if it heads along u else 0)`` or an arc
    ``(1, centre n, centre e, radius, angle, start bearing, direction)``."""
    cross = 0.0
    captured = False
    after = 0.0       # furthest from the line after the capture
    xt2 = 0.0
    for i in range(rows.shape[0]):
        if rows[i, 0] == 0.0:                             # a line
            n0, e0, n1, e1, ln = rows[i, 1], rows[i, 2], rows[i, 3], rows[i, 4], rows[i, 5]
            ahead = rows[i, 6] == 1.0
            dn, de = n1 - n0, e1 - e0
            n = max(int(ln / SAMPLE_M), 1)
            for k in range(n + 1):
                x = (n0 + dn * k / n - a0) * -ue + (e0 + de * k / n - a1) * un
                if not captured:
                    if side != 0.0 and -side * x > cross:
                        cross = -side * x
                    if ahead and abs(x) <= CAPTURE_M:
                        captured = True
                if captured:
                    if abs(x) > after:
                        after = abs(x)
                    xt2 += x * x * SAMPLE_M
        else:                                             # an arc, direction d
            c0, c1, r, ang, b0, d = rows[i, 1], rows[i, 2], rows[i, 3], rows[i, 4], rows[i, 5], rows[i, 6]
            n = max(int(r * ang / SAMPLE_M), 1)
            for k in range(n + 1):
                b = b0 + d * ang * k / n
                x = (c0 + r * math.cos(b) - a0) * -ue + (c1 + r * math.sin(b) - a1) * un
                if not captured:
                    if side != 0.0 and -side * x > cross:
                        cross = -side * x
                    if abs(x) <= CAPTURE_M and math.cos(b + d * 0.5 * math.pi - psi) > 0.0:
                        captured = True
                if captured:
                    if abs(x) > after:
                        after = abs(x)
                    xt2 += x * x * SAMPLE_M
    stray = max(max(cross - cross_tol_m, 0.0), after - CAPTURE_M)
    return STRAY_WEIGHT * stray + XT2_WEIGHT * xt2, stray


def turning(segments) -> float:
    """The total course change of a path's arcs [rad]."""
    return sum(sg[4] for sg in segments if sg[0] == "arc")


def join_leg(p, chi: float, a, b, radius: float, s_max: float, cross_tol_m: float = 2.0):
    """Plan the join onto the leg A->B from pose (p, chi).

    Returns (s_entry, length, segments, strays, cost): the entry point's distance along
    the leg's line from A, the path's length, its segments, how far it strays [m] and
    its cost (``path_cost`` plus the length). The entry is chosen on a grid along the
    line (a quarter turn radius apart, at most ~40 points) from A to ``s_max`` (where
    the turn onto the next leg starts) and on, past B, up to two turn radii beyond it
    (where the leg is too short to be joined before its end without a loop, taken only
    where that saves more than a full circle), and the word among the four, as the
    path of least cost: the shortest path is not the best one, since a path that
    reaches the line at a shallow angle far down the leg is short but flies beside the
    line all the way, and one that loops across the line overshoots it by up to a turn
    diameter; the cost weighs the cross-track the path itself flies once it is on the
    line as the mission's cross-track is scored."""
    ln = math.hypot(b[0] - a[0], b[1] - a[1])
    if ln < 1e-6:
        return None
    u = ((b[0] - a[0]) / ln, (b[1] - a[1]) / ln)
    psi = math.atan2(u[1], u[0])
    side = side_of(p, a, u, cross_tol_m)
    s_max = min(max(s_max, 0.0), ln)
    s_far = ln + 2.0 * radius
    step = max(0.25 * radius, s_far / 40.0, 1.0)
    grid = sorted({min(k * step, s_max) for k in range(int(s_max / step) + 2)}
                  | {s_max + k * step for k in range(1, int((s_far - s_max) / step) + 1)})
    best = None
    for s in grid:
        q = (a[0] + s * u[0], a[1] + s * u[1])
        for length, segs in csc_words(p, chi, q, psi, radius):
            extra, stray = path_cost(segs, a, u, side, cross_tol_m)
            # an entry past the next turn's start skips that turn: taken only where it
            # saves more than a full circle
            cost = extra + length + (TWO_PI * radius if s > s_max else 0.0)
            if turning(segs) > TWO_PI:
                cost += LOOP_PENALTY_M    # more than a full circle: kept only if nothing else

            if best is None or cost < best[0]:
                best = (cost, s, length, segs, stray)
    return best[1], best[2], best[3], best[4], best[0]


def on_leg(p, chi: float, a, b, xtrack_tol_m: float, course_tol_rad: float) -> bool:
    """Already flying the leg: within ``xtrack_tol_m`` of its line and within
    ``course_tol_rad`` of its course (no join needed)."""
    ln = math.hypot(b[0] - a[0], b[1] - a[1])
    if ln < 1e-6:
        return True
    tn, te = (b[0] - a[0]) / ln, (b[1] - a[1]) / ln
    xt = (p[0] - a[0]) * -te + (p[1] - a[1]) * tn
    chi_leg = math.atan2(te, tn)
    d = (chi - chi_leg + math.pi) % TWO_PI - math.pi
    return abs(xt) <= xtrack_tol_m and abs(d) <= course_tol_rad
