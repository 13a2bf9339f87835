"""``sitl``: run, report and benchmark headless SITL flights.

    sitl run    [--vehicle plane|quad] [--airframe NAME] [--mission FILE] [--scenario FILE]
                [--wind SPEED,FROM_DEG] [--turbulence LEVEL] [--seed N] [--speedup max|X]
                [--duration S] [--nav ekf|ukf|truth] [--home LAT,LON,ALT_M,HEADING_DEG]
                [--log-dir DIR] [--param NAME=VALUE ...] [--params FILE] [--json]
                [--gcs [URL] ...] [--param-store FILE] [--wipe] [--signing-key FILE]
                [--terrain DIR]
    sitl missions random --vehicle plane|quad --seed N -o FILE [--max-time S]
    sitl missions sample --vehicle plane|quad --seeds FIRST-LAST [--max-time S] [--jsonl FILE]
    sitl params save|load FILE [--vehicle plane|quad] [--param-store FILE] [--connect URL]
                [--signing-key FILE]
    sitl report RUN_DIR
    sitl bench  [--vehicle plane|quad] [--seconds S] [--json] [--profile]
    sitl bench  --false-alarms [--flights N] [--seconds S] [--seed N]
    sitl formation FILE [--seed N] [--duration S] [--loss P] [--latency S] [--rate HZ]
                [--udp] [--gcs] [--log-dir DIR] [--json]
    sitl campaign show|run|report|export ...   (tools/campaign: dispersion campaigns)
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from .runner import DEFAULT_MISSION, DEFAULT_SCENARIO, QUAD_DEFAULT_MISSION, RunConfig


class CliError(Exception):
    pass


def _floats(text: str, n: int, what: str) -> tuple[float, ...]:
    parts = text.split(",")
    if len(parts) != n:
        raise CliError(f"{what}: expected {n} comma-separated numbers, got {text!r}")
    try:
        return tuple(float(p) for p in parts)
    except ValueError:
        raise CliError(f"{what}: not a number in {text!r}") from None


def _config(args) -> RunConfig:
    airframe = args.airframe or ("f450" if args.vehicle == "quad" else "aerosonde")
    wind = None
    if args.wind is not None:
        speed, frm = _floats(args.wind, 2, "--wind")
        if speed < 0 or speed > 60:
            raise CliError("--wind: speed must be 0..60 m/s")
        wind = (speed, frm % 360.0)
    home = None
    if args.home is not None:
        lat, lon, alt, hdg = _floats(args.home, 4, "--home")
        if not (-90 <= lat <= 90 and -180 <= lon <= 180):
            raise CliError("--home: latitude must be within +-90 and longitude within +-180")
        home = (lat, lon, alt, hdg % 360.0)
    speedup = None
    if args.speedup not in (None, "max"):
        try:
            speedup = float(args.speedup)
        except ValueError:
            raise CliError("--speedup: 'max' or a positive number") from None
        if speedup <= 0:
            raise CliError("--speedup: 'max' or a positive number")
    scenario = Path(args.scenario) if args.scenario else None
    if scenario is None and wind is None and args.mission is None:
        scenario = DEFAULT_SCENARIO  # the default flight: 5 m/s crosswind, light turbulence
    overrides = {}
    for kv in args.param or []:
        if "=" not in kv:
            raise CliError(f"--param {kv!r}: expected NAME=VALUE")
        k, v = kv.split("=", 1)
        overrides[k.strip()] = v.strip()
    default_mission = QUAD_DEFAULT_MISSION if args.vehicle == "quad" else DEFAULT_MISSION
    gcs, param_store = _gcs_urls(args), None
    duration = args.duration
    if gcs is not None:
        # interactive: real time unless told otherwise, until Ctrl-C unless told otherwise
        if args.speedup is None:
            speedup = 1.0
        if duration is None:
            duration = float("inf")
        if not args.wipe:
            param_store = Path(args.param_store or f"sitl-params-{args.vehicle}.parm")
    signing_key = _signing_key(args, gcs)
    return RunConfig(vehicle=args.vehicle, airframe=airframe,
                     mission=Path(args.mission) if args.mission else default_mission,
                     scenario=scenario, wind=wind, turbulence=args.turbulence, seed=args.seed,
                     speedup=speedup, duration_s=1800.0 if duration is None else duration,
                     nav=args.nav, gps=args.gps, home=home,
                     log_dir=Path(args.log_dir) if args.log_dir else None,
                     progress=not args.json and sys.stderr.isatty() and gcs is None,
                     params_file=Path(args.params) if args.params else None,
                     param_overrides=overrides, gcs=gcs, param_store=param_store,
                     signing_key=signing_key,
                     fence=Path(args.fence) if args.fence else None,
                     rally=Path(args.rally) if args.rally else None,
                     terrain=Path(args.terrain) if args.terrain else None)


def _signing_key(args, gcs) -> bytes | None:
    """``--signing-key FILE`` (a passphrase or 64 hex digits, autopilot/link/signing.py);
    ``--wipe`` also removes the key stored beside the parameter store."""
    from autopilot.link.signing import KeyFileError, group_or_other_readable, key_store_beside, read_key_file
    if args.signing_key is not None and gcs is None:
        raise CliError("--signing-key: only with --gcs")
    if gcs is not None and args.wipe:
        store = key_store_beside(args.param_store or f"sitl-params-{args.vehicle}.parm")
        if store.remove():
            print(f"sitl: --wipe: signing key {store.path} removed", file=sys.stderr)
    if args.signing_key is None:
        return None
    try:
        key = read_key_file(args.signing_key)
    except KeyFileError as e:
        raise CliError(str(e)) from None
    if group_or_other_readable(args.signing_key):
        print(f"sitl: warning: {args.signing_key} is readable by other users (chmod 600 it)",
              file=sys.stderr)
    return key


def _gcs_urls(args) -> tuple[str, ...] | None:
    """``--gcs`` alone: TCP server on 127.0.0.1:5760 + UDP out to 127.0.0.1:14550
    (ArduPilot SITL's links, on loopback only); ``--gcs URL`` (repeatable): exactly those."""
    from autopilot.gcs import DEFAULT_URLS, LinkUrlError, parse_url
    if not args.gcs:
        return None
    urls: list[str] = []
    for u in args.gcs:
        for part in (DEFAULT_URLS if u == "default" else (u,)):
            try:
                parse_url(part)
            except LinkUrlError as e:
                raise CliError(f"--gcs: {e}") from None
            if part not in urls:
                urls.append(part)
    return tuple(urls)


def cmd_run(args) -> int:
    from autopilot.mission.files import MissionFileError
    from autopilot.params import ParamError
    from sim_bridge.scenario import ScenarioError
    from .runner import Session, write_run
    from .summary import format_summary, run_summary

    cfg = _config(args)
    if cfg.log_dir is None:
        cfg.log_dir = Path("runs") / time.strftime(f"%Y%m%d-%H%M%S-seed{cfg.seed}")
    log_dir = cfg.log_dir
    try:
        session = Session(cfg)
    except (MissionFileError, ScenarioError, ParamError, FileNotFoundError) as e:
        raise CliError(str(e)) from None
    except OSError as e:  # a ground-station port that cannot be opened
        raise CliError(f"--gcs: {e}") from None
    if session.gcs is not None:
        g = session.gcs
        for w in g.warnings(cfg.gcs):
            print(f"sitl: warning: {w}", file=sys.stderr, flush=True)
        print(f"sitl: signing {'on (key from ' + g.key_source + ')' if g.signing.active else 'off'}",
              file=sys.stderr, flush=True)
        print(f"sitl: {g.describe()}; waiting for a ground station "
              f"(Ctrl-C to stop)", file=sys.stderr, flush=True)
    try:
        session.run()
    finally:
        session.close()
    if session.gcs is not None:
        print(f"sitl: ground stations: {session.gcs.stats()}", file=sys.stderr, flush=True)
    summary = run_summary(session)
    if session.gcs is not None:
        summary["gcs_signing"] = session.gcs.signing.active
        summary["gcs_refused_messages"] = session.gcs.refused_total
        summary["gcs_refused_by_reason"] = dict(sorted(session.gcs.refused.items()))
    if (summary.get("nav_pos_h_rms_during_fault_m") is not None and session.gcs is None
            and not args.no_okf_replay and "FDI_RADAPT" in session.params.names()
            and int(session.params["FDI_RADAPT"]) != 0):
        # the comparison: the same seed flown again on the plain filter
        from .summary import okf_replay
        print("sitl: replaying the same seed with R adaptation off (FDI_RADAPT=0) for "
              "nav_pos_h_rms_during_fault_okf_m (--no-okf-replay skips it)", file=sys.stderr, flush=True)
        summary["nav_pos_h_rms_during_fault_okf_m"] = okf_replay(cfg)
    write_run(session, summary, log_dir)
    if args.json:
        print(json.dumps(summary, indent=2, sort_keys=True))
    else:
        print(format_summary(summary))
        print(f"{'run folder':>24}: {log_dir}")
    return 0


def cmd_missions(args) -> int:
    from .missions_random import describe, write_random
    if args.seed < 0:
        raise CliError("--seed: must be >= 0")
    try:
        if args.max_time is not None and not args.max_time > 0:
            raise CliError("--max-time: seconds > 0")
        notes = write_random(args.vehicle, args.seed, args.output, args.max_time)
    except OSError as e:
        raise CliError(f"-o: {e}") from None
    print(describe(args.vehicle, args.seed, notes))
    print(f"# written to {args.output}")
    return 0


def cmd_missions_sample(args) -> int:
    """Fly random missions one after the other; a JSON line per flight, then statistics."""
    import json as _json

    from .missions_random import fly_sample, sample_record, sample_statistics
    try:
        lo, hi = (int(x) for x in args.seeds.split("-", 1)) if "-" in args.seeds \
            else (int(args.seeds), int(args.seeds))
    except ValueError:
        raise CliError(f"--seeds: FIRST-LAST or N, got {args.seeds!r}") from None
    if lo < 0 or hi < lo:
        raise CliError(f"--seeds: FIRST-LAST with 0 <= FIRST <= LAST, got {args.seeds!r}")
    if args.max_time is not None and not args.max_time > 0:
        raise CliError("--max-time: seconds > 0")
    out = open(args.jsonl, "a", encoding="utf-8") if args.jsonl else None
    records = []
    try:
        for seed in range(lo, hi + 1):
            rec = sample_record(args.vehicle, seed, args.max_time,
                                fly_sample(args.vehicle, seed, args.max_time))
            records.append(rec)
            line = _json.dumps(rec, sort_keys=True)
            print(line, flush=True)
            if out is not None:
                out.write(line + "\n")
                out.flush()
    finally:
        if out is not None:
            out.close()
    print(sample_statistics(records), file=sys.stderr)
    return 0 if all(r["invariants_passed"] for r in records) else 1


def cmd_params(args) -> int:
    from .params_cli import params_command
    try:
        return params_command(args)
    except (OSError, ValueError) as e:
        raise CliError(str(e)) from None


def cmd_report(args) -> int:
    from .report import make_report
    run_dir = Path(args.run_dir)
    if not (run_dir / "flight.npz").exists() and not (run_dir / "formation.npz").exists():
        raise CliError(f"{run_dir}: no flight.npz (not a run folder)")
    for p in make_report(run_dir):
        print(p)
    return 0


def cmd_bench(args) -> int:
    if args.false_alarms:
        from .bench import run_false_alarms
        res = run_false_alarms(args.flights, args.seconds if args.seconds is not None else 600.0,
                               seed0=args.seed)
        return 1 if res["false_alarms"] else 0
    from .bench import run_bench
    if args.seconds is None:
        args.seconds = 60.0
    if args.profile:
        from .bench import run_profile
        run_profile(min(args.seconds, 30.0), vehicle=args.vehicle)
        return 0
    run_bench(args.seconds, vehicle=args.vehicle, as_json=args.json)
    return 0


def cmd_formation(args) -> int:
    from autopilot.formation import FormationError
    from .formation import run_formation
    log_dir = Path(args.log_dir) if args.log_dir else \
        Path("runs") / time.strftime(f"%Y%m%d-%H%M%S-formation-seed{args.seed}")
    try:
        summary = run_formation(args.file, seed=args.seed, duration_s=args.duration, loss=args.loss,
                                latency_s=args.latency, rate_hz=args.rate, udp=args.udp,
                                gcs=args.gcs, log_dir=log_dir)
    except (FormationError, FileNotFoundError) as e:
        raise CliError(str(e)) from None
    if args.json:
        print(json.dumps(summary, indent=2, sort_keys=True))
    else:
        for k in sorted(summary):
            print(f"{k:>28}: {summary[k]}")
        print(f"{'run folder':>28}: {log_dir}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    from sim_bridge.sensors.params import GPS_PRESETS
    ap = argparse.ArgumentParser(prog="sitl", description="Headless SITL flights: run, report, bench")
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run", help="fly a mission headless and print its summary")
    r.add_argument("--vehicle", default="plane", choices=["plane", "quad"])
    r.add_argument("--airframe", default=None,
                   help="plane: aerosonde (default) or c172p; quad: f450 (default)")
    r.add_argument("--mission", help=f"mission file (.waypoints or .plan), or random:VEHICLE:SEED[:MAX_TIME_S] "
                                     f"(the mission of 'sitl missions random'); default {DEFAULT_MISSION.name}"
                                     f" (quad: {QUAD_DEFAULT_MISSION.name})")
    r.add_argument("--scenario", help="scenario TOML: wind, turbulence, timed fault events")
    r.add_argument("--fence", help="geofence file (MAVProxy 'fence load' formats: QGC WPL 110 or "
                                   "LAT LON lines); replaces a .plan's geoFence")
    r.add_argument("--rally", help="rally point file (MAVProxy 'rally load' formats: QGC WPL 110 or "
                                   "RALLY lines); replaces a .plan's rallyPoints")
    r.add_argument("--wind", help="steady wind SPEED_MPS,FROM_DEG")
    r.add_argument("--turbulence", choices=["none", "light", "moderate", "severe"])
    r.add_argument("--seed", type=int, default=1)
    r.add_argument("--speedup", default=None, help="'max' (default) or a real-time multiple")
    r.add_argument("--duration", type=float, default=None,
                   help="simulated seconds at most (default 1800; with --gcs: until Ctrl-C)")
    r.add_argument("--nav", default="ekf", choices=["ekf", "ukf", "truth"],
                   help="navigation source (truth is a debugging aid)")
    r.add_argument("--gps", default="standard", choices=list(GPS_PRESETS),
                   help="receiver model: standard (u-blox M8/M9 class, default), rtk (ZED-F9P "
                        "RTK fixed: centimetres; the filter flies GPS height), long-horizon "
                        "(the data sheet's metres, wandering at minute rate); the filter's GPS "
                        "parameters are set to match")
    r.add_argument("--home", help="LAT,LON,ALT_M,HEADING_DEG (default: the mission's item 0)")
    r.add_argument("--log-dir", help="run folder (default runs/DATE-TIME-seedN)")
    r.add_argument("--param", action="append", help="NAME=VALUE parameter override (repeatable)")
    r.add_argument("--params", help=".parm file of parameters to load")
    r.add_argument("--json", action="store_true", help="print only the summary JSON on stdout")
    r.add_argument("--no-okf-replay", action="store_true",
                   help="with a sensor fault in the scenario: do not replay the seed with R adaptation "
                        "off for nav_pos_h_rms_during_fault_okf_m")
    r.add_argument("--gcs", action="append", nargs="?", const="default", metavar="URL",
                   help="serve ground stations and wait for one to fly the vehicle: tcpin:HOST:PORT, "
                        "udpout:HOST:PORT, udpin:HOST:PORT (repeatable); alone: "
                        "tcpin:127.0.0.1:5760 + udpout:127.0.0.1:14550 (loopback only; another "
                        "address must be given, e.g. tcpin:0.0.0.0:5760)")
    r.add_argument("--param-store", help="with --gcs: parameters persisted across runs "
                                         "(default sitl-params-VEHICLE.parm here)")
    r.add_argument("--wipe", action="store_true", help="with --gcs: start from the default parameters "
                                                       "and persist nothing; remove the stored signing key")
    r.add_argument("--signing-key", metavar="FILE",
                   help="with --gcs: MAVLink 2 signing key file (first line: a passphrase, as "
                        "MAVProxy's 'signing setup PASSPHRASE', or 64 hex digits); stored beside "
                        "the parameter store")
    r.add_argument("--terrain", metavar="DIR",
                   help="SRTM .hgt tiles (1 or 3 arc-second) for the ground under the vehicle "
                        "and the autopilot's terrain-relative altitudes; default: flat at home "
                        "(python -m tools.terrain_tile DIR writes a hilly tile); 'gcs' (with "
                        "--gcs): the autopilot asks the ground station (TERRAIN_REQUEST)")
    r.set_defaults(func=cmd_run)
    ms = sub.add_parser("missions", help="mission tools: random missions")
    ms_sub = ms.add_subparsers(dest="missions_cmd", required=True)
    mr = ms_sub.add_parser("random", help="write a random valid mission (QGC WPL 110) of a seed")
    mr.add_argument("--vehicle", default="plane", choices=["plane", "quad"])
    mr.add_argument("--seed", type=int, required=True)
    mr.add_argument("-o", "--output", required=True, help="the .waypoints file to write")
    mr.add_argument("--max-time", type=float, default=None,
                    help="estimated still-air flight time to stay under [s] (default: plane 720, quad 420)")
    mr.set_defaults(func=cmd_missions)
    msa = ms_sub.add_parser("sample", help="fly random missions one after the other, each in its own "
                                           "weather; a JSON line per flight, invariant counts and "
                                           "cross-track percentiles at the end (exit 1 if any failed)")
    msa.add_argument("--vehicle", default="plane", choices=["plane", "quad"])
    msa.add_argument("--seeds", required=True, help="FIRST-LAST (inclusive) or N")
    msa.add_argument("--max-time", type=float, default=None,
                     help="shorten each mission to this estimated still-air time [s]")
    msa.add_argument("--jsonl", help="also append the JSON lines to this file")
    msa.set_defaults(func=cmd_missions_sample)
    pp = sub.add_parser("params", help="save or load a .parm file (persistent store or a live vehicle)")
    pp.add_argument("action", choices=["save", "load"])
    pp.add_argument("file")
    pp.add_argument("--vehicle", default="plane", choices=["plane", "quad"])
    pp.add_argument("--param-store", help="the persistent store (default sitl-params-VEHICLE.parm)")
    pp.add_argument("--connect", help="a running vehicle instead, e.g. tcp:127.0.0.1:5760")
    pp.add_argument("--signing-key", metavar="FILE",
                    help="with --connect: sign with this key (the vehicle's --signing-key file)")
    pp.set_defaults(func=cmd_params)
    rp = sub.add_parser("report", help="draw PNG pictures of a run folder")
    rp.add_argument("run_dir")
    rp.set_defaults(func=cmd_report)
    b = sub.add_parser("bench", help="real-time factors and time per block")
    b.add_argument("--seconds", type=float, default=None,
                   help="simulated seconds per measurement (default 60; --false-alarms: per flight, 600)")
    b.add_argument("--vehicle", default="plane", choices=["plane", "quad"])
    b.add_argument("--json", action="store_true",
                   help="every figure (plane, quad, formations) as one JSON object")
    b.add_argument("--profile", action="store_true",
                   help="the full loop (nav ekf) under cProfile: top functions by cumulative time")
    b.add_argument("--false-alarms", action="store_true",
                   help="fault monitor: false alarms over fault-free flights of different seeds")
    b.add_argument("--flights", type=int, default=10, help="--false-alarms: number of flights")
    b.add_argument("--seed", type=int, default=1, help="--false-alarms: seed of the first flight")
    b.set_defaults(func=cmd_bench)
    fm = sub.add_parser("formation", help="fly N vehicles in formation (decentralised over MAVLink)")
    fm.add_argument("file", help="formation TOML (missions/formation_*.toml)")
    fm.add_argument("--seed", type=int, default=1)
    fm.add_argument("--duration", type=float, default=None, help="simulated seconds of formation flight at most")
    fm.add_argument("--loss", type=float, default=None, help="vehicle network: datagram loss probability")
    fm.add_argument("--latency", type=float, default=None, help="vehicle network: delay [s]")
    fm.add_argument("--rate", type=float, default=None, help="position publication rate [Hz]")
    fm.add_argument("--udp", action="store_true", help="vehicle network over loopback UDP sockets")
    fm.add_argument("--gcs", action="store_true",
                    help="quad: a ground-station TCP port per vehicle, 5760 + 10 (id - 1)")
    fm.add_argument("--log-dir", help="run folder (default runs/DATE-TIME-formation-seedN)")
    fm.add_argument("--json", action="store_true", help="print only the summary JSON on stdout")
    fm.set_defaults(func=cmd_formation)
    from .campaign.cli import add_parser as add_campaign_parser
    add_campaign_parser(sub)
    return ap


# options whose value is a comma-separated list of numbers that may start with a minus
# sign (a southern latitude): argparse would take "-41.0,179.95,10,90" for an option
_SIGNED_LIST_OPTIONS = ("--home", "--wind")


def _join_signed_values(argv: list[str]) -> list[str]:
    """``--home -41.0,179.95,10,90`` -> ``--home=-41.0,179.95,10,90``."""
    out: list[str] = []
    i = 0
    while i < len(argv):
        a = argv[i]
        if a in _SIGNED_LIST_OPTIONS and i + 1 < len(argv) and argv[i + 1][:1] == "-" \
                and argv[i + 1][1:2].isdigit():
            out.append(f"{a}={argv[i + 1]}")
            i += 2
            continue
        out.append(a)
        i += 1
    return out


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    args = build_parser().parse_args(_join_signed_values(argv))
    try:
        return args.func(args)
    except CliError as e:
        print(f"sitl: error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        return 130


if __name__ == "__main__":
    sys.exit(main())
