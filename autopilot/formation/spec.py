"""Formation files: the directed leader-follower graph, its checks, and the desired
final positions (seed ch. 9 secs. 3.4.2-3.4.4 and 3.5.2).

A formation file (TOML) in ``missions/``::

    model = "quad"               # "quad" | "point"
    speed_mps = 2.0              # the leader's constant speed v-bar
    epsilon = 0.01               # eq 3.21's epsilon [m]
    origin = [-35.3632, 149.1652, 604.0]   # lat_deg, lon_deg, alt_m (MSL) of the local NED frame
    ground_alt_m = 584.0         # optional: flat terrain altitude (MSL); default origin alt - 20 m
    duration_s = 30.0            # optional: simulated seconds at most

    [[vehicle]]
    id = 1                       # MAVLink system id, 1..N
    role = "leader"              # leader | first | second | ordinary
    start_ned = [1.0, 0.0, 0.0]  # [m] in the local frame
    follows = []                 # ids of the vehicles it keeps distances to
    goal_ned = [-3.9697, 2.7428, 1.0]   # leader: required; followers: optional

    [[distance]]
    a = 1
    b = 2
    d_m = 1.0

Optional tables: ``[network]`` (``rate_hz``, ``latency_s``, ``loss``), ``[control]``
(``gain_p``, ``gain_i``, ``follower_speed_factor``, ``reshape_step_m``), ``[point]`` (``dt_s``,
``noise_deg``, ``delay_s``), ``[quad]`` (``hil_rate_hz``, ``nav``, ``nav_div``, ``gps``).

The graph must be minimally persistent in the seed's leader-follower form: one leader
(follows nobody), one first follower (follows the leader), one second follower (follows
the leader and the first follower), every other vehicle an ordinary follower of exactly
three earlier vehicles (lower ids), so |E| = 3|V| - 6. Every follow edge needs its
distance, and a distance needs a follow edge. A bad file raises ``FormationError`` with
the reason (cycle, a follower of a later vehicle, a vehicle with too few or too many
constraints, a missing distance, collinear leaders, distances no position satisfies).

Desired final positions. The leader's is its goal. The seed's final positions of the
first three vehicles are not mutually at the constrained distances (|p_1 - p_2| =
0.911 m for d = 1 m); the design keeps the distances, which are the formation, and
treats a follower's goal as the *bearing* of its final position: the first follower's
final position is the point at d_12 from the leader's goal nearest its own goal, the
second follower's the point of the circle at d_13 / d_23 from those two nearest its own
goal (a follower without a goal keeps its start offset from the leader), an ordinary
follower's the three-sphere intersection of eqs 3.1-3.12 on the same side of its three
leaders as it started (its goal, if given, picks the side instead). The summary
reports errors against these consistent positions and, separately, against the file's.
"""
from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

from .geometry import (EPS_M, dist, nearest_on_circle, nearest_on_sphere, side_of_plane,
                       sphere_intersection)

ROLES = ("leader", "first", "second", "ordinary")
N_FOLLOWS = {"leader": 0, "first": 1, "second": 2, "ordinary": 3}
MAX_VEHICLES = 250


class FormationError(ValueError):
    """A formation file that cannot be flown; the message says why."""


@dataclass(frozen=True)
class VehicleSpec:
    id: int                               # MAVLink system id
    role: str                             # leader | first | second | ordinary
    start_ned: tuple[float, float, float]  # [m] local frame
    follows: tuple[int, ...]              # ids, in the file's order
    goal_ned: tuple[float, float, float] | None   # [m] as given in the file


@dataclass(frozen=True)
class NetworkSpec:
    rate_hz: float = 20.0      # GLOBAL_POSITION_INT publication rate per vehicle [Hz]
    latency_s: float = 0.02    # one-way delivery delay [s]
    loss: float = 0.0          # probability a datagram is lost (per receiver)


@dataclass(frozen=True)
class ControlSpec:
    gain_p: float = 1.0                # K_P of eq 3.22 [1/s]
    gain_i: float = 0.05               # K_I of eq 3.22 [1/s^2]
    follower_speed_factor: float = 2.0  # followers' speed limit = factor * v-bar
    reshape_step_m: float = 0.5        # first/second follower: carrot length while reshaping [m]


@dataclass(frozen=True)
class PointSpec:
    dt_s: float = 0.01          # integration step of eq 3.18 [s]
    noise_deg: float = 10.0     # bounded uniform noise on the velocity angles [deg]
    delay_s: float = 0.02       # transport delay of the applied velocity [s]


@dataclass(frozen=True)
class QuadSpec:
    hil_rate_hz: float = 125.0  # lockstep rate of each quad's HIL link
    nav: str = "ekf"            # ekf | truth
    nav_div: int = 5            # filter every Nth HIL step (output predictor between)
    gps: str = "rtk"            # rtk | standard


@dataclass(frozen=True)
class FormationSpec:
    model: str
    speed_mps: float
    epsilon: float
    origin: tuple[float, float, float]      # lat_deg, lon_deg, alt_m (MSL)
    ground_alt_m: float
    vehicles: tuple[VehicleSpec, ...]       # sorted by id
    distances: dict                         # frozenset({a, b}) -> d_m
    duration_s: float = 60.0
    network: NetworkSpec = field(default_factory=NetworkSpec)
    control: ControlSpec = field(default_factory=ControlSpec)
    point: PointSpec = field(default_factory=PointSpec)
    quad: QuadSpec = field(default_factory=QuadSpec)
    name: str = "formation"

    def vehicle(self, vid: int) -> VehicleSpec:
        return self.vehicles[self._index[vid]]

    @property
    def _index(self) -> dict:
        return {v.id: k for k, v in enumerate(self.vehicles)}

    def d(self, a: int, b: int) -> float:
        return self.distances[frozenset((a, b))]

    @property
    def pairs(self) -> list[tuple[int, int, float]]:
        """Constrained pairs (a < b) with their distances, sorted."""
        return sorted((min(k), max(k), d) for k, d in self.distances.items())

    @property
    def leader(self) -> VehicleSpec:
        return next(v for v in self.vehicles if v.role == "leader")

    def final_positions(self) -> dict[int, tuple[float, float, float]]:
        """Consistent desired final positions (module docstring)."""
        return _final_positions(self)

    def offsets(self) -> dict[int, tuple[float, float, float]]:
        """First and second followers: desired offset from the leader (eqs 3.15, 3.16)."""
        f = self.final_positions()
        lead = f[self.leader.id]
        return {v.id: tuple(f[v.id][k] - lead[k] for k in range(3))
                for v in self.vehicles if v.role in ("first", "second")}


# ------------------------------------------------------------------ loading ---
def load_formation(path: str | Path) -> FormationSpec:
    path = Path(path)
    try:
        with open(path, "rb") as f:
            data = tomllib.load(f)
    except tomllib.TOMLDecodeError as e:
        raise FormationError(f"{path}: not valid TOML: {e}") from None
    try:
        return parse_formation(data, name=path.stem)
    except FormationError as e:
        raise FormationError(f"{path}: {e}") from None


def _vec(x, what: str) -> tuple[float, float, float]:
    if not isinstance(x, (list, tuple)) or len(x) != 3:
        raise FormationError(f"{what}: expected [north, east, down] in metres")
    try:
        v = tuple(float(c) for c in x)
    except (TypeError, ValueError):
        raise FormationError(f"{what}: not numbers: {x!r}") from None
    if not all(math.isfinite(c) for c in v):
        raise FormationError(f"{what}: not finite: {x!r}")
    return v


def _num(d: dict, key: str, default, lo: float, hi: float, what: str) -> float:
    v = d.get(key, default)
    if v is None:
        raise FormationError(f"{what}: missing {key!r}")
    try:
        v = float(v)
    except (TypeError, ValueError):
        raise FormationError(f"{what}: {key} must be a number") from None
    if not (math.isfinite(v) and lo <= v <= hi):
        raise FormationError(f"{what}: {key} = {v} outside [{lo}, {hi}]")
    return v


def _table(data: dict, key: str) -> dict:
    t = data.get(key, {})
    if not isinstance(t, dict):
        raise FormationError(f"[{key}] must be a table")
    return t


def parse_formation(data: dict, name: str = "formation") -> FormationSpec:
    model = data.get("model", "point")
    if model not in ("quad", "point"):
        raise FormationError(f"model must be 'quad' or 'point', not {model!r}")
    speed = _num(data, "speed_mps", None, 1e-3, 20.0, "formation")
    eps = _num(data, "epsilon", 0.01, 1e-6, 1.0, "formation")
    org = data.get("origin")
    if not isinstance(org, (list, tuple)) or len(org) != 3:
        raise FormationError("origin: expected [lat_deg, lon_deg, alt_m]")
    origin = tuple(float(c) for c in org)
    if not (-90.0 <= origin[0] <= 90.0 and -180.0 <= origin[1] <= 180.0):
        raise FormationError("origin: latitude within +-90 and longitude within +-180")
    ground = _num(data, "ground_alt_m", origin[2] - 20.0, -500.0, 9000.0, "formation")
    duration = _num(data, "duration_s", 60.0, 0.1, 86400.0, "formation")

    raw_v = data.get("vehicle")
    if not isinstance(raw_v, list) or not raw_v:
        raise FormationError("no [[vehicle]] entries")
    vehicles = []
    for k, rv in enumerate(raw_v):
        what = f"vehicle #{k + 1}"
        if not isinstance(rv, dict) or "id" not in rv:
            raise FormationError(f"{what}: missing id")
        vid = rv["id"]
        if not isinstance(vid, int) or not 1 <= vid <= MAX_VEHICLES:
            raise FormationError(f"{what}: id must be an integer 1..{MAX_VEHICLES}")
        what = f"vehicle {vid}"
        role = rv.get("role")
        if role not in ROLES:
            raise FormationError(f"{what}: role must be one of {', '.join(ROLES)}, not {role!r}")
        if "start_ned" not in rv:
            raise FormationError(f"{what}: missing start_ned")
        follows = rv.get("follows", [])
        if not isinstance(follows, list) or not all(isinstance(j, int) for j in follows):
            raise FormationError(f"{what}: follows must be a list of vehicle ids")
        goal = _vec(rv["goal_ned"], f"{what}: goal_ned") if "goal_ned" in rv else None
        vehicles.append(VehicleSpec(vid, role, _vec(rv["start_ned"], f"{what}: start_ned"),
                                    tuple(follows), goal))
    ids = [v.id for v in vehicles]
    if len(set(ids)) != len(ids):
        dup = sorted({i for i in ids if ids.count(i) > 1})
        raise FormationError(f"duplicate vehicle id(s) {dup}")
    if sorted(ids) != list(range(1, len(ids) + 1)):
        raise FormationError(f"vehicle ids must be 1..{len(ids)} (MAVLink system ids), got {sorted(ids)}")
    vehicles.sort(key=lambda v: v.id)

    distances: dict = {}
    for k, rd in enumerate(data.get("distance", [])):
        what = f"distance #{k + 1}"
        if not isinstance(rd, dict) or not {"a", "b", "d_m"} <= set(rd):
            raise FormationError(f"{what}: needs a, b and d_m")
        a, b = rd["a"], rd["b"]
        if a not in ids or b not in ids or a == b:
            raise FormationError(f"{what}: a and b must be two different vehicle ids")
        d = _num(rd, "d_m", None, 1e-3, 1e4, what)
        key = frozenset((a, b))
        if key in distances:
            raise FormationError(f"{what}: pair ({min(a, b)}, {max(a, b)}) given twice")
        distances[key] = d

    net = _table(data, "network")
    ctl = _table(data, "control")
    pt = _table(data, "point")
    qd = _table(data, "quad")
    nav = qd.get("nav", "ekf")
    if nav not in ("ekf", "truth"):
        raise FormationError("[quad] nav must be 'ekf' or 'truth'")
    gps = qd.get("gps", "rtk")
    if gps not in ("rtk", "standard"):
        raise FormationError("[quad] gps must be 'rtk' or 'standard'")
    spec = FormationSpec(
        model=model, speed_mps=speed, epsilon=eps, origin=origin, ground_alt_m=ground,
        vehicles=tuple(vehicles), distances=distances, duration_s=duration,
        network=NetworkSpec(_num(net, "rate_hz", 20.0, 0.1, 1000.0, "[network]"),
                            _num(net, "latency_s", 0.02, 0.0, 10.0, "[network]"),
                            _num(net, "loss", 0.0, 0.0, 0.95, "[network]")),
        control=ControlSpec(_num(ctl, "gain_p", 1.0, 1e-3, 100.0, "[control]"),
                            _num(ctl, "gain_i", 0.05, 0.0, 100.0, "[control]"),
                            _num(ctl, "follower_speed_factor", 2.0, 1.0, 10.0, "[control]"),
                            _num(ctl, "reshape_step_m", 0.5, 0.01, 100.0, "[control]")),
        point=PointSpec(_num(pt, "dt_s", 0.01, 1e-4, 0.1, "[point]"),
                        _num(pt, "noise_deg", 10.0, 0.0, 45.0, "[point]"),
                        _num(pt, "delay_s", 0.02, 0.0, 1.0, "[point]")),
        quad=QuadSpec(_num(qd, "hil_rate_hz", 125.0, 50.0, 1000.0, "[quad]"), nav,
                      int(_num(qd, "nav_div", 5, 1, 10, "[quad]")), gps),
        name=name)
    validate(spec)
    return spec


# --------------------------------------------------------------- validation ---
def _find_cycle(vehicles) -> list[int] | None:
    follows = {v.id: v.follows for v in vehicles}
    state: dict[int, int] = {}          # 1 visiting, 2 done
    stack: list[int] = []

    def visit(i: int) -> list[int] | None:
        state[i] = 1
        stack.append(i)
        for j in follows.get(i, ()):
            if state.get(j) == 1:
                return stack[stack.index(j):] + [j]
            if state.get(j) is None and j in follows:
                c = visit(j)
                if c:
                    return c
        stack.pop()
        state[i] = 2
        return None

    for v in vehicles:
        if state.get(v.id) is None:
            c = visit(v.id)
            if c:
                return c
    return None


def validate(spec: FormationSpec) -> None:
    """The checks of the module docstring; raises ``FormationError``."""
    vs = spec.vehicles
    ids = {v.id for v in vs}
    for v in vs:
        for j in v.follows:
            if j not in ids:
                raise FormationError(f"vehicle {v.id} follows {j}, which is not in the formation")
            if j == v.id:
                raise FormationError(f"vehicle {v.id} follows itself")
        if len(set(v.follows)) != len(v.follows):
            raise FormationError(f"vehicle {v.id} lists a followed vehicle twice")
    cyc = _find_cycle(vs)
    if cyc:
        raise FormationError("the follow graph has a cycle: " + " -> ".join(map(str, cyc))
                             + " (a directed leader-follower graph must be acyclic)")
    for v in vs:
        later = [j for j in v.follows if j > v.id]
        if later:
            raise FormationError(f"vehicle {v.id} follows later vehicle(s) {later}: a follower "
                                 f"may follow only earlier vehicles (lower ids)")
    by_role: dict[str, list[int]] = {r: [] for r in ROLES}
    for v in vs:
        by_role[v.role].append(v.id)
    for r in ("leader", "first", "second"):
        if len(by_role[r]) > 1:
            raise FormationError(f"not minimally persistent: {len(by_role[r])} vehicles with role "
                                 f"{r} {by_role[r]} (exactly one allowed)")
    if not by_role["leader"]:
        raise FormationError("not minimally persistent: no leader")
    n = len(vs)
    need = ["leader", "first", "second"][:min(n, 3)]
    missing = [r for r in need if not by_role[r]]
    if missing:
        raise FormationError(f"not minimally persistent: {n} vehicles need a {missing[0]} follower")
    leader = by_role["leader"][0]
    first = by_role["first"][0] if by_role["first"] else None
    for v in vs:
        k = N_FOLLOWS[v.role]
        if len(v.follows) != k:
            raise FormationError(
                f"not minimally persistent: {v.role} vehicle {v.id} follows {len(v.follows)} "
                f"vehicle(s), its role needs exactly {k} (|E| = 3|V| - 6 in 3-D)")
        if v.role == "first" and set(v.follows) != {leader}:
            raise FormationError(f"not minimally persistent: first follower {v.id} must follow "
                                 f"the leader {leader}")
        if v.role == "second" and set(v.follows) != {leader, first}:
            raise FormationError(f"not minimally persistent: second follower {v.id} must follow "
                                 f"the leader {leader} and the first follower {first}")
    edges = {frozenset((v.id, j)) for v in vs for j in v.follows}
    if len(edges) != sum(len(v.follows) for v in vs):
        raise FormationError("not minimally persistent: a pair is constrained in both directions")
    for v in vs:
        for j in v.follows:
            if frozenset((v.id, j)) not in spec.distances:
                raise FormationError(f"missing distance for the pair ({min(v.id, j)}, {max(v.id, j)}): "
                                     f"vehicle {v.id} follows {j}")
    for key in spec.distances:
        if key not in edges:
            a, b = sorted(key)
            raise FormationError(f"distance for the pair ({a}, {b}), which no vehicle follows")
    if spec.leader.goal_ned is None:
        raise FormationError(f"the leader {leader} needs goal_ned")
    # geometry: an ordinary follower's three leaders must not start collinear
    start = {v.id: v.start_ned for v in vs}
    for v in vs:
        if v.role == "ordinary":
            _, _, status = sphere_intersection(*(x for j in v.follows for x in (start[j], 1.0)))
            if status == "collinear":
                raise FormationError(f"vehicle {v.id}: the vehicles it follows {list(v.follows)} "
                                     f"start collinear (their spheres do not fix a point)")
    _final_positions(spec)   # distances every final position can satisfy


def _final_positions(spec: FormationSpec) -> dict[int, tuple[float, float, float]]:
    start = {v.id: v.start_ned for v in spec.vehicles}
    lead = spec.leader
    f = {lead.id: lead.goal_ned}
    for v in spec.vehicles:
        if v.role == "leader":
            continue
        if v.role == "first":
            j = v.follows[0]
            ref = v.goal_ned if v.goal_ned is not None else \
                tuple(f[j][k] + start[v.id][k] - start[j][k] for k in range(3))
            p, status = nearest_on_sphere(f[j], spec.d(v.id, j), ref)
        elif v.role == "second":
            j1 = lead.id
            j2 = next(j for j in v.follows if j != j1)
            ref = v.goal_ned if v.goal_ned is not None else \
                tuple(f[j1][k] + start[v.id][k] - start[j1][k] for k in range(3))
            p, status = nearest_on_circle(f[j1], spec.d(v.id, j1), f[j2], spec.d(v.id, j2), ref)
            if status == "empty":
                raise FormationError(f"second follower {v.id}: distances {spec.d(v.id, j1)} / "
                                     f"{spec.d(v.id, j2)} to {j1} / {j2} cannot both hold "
                                     f"(triangle inequality with d({j1}, {j2}))")
        else:
            c = [f[j] for j in v.follows]
            r = [spec.d(v.id, j) for j in v.follows]
            a, b, status = sphere_intersection(c[0], r[0], c[1], r[1], c[2], r[2])
            if status in ("collinear", "empty"):
                raise FormationError(f"vehicle {v.id}: no final position at distances {r} from "
                                     f"{list(v.follows)} ({status} geometry)")
            if v.goal_ned is not None:
                p = a if dist(a, v.goal_ned) <= dist(b, v.goal_ned) else b
            else:
                s0 = side_of_plane(*(start[j] for j in v.follows), start[v.id])
                sa = side_of_plane(*c, a)
                p = a if (sa >= 0.0) == (s0 >= 0.0) else b
        f[v.id] = tuple(float(x) for x in p)
    return f


def start_distance_errors(spec: FormationSpec) -> list[tuple[int, int, float]]:
    """|p_a - p_b| - d_ab at the start positions (a formation file may start off its
    distances; the first seconds converge)."""
    s = {v.id: v.start_ned for v in spec.vehicles}
    return [(a, b, dist(s[a], s[b]) - d) for a, b, d in spec.pairs]


__all__ = ["FormationError", "FormationSpec", "VehicleSpec", "NetworkSpec", "ControlSpec",
           "PointSpec", "QuadSpec", "load_formation", "parse_formation", "validate", "EPS_M"]
