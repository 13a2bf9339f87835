"""MAVProxy (headless: no console, no map) drives the fixed-wing as it would ArduPlane:
its parameter download is not held up by MAVFTP (the vehicle NAKs it), ``wp load`` of a
.waypoints file, ``wp list``, ``param set`` / ``param show``, ``mode AUTO``, ``arm
throttle``; the mission is flown (a second client sees MISSION_ITEM_REACHED for every
item). MAVProxy reads its commands from standard input, as ArduPilot's own autotest
drives it."""
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
pytestmark = pytest.mark.skipif(not MAVPROXY.exists(), reason="MAVProxy not installed (test extra)")


class MavProxy:
    def __init__(self, url, cwd):
        self.proc = subprocess.Popen(
            [sys.executable, "-u", str(MAVPROXY), f"--master={url}", "--no-state",
             "--default-modules=wp,param,mode,arm,cmdlong,misc,ftp"],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, cwd=cwd)
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
            self.proc.wait(5)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait(5)


def test_mavproxy_loads_a_mission_sets_a_parameter_and_flies(tmp_path):
    wp = tmp_path / "mission.waypoints"
    wp.write_text((MISSIONS / "default.waypoints").read_text())
    sitl = Sitl(tmp_path / "run", speedup="max")
    reached = []
    stop = threading.Event()

    def monitor():
        m = connect(sitl.url, sysid=250)
        while not stop.is_set():
            msg = m.recv_match(type="MISSION_ITEM_REACHED", blocking=True, timeout=0.2)
            if msg is not None:
                reached.append(msg.seq)
        m.close()

    mon = threading.Thread(target=monitor, daemon=True)
    mon.start()
    mp = MavProxy(sitl.url, tmp_path)
    try:
        t0 = time.monotonic()
        mp.expect(r"Received (\d+) parameters", 30)
        param_fetch_s = time.monotonic() - t0
        mp.send(f"wp load {wp.name}")
        mp.expect(r"MISSION_ACK: TYPE_MISSION: ACCEPTED|Sent all 13 waypoints")
        mp.send("wp list")
        mp.expect(r"Requesting 13 waypoints")
        mp.expect(r"^20 3 0\.0+ 0\.0+")                              # the last item: RTL
        mp.send("param set NAVL1_PERIOD 18.5")
        time.sleep(0.5)
        mp.send("param show NAVL1_PERIOD")
        mp.expect(r"NAVL1_PERIOD\s+18\.5")
        mp.send("mode AUTO")
        mp.expect(r"DO_SET_MODE: ACCEPTED")
        for _ in range(60):                                          # until PreArm passes
            mp.send("arm throttle")
            m = mp.expect(r"COMPONENT_ARM_DISARM: (ACCEPTED|FAILED)")
            if m.group(1) == "ACCEPTED":
                break
            time.sleep(0.5)
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
    assert set(range(1, 13)) <= set(reached)
    assert summary["mission_items_reached"] >= 12
    assert sitl.stats()["errors"] == 0
