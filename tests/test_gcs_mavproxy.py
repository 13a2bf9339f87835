"""MAVProxy, headless as the issue asks (``--daemon --non-interactive``: no console, no
map, no standard input), drives the fixed-wing as it would ArduPlane: its parameter
download is not held up by MAVFTP (the vehicle NAKs it), ``wp load`` of a .waypoints
file, ``wp list``, ``param set`` / ``param show``, ``mode AUTO``, ``arm throttle``; the
mission is flown (a second client sees MISSION_ITEM_REACHED for every item).

A non-interactive MAVProxy reads no input, so its commands are given at start-up with
``--cmd``; they are staged in time with MAVProxy's own ``repeat add PERIOD script FILE``
(misc module): stage 1 (once, after the link is up) loads the mission and sets the
parameter, stage 2 repeats ``wp list``, ``param show``, ``mode AUTO`` and ``arm throttle``
until the vehicle is flying (an arming request the pre-arm checks refuse is simply asked
again, as a pilot would)."""
import queue
import re
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from test_gcs_support import MISSIONS, Sitl, connect

MAVPROXY = Path(sys.executable).parent / "mavproxy.py"


def test_mavproxy_is_installed_by_the_test_extra():
    # the real client is part of the test set-up (pyproject.toml [test]): a CI image
    # without it must fail here, not skip the protocol test below
    assert MAVPROXY.exists(), f"{MAVPROXY} missing: pip install -e '.[test]'"


class MavProxy:
    def __init__(self, url, cwd, *extra, env=None):
        self.proc = subprocess.Popen(
            [sys.executable, "-u", str(MAVPROXY), f"--master={url}", "--no-state",
             "--default-modules=wp,param,mode,arm,cmdlong,misc,ftp", *extra],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, cwd=cwd,
            env=env)
        self.lines: queue.Queue = queue.Queue()
        self.log: list[str] = []
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self):
        for line in self.proc.stdout:
            self.log.append(line)
            self.lines.put(line)

    def send(self, text):
        self.proc.stdin.write(text + "\n")
        self.proc.stdin.flush()

    def expect(self, pattern, timeout_s=20.0):
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            try:
                line = self.lines.get(timeout=0.2)
            except queue.Empty:
                continue
            m = re.search(pattern, line)
            if m:
                return m
        raise AssertionError(f"MAVProxy never said {pattern!r}:\n" + "".join(self.log[-40:]))

    def close(self):
        try:
            self.send("exit")
        except OSError:
            pass
        try:
            self.proc.wait(2)
        except subprocess.TimeoutExpired:                            # daemon: no stdin
            self.proc.terminate()
        try:
            self.proc.wait(5)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait(5)


def test_mavproxy_headless_loads_a_mission_sets_a_parameter_and_flies(tmp_path):
    wp = tmp_path / "mission.waypoints"
    wp.write_text((MISSIONS / "default.waypoints").read_text())
    stage2 = tmp_path / "stage2.scr"
    stage2.write_text("wp list\nparam show NAVL1_PERIOD\nmode AUTO\narm throttle\n")
    stage1 = tmp_path / "stage1.scr"
    stage1.write_text(f"wp load {wp.name}\nparam set NAVL1_PERIOD 18.5\nrepeat clean\n"
                      f"repeat add 2 script {stage2.name}\n")
    sitl = Sitl(tmp_path / "run", speedup="max")
    reached = []
    armed_at = []
    stop = threading.Event()

    def monitor():
        m = connect(sitl.url, sysid=250)
        while not stop.is_set():
            msg = m.recv_match(type=["MISSION_ITEM_REACHED", "HEARTBEAT"], blocking=True, timeout=0.2)
            if msg is None:
                continue
            if msg.get_type() == "MISSION_ITEM_REACHED":
                reached.append(msg.seq)
            elif msg.get_srcSystem() == 1 and msg.base_mode & 128 and not armed_at:
                armed_at.append(time.monotonic())
        m.close()

    mon = threading.Thread(target=monitor, daemon=True)
    mon.start()
    t0 = time.monotonic()
    mp = MavProxy(sitl.url, tmp_path, "--daemon", "--non-interactive",
                  "--cmd", f"repeat add 3 script {stage1.name}")
    try:
        mp.expect(r"Received (\d+) parameters", 30)
        param_fetch_s = time.monotonic() - t0
        mp.expect(r"MISSION_ACK: TYPE_MISSION: ACCEPTED|Sent all 13 waypoints", 30)
        mp.expect(r"Requesting 13 waypoints", 30)
        mp.expect(r"^20 3 0\.0+ 0\.0+", 30)                         # the last item: RTL
        mp.expect(r"NAVL1_PERIOD\s+18\.5", 30)
        mp.expect(r"DO_SET_MODE: ACCEPTED", 30)
        mp.expect(r"COMPONENT_ARM_DISARM: ACCEPTED", 90)
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and 12 not in reached:
            time.sleep(0.2)
    finally:
        stop.set()
        mp.close()
        mon.join(5)
        summary = sitl.stop()
    print(f"MAVProxy parameter download {param_fetch_s:.2f} s; reached {reached}")
    assert param_fetch_s < 8.0                                       # no MAVFTP timeouts
    assert armed_at                                                  # MAVProxy armed it
    assert set(range(1, 13)) <= set(reached)
    assert summary["mission_items_reached"] >= 12
    assert sitl.stats()["errors"] == 0
