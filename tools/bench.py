"""``sitl bench``: speed figures from one run of this command.

Machines are shared and noisy, so what matters are the ratios measured back to back in
one run: plant alone, the full loop on the memory pipe, the full loop over TCP between
two processes, and the time per step of each block. Block times come from wrapping each
block's entry point with a timer, so they include Python call overhead but not the
timer's own (subtracted by a calibration).
"""
from __future__ import annotations

import os
import socket
import subprocess
import sys
import time
from collections import defaultdict

from autopilot import heap
from autopilot.heap import settled_heap
from autopilot.mission.home import mission_home

from .runner import DEFAULT_MISSION, DEFAULT_SCENARIO, RunConfig, Session


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def bench_plant(seconds: float) -> float:
    from autopilot.mission.files import load_mission
    from sim_bridge.plants.base import PlaneControls
    from sim_bridge.plants.jsbsim_plane import JSBSimPlane
    import numpy as np
    home = mission_home(load_mission(DEFAULT_MISSION))
    plant = JSBSimPlane("aerosonde", home=home, rng=np.random.default_rng(1))
    c = plant.trim(25.0, 100.0)
    plant.set_wind((0.0, 5.0, 0.0), "light")
    n = int(seconds * 100)
    t0, c0 = time.perf_counter(), time.process_time()
    for _ in range(n):
        plant.step(c, 2)
    return seconds / (time.perf_counter() - t0), seconds / max(time.process_time() - c0, 1e-9)


def _link_floor(plant_step, controls0, steps: int) -> tuple[float, int]:
    """``steps`` lockstep steps of a plant with the link's own bytes and nothing else:
    each step the plant moves under the last answer, one HIL_SENSOR frame is made from
    its state and sent on a memory pipe, the autopilot end's codec reads it and answers
    with one HIL_ACTUATOR_CONTROLS frame (the first controls, nudged as a controller's
    would move them), which the simulator end's codec reads and the plant flies. Returns
    the wall seconds and how many answers came back carrying their step's time."""
    import struct
    from autopilot.link.codec import Codec, Routes
    from autopilot.link.hil import HIL_IDS, ID_ACTUATORS, ID_SENSOR
    from autopilot.link.transports import memory_pair
    from sim_bridge.hil import _SENSOR
    answer = struct.Struct("<Q8x4f48xB")       # time_usec, flags 0, controls[4], 12 zeros, mode
    sim_end, ap_end = memory_pair()
    sim_codec, ap_codec = Codec(1, 51), Codec(1, 1)
    last: list = [None, None]

    def on_sensor(v):
        last[0] = v

    def on_answer(v):
        last[1] = v

    def other(v):
        pass
    ap_routes = Routes({i: on_sensor if i == ID_SENSOR else other for i in HIL_IDS})
    sim_routes = Routes({i: on_answer if i == ID_ACTUATORS else other for i in HIL_IDS})
    c = controls0
    u0, u1, u2, u3 = controls0
    good = 0
    t0 = time.perf_counter()
    for k in range(steps):
        st = plant_step(c)
        ax, ay, az = st.f_b
        gx, gy, gz = st.omega_b
        sim_end.send(sim_codec.frame(ID_SENSOR, _SENSOR(st.t_us, ax, ay, az, gx, gy, gz, 0.2, 0.0, 0.4,
                                                       1013.25, 0.0, 100.0, 15.0, 0x1FFF, 0)))
        ap_codec.dispatch(ap_end.recv(), ap_routes)
        v = last[0]
        d = 1e-4 * (k % 7)
        ap_end.send(ap_codec.frame(ID_ACTUATORS, answer.pack(v[0], u0 + d, u1 - d, u2 + d, u3 - d, 128)))
        sim_codec.dispatch(sim_end.recv(), sim_routes)
        a = last[1]
        if a[0] == st.t_us:
            good += 1
        c = a[2:6]
    return time.perf_counter() - t0, good


def bench_link_floor(seconds: float, vehicle: str = "plane") -> tuple[float, int, int]:
    """The plant alone (as ``bench_plant`` / ``bench_quad_plant`` set it up) plus the
    lockstep link's two frames a step through this codec, and nothing else: no sensor
    model, filter, guidance, control, monitor or log. No loop whose link's bytes this
    codec makes can be faster; its ratio to the plant alone is the share of the plant's
    speed the link leaves for the rest of a step. Returns (x real time, steps, steps
    whose answer came back whole)."""
    import numpy as np
    if vehicle == "quad":
        from sim_bridge.plants.quadrotor import QuadrotorPlant
        plant = QuadrotorPlant(home=(-35.36, 149.17, 584.0, 0.0), wind_ned=(0.0, 3.0, 0.0),
                               turbulence="light", rng=np.random.default_rng(1))
        plant.set_airborne(10.0)
        u = plant.af.hover_command(plant.rho, plant.g)
        c0, dt_s = (u, u, u, u), plant.dt_s

        def plant_step(c):
            return plant.step(c)
    else:
        from autopilot.mission.files import load_mission
        from sim_bridge.plants.base import PlaneControls
        from sim_bridge.plants.jsbsim_plane import JSBSimPlane
        plant = JSBSimPlane("aerosonde", home=mission_home(load_mission(DEFAULT_MISSION)),
                            rng=np.random.default_rng(1))
        trim = plant.trim(25.0, 100.0)
        plant.set_wind((0.0, 5.0, 0.0), "light")
        c0, dt_s = (trim.aileron, trim.elevator, trim.rudder, trim.throttle), 0.01
        make = PlaneControls.make

        def plant_step(c):
            return plant.step(make(*c), 2)
    _link_floor(plant_step, c0, 10)              # (a first run compiles what it compiles here)
    n = int(seconds / dt_s)
    wall_s, good = _link_floor(plant_step, c0, n)
    return seconds / wall_s, n, good


class _Timers:
    def __init__(self):
        self.total = defaultdict(float)
        self.count = defaultdict(int)

    def wrap(self, obj, name: str, label: str):
        fn = getattr(obj, name)
        total, count = self.total, self.count
        clock = time.perf_counter

        def timed(*a, **k):
            t = clock()
            r = fn(*a, **k)
            total[label] += clock() - t
            count[label] += 1
            return r
        setattr(obj, name, timed)


def bench_memory(seconds: float, nav: str, timers: _Timers | None = None) -> tuple[float, Session]:
    cfg = RunConfig(nav=nav, scenario=DEFAULT_SCENARIO, duration_s=1e9, seed=1)
    s = Session(cfg)
    # start-up (alignment, arming) is excluded: run until armed and flying
    while not s.vehicle.armed or s.t_s < 5.0:
        s.step()
    if timers is not None:
        v = s.vehicle
        timers.wrap(s.plant, "step", "plant")
        timers.wrap(s.world.sensors, "sample", "sensors")
        timers.wrap(s.bridge.link, "send_step", "codec (sim: encode)")
        timers.wrap(s.ap_end, "poll", "codec (autopilot: decode)")
        timers.wrap(s.ap_end, "answer", "codec (autopilot: encode)")
        timers.wrap(s.bridge.link, "poll_answer", "codec (sim: decode)")
        timers.wrap(v.nav, "update", "navigation")
        timers.wrap(v.sequencer, "update", "guidance (mission)")
        timers.wrap(v.l1, "line", "guidance (L1)")
        timers.wrap(v.l1, "loiter", "guidance (L1)")
        timers.wrap(v.ctrl, "update", "control")
        if getattr(v, "monitor", None) is not None:
            timers.wrap(v.monitor, "update", "fault monitor")
            # the actuator balances (elevator, aileron and rudder, throttle) step after
            # the answer, in finish_step: their cost is the monitor's as well
            timers.wrap(v.monitor, "observe_controls", "fault monitor")
        timers.wrap(v, "_log", "flight log")
    t_end = s.t_s + seconds
    best = 0.0
    with settled_heap():                         # as Session.run() flies
        t0, c0 = time.perf_counter(), time.process_time()
        while s.t_s < t_end:
            # WINDOW_S windows: the best one shows the speed when the machine is not shared
            w0, sim0 = time.perf_counter(), s.t_s
            w_end = min(sim0 + WINDOW_S, t_end)
            while s.t_s < w_end:
                s.step()
            if s.t_s - sim0 >= WINDOW_S - 0.01:
                best = max(best, (s.t_s - sim0) / (time.perf_counter() - w0))
        wall = time.perf_counter() - t0
    s.bench_cpu_rtf = seconds / max(time.process_time() - c0, 1e-9)
    s.bench_best_window_rtf = best
    return seconds / wall, s


WINDOW_S = 5.0     # simulated seconds of the windows whose best is reported beside the mean


def bench_tcp(seconds: float, nav: str, best_window: list | None = None) -> float:
    """sim-bridge and autopilot as two processes on TCP loopback, truth paced as the
    memory pipe's run paces it (every LOG_DIV-th step and with every fix: the truth the
    flight log keeps), so that the two loops do the same work. ``best_window``: a list
    that receives the best WINDOW_S window's real-time factor."""
    from autopilot.vehicle import LOG_DIV
    port = _free_port()
    env = dict(os.environ)
    sim = subprocess.Popen([sys.executable, "-m", "sim_bridge.cli", "--listen", f"tcpin:127.0.0.1:{port}",
                            "--scenario", str(DEFAULT_SCENARIO), "--duration", str(seconds + 30.0),
                            "--truth-div", str(LOG_DIV)],
                           stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=env)
    try:
        from autopilot.link.hil import AutopilotHilEnd
        from autopilot.link.transports import open_url
        from autopilot.log.flightlog import FlightLog
        from autopilot.mission.files import load_mission
        from autopilot.params import ParamStore
        from autopilot.vehicle import LOG_COLUMNS, PlaneVehicle, plane_param_declarations
        transport = open_url(f"tcp:127.0.0.1:{port}", connect_timeout_s=30.0)
        params = ParamStore(plane_param_declarations())
        vehicle = PlaneVehicle(params, load_mission(DEFAULT_MISSION), nav, True, FlightLog(LOG_COLUMNS))
        end = AutopilotHilEnd(transport)
        t_s = 0.0
        t0 = None
        t_start = None
        best = 0.0
        heap.settle()                            # as the autopilot's own process does
        while True:
            steps = end.poll(1.0)
            if not steps and transport.closed:
                break
            for frame, truth in steps:
                end.answer(vehicle.control_step(frame, truth))
                vehicle.finish_step()            # (as autopilot/cli.py: after the answer)
                t_s = frame.t_us * 1e-6
            if t0 is None and vehicle.armed and t_s >= 5.0:
                t0, t_start = time.perf_counter(), t_s
                w0, w_sim = t0, t_s
            if t0 is not None and t_s - w_sim >= WINDOW_S - 0.005:
                now = time.perf_counter()
                best = max(best, (t_s - w_sim) / (now - w0))
                w0, w_sim = now, t_s
            if t0 is not None and t_s - t_start >= seconds:
                break
        wall = time.perf_counter() - t0
        if best_window is not None:
            best_window.append(best)
        transport.close()
        return (t_s - t_start) / wall
    finally:
        heap.release()
        sim.terminate()
        sim.wait(10)


def bench_quad_plant(seconds: float) -> float:
    """The quadrotor model alone, one 4 ms step per call, commands changing every step
    (as they do in flight, so the thrust-curve cache never hits)."""
    import numpy as np
    from sim_bridge.plants.quadrotor import QuadrotorPlant
    plant = QuadrotorPlant(home=(-35.36, 149.17, 584.0, 0.0), wind_ned=(0.0, 3.0, 0.0),
                           turbulence="light", rng=np.random.default_rng(1))
    plant.set_airborne(10.0)
    u = plant.af.hover_command(plant.rho, plant.g)
    n = int(seconds / plant.dt_s)
    for _ in range(10):                          # (a first run compiles the plant's kernel here)
        plant.step((u, u, u, u))
    t0 = time.perf_counter()
    for k in range(n):
        d = 1e-4 * (k % 7)
        plant.step((u + d, u - d, u + d, u - d))
    return seconds / (time.perf_counter() - t0)


def bench_quad_memory(seconds: float, nav: str, timers: _Timers | None = None) -> tuple[float, Session]:
    from .runner import QUAD_DEFAULT_MISSION
    cfg = RunConfig(vehicle="quad", airframe="f450", mission=QUAD_DEFAULT_MISSION, nav=nav,
                    scenario=DEFAULT_SCENARIO, duration_s=1e9, seed=1)
    s = Session(cfg)
    # start-up (alignment, arming, takeoff) is excluded: run until flying the mission
    while not s.vehicle.armed or s.t_s < 12.0:
        s.step()
    if timers is not None:
        v = s.vehicle
        timers.wrap(s.plant, "step", "plant")
        timers.wrap(s.world.sensors, "sample", "sensors")
        timers.wrap(s.bridge.link, "send_step", "codec (sim: encode)")
        timers.wrap(s.ap_end, "poll", "codec (autopilot: decode)")
        timers.wrap(s.ap_end, "answer", "codec (autopilot: encode)")
        timers.wrap(s.bridge.link, "poll_answer", "codec (sim: decode)")
        if nav != "truth":
            timers.wrap(v.nav, "update", "navigation (filter + predictor)")
        timers.wrap(v, "_fly", "guidance + control")
        timers.wrap(v, "_log", "flight log")
    t_start = s.t_s
    t_end = t_start + seconds
    best = 0.0
    with settled_heap():                         # as Session.run() flies
        t0 = time.perf_counter()
        while s.t_s < t_end and not s.done():
            # 5 s windows: the best one shows the speed when the machine is not shared
            w0, sim0 = time.perf_counter(), s.t_s
            while s.t_s < min(sim0 + 5.0, t_end) and not s.done():
                s.step()
            if s.t_s - sim0 >= 4.99:
                best = max(best, (s.t_s - sim0) / (time.perf_counter() - w0))
        wall = time.perf_counter() - t0
    s.bench_best_window_rtf = best
    return (s.t_s - t_start) / wall, s


def run_quad_bench(seconds: float = 60.0) -> None:
    """``sitl bench --vehicle quad``: the quadrotor at its 250 Hz lockstep."""
    print(f"sitl bench --vehicle quad: {seconds:.0f} simulated seconds per measurement, "
          f"quad_default mission, 250 Hz lockstep (4 ms), inner loop every step")
    plant_rtf = bench_quad_plant(seconds)
    print(f"  plant alone (quadrotor model, 4 ms steps):     {plant_rtf:8.1f} x real time")
    rows = {}
    for nav in ("truth", "ekf"):
        rtf, s = bench_quad_memory(seconds, nav)
        rows[nav] = rtf
        extra = f"; filter every {int(s.params['QD_NAV_DIV'])} steps" if nav != "truth" else ""
        print(f"  full loop, memory pipe, nav {nav:5s}:            {rtf:8.1f} x real time "
              f"(best 5 s window {s.bench_best_window_rtf:.1f}{extra})")
    timers = _Timers()
    _, s = bench_quad_memory(min(seconds, 30.0), "ekf", timers)
    steps = max(timers.count["plant"], 1)
    total = sum(timers.total.values()) / steps * 1e6
    print(f"  time per 4 ms step by block (nav ekf), microseconds (sum {total:.0f}; "
          f"20x real time needs <= 200 in all):")
    for label in sorted(timers.total, key=lambda k: -timers.total[k]):
        print(f"    {label:32s} {timers.total[label] / steps * 1e6:8.1f}")


def bench_formation(path, seconds: float) -> float:
    """The seed's quadrotor formation (``path``) at full rates: the 250 Hz lockstep and the
    single-quad filter rate (QD_NAV_DIV's default), ``seconds`` of simulated time from
    power-on (alignment and the hold before the common start included, as a campaign pays
    them), flown to the end of that window even where the formation completes before it
    (the 5-quad formation does at 14.4 s of 20: a shorter window holds more of the cheaper
    hold before the start, and the 10 / 5 quads ratio compared unlike flights). Real-time
    factor of the whole formation (all vehicles share this process)."""
    import dataclasses
    from autopilot.formation import load_formation
    from autopilot.vehicle_quad import quad_param_declarations
    from .formation import VehicleNetwork, run_quad
    import numpy as np
    nav_div = int(next(d.default for d in quad_param_declarations() if d.name == "QD_NAV_DIV"))
    spec = load_formation(path)
    spec = dataclasses.replace(spec, quad=dataclasses.replace(spec.quad, hil_rate_hz=250.0,
                                                              nav_div=nav_div))
    net = VehicleNetwork([v.id for v in spec.vehicles], spec.network.latency_s, spec.network.loss,
                         np.random.default_rng(1))
    from .formation import QUAD_START_S
    out, _ = run_quad(spec, 1, net, max(seconds - QUAD_START_S, 0.1), to_the_end=True)
    return out["sim_time_s"] / out["wall_s"]


_FIRST_STEP = """
import sys, time
from tools.runner import RunConfig, Session
s = Session(RunConfig(nav=sys.argv[1], duration_s=float(sys.argv[2]), seed=1))
s.step()
t1 = time.time()
while s.t_s < float(sys.argv[2]):
    s.step()
print(t1, time.time())
"""


def bench_startup(nav: str = "ekf", seconds: float = 0.0, cache_dir: str | None = None) -> tuple:
    """(start-up, total) wall seconds of a fresh ``python`` process: from its spawn to the
    first lockstep step of a run (imports, JSBSim, the vehicle: what ``sitl run`` pays
    before it flies), and to ``seconds`` of simulated flight. ``cache_dir``: the numba
    cache to use (an empty one measures a fresh install's first run, kernels compiled)."""
    env = dict(os.environ)
    if cache_dir is not None:
        env["NUMBA_CACHE_DIR"] = cache_dir
    root = str(DEFAULT_MISSION.parent.parent)
    t0 = time.time()
    out = subprocess.run([sys.executable, "-c", _FIRST_STEP, nav, str(seconds)], cwd=root, env=env,
                         capture_output=True, text=True, check=True).stdout.split()
    return float(out[-2]) - t0, float(out[-1]) - t0


FORMATION5 = DEFAULT_MISSION.parent / "formation_seed_quad.toml"
FORMATION10 = DEFAULT_MISSION.parent / "formation_ten_quad.toml"


def bench_figures(seconds: float = 60.0, out=print) -> dict:
    """Every figure of ``sitl bench`` in one run (ratios are only comparable within a run):
    the keys of ``sitl bench --json``. ``out`` receives one line per figure as it is
    measured (None: silent)."""
    say = out or (lambda *_: None)
    fig: dict = {"seconds": seconds}
    bench_startup()                              # warm the file cache and the kernel cache
    fig["startup_s"] = min(bench_startup()[0] for _ in range(2))
    say(f"  start-up, process spawn to the first lockstep step (nav ekf): {fig['startup_s']:.2f} s")
    import tempfile
    with tempfile.TemporaryDirectory() as d:
        cold = bench_startup("ukf", 15.0, cache_dir=d)[1]
    bench_startup("ukf", 15.0)                   # (fills the kernel cache if it was empty)
    warm = bench_startup("ukf", 15.0)[1]
    fig["first_run_compile_s"] = cold - warm
    say(f"  first run after install (nav ukf, 15 s flight, empty kernel cache): {cold:.2f} s, "
        f"{fig['first_run_compile_s']:.2f} s more than with the cache")
    plant_rtf, plant_cpu = bench_plant(seconds)
    fig["plant_rtf"], fig["plant_cpu_rtf"] = plant_rtf, plant_cpu
    say(f"  plant alone (JSBSim, 2 x 5 ms per step):       {plant_rtf:8.1f} x real time"
        f"   (per CPU second of this process: {plant_cpu:6.1f} x)")
    fig["link_floor_rtf"] = bench_link_floor(seconds)[0]
    say(f"  plant + the link's two frames, nothing else:   {fig['link_floor_rtf']:8.1f} x real time")
    for nav in ("truth", "ekf", "ukf"):
        rtf, s = bench_memory(seconds if nav != "ukf" else min(seconds, 20.0), nav)
        fig[f"loop_{nav}_rtf"], fig[f"loop_{nav}_cpu_rtf"] = rtf, s.bench_cpu_rtf
        say(f"  full loop, memory pipe, nav {nav:5s}:            {rtf:8.1f} x real time"
            f"   (per CPU second of this process: {s.bench_cpu_rtf:6.1f} x)")
        if nav == "ekf":
            fig["loop_ekf_best_rtf"] = s.bench_best_window_rtf
    try:
        best: list = []
        fig["loop_tcp_rtf"] = bench_tcp(seconds, "ekf", best)
        fig["loop_tcp_best_rtf"] = best[0] if best else None
        say(f"  full loop, TCP, two processes (ekf):           {fig['loop_tcp_rtf']:8.1f} x real time"
            f"   (best {WINDOW_S:.0f} s window {fig['loop_tcp_best_rtf'] or 0.0:.1f} x; memory pipe's "
            f"{fig['loop_ekf_best_rtf']:.1f} x)")
    except Exception as e:  # report, do not hide
        fig["loop_tcp_rtf"] = fig["loop_tcp_best_rtf"] = None
        say(f"  full loop, TCP, two processes: failed ({e})")
    fig["quad_plant_rtf"] = bench_quad_plant(seconds)
    say(f"  quadrotor plant alone (4 ms steps):            {fig['quad_plant_rtf']:8.1f} x real time")
    fig["quad_link_floor_rtf"] = bench_link_floor(seconds, "quad")[0]
    say(f"  quadrotor plant + the link's two frames:       {fig['quad_link_floor_rtf']:8.1f} x real time")
    rtf, s = bench_quad_memory(seconds, "ekf")
    fig["quad_loop_ekf_rtf"] = rtf
    say(f"  quadrotor full loop, memory pipe, nav ekf:     {rtf:8.1f} x real time "
        f"(best 5 s window {s.bench_best_window_rtf:.1f})")
    fsec = min(seconds, 20.0)
    fig["formation5_rtf"] = bench_formation(FORMATION5, fsec)
    say(f"  5-quad formation, 250 Hz, full filter rate:    {fig['formation5_rtf']:8.1f} x real time")
    fig["formation10_rtf"] = bench_formation(FORMATION10, fsec)
    say(f"  10-quad formation, 250 Hz, full filter rate:   {fig['formation10_rtf']:8.1f} x real time")
    tcp = fig["loop_tcp_rtf"]
    fig["ratio_loop_ekf_to_plant"] = fig["loop_ekf_rtf"] / plant_rtf
    fig["ratio_loop_ekf_to_plant_cpu"] = fig["loop_ekf_cpu_rtf"] / plant_cpu
    fig["ratio_tcp_to_memory"] = tcp / fig["loop_ekf_rtf"] if tcp else None
    # the same from each loop's best window: on a shared machine the nearest to a quiet one
    tcp_best = fig["loop_tcp_best_rtf"]
    fig["ratio_tcp_to_memory_best"] = (tcp_best / fig["loop_ekf_best_rtf"]
                                       if tcp_best and fig["loop_ekf_best_rtf"] else None)
    fig["ratio_quad_loop_to_plant"] = fig["quad_loop_ekf_rtf"] / fig["quad_plant_rtf"]
    fig["ratio_formation10_to_5"] = fig["formation10_rtf"] / fig["formation5_rtf"]
    # the most of the plant's speed a loop can keep once its link's bytes are made and read
    fig["ratio_link_floor_to_plant"] = fig["link_floor_rtf"] / plant_rtf
    fig["ratio_quad_link_floor_to_plant"] = fig["quad_link_floor_rtf"] / fig["quad_plant_rtf"]
    say(f"  ratios: loop ekf / plant {fig['ratio_loop_ekf_to_plant']:.3f} (CPU "
        f"{fig['ratio_loop_ekf_to_plant_cpu']:.3f}), TCP / memory "
        f"{fig['ratio_tcp_to_memory'] or float('nan'):.3f} (best windows "
        f"{fig['ratio_tcp_to_memory_best'] or float('nan'):.3f}), quad loop / quad plant "
        f"{fig['ratio_quad_loop_to_plant']:.3f}, 10 quads / 5 quads {fig['ratio_formation10_to_5']:.3f}")
    say(f"  the link alone leaves: fixed-wing {fig['ratio_link_floor_to_plant']:.3f}, quadrotor "
        f"{fig['ratio_quad_link_floor_to_plant']:.3f} of the plant's speed (plant + two frames / plant)")
    timers = _Timers()
    _, s = bench_memory(min(seconds, 30.0), "ekf", timers)
    steps = max(timers.count["plant"], 1)
    fig["block_us"] = {k: timers.total[k] / steps * 1e6 for k in timers.total}
    say("  time per 10 ms step by block (nav ekf), microseconds:")
    for label in sorted(timers.total, key=lambda k: -timers.total[k]):
        say(f"    {label:28s} {fig['block_us'][label]:8.1f}")
    from autopilot.nav.bench import bench as nav_bench
    from autopilot.nav.ukf import InsGpsUkf
    from autopilot.nav.ekf import InsGpsEkf
    say("  navigation filters alone, per 100 Hz step (best of 3), microseconds:")
    for name, cls, secs in (("ekf", InsGpsEkf, 20.0), ("ukf", InsGpsUkf, 5.0)):
        r = nav_bench(cls, aux_hz=50.0, seconds=secs, repeats=3)
        fig[f"{name}_alone_us"] = r
        say(f"    {name.upper()}: predict {r['predict_us']:7.1f}   update {r['update_us']:7.1f}   "
            f"step {r['step_us']:7.1f}")
    return fig


def run_profile(seconds: float = 30.0, vehicle: str = "plane", top: int = 40) -> None:
    """``sitl bench --profile``: the full loop (memory pipe, EKF) under cProfile, the top
    functions by cumulative time, then by own time."""
    import cProfile
    import pstats
    prof = cProfile.Profile()
    if vehicle == "quad":
        from .runner import QUAD_DEFAULT_MISSION
        cfg = RunConfig(vehicle="quad", airframe="f450", mission=QUAD_DEFAULT_MISSION, nav="ekf",
                        scenario=DEFAULT_SCENARIO, duration_s=1e9, seed=1)
        warm = 12.0
    else:
        cfg = RunConfig(nav="ekf", scenario=DEFAULT_SCENARIO, duration_s=1e9, seed=1)
        warm = 5.0
    s = Session(cfg)
    while not s.vehicle.armed or s.t_s < warm:
        s.step()
    t_end = s.t_s + seconds
    prof.enable()
    while s.t_s < t_end:
        s.step()
    prof.disable()
    print(f"sitl bench --profile: {vehicle}, nav ekf, memory pipe, {seconds:.0f} simulated s "
          f"after arming (cProfile slows Python calls ~2x: read shares, not speeds)")
    st = pstats.Stats(prof)
    st.sort_stats("cumulative").print_stats(top)
    st.sort_stats("tottime").print_stats(top)


def run_bench(seconds: float = 60.0, vehicle: str = "plane", as_json: bool = False) -> None:
    if as_json:
        import json
        print(json.dumps(bench_figures(seconds, out=None), indent=1, sort_keys=True))
        return
    if vehicle == "quad":
        run_quad_bench(seconds)
        return
    print(f"sitl bench: {seconds:.0f} simulated seconds per measurement, default mission, 100 Hz lockstep")
    print("  (wall-clock figures; in brackets the same per CPU second of this process, which a\n"
          "   shared machine disturbs less)")
    bench_figures(seconds)


# --- fault monitor: false alarms over fault-free flights ------------------------------
def _looping_mission(path, repeats: int):
    """The default mission with its DO_JUMP (177) repeat count raised, written to
    ``path``: the circuit is flown over and over, so a long flight stays a mission flight
    (turns, climbs, descents) instead of an RTL loiter after 260 s."""
    lines = []
    for line in DEFAULT_MISSION.read_text().splitlines():
        f = line.split("\t")
        if len(f) >= 12 and f[3] == "177":
            f[5] = str(repeats)
        lines.append("\t".join(f))
    path.write_text("\n".join(lines) + "\n")
    return path


def false_alarm_flight(seed: int, seconds: float, mission=None, params=None) -> dict:
    """One fault-free flight of ``seconds`` (default scenario: 5 m/s wind, light
    turbulence): its false alarms, the episodes (start, trigger) and the largest
    detection statistic / threshold per channel while no fault was detected."""
    from .summary import run_summary
    cfg = RunConfig(scenario=DEFAULT_SCENARIO, duration_s=seconds, seed=seed,
                    mission=mission or DEFAULT_MISSION, param_overrides=dict(params or {}))
    s = Session(cfg)
    while s.t_s < seconds and not s.crashed:
        s.step()
        s.done()                         # sets crashed if back on the ground
    summ = run_summary(s)
    mon = s.vehicle.monitor
    return {"seed": seed, "sim_time_s": round(s.t_s, 1), "crashed": s.crashed,
            "false_alarms": summ.get("false_alarms", 0),
            "episodes": [(ep["start_s"], ep["trigger"]) for ep in summ.get("fdi_episodes", [])],
            "peaks": {k: round(v, 3) for k, v in sorted(mon.peaks.items())} if mon else {}}


def run_false_alarms(flights: int = 10, seconds: float = 600.0, seed0: int = 1,
                     params=None, out=print) -> dict:
    """``sitl bench --false-alarms``: ``flights`` fault-free flights of ``seconds``, seeds
    seed0 .. seed0 + flights - 1, the default mission looped. Prints one line per flight
    and the total ``false_alarms``, which must be 0 over ten 10-minute flights (the
    measured margins: docs/status.md, "Faults and the monitor")."""
    import tempfile
    from pathlib import Path
    out(f"sitl bench --false-alarms: {flights} fault-free flights x {seconds:.0f} s, seeds "
        f"{seed0}..{seed0 + flights - 1}, default scenario, default mission looped")
    rows = []
    with tempfile.TemporaryDirectory() as d:
        mission = _looping_mission(Path(d) / "looped.waypoints", max(1, int(seconds / 40.0)))
        for seed in range(seed0, seed0 + flights):
            r = false_alarm_flight(seed, seconds, mission, params)
            rows.append(r)
            peaks = " ".join(f"{k}={v:.2f}" for k, v in r["peaks"].items())
            out(f"  seed {seed:3d}: {r['sim_time_s']:6.1f} s  false_alarms {r['false_alarms']}"
                f"{'  CRASHED' if r['crashed'] else ''}  {r['episodes'] or ''}")
            out(f"            peak statistic / threshold: {peaks}")
    total = sum(r["false_alarms"] for r in rows)
    hours = sum(r["sim_time_s"] for r in rows) / 3600.0
    worst = {}
    for r in rows:
        for k, v in r["peaks"].items():
            worst[k] = max(worst.get(k, 0.0), v)
    out(f"  largest statistic / threshold over all flights: "
        + " ".join(f"{k}={v:.2f}" for k, v in sorted(worst.items())))
    out(f"false_alarms: {total}  ({len(rows)} flights, {hours:.2f} flight hours)")
    return {"false_alarms": total, "flights": rows, "hours": hours, "worst_peaks": worst}
