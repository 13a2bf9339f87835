"""MAVLink 2 message signing (autopilot/link/signing.py, autopilot/gcs/service.py).

Frame level, against pymavlink's own signing: our signatures are accepted by pymavlink
with the key, pymavlink's by us; wrong key, unsigned, replayed and too old frames are
refused for their reasons; RADIO_STATUS passes unsigned. Over real sockets, with a
``sitl run --gcs`` process: pymavlink clients (``MAVLINK20=1`` and ``setup_signing``, as
a user would) with the right key, a wrong key, no key, and a captured signed
COMMAND_LONG replayed; the key survives a restart, is removed by an all-zero
SETUP_SIGNING over a signed link only, and by ``--wipe``. MAVProxy (``signing setup``)
flies a mission while another MAVProxy without the key changes nothing.
"""
import hashlib
import os
import socket
import stat
import subprocess
import sys
import time

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mav2

from autopilot.link.codec import Codec
from autopilot.link.signing import (BAD_SIGNATURE, ONE_MINUTE, REPLAY, TOO_OLD, UNSIGNED, KeyStore,
                                    Signing, clock_timestamp, passphrase_key, read_key_file)
from test_gcs_support import REPO, Sitl, wait_for

KEY = passphrase_key("correct horse battery staple")
WRONG = passphrase_key("wrong horse")
NOW = 1.75e9                                   # a fixed Unix time for the frame-level tests


def _pymav(key, link_id=0, ts=None, sysid=255):
    m = mav2.MAVLink(None, srcSystem=sysid, srcComponent=190)
    if key is not None:
        m.signing.secret_key = key
        m.signing.link_id = link_id
        m.signing.timestamp = clock_timestamp(NOW) if ts is None else ts
        m.signing.sign_outgoing = True
    return m


def _frame(m, msg=None):
    msg = msg or mav2.MAVLink_command_long_message(1, 1, 400, 0, 1, 0, 0, 0, 0, 0, 0)
    return bytes(msg.pack(m))


def test_signatures_agree_with_pymavlink_both_ways():
    ours = Signing(KEY, clock_timestamp(NOW), clock=lambda: NOW)
    c = Codec(1, 1)
    c.signing, c.link_id = ours, 7
    buf = c.encode(mav2.MAVLink_heartbeat_message(1, 3, 0, 0, 0, 3))
    assert len(buf) == 12 + 9 + 13 and buf[2] & 1 and buf[-13] == 7
    theirs = _pymav(KEY)
    msg = theirs.decode(bytearray(buf))                          # raises on a bad signature
    assert msg.get_type() == "HEARTBEAT" and msg._signed
    with pytest.raises(mav2.MAVError):
        _pymav(WRONG).decode(bytearray(buf))
    # pymavlink's signed frame is accepted once, then is a replay
    f = _frame(_pymav(KEY))
    assert ours.check(f) is None
    assert ours.check(f) == REPLAY
    # the logged form: same message, no signature, valid CRC
    plain = Codec.unsigned(buf)
    assert len(plain) == len(buf) - 13 and not plain[2] & 1
    assert Codec(9, 9).decode(plain)[0].get_type() == "HEARTBEAT"


def test_wrong_key_unsigned_old_and_radio_status():
    s = Signing(KEY, clock_timestamp(NOW), clock=lambda: NOW)
    assert s.check(_frame(_pymav(WRONG))) == BAD_SIGNATURE
    assert s.check(_frame(_pymav(None))) == UNSIGNED
    v1 = bytes(mav2.MAVLink_command_long_message(1, 1, 400, 0, 1, 0, 0, 0, 0, 0, 0)
               .pack(_pymav(None), force_mavlink1=True))
    assert s.check(v1) == UNSIGNED
    radio = _frame(_pymav(None), mav2.MAVLink_radio_status_message(200, 190, 50, 40, 30, 0, 0))
    assert s.check(radio) is None                                # telemetry radios: unsigned
    # a new stream more than a minute behind our timestamp: too old
    assert s.check(_frame(_pymav(KEY, link_id=3, ts=s.timestamp - ONE_MINUTE - 10))) == TOO_OLD
    assert s.check(_frame(_pymav(KEY, link_id=4, ts=s.timestamp - ONE_MINUTE + 10))) is None
    # streams are (sysid, compid, link id): the same timestamp on another link is new
    t = s.timestamp + 100
    assert s.check(_frame(_pymav(KEY, link_id=5, ts=t))) is None
    assert s.check(_frame(_pymav(KEY, link_id=6, ts=t))) is None
    assert s.check(_frame(_pymav(KEY, link_id=5, ts=t))) == REPLAY
    # an accepted timestamp ahead of ours moves ours on; a refused one does not
    s.check(_frame(_pymav(WRONG, link_id=8, ts=t + 10**9)))
    assert s.timestamp == t
    s.check(_frame(_pymav(KEY, link_id=8, ts=t + 10**6)))
    assert s.timestamp == t + 10**6


def test_restart_timestamp_and_key_store(tmp_path):
    store = KeyStore(tmp_path / "v.signing")
    store.save(KEY, 5_000)
    assert stat.S_IMODE(os.stat(store.path).st_mode) == 0o600
    key, ts = store.load()
    assert key == KEY and ts == 5_000
    s = Signing(clock=lambda: 0.0)                               # a clock before 2015
    s.restore(key, ts)
    assert s.timestamp == 5_000 + ONE_MINUTE + 1
    # a frame signed before the restart (timestamp <= stored) is too old, a later one is not
    assert s.check(_frame(_pymav(KEY, ts=ts))) == TOO_OLD
    assert s.check(_frame(_pymav(KEY, ts=ts + 1))) is None
    assert store.remove() and store.load() is None
    # key files: a passphrase as MAVProxy hashes it, or 64 hex digits
    (tmp_path / "p").write_text("correct horse battery staple\n")
    (tmp_path / "h").write_text(KEY.hex() + "\n")
    (tmp_path / "z").write_text("00" * 32 + "\n")
    assert read_key_file(tmp_path / "p") == KEY == read_key_file(tmp_path / "h")
    assert KEY == hashlib.sha256(b"correct horse battery staple").digest()
    with pytest.raises(ValueError):
        read_key_file(tmp_path / "z")


def test_setup_signing_refused_while_armed_and_with_an_impossible_timestamp():
    """The class of SETUP_SIGNING a vehicle must not obey: in flight (ArduPilot refuses
    it armed), or with an initial timestamp the 48-bit signature cannot carry (it would
    overflow every signature after it). Refused with a STATUSTEXT; the key unchanged."""
    from test_gcs_protocol import make_core, take, wire
    core, v, _, _ = make_core()
    core.signing = Signing(clock=lambda: NOW)
    changes = []
    core.on_signing_change = lambda: changes.append(core.signing.key)
    for ts in (2**48, 2**64 - 1):
        core.receive(1, wire(mav2.MAVLink_setup_signing_message(1, 1, list(KEY), ts)), 0)
        assert [m.text for m in take(core, kind="STATUSTEXT")] == ["Signing: initial timestamp out of range"]
    assert not core.signing.active and changes == []
    core.receive(1, wire(mav2.MAVLink_setup_signing_message(1, 1, list(KEY), 2**48 - 1)), 0)
    assert core.signing.key == KEY and changes == [KEY] and core.signing.timestamp == 2**48 - 1
    assert [m.text for m in take(core, kind="STATUSTEXT")] == ["Signing on: key set"]
    c = Codec(1, 1)
    c.signing = core.signing
    assert _pymav(KEY, ts=0).decode(bytearray(c.encode(mav2.MAVLink_heartbeat_message(1, 3, 0, 0, 0, 3))))
    v.armed = True
    core.receive(1, wire(mav2.MAVLink_setup_signing_message(1, 1, [0] * 32, 0)), 0)
    assert [m.text for m in take(core, kind="STATUSTEXT")] == ["Won't setup signing when armed"]
    assert core.signing.key == KEY and changes == [KEY]
    assert core.errors == 0


# ----------------------------------------------------------------- over sockets ---
def _client(url, key=None, sysid=255, link_id=0, heartbeat=True):
    """pymavlink as a user sets it up: MAVLINK20=1 (mavutil speaks MAVLink 1 without it)
    and ``setup_signing``; the environment is restored for the other tests."""
    from pymavlink import mavutil
    old = os.environ.get("MAVLINK20")
    os.environ["MAVLINK20"] = "1"
    try:
        m = mavutil.mavlink_connection(url, source_system=sysid, source_component=190,
                                       dialect="ardupilotmega")
    finally:
        if old is None:
            del os.environ["MAVLINK20"]
        else:
            os.environ["MAVLINK20"] = old
    if key is not None:
        m.setup_signing(key, sign_outgoing=True, link_id=link_id)
    if heartbeat:
        assert m.wait_heartbeat(timeout=15) is not None
    return m


def _param(m, name, timeout_s=2.0):
    m.mav.param_request_read_send(1, 1, name.encode(), -1)
    msg = wait_for(m, "PARAM_VALUE", timeout_s, lambda p: p.param_id == name)
    return None if msg is None else msg.param_value


class RawTcp:
    """A socket that sends exact bytes and parses what comes back (no signing state)."""

    def __init__(self, port):
        self.sock = socket.create_connection(("127.0.0.1", port))
        self.sock.settimeout(0.2)
        self.mav = mav2.MAVLink(None)
        self.mav.robust_parsing = True

    def acks(self, seconds):
        out = []
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            try:
                data = self.sock.recv(65536)
            except socket.timeout:
                continue
            for msg in self.mav.parse_buffer(data) or []:
                if msg.get_type() == "COMMAND_ACK":
                    out.append(msg)
        return out


def test_signed_clients_only_over_sockets_restart_and_removal(tmp_path):
    keyfile = tmp_path / "key.txt"
    keyfile.write_text("correct horse battery staple\n")
    keyfile.chmod(0o600)
    store = tmp_path / "store.parm"
    sitl = Sitl(tmp_path / "run1", "--signing-key", str(keyfile), speedup="1", store=store,
                gcs=("tcpin:127.0.0.1:0", "udpin:127.0.0.1:0"))
    t_start = time.monotonic()
    try:
        # udpin answers the last sender it accepted: an unsigned datagram cannot steer it
        import re
        udp_port = int(re.search(r"udpin 127\.0\.0\.1:(\d+)", "".join(sitl.err)).group(1))
        u = _client(f"udpout:127.0.0.1:{udp_port}", KEY, sysid=246, heartbeat=False)
        u.mav.heartbeat_send(6, 8, 0, 0, 0)
        assert wait_for(u, "ATTITUDE", 5.0) is not None
        intruder = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        intruder.bind(("127.0.0.1", 0))
        intruder.settimeout(0.5)
        intruder.sendto(_frame(_pymav(None, sysid=244), mav2.MAVLink_heartbeat_message(6, 8, 0, 0, 0, 3)),
                        ("127.0.0.1", udp_port))
        time.sleep(0.5)
        while u.recv_match(blocking=False) is not None:
            pass
        assert wait_for(u, "ATTITUDE", 2.0) is not None
        with pytest.raises(socket.timeout):
            intruder.recv(65536)
        intruder.close()
        u.close()
        assert "signing on (key from --signing-key)" in "".join(sitl.err)
        key_file = tmp_path / "store.signing"
        assert stat.S_IMODE(os.stat(key_file).st_mode) == 0o600
        good = _client(sitl.url, KEY)
        assert _param(good, "NAVL1_PERIOD") is not None
        # wrong key, unsigned MAVLink 2, unsigned MAVLink 1: no reply, no change
        for kw in ({"key": WRONG, "sysid": 250}, {"sysid": 251}):
            bad = _client(sitl.url, heartbeat=False, **kw)   # a wrong key drops our frames
            time.sleep(0.5)
            bad.mav.param_set_send(1, 1, b"NAVL1_PERIOD", 33.0, 9)
            bad.mav.command_long_send(1, 1, 400, 0, 1, 0, 0, 0, 0, 0, 0)
            assert wait_for(bad, "COMMAND_ACK", 2.0) is None
            assert wait_for(bad, "PARAM_VALUE", 0.5) is None
            bad.close()
        v1 = RawTcp(sitl.port)
        v1.sock.sendall(bytes(mav2.MAVLink_command_long_message(1, 1, 400, 0, 1, 0, 0, 0, 0, 0, 0)
                              .pack(mav2.MAVLink(None, 249, 190), force_mavlink1=True)))
        assert v1.acks(1.5) == []
        burst = _frame(_pymav(None)) * 1000                      # 1000 refusals at once
        v1.sock.sendall(burst)
        assert _param(good, "NAVL1_PERIOD") != 33.0
        hb = wait_for(good, "HEARTBEAT", 3, lambda h: h.get_srcSystem() == 1)
        assert not hb.base_mode & 128                            # not armed
        # a captured signed COMMAND_LONG: answered once, ignored when replayed later,
        # on the same connection and on another
        cap = _pymav(KEY, link_id=9, sysid=252)
        cap.signing.timestamp = clock_timestamp(time.time())
        frame = _frame(cap, mav2.MAVLink_command_long_message(1, 1, 512, 0, 242, 0, 0, 0, 0, 0, 0))
        a = RawTcp(sitl.port)
        a.sock.sendall(frame)
        assert [k.command for k in a.acks(1.5)] == [512]
        time.sleep(1.0)
        a.sock.sendall(frame)
        b = RawTcp(sitl.port)
        b.sock.sendall(frame)
        assert a.acks(1.5) == [] and b.acks(0.5) == []
        # unsigned all-zero SETUP_SIGNING: refused, the key stays
        unsigned = _client(sitl.url, sysid=248)
        unsigned.mav.setup_signing_send(1, 1, [0] * 32, 0)
        time.sleep(1.0)
        assert key_file.exists()
        unsigned.close()
        good.close()
    finally:
        summary = sitl.stop()
    session_s = time.monotonic() - t_start
    assert summary["gcs_signing"] is True
    reasons = summary["gcs_refused_by_reason"]
    assert reasons.get("bad signature", 0) >= 2 and reasons.get("unsigned", 0) >= 1004
    assert reasons.get("replay", 0) == 2
    assert summary["gcs_refused_messages"] == sum(reasons.values())
    assert "messages refused" in "".join(sitl.err)
    # the refusals were announced, at most once every 10 s; the log holds no signature
    from pymavlink import mavutil
    log = mavutil.mavlink_connection(str(tmp_path / "run1" / "gcs.tlog"), dialect="ardupilotmega")
    said, signed = [], 0
    while (msg := log.recv_match()) is not None:
        signed += bool(msg.get_msgbuf()[0] == 0xFD and msg.get_msgbuf()[2] & 1)
        if msg.get_type() == "STATUSTEXT" and msg.text.startswith("Signing: refused"):
            said.append(int(msg.text.split()[2]))
    assert 1 <= len(said) <= 1 + session_s / 10.0 and sum(said) <= summary["gcs_refused_messages"]
    assert signed == 0

    # restart: the key comes from the store; unsigned still refused
    sitl = Sitl(tmp_path / "run2", speedup="1", store=store)
    try:
        assert f"signing on (key from {key_file})" in "".join(sitl.err)
        plain = _client(sitl.url, sysid=247)
        assert _param(plain, "NAVL1_PERIOD") is None
        good = _client(sitl.url, KEY)
        assert _param(good, "NAVL1_PERIOD") is not None
        out = tmp_path / "saved.parm"                            # our own client signs too
        r = subprocess.run([sys.executable, "-m", "tools.sitl", "params", "save", str(out),
                            "--connect", sitl.url, "--signing-key", str(keyfile)],
                           cwd=REPO, capture_output=True, text=True, timeout=60)
        assert r.returncode == 0, r.stderr
        assert "NAVL1_PERIOD" in out.read_text()
        good.mav.setup_signing_send(1, 1, [0] * 32, 0)          # signed: removes the key
        good.disable_signing()                                   # as MAVProxy's 'signing remove'
        assert wait_for(good, "STATUSTEXT", 5, lambda s: "Signing off" in s.text) is not None
        assert not key_file.exists()
        assert _param(plain, "NAVL1_PERIOD", 3.0) is not None   # unsigned accepted again
        plain.close()
        good.close()
    finally:
        summary = sitl.stop()
    assert summary["gcs_signing"] is False

    # --wipe removes a stored key
    KeyStore(key_file).save(KEY, 0)
    r = subprocess.run([sys.executable, "-m", "tools.sitl", "run", "--gcs", "tcpin:127.0.0.1:0",
                        "--param-store", str(store), "--wipe", "--duration", "0.5", "--json",
                        "--log-dir", str(tmp_path / "run3")],
                       cwd=REPO, capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    assert "signing key" in r.stderr and "removed" in r.stderr and not key_file.exists()


# ---------------------------------------------------------------------- MAVProxy ---
def _mission_count(m) -> int | None:
    m.mav.mission_request_list_send(1, 1, 0)
    msg = wait_for(m, "MISSION_COUNT", 3.0)
    if msg is not None:
        m.mav.mission_ack_send(1, 1, 0, 0)
    return None if msg is None else msg.count


def test_mavproxy_sets_up_signing_and_flies_while_one_without_the_key_changes_nothing(tmp_path):
    """MAVProxy A runs ``signing setup PASSPHRASE`` over the wire; MAVProxy B, without
    the key, then tries to set a parameter, upload another mission, arm, switch to AUTO
    and inject a GPS failure; the vehicle's state (checked by a signed pymavlink client)
    is unchanged. Then A -- whose next stage script the test writes only now -- loads the
    mission, sets a parameter, arms and flies it to the end. (Its mission is the default
    mission's take-off, speed change and first three waypoints, then RTL: a mission other
    than the one on the vehicle, so its upload is seen to take, and a third of the default
    mission's flight; test_gcs_mavproxy.py flies the whole default mission, its DO_JUMP
    included, with MAVProxy unsigned.)"""
    from test_gcs_mavproxy import MavProxy
    default = (REPO / "missions" / "default.waypoints").read_text()
    lines = default.splitlines()
    (tmp_path / "mission.waypoints").write_text("\n".join(lines[:7] + [lines[-1].replace("12\t", "6\t", 1)])
                                                + "\n")
    last = 6                                             # RTL
    (tmp_path / "other.waypoints").write_text("\n".join(default.splitlines()[:5]) + "\n")
    (tmp_path / "a1.scr").write_text("signing setup sesame-7\nrepeat clean\nrepeat add 2 script a2.scr\n")
    (tmp_path / "b.scr").write_text("param set NAVL1_PERIOD 25\nwp load other.waypoints\narm throttle\n"
                                    "mode AUTO\nlong INJECT_FAILURE 4 1\n")
    a2 = ("wp load mission.waypoints\nparam set NAVL1_PERIOD 18.5\nrepeat clean\n"
          "repeat add 2 script a3.scr\n")
    (tmp_path / "a3.scr").write_text("mode AUTO\narm throttle\n")
    key = passphrase_key("sesame-7")
    sitl = Sitl(tmp_path / "run", speedup="max")
    watch = _client(sitl.url, sysid=250)                 # listens only: needs no key
    a = MavProxy(sitl.url, tmp_path, "--daemon", "--non-interactive",
                 "--default-modules=wp,param,mode,arm,cmdlong,misc,signing",
                 "--cmd", "repeat add 3 script a1.scr")
    b = None
    reached = set()
    try:
        assert wait_for(watch, "STATUSTEXT", 30, lambda s: "Signing on" in s.text) is not None
        s = _client(sitl.url, key, sysid=245)
        before = (_param(s, "NAVL1_PERIOD"), _mission_count(s))
        assert before[0] is not None and before[1] == 13
        b = MavProxy(sitl.url, tmp_path, "--daemon", "--non-interactive",
                     "--default-modules=wp,param,mode,arm,cmdlong,misc",
                     "--cmd", "repeat add 2 script b.scr")
        b.expect(r"Running script b\.scr", 20)
        b.expect(r"Running script b\.scr", 20)         # twice: every attempt made at least once
        time.sleep(2.0)
        b.close()
        after = (_param(s, "NAVL1_PERIOD"), _mission_count(s))
        hb = wait_for(s, "HEARTBEAT", 3, lambda h: h.get_srcSystem() == 1)
        assert after == before and after[0] != 25.0
        assert not hb.base_mode & 128 and hb.custom_mode == 0          # disarmed, MANUAL
        assert not any("ACCEPTED" in ln for ln in b.log), "".join(b.log[-20:])
        # now A flies
        (tmp_path / "a2.scr").write_text(a2)
        deadline = time.monotonic() + 150
        while time.monotonic() < deadline and last not in reached:
            msg = watch.recv_match(type="MISSION_ITEM_REACHED", blocking=True, timeout=0.2)
            if msg is not None:
                reached.add(msg.seq)
        assert _param(s, "NAVL1_PERIOD") == 18.5
        assert _mission_count(s) == last + 1                           # A's mission, home first
        s.close()
    finally:
        a.close()
        if b is not None:
            b.close()
        watch.close()
        summary = sitl.stop()
    assert set(range(1, last + 1)) <= reached
    assert summary["gcs_signing"] is True and summary["mission_items_reached"] >= last
    assert summary["faults_injected"] == []                            # B's failure never relayed
    assert summary["gcs_refused_by_reason"].get("unsigned", 0) >= 5     # B's attempts, refused


# ------------------------------------------------------------------- campaign ---
@pytest.mark.skipif(not os.environ.get("FUZZ_SIGNING"), reason="campaign: FUZZ_SIGNING=1 (about 2 min)")
def test_campaign_the_fuzz_test_with_signing_on(tmp_path):
    """test_gcs_fuzz.py's flight with a signing key: the pilot signs; the fuzzer signs
    half of its absurd messages with the key (a trusted but broken ground station) and
    sends the rest unsigned, truncated or as noise. The same figures must hold."""
    import random
    import threading
    from test_gcs_fuzz import FUZZ_S, SPEEDUP, random_message
    keyfile = tmp_path / "key"
    keyfile.write_text(KEY.hex() + "\n")
    keyfile.chmod(0o600)
    sitl = Sitl(tmp_path / "run", "--signing-key", str(keyfile), speedup=str(SPEEDUP))
    counts = {"signed": 0, "unsigned": 0, "noise": 0}
    tele = {"attitude": 0, "seconds": 0.0}
    stop = threading.Event()

    def fuzzer():
        rng = random.Random(11)
        signed = _pymav(KEY, link_id=3, ts=clock_timestamp(time.time()), sysid=200)
        plain = _pymav(None, sysid=201)
        sock = socket.create_connection(("127.0.0.1", sitl.port))
        sock.setblocking(False)
        deadline = time.monotonic() + FUZZ_S
        while time.monotonic() < deadline:
            try:
                if rng.random() < 0.2:
                    sock.send(bytes(rng.randrange(256) for _ in range(rng.randrange(1, 400))))
                    counts["noise"] += 1
                else:
                    msg = random_message(rng)
                    if msg.get_type() == "SETUP_SIGNING":
                        continue                    # a real request to change the key
                    sign = rng.random() < 0.5
                    try:
                        buf = bytes(msg.pack(signed if sign else plain))
                    except Exception:                                # noqa: BLE001
                        continue
                    if rng.random() < 0.05:
                        buf = buf[:rng.randrange(1, len(buf))]
                    sock.send(buf)
                    counts["signed" if sign else "unsigned"] += 1
                try:
                    while sock.recv(65536):
                        pass
                except (BlockingIOError, OSError):
                    pass
            except (BlockingIOError, BrokenPipeError, ConnectionResetError):
                pass
            time.sleep(0.002)
        sock.close()

    def watcher():
        m = _client(sitl.url, sysid=251)
        t0 = time.monotonic()
        while not stop.is_set():
            if m.recv_match(type="ATTITUDE", blocking=True, timeout=0.2) is not None:
                tele["attitude"] += 1
        tele["seconds"] = time.monotonic() - t0
        m.close()

    w = threading.Thread(target=watcher, daemon=True)
    w.start()
    f = threading.Thread(target=fuzzer, daemon=True)
    f.start()
    from test_gcs_support import arm_and_auto
    pilot = _client(sitl.url, KEY)
    try:
        arm_and_auto(pilot)
        reached, last_hb, complete_at = set(), 0.0, None
        deadline = time.monotonic() + 180
        while time.monotonic() < deadline:
            if time.monotonic() - last_hb > 1.0:
                pilot.mav.heartbeat_send(6, 8, 0, 0, 0)
                last_hb = time.monotonic()
            msg = pilot.recv_match(type="MISSION_ITEM_REACHED", blocking=True, timeout=0.2)
            if msg is not None:
                reached.add(msg.seq)
            if 12 in reached and complete_at is None:
                complete_at = time.monotonic()
            if complete_at and time.monotonic() - complete_at > 6.0 and not f.is_alive():
                break
        f.join(5)
    finally:
        stop.set()
        w.join(5)
        pilot.close()
        summary = sitl.stop()
    stats = sitl.stats()
    print("fuzz with signing:", counts, "service:", stats, "refused:", summary["gcs_refused_by_reason"],
          "telemetry:", tele, {k: summary[k] for k in ("xtrack_rms_m", "xtrack_max_m", "alt_rms_m",
                                                       "airspeed_rms_mps")})
    assert counts["signed"] > 1000 and counts["unsigned"] > 1000
    assert stats["errors"] == 0
    assert summary["gcs_refused_by_reason"].get("unsigned", 0) > 500
    assert summary["completed"] is True and not summary["crashed"]
    assert summary["mission_items_reached"] == summary["mission_items_total"] == 12
    assert summary["xtrack_rms_m"] <= 2.0 and summary["xtrack_max_m"] <= 15.0
    assert summary["alt_rms_m"] <= 3.0 and summary["airspeed_rms_mps"] <= 2.0
    assert tele["attitude"] / tele["seconds"] >= 0.8 * 10 * SPEEDUP
