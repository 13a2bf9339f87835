"""Bad input: 30 s of random bytes and random well-formed messages with absurd field
values on the TCP port while a ground station flies the default mission. No exception
escapes (the service counts none, even caught), the mission completes with the
fixed-wing figures intact, and another client keeps receiving telemetry."""
import math
import random
import socket
import threading
import time

from pymavlink.dialects.v20 import ardupilotmega as mav2

from test_gcs_support import Sitl, arm_and_auto, connect

FUZZ_S = 30.0
SPEEDUP = 10
# commands we implement, sent with absurd parameters (each must be refused or harmless)
COMMANDS = (400, 176, 22, 178, 179, 192, 224, 410, 420, 510, 511, 512, 520, 246, 31000, 65535)
ABSURD_F = (math.inf, -math.inf, 1e38, -1e38, 3.4e38, -3.4e38)
PARAM_NAMES = (b"NAVL1_PERIOD", b"RTL_ALT", b"FS_GCS_ENABL", b"FS_GCS_TIMEOUT", b"TRIM_ARSPD",
               b"\xff\xfe\x00garbage", b"X" * 16)


# every message type, less MISSION_CLEAR_ALL and SETUP_SIGNING: with any field values they
# are legitimate requests (clear the mission -- mission_type 255 means "all" -- and, on a
# vehicle without a key, set up signing with that key), not absurd ones
RANDOM_TYPES = [c for c in mav2.mavlink_map.values() if c.msgname not in ("MISSION_CLEAR_ALL",
                                                                            "SETUP_SIGNING")]


def _absurd_value(rng: random.Random, fmt: str, name: str):
    if name in ("target_system",):
        return rng.choice((0, 1, 1, 2, 255))
    if name in ("target_component",):
        return rng.choice((0, 1, 1, 190))
    if fmt in ("f", "d"):
        return rng.choice(ABSURD_F + (math.nan,))
    bits = {"B": 8, "b": 8, "H": 16, "h": 16, "I": 32, "i": 32, "Q": 64, "q": 64}.get(fmt)
    if bits is None:
        return 0
    if fmt.isupper():
        return rng.choice(((1 << bits) - 1, (1 << bits) - 2, (1 << bits) - 1 - rng.randrange(16)))
    return rng.choice((-(1 << (bits - 1)), (1 << (bits - 1)) - 1))


def random_message(rng: random.Random):
    """A well-formed message of a random type with absurd field values."""
    kind = rng.random()
    if kind < 0.25:
        p = [rng.choice(ABSURD_F + (math.nan,)) for _ in range(7)]
        cmd = rng.choice(COMMANDS)
        if cmd == 192:                      # NaN lat/lon means "here" for DO_REPOSITION: not absurd
            p = [rng.choice(ABSURD_F) for _ in range(7)]
        return mav2.MAVLink_command_long_message(rng.choice((0, 1)), rng.choice((0, 1)), cmd, 0, *p)
    if kind < 0.35:
        return mav2.MAVLink_param_set_message(1, 1, rng.choice(PARAM_NAMES),
                                              rng.choice(ABSURD_F + (math.nan,)), rng.choice((9, 6, 255)))
    if kind < 0.45:
        return mav2.MAVLink_mission_count_message(1, 1, rng.choice((65535, 65534, 10000)),
                                                  rng.choice((0, 1, 2, 255)))
    cls = rng.choice(RANDOM_TYPES)
    args = []
    for i, name in enumerate(cls.fieldnames):
        length = cls.array_lengths[cls.orders[i]]
        code = {"float": "f", "double": "d", "uint8_t": "B", "int8_t": "b", "uint16_t": "H",
                "int16_t": "h", "uint32_t": "I", "int32_t": "i", "uint64_t": "Q", "int64_t": "q",
                "char": "c"}.get(cls.fieldtypes[i], "B")
        if code == "c":
            args.append(bytes(rng.randrange(1, 256) for _ in range(max(length, 1))))
        elif length:
            args.append([_absurd_value(rng, code, name) for _ in range(length)])
        else:
            args.append(_absurd_value(rng, code, name))
    return cls(*args)


def fuzz(port: int, seconds: float, counts: dict, seed: int = 11):
    rng = random.Random(seed)
    tx = mav2.MAVLink(None, srcSystem=200, srcComponent=190)
    deadline = time.monotonic() + seconds
    sock = None
    while time.monotonic() < deadline:
        if sock is None or rng.random() < 0.01:
            if sock is not None:
                sock.close()                                   # gone, sometimes mid-frame
                counts["reconnects"] += 1
            sock = socket.create_connection(("127.0.0.1", port))
            sock.setblocking(False)
        try:
            if rng.random() < 0.3:
                sock.send(bytes(rng.randrange(256) for _ in range(rng.randrange(1, 400))))
                counts["noise"] += 1
            else:
                msg = random_message(rng)
                try:
                    buf = msg.pack(tx, force_mavlink1=rng.random() < 0.2)
                except Exception:                              # noqa: BLE001 - unencodable: skip
                    continue
                if rng.random() < 0.1:
                    buf = buf[:rng.randrange(1, len(buf))]     # truncated
                sock.send(buf)
                counts["messages"] += 1
            try:
                while sock.recv(65536):
                    pass
            except (BlockingIOError, OSError):
                pass
        except (BlockingIOError, BrokenPipeError, ConnectionResetError):
            sock.close()
            sock = None
        time.sleep(0.002)
    if sock is not None:
        sock.close()


def test_random_bytes_and_absurd_messages_do_not_disturb_a_mission(tmp_path):
    sitl = Sitl(tmp_path / "run", speedup=str(SPEEDUP))
    counts = {"noise": 0, "messages": 0, "reconnects": 0}
    tele = {"attitude": 0, "seconds": 0.0}
    stop = threading.Event()

    def watcher():                                             # another client, only listening
        m = connect(sitl.url, sysid=251)
        t0 = time.monotonic()
        while not stop.is_set():
            if m.recv_match(type="ATTITUDE", blocking=True, timeout=0.2) is not None:
                tele["attitude"] += 1
        tele["seconds"] = time.monotonic() - t0
        m.close()

    w = threading.Thread(target=watcher, daemon=True)
    w.start()
    f = threading.Thread(target=fuzz, args=(sitl.port, FUZZ_S, counts), daemon=True)
    f.start()
    pilot = connect(sitl.url)
    try:
        arm_and_auto(pilot)
        reached = set()
        deadline = time.monotonic() + 180
        last_hb = 0.0
        complete_at = None
        while time.monotonic() < deadline:
            if time.monotonic() - last_hb > 1.0:               # a ground station's heartbeat
                pilot.mav.heartbeat_send(6, 8, 0, 0, 0)
                last_hb = time.monotonic()
            msg = pilot.recv_match(type="MISSION_ITEM_REACHED", blocking=True, timeout=0.2)
            if msg is not None:
                reached.add(msg.seq)
            if 12 in reached and complete_at is None:
                complete_at = time.monotonic()
            if complete_at and time.monotonic() - complete_at > 6.0 and not f.is_alive():
                break                                          # the loiter over home is established
        f.join(5)
    finally:
        stop.set()
        w.join(5)
        pilot.close()
        summary = sitl.stop()
    stats = sitl.stats()
    print("fuzz:", counts, "service:", stats, "telemetry:", tele)
    assert counts["messages"] > 3000 and counts["noise"] > 1000
    assert stats["errors"] == 0                                # no handler raised, even caught
    assert summary["completed"] is True and not summary["crashed"]
    assert summary["mission_items_reached"] == summary["mission_items_total"] == 12
    assert summary["xtrack_rms_m"] <= 2.0 and summary["xtrack_max_m"] <= 15.0
    assert summary["alt_rms_m"] <= 3.0 and summary["airspeed_rms_mps"] <= 2.0
    # the listener kept its 10 Hz (sim time) ATTITUDE: 10 * SPEEDUP per wall second
    assert tele["attitude"] / tele["seconds"] >= 0.8 * 10 * SPEEDUP
