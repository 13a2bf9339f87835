"""``sitl formation FILE``: N vehicles in one SITL, flying a formation decentralised
over a vehicle-to-vehicle MAVLink network (seed ch. 9 secs. 3.4-3.7).

What runs, per vehicle (system id 1..N):

* ``model = "quad"``: a quadrotor plant, its sensor suite and its own autopilot
  (``autopilot.formation.quad.FormationQuad``) joined by their own lockstep HIL link
  (MAVLink 2 bytes through an in-process pipe), as ``sitl run --vehicle quad`` builds
  one; optionally a ground-station port, TCP 5760 + 10 (id - 1) as ArduPilot numbers
  instances (``--gcs``).
* ``model = "point"``: the point vehicle of eqs 3.18-3.22 with the seed's disturbances
  (``autopilot.formation.point``) and the same guidance.

The vehicle network (``VehicleNetwork``) carries the MAVLink bytes each vehicle publishes
(GLOBAL_POSITION_INT at ``network.rate_hz``) to every other vehicle after
``network.latency_s``, each datagram to each receiver lost with probability
``network.loss`` (an injected ``numpy.random.Generator``). ``--udp`` sends them over
real loopback UDP sockets instead (one per vehicle), with the same latency and loss
applied at the receiver. Each vehicle computes its commands from what it received; no
vehicle reads another's state.

Quadrotor cost. Five quads share the machine, so five at the standard 250 Hz lockstep
run at a fifth of one quad's real-time factor (``sitl bench --vehicle quad``), short of
the 5x real time aimed at. A formation quad therefore runs a 125 Hz lockstep (the plant
still integrates at 4 ms, two steps per HIL period; its controllers are discretised at
8 ms) and its navigation filter at 125 / ``nav_div`` Hz (default 25 Hz) with the output
predictor between: a stated trade, whose speed is measured by ``--json``'s
``realtime_factor`` (docs/status.md, "Formation flight").

GPS: formation flight at 1 m spacing needs relative positions good to centimetres, which
a standard GNSS receiver (metres of slowly wandering error per vehicle) cannot give. The
default ``[quad] gps = "rtk"`` gives each vehicle an RTK-class receiver (u-blox ZED-F9P
class: 1 cm white + 1 cm Gauss-Markov per horizontal axis, 20 Hz, 50 ms latency) and sets its
filter's GPS noise to match (and trusts the barometer less, 1 m, and takes the GPS as its
height reference, EK_HGT_REF = 1, as PX4's EKF2_HGT_REF = GNSS and ArduPilot's
EK3_SRC1_POSZ = GPS are set for RTK); ``gps = "standard"`` keeps the default receiver (the
formation then holds to the receivers' relative error, metres).

Figures (truth, the formation's local NED frame): ``distance_error_max_m`` /
``distance_error_rms_m`` over every constrained pair after the first 5 s of formation
flight, ``min_separation_m`` over all pairs and all time, ``leader_final_error_m``,
``final_errors_m`` (against the consistent desired final positions, and
``final_errors_to_file_m`` against the file's goals), ``completed``.
"""
from __future__ import annotations

import heapq
import json
import math
import socket
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from autopilot.heap import settled_heap
from autopilot.interrupt import StopOnInterrupt
from autopilot.formation import FormationGuidance, FormationSpec, load_formation
from autopilot.formation.geometry import dist
from autopilot.formation.peers import PeerTable, PositionPublisher
from autopilot.formation.point import PointVehicle
from autopilot.geo import LocalFrame
from autopilot.nav.config import NAV_GPS_RTK as RTK_EKF
from sim_bridge.sensors.params import GPS_RTK as RTK_GPS

CONVERGE_S = 5.0           # figures exclude the first 5 s of formation flight
LOG_HZ = 25.0              # truth samples for the figures
SETTLE_HOLD_S = 2.0        # completed: conditions held this long ends the run
COMPLETE_LEADER_M = 0.2
COMPLETE_DIST_M = 0.1
COMPLETE_SPEED_MPS = 0.3
QUAD_START_S = 8.0         # common formation start time of the quadrotors (sim time)


# ------------------------------------------------------------------ network ---
class VehicleNetwork:
    """In-process bus of MAVLink datagrams between vehicles: broadcast, latency, loss."""

    def __init__(self, ids, latency_s: float, loss: float, rng: np.random.Generator):
        self.ids = list(ids)
        self.latency_us = int(round(latency_s * 1e6))
        self.loss = loss
        self.rng = rng
        self._q: list = []        # (deliver_us, seq, dst, data)
        self._seq = 0
        self.sent = self.delivered = self.lost = 0

    def send(self, src: int, t_us: int, data: bytes) -> None:
        self.sent += 1
        for dst in self.ids:
            if dst == src:
                continue
            if self.loss > 0.0 and self.rng.random() < self.loss:
                self.lost += 1
                continue
            heapq.heappush(self._q, (t_us + self.latency_us, self._seq, dst, data))
            self._seq += 1

    def due(self, t_us: int):
        """Datagrams due at ``t_us``: list of (dst, data)."""
        out = []
        q = self._q
        while q and q[0][0] <= t_us:
            _, _, dst, data = heapq.heappop(q)
            out.append((dst, data))
            self.delivered += 1
        return out

    def close(self) -> None:
        pass


class UdpVehicleNetwork(VehicleNetwork):
    """The same over loopback UDP: one socket per vehicle; a datagram is sent to every
    other vehicle's port and read back from the socket. Latency and loss are applied
    at the receiver (loopback itself is instantaneous and lossless)."""

    def __init__(self, ids, latency_s: float, loss: float, rng: np.random.Generator,
                 base_port: int = 0):
        super().__init__(ids, latency_s, loss, rng)
        self.socks = {}
        for i in self.ids:
            s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            s.bind(("127.0.0.1", base_port + i - 1 if base_port else 0))
            s.setblocking(False)
            self.socks[i] = s
        self.addr = {i: s.getsockname() for i, s in self.socks.items()}
        self._tx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)

    def send(self, src: int, t_us: int, data: bytes) -> None:
        self.sent += 1
        for dst in self.ids:
            if dst != src:
                self._tx.sendto(data, self.addr[dst])
        # read back what loopback delivered, then apply latency and loss
        for dst in self.ids:
            if dst == src:
                continue
            s = self.socks[dst]
            while True:
                try:
                    pkt = s.recv(2048)
                except BlockingIOError:
                    break
                if self.loss > 0.0 and self.rng.random() < self.loss:
                    self.lost += 1
                    continue
                heapq.heappush(self._q, (t_us + self.latency_us, self._seq, dst, pkt))
                self._seq += 1

    def close(self) -> None:
        for s in self.socks.values():
            s.close()
        self._tx.close()


# ------------------------------------------------------------------ figures ---
@dataclass
class Recorder:
    spec: FormationSpec
    t: list = field(default_factory=list)
    p: list = field(default_factory=list)        # per sample: N x 3 truth positions
    p_des: list = field(default_factory=list)    # per sample: N x 3 desired positions

    def add(self, t_s: float, p, p_des) -> None:
        self.t.append(t_s)
        self.p.append(p)
        self.p_des.append(p_des)

    def arrays(self):
        n = len(self.spec.vehicles)     # (samples x vehicles x 3, also with no sample)
        return (np.array(self.t, dtype=float), np.array(self.p, dtype=float).reshape(-1, n, 3),
                np.array(self.p_des, dtype=float).reshape(-1, n, 3))


def pair_distances(spec: FormationSpec, P: np.ndarray) -> np.ndarray:
    """|p_a - p_b| of the constrained pairs: samples x pairs."""
    cols = [np.linalg.norm(P[:, a - 1] - P[:, b - 1], axis=1) for a, b, _ in spec.pairs]
    return np.stack(cols, axis=1) if cols else np.zeros((len(P), 0))


def min_separation(P: np.ndarray) -> float:
    n = P.shape[1]
    best = math.inf
    for i in range(n):
        for j in range(i + 1, n):
            best = min(best, float(np.min(np.linalg.norm(P[:, i] - P[:, j], axis=1))))
    return best


def formation_figures(spec: FormationSpec, t: np.ndarray, P: np.ndarray, t0_s: float) -> dict:
    if len(t) == 0:                     # stopped (Ctrl-C) before its first sample
        return {"distance_error_max_m": None, "distance_error_rms_m": None, "min_separation_m": None,
                "leader_final_error_m": None, "final_errors_m": {}, "final_errors_to_file_m": {},
                "pair_distance_error_max_m": {}}
    d_want = np.array([d for _, _, d in spec.pairs])
    D = pair_distances(spec, P)
    E = D - d_want
    after = t >= t0_s + CONVERGE_S
    finals = spec.final_positions()
    last = P[-1]
    out = {
        "distance_error_max_m": float(np.max(np.abs(E[after]))) if after.any() else None,
        "distance_error_rms_m": float(np.sqrt(np.mean(E[after] ** 2))) if after.any() else None,
        "min_separation_m": min_separation(P) if P.shape[1] > 1 else None,
        "leader_final_error_m": float(dist(last[spec.leader.id - 1], finals[spec.leader.id])),
        "final_errors_m": {str(v.id): round(float(dist(last[v.id - 1], finals[v.id])), 4)
                           for v in spec.vehicles},
        "final_errors_to_file_m": {str(v.id): round(float(dist(last[v.id - 1], v.goal_ned)), 4)
                                   for v in spec.vehicles if v.goal_ned is not None},
        "pair_distance_error_max_m": {f"{a}-{b}": round(float(np.max(np.abs(E[after, k]))), 4)
                                      for k, (a, b, _) in enumerate(spec.pairs)} if after.any() else {},
    }
    return out


class _Completion:
    """``completed``: the leader within COMPLETE_LEADER_M of its goal, every constrained
    distance within COMPLETE_DIST_M, every vehicle slower than COMPLETE_SPEED_MPS, held
    for SETTLE_HOLD_S."""

    def __init__(self, spec: FormationSpec):
        self.spec = spec
        self.goal = spec.final_positions()[spec.leader.id]
        self.since: float | None = None
        self.completed = False
        self.t_completed: float | None = None
        self._prev = None

    def check(self, t_s: float, p: list) -> bool:
        spec = self.spec
        ok = dist(p[spec.leader.id - 1], self.goal) <= COMPLETE_LEADER_M
        if ok:
            ok = all(abs(dist(p[a - 1], p[b - 1]) - d) <= COMPLETE_DIST_M for a, b, d in spec.pairs)
        if ok and self._prev is not None:
            tp, pp = self._prev
            dt = t_s - tp
            if dt > 0:
                ok = all(dist(p[k], pp[k]) / dt <= COMPLETE_SPEED_MPS for k in range(len(p)))
        self._prev = (t_s, [tuple(x) for x in p])
        if not ok:
            self.since = None
            return False
        if self.since is None:
            self.since = t_s
        if t_s - self.since >= SETTLE_HOLD_S and not self.completed:
            self.completed = True
            self.t_completed = self.since
        return self.completed


# -------------------------------------------------------------------- point ---
def run_point(spec: FormationSpec, seed: int, net, duration_s: float) -> dict:
    dt = spec.point.dt_s
    dt_us = int(round(dt * 1e6))
    origin = LocalFrame.from_degrees(*spec.origin)
    rngs = [np.random.default_rng(s) for s in np.random.SeedSequence(seed).spawn(len(spec.vehicles) + 1)]
    vs = []
    for k, v in enumerate(spec.vehicles):
        vs.append(dict(id=v.id, model=PointVehicle(v.start_ned, dt, rngs[k], spec.point.noise_deg,
                                                    spec.point.delay_s),
                       guid=FormationGuidance(spec, v.id), peers=PeerTable(v.id, origin, only=v.follows),
                       pub=PositionPublisher(v.id, spec.ground_alt_m)))
    by_id = {x["id"]: x for x in vs}
    period_us = int(round(1e6 / spec.network.rate_hz))
    log_every = max(1, int(round(1.0 / (LOG_HZ * dt))))
    rec = Recorder(spec)
    done = _Completion(spec)
    t_us, k = 0, 0
    next_pub = 0
    wall0 = time.perf_counter()
    end_us = int(duration_s * 1e6)
    while t_us <= end_us:
        for dst, data in net.due(t_us):
            by_id[dst]["peers"].receive(data)
        if t_us >= next_pub:
            next_pub += period_us
            for x in vs:
                p = x["model"].p
                lat, lon, alt = origin.to_geodetic_fast(p)
                net.send(x["id"], t_us, x["pub"].encode(t_us, lat, lon, alt, x["model"].v))
        t_s = t_us * 1e-6
        des = []
        for x in vs:
            g = x["guid"].update(t_s, dt, tuple(x["model"].p), x["peers"])
            des.append(g.p_des)
            x["model"].step(g.v_cmd)
        t_us += dt_us
        k += 1
        if k % log_every == 0:
            ps = [tuple(x["model"].p) for x in vs]
            rec.add(t_us * 1e-6, ps, des)
            if done.check(t_us * 1e-6, ps):
                break
    wall = time.perf_counter() - wall0
    t, P, Pd = rec.arrays()
    out = {"vehicles": len(vs), "model": "point", "sim_time_s": round(t_us * 1e-6, 3),
           "formation_start_s": 0.0, "wall_s": round(wall, 3),
           "realtime_factor": round(t_us * 1e-6 / wall, 2) if wall > 0 else None,
           "completed": done.completed, "completed_at_s": done.t_completed,
           "degenerate_geometry_events": {str(x["id"]): x["guid"].degenerate_events for x in vs}}
    out.update(formation_figures(spec, t, P, 0.0))
    return out, (t, P, Pd)


# --------------------------------------------------------------------- quad ---


class QuadMember:
    """One quadrotor of the formation: plant + sensors + simulator end, the HIL pipe,
    and its autopilot."""

    def __init__(self, spec: FormationSpec, vid: int, seed: int, gcs_port: int | None = None):
        from autopilot.formation.quad import FormationQuad
        from autopilot.link.hil import AutopilotHilEnd
        from autopilot.link.transports import memory_pair
        from autopilot.log.flightlog import FlightLog
        from autopilot.params import ParamStore
        from autopilot.vehicle_quad import LOG_COLUMNS, quad_param_declarations
        from sim_bridge.bridge import SimBridge
        from sim_bridge.hil import SimulatorHilEnd
        from sim_bridge.plants.quadrotor import QuadrotorPlant
        from sim_bridge.sensors import SensorParams, SensorSuite

        qs = spec.quad
        hil_dt = 1.0 / qs.hil_rate_hz
        origin = LocalFrame.from_degrees(*spec.origin)
        v = spec.vehicle(vid)
        n, e, d = v.start_ned
        lat, lon, _ = origin.to_geodetic_fast((n, e, 0.0))
        home = (math.degrees(lat), math.degrees(lon), spec.ground_alt_m, 0.0)
        self.height_m = spec.origin[2] - d - spec.ground_alt_m
        if self.height_m < 1.0:
            raise ValueError(f"vehicle {vid} starts {self.height_m:.1f} m above the ground")
        rng_plant, rng_sensors = (np.random.default_rng(s)
                                  for s in np.random.SeedSequence([seed, vid]).spawn(2))
        self.plant = QuadrotorPlant(home, "f450", dt_s=0.004, rng=rng_plant)
        self.plant.set_airborne(self.height_m)
        sp = SensorParams(**RTK_GPS) if qs.gps == "rtk" else SensorParams()
        sensors = SensorSuite(sp, rng_sensors, dt_s=hil_dt)
        sensors.set_home(math.radians(home[0]), math.radians(home[1]), home[2])
        sim_pipe, ap_pipe = memory_pair()
        self.bridge = SimBridge(self.plant, sensors, SimulatorHilEnd(sim_pipe), None, (),
                                hil_rate_hz=qs.hil_rate_hz, vehicle="quad")
        decls = quad_param_declarations()
        if gcs_port is not None:
            from autopilot.gcs import GCS_PARAMS
            decls = list(decls) + list(GCS_PARAMS)
        self.params = ParamStore(decls)
        self.params.set("QD_NAV_DIV", qs.nav_div)
        self.params.set("QD_LOG_DIV", 100)
        if qs.gps == "rtk":
            for k2, val in RTK_EKF.items():
                self.params.set(k2, val)
        # no truth on the HIL link unless the vehicle flies on it: the formation is
        # scored from the plants, and the vehicles' own flight logs are not kept
        self.bridge.link.truth_div = 1 if qs.nav == "truth" else 0
        self.ap_end = AutopilotHilEnd(ap_pipe)
        self.vehicle = FormationQuad(self.params, spec, vid, qs.nav, FlightLog(LOG_COLUMNS),
                                     dt_s=self.bridge.hil_period_us * 1e-6, start_s=QUAD_START_S)
        self.vid = vid
        self.released = False
        self.gcs = None
        if gcs_port is not None:
            from autopilot.gcs import GcsService
            self.gcs = GcsService(self.vehicle, (f"tcpin:0.0.0.0:{gcs_port}",), hil=self.ap_end,
                                  system_id=vid)

    def step(self) -> None:
        br = self.bridge
        br.send_current()
        gcs = self.gcs
        for frame, truth in self.ap_end.poll():
            out = self.vehicle.step(frame, truth)
            self.ap_end.answer(out)
            if gcs is not None:
                gcs.after_step(frame, out)
        br.advance(br.link.poll_answer(br.t_us))
        if not self.released:
            if self.vehicle.armed:
                self.released = True
            else:
                br.state = self.plant.hold_airborne(self.height_m)   # held by the simulator until armed
        if gcs is not None:
            gcs.step(br.t_us)

    def truth_form(self, origin: LocalFrame) -> tuple:
        st = self.bridge.state
        return origin.ned_fast(st.lat_rad, st.lon_rad, st.alt_m)


def run_quad(spec: FormationSpec, seed: int, net, duration_s: float, gcs: bool = False,
             to_the_end: bool = False) -> dict:
    """Fly the quadrotor formation ``duration_s`` after the common start (it ends
    earlier once the formation has completed, unless ``to_the_end``: the bench's windows,
    the same simulated time for every formation)."""
    origin = LocalFrame.from_degrees(*spec.origin)
    members = [QuadMember(spec, v.id, seed, 5760 + 10 * (v.id - 1) if gcs else None)
               for v in spec.vehicles]
    by_id = {m.vid: m for m in members}
    period_us = members[0].bridge.hil_period_us
    log_every = max(1, int(round(1e6 / (LOG_HZ * period_us))))
    rec = Recorder(spec)
    done = _Completion(spec)
    end_us = int((QUAD_START_S + duration_s) * 1e6)
    k = 0
    t_us = 0
    stop = StopOnInterrupt()   # Ctrl-C: the loop stops after its step (autopilot/interrupt.py)
    wall = 0.0
    try:
        with stop, settled_heap():   # the objects built so far kept out of the collector
            wall0 = time.perf_counter()
            while t_us < end_us and not stop.requested:
                for dst, data in net.due(t_us):
                    by_id[dst].vehicle.peers.receive(data)
                for m in members:
                    m.step()
                    ob = m.vehicle.outbox
                    if ob:
                        for data in ob:
                            net.send(m.vid, t_us, data)
                        ob.clear()
                t_us = members[0].bridge.t_us
                k += 1
                if k % log_every == 0:
                    ps = [m.truth_form(origin) for m in members]
                    des = [m.vehicle.last_guidance.p_des if m.vehicle.last_guidance is not None
                           else m.vehicle.start_ned for m in members]
                    rec.add(t_us * 1e-6, ps, des)
                    if t_us * 1e-6 > QUAD_START_S and done.check(t_us * 1e-6, ps) and not to_the_end:
                        break
                    if any(m.plant.crashed for m in members):
                        break
            wall = time.perf_counter() - wall0
    except KeyboardInterrupt:
        pass                   # a second Ctrl-C
    finally:
        for m in members:
            if m.gcs is not None:
                m.gcs.close()
    t, P, Pd = rec.arrays()
    out = {"vehicles": len(members), "model": "quad", "sim_time_s": round(t_us * 1e-6, 3),
           "formation_start_s": QUAD_START_S, "wall_s": round(wall, 3),
           "realtime_factor": round(t_us * 1e-6 / wall, 2) if wall > 0 else None,
           "completed": done.completed, "completed_at_s": done.t_completed,
           "armed": {str(m.vid): bool(m.vehicle.armed) for m in members},
           "crashed": any(m.plant.crashed for m in members),
           "hil_rate_hz": spec.quad.hil_rate_hz, "nav": spec.quad.nav,
           "nav_rate_hz": spec.quad.hil_rate_hz / spec.quad.nav_div, "gps": spec.quad.gps,
           "degenerate_geometry_events": {str(m.vid): m.vehicle.guidance.degenerate_events
                                          for m in members}}
    out.update(formation_figures(spec, t, P, QUAD_START_S))
    return out, (t, P, Pd)


# ---------------------------------------------------------------------- run ---
def run_formation(path, seed: int = 1, duration_s: float | None = None, loss: float | None = None,
                  latency_s: float | None = None, rate_hz: float | None = None, udp: bool = False,
                  gcs: bool = False, log_dir: Path | None = None, model: str | None = None) -> dict:
    import dataclasses
    spec = load_formation(path)
    net_spec = spec.network
    if loss is not None or latency_s is not None or rate_hz is not None:
        net_spec = dataclasses.replace(
            net_spec, loss=net_spec.loss if loss is None else loss,
            latency_s=net_spec.latency_s if latency_s is None else latency_s,
            rate_hz=net_spec.rate_hz if rate_hz is None else rate_hz)
    if model is not None:
        spec = dataclasses.replace(spec, model=model)
    spec = dataclasses.replace(spec, network=net_spec)
    dur = spec.duration_s if duration_s is None else duration_s
    rng_net = np.random.default_rng(np.random.SeedSequence([seed, 0x4E4554]))
    ids = [v.id for v in spec.vehicles]
    net = (UdpVehicleNetwork if udp else VehicleNetwork)(ids, net_spec.latency_s, net_spec.loss, rng_net)
    try:
        if spec.model == "point":
            summary, arrays = run_point(spec, seed, net, dur)
        else:
            summary, arrays = run_quad(spec, seed, net, dur, gcs)
    finally:
        net.close()
    summary.update({"formation": str(path), "seed": seed,
                    "network": {"rate_hz": net_spec.rate_hz, "latency_s": net_spec.latency_s,
                                "loss": net_spec.loss, "transport": "udp" if udp else "bus",
                                "sent": net.sent, "delivered": net.delivered, "lost": net.lost}})
    if log_dir is not None:
        write_formation_run(spec, summary, arrays, Path(log_dir))
    return summary


def write_formation_run(spec: FormationSpec, summary: dict, arrays, log_dir: Path) -> None:
    log_dir.mkdir(parents=True, exist_ok=True)
    t, P, Pd = arrays
    finals = spec.final_positions()
    np.savez_compressed(log_dir / "formation.npz", t_s=t, p_ned=P, p_des_ned=Pd,
                        pairs=np.array([(a, b, d) for a, b, d in spec.pairs], dtype=float).reshape(-1, 3),
                        final_ned=np.array([finals[v.id] for v in spec.vehicles]),
                        roles=np.array([v.role for v in spec.vehicles]),
                        formation_start_s=np.array(summary.get("formation_start_s", 0.0)))
    with open(log_dir / "summary.json", "w") as f:
        json.dump(summary, f, indent=2, sort_keys=True)
        f.write("\n")
