"""Sphere geometry of the formation (seed ch. 9 sec. 3.5.1, eqs 3.1-3.12, and the
nearer-solution choice of eq 3.17).

Our copy of the seed lost the subscripts and fractions of these equations; they are
rebuilt here from the geometry the text describes (three spheres, the first centred at
the origin, the second on the x axis, the third in the x-y plane) and from the seed's
references (Bayezit & Fidan, "Distributed cohesive motion control of flight vehicle
formations", IEEE Trans. Ind. Electron. 60(12), 2013; the trilateration of Fang,
"Trilateration and extension to GPS navigation", J. Guidance 9(6), 1986).

Three spheres S(p_1, r_1), S(p_2, r_2), S(p_3, r_3). In the frame {s} with s_1 = 0,
s_2 = (x_2, 0, 0), s_3 = (x_3, y_3, 0):

    x^2 + y^2 + z^2 = r_1^2                                        (3.1)
    (x - x_2)^2 + y^2 + z^2 = r_2^2                                (3.2)
    (x - x_3)^2 + (y - y_3)^2 + z^2 = r_3^2                        (3.3)
    x = (r_1^2 - r_2^2 + x_2^2) / (2 x_2)                          (3.4)
    y^2 + z^2 = r_1^2 - x^2                                        (3.5)
    y = (r_1^2 - r_3^2 + x_3^2 + y_3^2) / (2 y_3) - (x_3 / y_3) x  (3.6)
    z = +- sqrt(r_1^2 - x^2 - y^2)                                 (3.7)

The frame change (eqs 3.8-3.11): [s_i; 1] = T [p_i; 1] with T = [R, -R p_1; 0, 1] and
R = [e_x; e_y; e_z] (rows), e_x = (p_2 - p_1)/|p_2 - p_1|, e_y the unit part of
p_3 - p_1 normal to e_x, e_z = e_x x e_y (the seed writes R as a product of elementary
rotations; any rotation taking e_x, e_y, e_z to the axes is the same R). The solution
back in the earth frame (eq 3.12): [P; 1] = T^-1 [x, y, z, 1], i.e. P = p_1 + R^T (x, y, z).

Of the two solutions, eq 3.17 keeps the one nearer a reference point (the follower's
current position).

Degenerate geometry is handled on purpose and reported in ``status``, never a NaN:

* ``"collinear"``: the three centres (nearly) on one line (|p_2 - p_1| or y_3 below
  ``EPS_M``); the intersection is then a circle or empty and does not fix a point; we
  return the point of the circle of the first two spheres nearest the reference.
* ``"empty"``: r_1^2 - x^2 - y^2 < 0 (the spheres do not meet, e.g. while the leaders
  are still off their own distances); ``sphere_intersection`` returns the point in the
  plane of the centres (z = 0) twice, the solution of eqs 3.4 and 3.6; ``intersection_near``
  keeps the reference's own height above that plane instead (so two followers on the
  two sides of their leaders' plane are never both pulled into it).
* ``"tangent"``: the two solutions coincide (|z| below ``EPS_M``).

The functions are ``jitable``: plain Python where Python calls them (the formation's
checks, its figures), compiled into the formation's guidance kernel (``guidance``) where
that calls them; there, a status is its code (``STATUS`` names them).
"""
from __future__ import annotations

import math

from numba.extending import register_jitable as jitable

EPS_M = 1e-6          # lengths below this count as zero [m]

# status codes (their names: STATUS); "waiting" is the guidance's (a followed vehicle
# not heard yet); the first three are no degenerate event
OK, TANGENT, WAITING, EMPTY, COLLINEAR, DEGENERATE = range(6)
STATUS = ("ok", "tangent", "waiting", "empty", "collinear", "degenerate")

Vec = tuple[float, float, float]


@jitable
def _sub(a, b) -> Vec:
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


@jitable
def _add(a, b) -> Vec:
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


@jitable
def _scale(a, k: float) -> Vec:
    return (a[0] * k, a[1] * k, a[2] * k)


@jitable
def _dot(a, b) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@jitable
def _cross(a, b) -> Vec:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@jitable
def norm(a) -> float:
    return math.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])


@jitable
def dist(a, b) -> float:
    return norm(_sub(a, b))


@jitable
def _any_perpendicular(u: Vec) -> Vec:
    """A unit vector normal to the unit vector ``u`` (deterministic)."""
    a = (1.0, 0.0, 0.0) if abs(u[0]) < 0.9 else (0.0, 1.0, 0.0)
    w = _cross(u, a)
    return _scale(w, 1.0 / norm(w))


def nearest_on_sphere(c, r: float, q) -> tuple[Vec, str]:
    """The point of S(c, r) nearest ``q`` (the first follower's constraint). ``q`` at
    the centre: any point (``"degenerate"``)."""
    p, status = on_sphere(c, r, q)
    return p, STATUS[status]


def nearest_on_circle(c1, r1: float, c2, r2: float, q) -> tuple[Vec, str]:
    """The point of S(c1, r1) n S(c2, r2) (a circle) nearest ``q`` (the second
    follower's constraints). Coincident centres: ``"collinear"`` (the constraint is a
    sphere, nearest point of S(c1, r1)); spheres apart or nested: ``"empty"`` (the
    point of the centre line between them that splits the radii's excess); ``q`` on the
    axis of the circle: ``"degenerate"`` (a fixed point of the circle)."""
    p, status = on_circle(c1, r1, c2, r2, q)
    return p, STATUS[status]


def sphere_intersection(p1, r1: float, p2, r2: float, p3, r3: float) -> tuple[Vec, Vec, str]:
    """Both intersection points of three spheres (eqs 3.1-3.12) and a status
    (module docstring). In the degenerate cases both points are the same fallback."""
    a, b, status = three_spheres(p1, r1, p2, r2, p3, r3)
    return a, b, STATUS[status]


def intersection_near(p1, r1, p2, r2, p3, r3, ref) -> tuple[Vec, str]:
    """The three-sphere intersection nearer ``ref`` (eqs 3.1-3.12, 3.17). Collinear
    centres: the point of the first two spheres' circle nearest ``ref``. Empty: the
    solution of eqs 3.4 and 3.6 at ``ref``'s own height above the centres' plane."""
    p, status = three_spheres_near(p1, r1, p2, r2, p3, r3, ref)
    return p, STATUS[status]


# ---------------------------------------- the same with status codes (jitable) ---
@jitable
def on_sphere(c, r, q):
    """``nearest_on_sphere`` with its status code."""
    dn, de, dd = q[0] - c[0], q[1] - c[1], q[2] - c[2]
    n = math.sqrt(dn * dn + de * de + dd * dd)
    if n < EPS_M:
        return _add(c, (r, 0.0, 0.0)), DEGENERATE
    k = r / n
    return (c[0] + dn * k, c[1] + de * k, c[2] + dd * k), OK


@jitable
def on_circle(c1, r1, c2, r2, q):
    """``nearest_on_circle`` with its status code."""
    un, ue, ud = c2[0] - c1[0], c2[1] - c1[1], c2[2] - c1[2]
    d = math.sqrt(un * un + ue * ue + ud * ud)
    if d < EPS_M:
        p, _ = on_sphere(c1, r1, q)
        return p, COLLINEAR
    k = 1.0 / d
    un, ue, ud = un * k, ue * k, ud * k
    a = (r1 * r1 - r2 * r2 + d * d) / (2.0 * d)     # eq 3.4 with x_2 = d
    h2 = r1 * r1 - a * a                             # eq 3.5 with the circle's radius^2
    cn, ce, cd = c1[0] + un * a, c1[1] + ue * a, c1[2] + ud * a
    if h2 <= 0.0:
        return (cn, ce, cd), (EMPTY if h2 < -EPS_M * EPS_M else TANGENT)
    h = math.sqrt(h2)
    wn, we, wd = q[0] - cn, q[1] - ce, q[2] - cd
    k = wn * un + we * ue + wd * ud
    wn, we, wd = wn - un * k, we - ue * k, wd - ud * k   # q's offset normal to the axis
    n = math.sqrt(wn * wn + we * we + wd * wd)
    if n < EPS_M:
        return _add((cn, ce, cd), _scale(_any_perpendicular((un, ue, ud)), h)), DEGENERATE
    k = h / n
    return (cn + wn * k, ce + we * k, cd + wd * k), OK


@jitable
def three_spheres(p1, r1, p2, r2, p3, r3):
    """``sphere_intersection`` with its status code. (Written out on scalars.)"""
    p1n, p1e, p1d = p1
    exn, exe, exd = p2[0] - p1n, p2[1] - p1e, p2[2] - p1d
    x2 = math.sqrt(exn * exn + exe * exe + exd * exd)           # s_2 = (x_2, 0, 0)
    if x2 < EPS_M:
        return p1, p1, COLLINEAR
    k = 1.0 / x2
    exn, exe, exd = exn * k, exe * k, exd * k
    wn, we, wd = p3[0] - p1n, p3[1] - p1e, p3[2] - p1d
    x3 = exn * wn + exe * we + exd * wd                          # s_3 = (x_3, y_3, 0)   eq 3.8
    eyn, eye, eyd = wn - exn * x3, we - exe * x3, wd - exd * x3
    y3 = math.sqrt(eyn * eyn + eye * eye + eyd * eyd)
    if y3 < EPS_M:
        return p1, p1, COLLINEAR
    k = 1.0 / y3
    eyn, eye, eyd = eyn * k, eye * k, eyd * k
    # R = [e_x; e_y; e_z], e_z = e_x x e_y                                eqs 3.9-3.10
    ezn, eze, ezd = exe * eyd - exd * eye, exd * eyn - exn * eyd, exn * eye - exe * eyn
    x = (r1 * r1 - r2 * r2 + x2 * x2) / (2.0 * x2)                                   # eq 3.4
    y = (r1 * r1 - r3 * r3 + x3 * x3 + y3 * y3) / (2.0 * y3) - (x3 / y3) * x         # eq 3.6
    z2 = r1 * r1 - x * x - y * y                                                     # eq 3.5
    status = OK
    if z2 < 0.0:
        status = EMPTY if z2 < -1e-9 else TANGENT
        z = 0.0
    else:
        z = math.sqrt(z2)                                                            # eq 3.7
        if z < EPS_M:
            status = TANGENT
    # eq 3.12: P = p_1 + R^T (x, y, z)
    bn, be, bd = p1n + (exn * x + eyn * y), p1e + (exe * x + eye * y), p1d + (exd * x + eyd * y)
    mz = -z
    return ((bn + ezn * z, be + eze * z, bd + ezd * z),
            (bn + ezn * mz, be + eze * mz, bd + ezd * mz), status)


@jitable
def nearer(a, b, ref) -> Vec:
    """Eq 3.17: of two candidate points, the one nearer ``ref`` (ties: ``a``)."""
    an, ae, ad = a[0] - ref[0], a[1] - ref[1], a[2] - ref[2]
    bn, be, bd = b[0] - ref[0], b[1] - ref[1], b[2] - ref[2]
    # (the distances themselves, not their squares: the same tie-break as dist())
    return a if (math.sqrt(an * an + ae * ae + ad * ad)
                 <= math.sqrt(bn * bn + be * be + bd * bd)) else b


@jitable
def three_spheres_near(p1, r1, p2, r2, p3, r3, ref):
    """``intersection_near`` with its status code."""
    a, b, status = three_spheres(p1, r1, p2, r2, p3, r3)
    if status == OK or status == TANGENT:
        return nearer(a, b, ref), status
    if status == COLLINEAR:
        p, _ = on_circle(p1, r1, p2, r2, ref)
        return p, status
    n = _cross(_sub(p2, p1), _sub(p3, p1))                 # empty
    n = _scale(n, 1.0 / norm(n))
    return _add(a, _scale(n, _dot(n, _sub(ref, a)))), status


def side_of_plane(p1, p2, p3, q) -> float:
    """Signed volume (p2 - p1) x (p3 - p1) . (q - p1): which side of the plane of the
    three centres ``q`` lies on (used to carry an ordinary follower's side from its
    start to its final position)."""
    return _dot(_cross(_sub(p2, p1), _sub(p3, p1)), _sub(q, p1))
