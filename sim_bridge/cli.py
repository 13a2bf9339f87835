"""``sim-bridge``: the simulator as its own process. Listens for an autopilot on the HIL
link (PX4 simulator interface: TCP 4560 by default) and runs the plant in lockstep with
it, e.g.

    sim-bridge --vehicle plane --mission missions/default.waypoints &
    autopilot --sim tcp:127.0.0.1:4560
"""
from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

from autopilot import heap
from autopilot.interrupt import StopOnInterrupt
from autopilot.link.transports import TransportError, open_url

from .sensors.params import GPS_PRESETS, SensorParams

DEFAULT_MISSION = Path(__file__).resolve().parent.parent / "missions" / "default.waypoints"


def _home_from(args) -> tuple[float, float, float, float]:
    if args.home:
        lat, lon, alt, hdg = (float(x) for x in args.home.split(","))
        return lat, lon, alt, hdg
    from autopilot.mission.files import load_mission
    from autopilot.mission.home import mission_home
    return mission_home(load_mission(args.mission))


def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(prog="sim-bridge", description="JSBSim plant + sensors behind the HIL link")
    ap.add_argument("--vehicle", default="plane", choices=["plane"])
    ap.add_argument("--airframe", default="aerosonde")
    ap.add_argument("--listen", default="tcpin:0.0.0.0:4560", help="tcpin:HOST:PORT or udpin:HOST:PORT")
    ap.add_argument("--home", help="LAT,LON,ALT_M,HEADING_DEG")
    ap.add_argument("--mission", default=str(DEFAULT_MISSION), help="take home from this mission's item 0")
    ap.add_argument("--scenario")
    ap.add_argument("--wind", help="SPEED_MPS,FROM_DEG")
    ap.add_argument("--turbulence", choices=["none", "light", "moderate", "severe"])
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--gps", default="standard", choices=list(GPS_PRESETS),
                    help="receiver model (sim_bridge/sensors/params.py GPS_PRESETS); give the "
                         "autopilot the same --gps")
    ap.add_argument("--speedup", type=float, default=None, help="real-time multiple (default: as fast as lockstep allows)")
    ap.add_argument("--duration", type=float, default=1e9, help="simulated seconds")
    ap.add_argument("--accept-timeout", type=float, default=60.0)
    ap.add_argument("--truth-div", type=int, default=1,
                    help="HIL_STATE_QUATERNION (truth) every N-th step and with every HIL_GPS "
                         "(sim_bridge/hil.py); 1, the default, every step (an autopilot flying "
                         "on --nav truth needs it); the autopilot's flight-log divisor (2, "
                         "as `sitl run` paces it) sends only the truth its log keeps; 0 never")
    return ap


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    from .scenario import ScenarioError, parse_wind_arg
    from .world import build_world
    try:
        home = _home_from(args)
        w = parse_wind_arg(args.wind) if args.wind else None
        wind = (w.speed_mps, w.from_deg) if w else None
        world = build_world(home, args.seed, args.airframe, Path(args.scenario) if args.scenario else None,
                            wind, args.turbulence, args.vehicle, SensorParams(**GPS_PRESETS[args.gps]))
        transport = open_url(args.listen)
    except (ScenarioError, TransportError, ValueError, OSError) as e:
        print(f"sim-bridge: error: {e}", file=sys.stderr)
        return 2
    bridge = world.bridge(transport, args.vehicle)
    bridge.link.truth_div = max(0, args.truth_div)
    if hasattr(transport, "accept"):
        print(f"sim-bridge: waiting for an autopilot on {args.listen}", file=sys.stderr)
        if not transport.accept(args.accept_timeout):
            print("sim-bridge: no autopilot connected", file=sys.stderr)
            return 1
    else:
        # udpin: wait for the autopilot's first datagram to learn its address
        deadline = time.monotonic() + args.accept_timeout
        while transport.peer is None and time.monotonic() < deadline:
            transport.recv(0.5)
    heap.settle()              # what exists now kept out of the collector (autopilot/heap.py)
    t0 = time.perf_counter()
    stop = StopOnInterrupt()   # Ctrl-C: the loop stops after its step (autopilot/interrupt.py)
    try:
        with stop:
            while bridge.t_us * 1e-6 < args.duration and not stop.requested:
                if not bridge.run_step():
                    if bridge.link.missed >= 3:
                        print("sim-bridge: autopilot stopped answering", file=sys.stderr)
                        break
                if args.speedup:
                    ahead = bridge.t_us * 1e-6 / args.speedup - (time.perf_counter() - t0)
                    if ahead > 0.002:
                        time.sleep(ahead)
    except KeyboardInterrupt:
        pass
    finally:
        heap.release()
        transport.close()
    wall = time.perf_counter() - t0
    print(f"sim-bridge: {bridge.t_us * 1e-6:.1f} s simulated in {wall:.1f} s wall "
          f"({bridge.t_us * 1e-6 / max(wall, 1e-9):.1f}x), retried {bridge.link.retried}, "
          f"missed {bridge.link.missed}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
