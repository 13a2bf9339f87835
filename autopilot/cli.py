"""``autopilot``: the flight software as its own process, flying a simulator over the
HIL link (PX4 simulator interface), e.g.

    sim-bridge --vehicle plane &                 # listens on tcp 4560
    autopilot --sim tcp:127.0.0.1:4560 --mission missions/default.waypoints
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from . import heap
from .interrupt import StopOnInterrupt
from .link.hil import AutopilotHilEnd
from .link.transports import TransportError, open_url
from .log.flightlog import FlightLog
from .mission.files import MissionFileError, load_mission
from .nav.config import NAV_GPS_PRESETS
from .params import ParamError, ParamStore
from .vehicle import LOG_COLUMNS, PlaneVehicle, plane_param_declarations

DEFAULT_MISSION = Path(__file__).resolve().parent.parent / "missions" / "default.waypoints"


def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(prog="autopilot", description="Fly a simulator over the MAVLink HIL link")
    ap.add_argument("--sim", default="tcp:127.0.0.1:4560",
                    help="simulator link: tcp:HOST:PORT, udp:HOST:PORT (default tcp:127.0.0.1:4560)")
    ap.add_argument("--vehicle", default="plane", choices=["plane"])
    ap.add_argument("--mission", default=str(DEFAULT_MISSION),
                    help=".waypoints or .plan (a .plan's geoFence and rallyPoints load with it)")
    ap.add_argument("--fence", help="geofence file (MAVProxy's fence formats; autopilot/fence/files.py)")
    ap.add_argument("--rally", help="rally point file (MAVProxy's rally formats)")
    ap.add_argument("--nav", default="ekf", choices=["ekf", "ukf", "truth"])
    ap.add_argument("--params", help=".parm file to load")
    ap.add_argument("--gps", default="standard", choices=list(NAV_GPS_PRESETS),
                    help="the simulator's receiver model: the filter's GPS parameters to match "
                         "(autopilot/nav/config.py NAV_GPS_PRESETS), before --params")
    ap.add_argument("--duration", type=float, default=1e9, help="stop after this much simulated time [s]")
    ap.add_argument("--log-dir", help="write flight.npz and params.parm here at the end")
    ap.add_argument("--connect-timeout", type=float, default=30.0)
    ap.add_argument("--gcs", action="append", nargs="?", const="default", metavar="URL",
                    help="serve ground stations (tcpin:/udpout:/udpin:HOST:PORT, repeatable; alone: "
                         "tcpin:127.0.0.1:5760 + udpout:127.0.0.1:14550, loopback only) and wait "
                         "for one to fly")
    ap.add_argument("--param-store", help="with --gcs: parameters persisted across runs (and the "
                                          "signing key, beside it)")
    ap.add_argument("--signing-key", metavar="FILE",
                    help="with --gcs: MAVLink 2 signing key file (first line: a passphrase, as "
                         "MAVProxy's 'signing setup PASSPHRASE', or 64 hex digits)")
    return ap


def _gcs_urls(values) -> tuple[str, ...] | None:
    from .gcs import DEFAULT_URLS, parse_url
    if not values:
        return None
    urls = []
    for u in values:
        for part in (DEFAULT_URLS if u == "default" else (u,)):
            parse_url(part)
            if part not in urls:
                urls.append(part)
    return tuple(urls)


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        gcs_urls = _gcs_urls(args.gcs)
        mission = load_mission(args.mission, vehicle="plane")
        from .fence.files import load_fence, load_plan_fence, load_rally
        fence, rally = load_plan_fence(args.mission) if args.mission.lower().endswith(".plan") else ((), ())
        fence = load_fence(args.fence) if args.fence else fence
        rally = load_rally(args.rally) if args.rally else rally
        decls = list(plane_param_declarations())
        if gcs_urls is not None:
            from .gcs import GCS_PARAMS, load_lenient
            decls += list(GCS_PARAMS)
        params = ParamStore(decls)
        for name, value in NAV_GPS_PRESETS[args.gps].items():
            params.set(name, value)
        if gcs_urls is not None and args.param_store and Path(args.param_store).exists():
            load_lenient(params, Path(args.param_store))
        if args.params:
            params.load(args.params)
        signing_key = None
        if args.signing_key is not None:
            from .link.signing import read_key_file
            if gcs_urls is None:
                raise ValueError("--signing-key: only with --gcs")
            signing_key = read_key_file(args.signing_key)
        transport = open_url(args.sim, connect_timeout_s=args.connect_timeout)
    except (MissionFileError, ParamError, TransportError, FileNotFoundError, ValueError) as e:
        print(f"autopilot: error: {e}", file=sys.stderr)
        return 2
    if args.sim.startswith(("udp:", "udpout:")):
        transport.send(b"")  # make ourselves known to a udpin simulator
    log = FlightLog(LOG_COLUMNS)
    vehicle = PlaneVehicle(params, mission, args.nav, autostart=gcs_urls is None, log=log)
    vehicle.set_fence(fence, 0)
    vehicle.set_rally(rally, 0)
    why = vehicle.geofence.mission_problem(mission.items, None)
    if why is not None:
        print(f"autopilot: error: {args.mission}: the mission leaves the enabled fence: {why}", file=sys.stderr)
        transport.close()
        return 2
    end = AutopilotHilEnd(transport)
    gcs = None
    if gcs_urls is not None:
        from .gcs import GcsService
        try:
            gcs = GcsService(vehicle, gcs_urls, hil=end, param_store_path=args.param_store,
                             tlog_path=Path(args.log_dir) / "gcs.tlog" if args.log_dir else None,
                             signing_key=signing_key)
        except OSError as e:
            print(f"autopilot: error: --gcs: {e}", file=sys.stderr)
            transport.close()
            return 2
        for w in gcs.warnings(gcs_urls):
            print(f"autopilot: warning: {w}", file=sys.stderr, flush=True)
        print(f"autopilot: signing {'on' if gcs.signing.active else 'off'}; {gcs.describe()}",
              file=sys.stderr, flush=True)
    last_rx = time.monotonic()
    t_s = 0.0
    heap.settle()              # what exists now kept out of the collector (heap.py)
    stop = StopOnInterrupt()   # Ctrl-C: the loop stops after its step (interrupt.py)
    try:
        with stop:
            while t_s < args.duration and not stop.requested:
                steps = end.poll(timeout_s=0.5 if gcs is None else 0.005)
                for frame, truth in steps:
                    out = vehicle.control_step(frame, truth)
                    end.answer(out)          # the simulator advances while the step finishes
                    vehicle.finish_step()
                    t_s = frame.t_us * 1e-6
                    if gcs is not None:
                        gcs.after_step(frame, out)
                        gcs.step(frame.t_us)
                if steps:
                    last_rx = time.monotonic()
                elif getattr(transport, "closed", False) or time.monotonic() - last_rx > 10.0:
                    break
                elif gcs is not None:
                    gcs.wait(0.005)
                seq = vehicle.sequencer
                if gcs is None and seq is not None and seq.finished and seq.rtl_established:
                    print(f"autopilot: mission complete at t={t_s:.1f} s", file=sys.stderr)
                    break
    except KeyboardInterrupt:
        pass
    finally:
        heap.release()
        transport.close()
        if gcs is not None:
            gcs.close()
    if args.log_dir:
        d = Path(args.log_dir)
        d.mkdir(parents=True, exist_ok=True)
        log.save(d / "flight.npz")
        params.save(d / "params.parm")
    return 0


if __name__ == "__main__":
    sys.exit(main())
