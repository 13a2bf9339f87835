"""Ground-station links over real sockets: several clients, rates in real time, MAVLink 1,
UDP in and out, garbage and disconnects, the .tlog, parameter persistence, Ctrl-C.

One ``sitl run --gcs`` process at real time (``--speedup 1``) serves the rate tests."""
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
from pymavlink.dialects.v10 import ardupilotmega as mav1
from pymavlink.dialects.v20 import ardupilotmega as mav2

from test_gcs_support import REPO, Sitl, command, connect, wait_for


@pytest.fixture(scope="module")
def realtime(tmp_path_factory):
    d = tmp_path_factory.mktemp("rt")
    s = Sitl(d / "run", speedup="1", gcs=("tcpin:127.0.0.1:0", "udpin:127.0.0.1:0"))
    yield s
    s.kill()


def _count_attitude(url, seconds, result, key, interval_us=None, start=None):
    m = connect(url)
    if interval_us:
        ack = command(m, 511, mav2.MAVLINK_MSG_ID_ATTITUDE, interval_us)
        assert ack is not None and ack.result == 0
    start.wait()
    t0 = time.monotonic()
    while time.monotonic() - t0 < 1.0:                      # settle
        m.recv_match(blocking=True, timeout=0.1)
    n = 0
    t0 = time.monotonic()
    while time.monotonic() - t0 < seconds:
        msg = m.recv_match(type="ATTITUDE", blocking=True, timeout=0.1)
        if msg is not None:
            n += 1
    result[key] = n / (time.monotonic() - t0)
    m.close()


def test_three_clients_get_attitude_at_their_configured_rates_in_real_time(realtime):
    results = {}
    start = threading.Event()
    threads = [threading.Thread(target=_count_attitude, args=(realtime.url, 5.0, results, k, iv, start))
               for k, iv in (("default", None), ("fast", 40_000), ("slow", 200_000))]
    for t in threads:
        t.start()
    time.sleep(3.0)
    start.set()
    for t in threads:
        t.join(30)
    assert results["default"] == pytest.approx(10.0, rel=0.10)   # the default 10 Hz
    assert results["fast"] == pytest.approx(25.0, rel=0.10)      # SET_MESSAGE_INTERVAL 40 ms
    assert results["slow"] == pytest.approx(5.0, rel=0.10)       # SET_MESSAGE_INTERVAL 200 ms
    print("ATTITUDE rates (Hz):", results)


def test_garbage_and_disconnects_do_not_disturb_another_client(realtime):
    good = connect(realtime.url)
    bad = []
    for k in range(5):
        s = socket.create_connection(("127.0.0.1", realtime.port))
        s.sendall(bytes(range(256)) * 20 + b"\xfd\xff\x00" * 300)   # noise and broken frames
        if k % 2:
            s.close()                                               # gone mid-stream
        else:
            bad.append(s)
    t0 = time.monotonic()
    n = 0
    while time.monotonic() - t0 < 2.0:
        if good.recv_match(type="ATTITUDE", blocking=True, timeout=0.2) is not None:
            n += 1
    assert n >= 15
    ack = command(good, 520, 1)
    assert ack is not None and ack.result == 0
    for s in bad:
        s.close()
    good.close()


def test_a_command_to_another_system_is_ignored_and_target_0_is_answered(realtime):
    m = connect(realtime.url)
    assert command(m, 520, 1, target=(42, 1), timeout_s=1.5) is None
    ack = command(m, 520, 1, target=(0, 0))
    assert ack is not None and ack.result == 0
    m.close()


def test_a_mavlink1_client_is_understood_and_answered_in_mavlink1(realtime):
    s = socket.create_connection(("127.0.0.1", realtime.port))
    s.settimeout(0.5)
    tx = mav1.MAVLink(None, srcSystem=250, srcComponent=190)
    rx = mav1.MAVLink(None)
    rx.robust_parsing = True
    s.sendall(tx.heartbeat_encode(6, 8, 0, 0, 0).pack(tx))
    s.sendall(tx.command_long_encode(1, 1, 520, 0, 1, 0, 0, 0, 0, 0, 0).pack(tx))
    got = []
    deadline = time.monotonic() + 5.0
    while time.monotonic() < deadline and not {"AUTOPILOT_VERSION", "HEARTBEAT"} <= {m.get_type() for m in got}:
        try:
            data = s.recv(65536)
        except socket.timeout:
            continue
        for m in rx.parse_buffer(data) or []:
            got.append(m)
    kinds = {m.get_type() for m in got}
    assert {"COMMAND_ACK", "AUTOPILOT_VERSION"} <= kinds
    assert "HEARTBEAT" in kinds
    # the streams a TCP server starts at the connection may go out in MAVLink 2 before
    # the client's first frame is read; from the first
    # MAVLink 1 frame on, every frame is MAVLink 1, the replies among them
    first = next(i for i, m in enumerate(got) if m.get_msgbuf()[0] == 0xFE)
    assert all(m.get_msgbuf()[0] == 0xFE for m in got[first:])
    assert {"COMMAND_ACK", "AUTOPILOT_VERSION"} <= {m.get_type() for m in got[first:]}
    s.close()


def test_udpin_answers_whoever_speaks_to_it(realtime):
    from pymavlink import mavutil
    m = mavutil.mavlink_connection(f"udpout:127.0.0.1:{_udpin_port(realtime)}", source_system=254,
                                   dialect="ardupilotmega")
    m.mav.heartbeat_send(6, 8, 0, 0, 0)                # a ground station says hello
    assert wait_for(m, "ATTITUDE", 5.0) is not None
    m.close()


def _udpin_port(sitl):
    import re
    text = "".join(sitl.err)
    return int(re.search(r"udpin 127\.0\.0\.1:(\d+)", text).group(1))


def test_udpout_sends_heartbeats_then_streams_once_the_ground_station_answers(tmp_path):
    rx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    rx.bind(("127.0.0.1", 0))
    rx.settimeout(0.5)
    port = rx.getsockname()[1]
    s = Sitl(tmp_path / "run", gcs=("tcpin:127.0.0.1:0", f"udpout:127.0.0.1:{port}"), speedup="1")
    try:
        p = mav2.MAVLink(None)
        p.robust_parsing = True
        kinds, src = set(), None
        deadline = time.monotonic() + 20.0
        first = None
        while time.monotonic() < deadline and (first is None or time.monotonic() - first < 2.5):
            try:
                data, src = rx.recvfrom(65536)
            except socket.timeout:
                continue
            kinds |= {m.get_type() for m in p.parse_buffer(data) or []}
            first = first or time.monotonic()
        assert kinds == {"HEARTBEAT"}                     # nobody has answered yet
        tx = mav2.MAVLink(None, srcSystem=255, srcComponent=190)
        rx.sendto(tx.heartbeat_encode(6, 8, 0, 0, 0).pack(tx), src)
        deadline = time.monotonic() + 3.0
        while time.monotonic() < deadline and "ATTITUDE" not in kinds:
            try:
                data, _ = rx.recvfrom(65536)
            except socket.timeout:
                continue
            kinds |= {m.get_type() for m in p.parse_buffer(data) or []}
        assert "ATTITUDE" in kinds
    finally:
        s.kill()
        rx.close()


def test_params_persist_across_restarts_and_ctrl_c_writes_a_readable_tlog(tmp_path):
    store = tmp_path / "store.parm"
    s = Sitl(tmp_path / "run1", store=store)
    m = connect(s.url)
    m.mav.param_set_send(1, 1, b"NAVL1_PERIOD", 19.25, 9)
    echo = wait_for(m, "PARAM_VALUE", 5.0, lambda p: p.param_id == "NAVL1_PERIOD")
    assert echo.param_value == 19.25
    m.mav.param_set_send(1, 1, b"NAVL1_PERIOD", 500.0, 9)           # out of range
    echo = wait_for(m, "PARAM_VALUE", 5.0, lambda p: p.param_id == "NAVL1_PERIOD")
    assert echo.param_value == 19.25
    m.close()
    summary = s.stop()
    assert summary["completed"] is False                             # nobody flew it
    assert "NAVL1_PERIOD     19.25" in store.read_text()
    tlog = tmp_path / "run1" / "gcs.tlog"
    mavlogdump = Path(sys.executable).parent / "mavlogdump.py"
    dump = subprocess.run([sys.executable, str(mavlogdump), "--types", "HEARTBEAT,PARAM_SET,PARAM_VALUE",
                           str(tlog)], capture_output=True, text=True, timeout=60)
    assert dump.returncode == 0, dump.stderr
    assert "PARAM_SET" in dump.stdout and "NAVL1_PERIOD" in dump.stdout and "HEARTBEAT" in dump.stdout
    assert (tmp_path / "run1" / "flight.npz").exists() and (tmp_path / "run1" / "params.parm").exists()
    # a new run starts from the stored value; `sitl params save` shows the store
    s2 = Sitl(tmp_path / "run2", store=store)
    m = connect(s2.url)
    m.mav.param_request_read_send(1, 1, b"NAVL1_PERIOD", -1)
    assert wait_for(m, "PARAM_VALUE", 5.0).param_value == 19.25
    out = tmp_path / "saved.parm"
    r = subprocess.run([sys.executable, "-m", "tools.sitl", "params", "save", str(out), "--connect", s2.url],
                       cwd=REPO, capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    assert "NAVL1_PERIOD     19.25" in out.read_text()
    m.close()
    s2.stop()


def test_a_700_item_mission_and_out_of_order_items_over_the_wire(realtime):
    m = connect(realtime.url, sysid=253)
    n = 700
    sent = set()
    m.mav.mission_count_send(1, 1, n, 0)
    t0 = time.monotonic()
    ack = None
    while time.monotonic() - t0 < 30:
        msg = m.recv_match(type=["MISSION_REQUEST_INT", "MISSION_REQUEST", "MISSION_ACK"], blocking=True, timeout=2)
        assert msg is not None
        if msg.get_type() == "MISSION_ACK":
            ack = msg
            break
        k = msg.seq
        for seq in ([k + 1, k] if k % 50 == 7 and k + 1 < n else [k]):   # now and then one early
            m.mav.mission_item_int_send(1, 1, seq, 0 if seq == 0 else 3, 16, 0, 1, 0, 0, 0, 0,
                                        int(-35.36e7) + seq * 100, int(149.16e7), 100 + seq % 50)
            sent.add(seq)
    assert ack is not None and ack.type == 0
    m.mav.mission_request_list_send(1, 1)
    assert wait_for(m, "MISSION_COUNT", 5).count == n
    m.close()


def test_a_supported_failure_injection_is_relayed_and_accepted(realtime):
    m = connect(realtime.url, sysid=252)
    ack = command(m, 420, 0, 0, 0)     # gyro 0: "ok" (no fault), answered by the simulator
    assert ack is not None and ack.result == 0
    ack = command(m, 420, 105, 1, 0)   # MAVLink signal off: not something the simulator does
    assert ack is not None and ack.result == 3
    m.close()


def test_sitl_params_save_and_load_the_store(tmp_path):
    store = tmp_path / "store.parm"
    src = tmp_path / "in.parm"
    src.write_text("NAVL1_PERIOD 21\nRTL_ALT 150\n")
    run = [sys.executable, "-m", "tools.sitl", "params"]
    r = subprocess.run(run + ["load", str(src), "--param-store", str(store)], cwd=REPO,
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    out = tmp_path / "out.parm"
    r = subprocess.run(run + ["save", str(out), "--param-store", str(store)], cwd=REPO,
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    text = out.read_text()
    assert "NAVL1_PERIOD     21\n" in text and "RTL_ALT          150\n" in text and "FS_GCS_TIMEOUT" in text
    src.write_text("NAVL1_PERIOD 2100\n")                   # out of range: refused, store unchanged
    r = subprocess.run(run + ["load", str(src), "--param-store", str(store)], cwd=REPO,
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 2 and "NAVL1_PERIOD" in r.stderr
    assert "NAVL1_PERIOD     21\n" in store.read_text()


def test_a_burst_of_connections_is_served_and_refused_in_arrival_order():
    """More clients than the limit connecting at once, before the service polls: every
    handshake completes at once (none waits on a retransmit, which takes a second or
    more), the first MAX_TCP_CLIENTS are served and the rest closed, in arrival order."""
    from autopilot.gcs.links import MAX_TCP_CLIENTS, GcsLinks
    links = GcsLinks(["tcpin:127.0.0.1:0"])
    extra = 5
    try:
        host, port = links.tcp_ports()[0]
        t0 = time.monotonic()
        socks = [socket.create_connection((host, port), timeout=0.9)
                 for _ in range(MAX_TCP_CLIENTS + extra)]
        connect_s = time.monotonic() - t0
        for _ in range(50):
            links.poll(0.01)
            if len(links._tcp) + links.refused_connections == MAX_TCP_CLIENTS + extra:
                break
        assert connect_s < 0.5
        assert len(links._tcp) == MAX_TCP_CLIENTS and links.refused_connections == extra
        closed = []
        for s in socks:
            s.settimeout(0.2)
            try:
                closed.append(s.recv(1) == b"")       # the service's close: end of stream
            except (TimeoutError, socket.timeout):
                closed.append(False)                   # open, nothing sent yet
            s.close()
        assert closed == [False] * MAX_TCP_CLIENTS + [True] * extra
    finally:
        links.close()
