"""Build and run a headless SITL session in one process (the memory-pipe lockstep).

Used by ``sitl run``, ``sitl bench`` and the end-to-end tests. The autopilot and the
simulator are the same objects the two console scripts build; here they share one OS
thread and talk MAVLink 2 bytes through the in-process pipe.
"""
from __future__ import annotations

import json
import math
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from autopilot.heap import settled_heap
from autopilot.interrupt import StopOnInterrupt
from autopilot.link.hil import AutopilotHilEnd
from autopilot.link.transports import memory_pair
from autopilot.mission.files import MissionFileError, save_waypoints
from autopilot.mission.home import mission_home  # noqa: F401 - also this module's API
from autopilot.mission.items import POSITION_COMMANDS, Mission, validate_mission
from autopilot.nav.config import NAV_GPS_PRESETS
from autopilot.params import ParamStore
from autopilot.vehicle import LOG_COLUMNS, PlaneVehicle, plane_param_declarations
from autopilot.log.flightlog import FlightLog

from .missions_random import is_random_source, load_source, parse_source

REPO_ROOT = Path(__file__).resolve().parent.parent
MISSIONS_DIR = REPO_ROOT / "missions"
DEFAULT_MISSION = MISSIONS_DIR / "default.waypoints"
DEFAULT_SCENARIO = MISSIONS_DIR / "default_scenario.toml"
QUAD_DEFAULT_MISSION = MISSIONS_DIR / "quad_default.waypoints"
LAUNCH_INTO_WIND_MPS = 3.0       # a wind this strong: the launcher points into it ...
LAUNCH_MAX_TAILWIND_MPS = 1.0    # ... and so does any wind blowing this much along the shot
LEFT_GROUND_M = 1.0              # off the ground this high above where it rested: flying (a
                                 # wheeled take-off's hop in a gust is not, nor its landing a crash)


@dataclass
class RunConfig:
    vehicle: str = "plane"
    airframe: str = "aerosonde"
    mission: Path = DEFAULT_MISSION
    scenario: Path | None = None
    wind: tuple[float, float] | None = None        # (speed m/s, from deg)
    turbulence: str | None = None
    seed: int = 1
    speedup: float | None = None                   # None = as fast as possible
    duration_s: float = 1800.0
    nav: str = "ekf"
    gps: str = "standard"                           # receiver model (GPS_PRESETS)
    home: tuple[float, float, float, float] | None = None  # lat, lon, alt, heading
    log_dir: Path | None = None
    progress: bool = False
    params_file: Path | None = None
    param_overrides: dict = field(default_factory=dict)
    # ground stations (autopilot/gcs): None = headless (arm and fly by itself); a list of
    # URLs = interactive: serve them, sit disarmed at home until a ground station flies it
    gcs: tuple[str, ...] | None = None
    param_store: Path | None = None                # parameters persisted across runs (gcs)
    signing_key: bytes | None = None               # MAVLink 2 signing key (gcs)
    # geofence / rally points (autopilot/fence/files.py): a .plan mission brings its own;
    # these files (MAVProxy's fence / rally formats, or QGC WPL 110) replace them
    fence: Path | None = None
    rally: Path | None = None
    terrain: Path | None = None                    # SRTM .hgt tiles (None: flat at home)


class Session:
    """Everything of one in-process run; ``step()`` advances one lockstep step."""

    def __init__(self, cfg: RunConfig):
        from sim_bridge.world import build_world

        self.cfg = cfg
        # a mission file, or random:VEHICLE:SEED (tools/missions_random.py)
        self.mission, self.mission_notes = load_source(cfg.mission)
        if is_random_source(cfg.mission) and parse_source(cfg.mission)[0] != cfg.vehicle:
            raise MissionFileError(str(cfg.mission), None,
                                   f"a {parse_source(cfg.mission)[0]} mission; the vehicle is a {cfg.vehicle}")
        problem = validate_mission(self.mission.items, cfg.vehicle)
        if problem is not None:               # a command this vehicle does not fly (yet)
            raise MissionFileError(str(cfg.mission), f"item {problem.seq}", str(problem))
        self.home = cfg.home or mission_home(self.mission)
        self.terrain = None
        self.gcs_terrain = str(cfg.terrain) == "gcs"   # heights from the ground station
        if self.gcs_terrain and cfg.gcs is None:
            raise MissionFileError("--terrain gcs", None, "the ground station's terrain needs --gcs")
        if cfg.terrain is not None and not self.gcs_terrain:
            # the ground is the tiles' (the vehicle rests on it at home) and the
            # autopilot reads the same tiles for its terrain-relative altitudes
            from autopilot.geo.terrain import TerrainTiles
            self.terrain = TerrainTiles(str(cfg.terrain))
            h = self.terrain(self.home[0], self.home[1])
            if h is None:
                raise MissionFileError(str(cfg.terrain), None, f"no terrain tile covers home "
                                       f"{self.home[0]:.6f} {self.home[1]:.6f}")
            self.home = (self.home[0], self.home[1], h, self.home[3])
        from sim_bridge.sensors.params import GPS_PRESETS, SensorParams
        if cfg.gps not in GPS_PRESETS:
            raise ValueError(f"unknown GPS receiver model {cfg.gps!r} ({', '.join(GPS_PRESETS)})")
        sensor_params = SensorParams(**GPS_PRESETS[cfg.gps])
        world = build_world(self.home, cfg.seed, cfg.airframe, cfg.scenario, cfg.wind,
                            cfg.turbulence, cfg.vehicle, sensor_params, self.terrain)
        quad = cfg.vehicle == "quad"
        tailwind = -world.wind.speed_mps * math.cos(math.radians(world.wind.from_deg - self.home[3]))
        if cfg.home is None and not quad and (world.wind.speed_mps >= LAUNCH_INTO_WIND_MPS
                                              or tailwind >= LAUNCH_MAX_TAILWIND_MPS):
            # as an operator would: the launcher points into the wind (a catapult shot
            # downwind leaves the rail below stall speed: 2.5 m/s behind it in moderate
            # turbulence sank the Aerosonde 1.5 m onto the ground); --home's heading overrides
            self.home = (*self.home[:3], world.wind.from_deg % 360.0)
            world = build_world(self.home, cfg.seed, cfg.airframe, cfg.scenario, cfg.wind,
                                cfg.turbulence, cfg.vehicle, sensor_params, self.terrain)
        self.world = world
        self.wind = world.wind
        self.plant = world.plant
        sim_pipe, ap_pipe = memory_pair()
        if quad:
            from sim_bridge.world import QUAD_HIL_RATE_HZ
            self.bridge = world.bridge(sim_pipe, cfg.vehicle, hil_rate_hz=QUAD_HIL_RATE_HZ)
        else:
            self.bridge = world.bridge(sim_pipe, cfg.vehicle)
        self.sim_end = self.bridge.link
        self.interactive = cfg.gcs is not None
        if quad:
            from autopilot.vehicle_quad import quad_param_declarations
            decls = quad_param_declarations()
        else:
            decls = plane_param_declarations()
        if self.interactive:
            from autopilot.gcs import GCS_PARAMS
            decls = list(decls) + list(GCS_PARAMS)
        self.params = ParamStore(decls)
        airframe_parm = MISSIONS_DIR / "params" / f"{cfg.airframe}.parm"
        # (a quad's RunConfig built in code keeps the default airframe, the Aerosonde's:
        # the quad flies the F450 whatever it says, and takes none of a plane's tuning)
        if airframe_parm.exists() and not (cfg.vehicle == "quad" and cfg.airframe in ("aerosonde", "c172p")):
            self.params.load(airframe_parm)   # the airframe's tuning, before the user's
        for k, v in NAV_GPS_PRESETS[cfg.gps].items():
            self.params.set(k, v)             # the filter told of the receiver, before the user
        if self.interactive and cfg.param_store is not None and Path(cfg.param_store).exists():
            from autopilot.gcs import load_lenient
            for problem in load_lenient(self.params, Path(cfg.param_store))[1]:
                print(f"sitl: parameter store: {problem} (ignored)", file=sys.stderr)
        if cfg.params_file is not None:
            self.params.load(cfg.params_file)
        for k, v in cfg.param_overrides.items():
            self.params.set(k, v)
        self.ap_end = AutopilotHilEnd(ap_pipe)
        if quad:
            from autopilot.vehicle_quad import LOG_COLUMNS as QUAD_COLUMNS, QuadVehicle
            self.log = FlightLog(QUAD_COLUMNS)
            self.vehicle = QuadVehicle(self.params, self.mission, cfg.nav, autostart=not self.interactive,
                                       log=self.log, dt_s=self.bridge.hil_period_us * 1e-6)
        else:
            self.log = FlightLog(LOG_COLUMNS)
            self.vehicle = PlaneVehicle(self.params, self.mission, cfg.nav,
                                        autostart=not self.interactive, log=self.log)
        if self.terrain is not None:
            self.vehicle.terrain = self.terrain
        elif self.gcs_terrain:
            # the simulator's ground stays flat; the autopilot asks the ground station
            # (TERRAIN_REQUEST / TERRAIN_DATA, autopilot/gcs/terrain.py)
            from autopilot.gcs.terrain import GridTerrain
            self.vehicle.terrain = GridTerrain()
        # truth (HIL_STATE_QUATERNION) only where the flight log keeps it: on its row
        # steps (and with every GPS fix); every step when the run flies on truth
        if cfg.nav == "truth":
            self.sim_end.truth_div = 1
        elif quad:
            self.sim_end.truth_div = int(self.params["QD_LOG_DIV"])
        else:
            from autopilot.vehicle import LOG_DIV
            self.sim_end.truth_div = LOG_DIV
        self._load_fence(cfg)
        self.crashed = False
        self.landing_score = None
        if not quad:
            from .landing_score import LandingScore
            self.landing_score = LandingScore(self.home[2])   # the ground at home (MSL)
        self.wall_loop_s = 0.0
        self.interrupted = False
        self.gcs = None
        if self.interactive:
            from autopilot.gcs import DEFAULT_URLS, GcsService
            tlog = Path(cfg.log_dir) / "gcs.tlog" if cfg.log_dir is not None else None
            self.gcs = GcsService(self.vehicle, cfg.gcs or DEFAULT_URLS, hil=self.ap_end,
                                  tlog_path=tlog, param_store_path=cfg.param_store,
                                  signing_key=cfg.signing_key)

    def _load_fence(self, cfg: RunConfig) -> None:
        """The fence and rally points of the run: the .plan's, then --fence / --rally;
        the mission must lie inside an enabled fence (as an upload must)."""
        from autopilot.fence.files import load_fence, load_plan_fence, load_rally
        fence, rally = (), ()
        if str(cfg.mission).lower().endswith(".plan") and Path(cfg.mission).exists():
            fence, rally = load_plan_fence(cfg.mission)
        if cfg.fence is not None:
            fence = load_fence(cfg.fence)
        if cfg.rally is not None:
            rally = load_rally(cfg.rally)
        v = self.vehicle
        if fence:
            v.set_fence(fence, 0)
        if rally:
            v.set_rally(rally, 0)
        why = v.geofence.mission_problem(self.mission.items, None)
        if why is not None:
            raise MissionFileError(str(cfg.mission), None, f"the mission leaves the enabled fence: {why}")

    @property
    def t_s(self) -> float:
        return self.bridge.t_us * 1e-6

    def step(self) -> None:
        bridge, ap_end, vehicle, gcs = self.bridge, self.ap_end, self.vehicle, self.gcs
        bridge.send_current()
        for frame, truth in ap_end.poll():
            out = vehicle.step(frame, truth)
            ap_end.answer(out)
            if gcs is not None:
                gcs.after_step(frame, out)
        controls = self.sim_end.poll_answer(bridge.state.t_us)
        bridge.advance(controls)
        if self.landing_score is not None:
            self.landing_score.update(bridge.state, vehicle, self.plant)
        if gcs is not None:
            gcs.step(bridge.state.t_us)

    def done(self) -> bool:
        if self.cfg.vehicle == "quad":
            # landed at the end of the mission (and disarmed), or crashed
            if getattr(self.plant, "crashed", False):
                self.crashed = True
                return True
            return bool(self.vehicle.mission_landed and not self.vehicle.armed)
        seq = self.vehicle.sequencer
        if seq is not None and seq.finished and (seq.rtl_established or seq.land_complete):
            return True
        if getattr(self.vehicle, "crash", None) is not None:
            self.crashed = True  # the vehicle's crash detection disarmed it
            return True
        st = self.bridge.state
        if self._rest_alt_m is None:
            self._rest_alt_m = st.alt_m
        if not st.on_ground and not self.plant.on_launcher \
                and st.alt_m - self._rest_alt_m >= LEFT_GROUND_M:
            self._left_ground = True
        if self.vehicle.armed and st.on_ground and self._left_ground \
                and (seq is None or seq.landing is None):   # (touching down in a landing is no crash)
            self.crashed = True  # back on the ground after the takeoff: crashed
            return True
        return False

    _left_ground = False     # the aircraft has been off its launcher / runway
    _rest_alt_m = None       # where it rested at the start [m]: the height it flew from

    def run(self) -> None:
        cfg = self.cfg
        stop = StopOnInterrupt()
        t0 = None
        try:
            # Ctrl-C: the loop stops after its step (autopilot/interrupt.py); caught from
            # before the heap is settled (its collection can take a second on a loaded
            # host, and a Ctrl-C landing there escaped as a KeyboardInterrupt)
            with stop, settled_heap():   # the objects built so far kept out of the collector
                t0 = time.perf_counter()
                self._loop(cfg.duration_s, t0, self.t_s, stop)
        except KeyboardInterrupt:
            self.interrupted = True  # a second Ctrl-C
        if stop.requested:
            self.interrupted = True  # Ctrl-C: stop cleanly, the run folder is still written
        self.wall_loop_s = 0.0 if t0 is None else time.perf_counter() - t0
        if cfg.progress:
            sys.stderr.write("\n")

    def _loop(self, end_s: float, t0: float, sim0: float, stop: StopOnInterrupt) -> None:
        cfg = self.cfg
        gcs = self.gcs
        next_progress = 0.0
        while self.t_s < end_s and not stop.requested:
            self.step()
            if gcs is None and self.done():
                break  # interactive runs go on until Ctrl-C or --duration
            if cfg.speedup is not None:
                ahead = (self.t_s - sim0) / cfg.speedup - (time.perf_counter() - t0)
                if gcs is not None:
                    if ahead > 0.0:
                        gcs.wait(ahead)  # answer requests while waiting for real time
                elif ahead > 0.002:
                    time.sleep(ahead)
            if cfg.progress and self.t_s >= next_progress:
                _progress(self, end_s)
                next_progress = self.t_s + 10.0

    def close(self) -> None:
        """Close the ground-station links and flush their telemetry log."""
        if self.gcs is not None:
            self.gcs.close()


def _progress(s: Session, end_s: float) -> None:
    seq = s.vehicle.sequencer
    reached = len(seq.reached_seqs) if seq else 0
    total = seq.total_items if seq else len(s.mission) - 1
    width = 30
    frac = min(s.t_s / end_s, 1.0)
    bar = "#" * int(width * reached / max(total, 1))
    sys.stderr.write(f"\r[{bar:<{width}}] items {reached}/{total}  t={s.t_s:7.1f} s")
    sys.stderr.flush()


def write_run(session: Session, summary: dict, log_dir: Path) -> Path:
    log_dir.mkdir(parents=True, exist_ok=True)
    mission_xy = []
    hf = session.vehicle.home_frame
    if hf is not None:
        for it in session.mission:
            if it.command in POSITION_COMMANDS and (it.x_lat_deg, it.y_lon_deg) != (0.0, 0.0):
                p = hf.to_ned_fast(math.radians(it.x_lat_deg), math.radians(it.y_lon_deg), hf.alt0_m)
                mission_xy.append((it.seq, p[0], p[1]))
    extra = {"mission_wp": np.array(mission_xy, dtype=float).reshape(-1, 3)}
    if hf is not None:
        # the lines of the mission as written, in flying order (tools/invariants.py):
        # seq of the line's end, start north/east, end north/east [m]
        from .invariants import mission_legs
        flown = session.vehicle.mission if session.vehicle.mission is not None else session.mission
        legs = mission_legs(flown, hf, session.cfg.vehicle, session.params)
        extra["mission_lines"] = np.array([(g["seq"], *g["a"], *g["b"]) for g in legs],
                                          dtype=float).reshape(-1, 5)
    innov = getattr(getattr(session.vehicle, "monitor", None), "innovation_log", None)
    if innov is not None:
        extra.update(innov.arrays())        # innov_* columns: every innovation record
    session.log.save(log_dir / "flight.npz", extra=extra)
    # the mission flown (the last one loaded: a ground station may have replaced it)
    flown = session.vehicle.mission if session.vehicle.mission is not None else session.mission
    save_waypoints(flown, log_dir / "mission.waypoints")
    session.params.save(log_dir / "params.parm")
    with open(log_dir / "summary.json", "w") as f:
        json.dump(summary, f, indent=2, sort_keys=True)
        f.write("\n")
    return log_dir
