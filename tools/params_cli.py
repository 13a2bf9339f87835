"""``sitl params save|load FILE``: parameters as ``.parm`` files (``NAME VALUE`` lines, as
ArduPilot and MAVProxy write them).

Without ``--connect`` it works on the persistent parameter store that ``sitl run --gcs``
reads at start and writes on every accepted PARAM_SET: ``save`` writes the store's
values (defaults where the store says nothing) to FILE; ``load`` checks every line of
FILE and, only if all are valid, writes the merged values to the store (atomically).

With ``--connect URL`` it talks to a running vehicle over MAVLink with the parameter
protocol: ``save`` downloads the whole table (PARAM_REQUEST_LIST) and writes it; ``load``
sends a PARAM_SET per line and checks each PARAM_VALUE echo.
"""
from __future__ import annotations

import sys
import time
from pathlib import Path


def _store(args):
    from autopilot.gcs import GCS_PARAMS, load_lenient
    from autopilot.params import ParamStore
    if args.vehicle == "quad":
        from autopilot.vehicle_quad import quad_param_declarations as decls
    else:
        from autopilot.vehicle import plane_param_declarations as decls
    store = ParamStore(list(decls()) + list(GCS_PARAMS))
    path = Path(args.param_store or f"sitl-params-{args.vehicle}.parm")
    if path.exists():
        for problem in load_lenient(store, path)[1]:
            print(f"sitl: {problem} (ignored)", file=sys.stderr)
    return store, path


PARAMS_LINK_ID = 250


def _connect(url: str, key: bytes | None = None):
    """A pymavlink connection; with a signing key, MAVLink 2 (mavutil speaks MAVLink 1
    unless MAVLINK20 is set when the connection is made) and every message signed."""
    import os
    if key is not None:
        os.environ["MAVLINK20"] = "1"
    from pymavlink import mavutil
    m = mavutil.mavlink_connection(url, source_system=255, source_component=190, dialect="ardupilotmega")
    if key is not None:
        # a link id of its own: a ground station signing as 255/190 on link 0 at the same
        # time is another stream (its timestamps would otherwise look like replays)
        m.setup_signing(key, sign_outgoing=True, link_id=PARAMS_LINK_ID)
    hb = m.wait_heartbeat(timeout=10)
    if hb is None:
        raise OSError(f"no heartbeat from {url}")
    return m


def _download(m, timeout_s: float = 20.0) -> dict[str, float]:
    m.mav.param_request_list_send(m.target_system, m.target_component)
    values: dict[str, float] = {}
    count = None
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        msg = m.recv_match(type="PARAM_VALUE", blocking=True, timeout=1.0)
        if msg is None:
            if count is not None and len(values) >= count:
                break
            continue
        values[msg.param_id] = msg.param_value
        count = msg.param_count
        if len(values) >= count:
            break
    if count is None or len(values) < count:
        raise OSError(f"parameter download incomplete: {len(values)} of {count}")
    return values


def _read_parm(path: Path) -> list[tuple[str, float]]:
    out = []
    with open(path, encoding="utf-8") as f:
        for lineno, raw in enumerate(f, 1):
            line = raw.split("#", 1)[0].strip()
            if not line:
                continue
            parts = line.replace(",", " ").split()
            if len(parts) != 2:
                raise ValueError(f"{path}:{lineno}: expected 'NAME VALUE'")
            try:
                out.append((parts[0], float(parts[1])))
            except ValueError:
                raise ValueError(f"{path}:{lineno}: {parts[0]}: not a number") from None
    return out


def params_command(args) -> int:
    path = Path(args.file)
    if args.connect is None:
        store, store_path = _store(args)
        if args.action == "save":
            store.save(path)
            print(f"{len(store)} parameters -> {path}")
        else:
            names = store.load(path)      # all lines checked before any value changes
            store.save(store_path)        # atomic
            print(f"{len(names)} parameters from {path} -> {store_path}")
        return 0
    key = None
    if getattr(args, "signing_key", None) is not None:
        from autopilot.link.signing import read_key_file
        key = read_key_file(args.signing_key)       # KeyFileError is a ValueError
    m = _connect(args.connect, key)
    try:
        if args.action == "save":
            values = _download(m)
            tmp = path.with_suffix(path.suffix + ".tmp")
            with open(tmp, "w", encoding="ascii") as f:
                for name in sorted(values):
                    v = values[name]
                    f.write(f"{name:<16} {int(v) if v == int(v) else repr(v)}\n")
            tmp.replace(path)
            print(f"{len(values)} parameters -> {path}")
            return 0
        refused = 0
        for name, value in _read_parm(path):
            m.mav.param_set_send(m.target_system, m.target_component, name.encode(), value,
                                 9)  # MAV_PARAM_TYPE_REAL32
            echo = None
            deadline = time.monotonic() + 3.0
            while time.monotonic() < deadline:
                msg = m.recv_match(type="PARAM_VALUE", blocking=True, timeout=0.5)
                if msg is not None and msg.param_id == name:
                    echo = msg
                    break
            if echo is None or abs(echo.param_value - value) > 1e-6 * max(1.0, abs(value)):
                refused += 1
                print(f"sitl: {name} = {value:g} refused", file=sys.stderr)
        print(f"{path}: sent, {refused} refused")
        return 1 if refused else 0
    finally:
        m.close()
