"""Support for the ground-station tests: ``sitl run --gcs`` as a real process, and a few
pymavlink helpers. (No tests here.)"""
from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
MISSIONS = REPO / "missions"


class Sitl:
    """``sitl run --gcs tcpin:127.0.0.1:0 ...`` in a child process; ``port`` is the TCP
    port it listens on; ``stop()`` is Ctrl-C (a clean shutdown) and returns the summary."""

    def __init__(self, run_dir: Path, *extra: str, speedup: str = "max", gcs=("tcpin:127.0.0.1:0",),
                 store: Path | None = None):
        self.run_dir = Path(run_dir)
        args = [sys.executable, "-m", "tools.sitl", "run", "--speedup", speedup,
                "--log-dir", str(self.run_dir), "--json"]
        for u in gcs:
            args += ["--gcs", u]
        args += ["--param-store", str(store or (self.run_dir.parent / f"{self.run_dir.name}-store.parm"))]
        args += list(extra)
        env = dict(os.environ, PYTHONUNBUFFERED="1")
        # with SIGINT's default action: stop() is Ctrl-C, and a shell starts its
        # background jobs (a test run among them) with SIGINT ignored, which the child
        # would inherit and never stop (the run hung in stop())
        self.proc = subprocess.Popen(args, cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                     text=True, env=env,
                                     preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
        self.err: list[str] = []
        self._ready = threading.Event()
        self.port = None
        self._t = threading.Thread(target=self._drain, daemon=True)
        self._t.start()
        if not self._ready.wait(60):
            self.proc.kill()
            raise RuntimeError("sitl did not start: " + "".join(self.err))
        if self.port is None:
            raise RuntimeError("sitl failed: " + "".join(self.err))

    def _drain(self):
        for line in self.proc.stderr:
            self.err.append(line)
            m = re.search(r"ground stations: tcp [\d.]+:(\d+)", line)
            if m and self.port is None:
                self.port = int(m.group(1))
                self._ready.set()
        self._ready.set()

    @property
    def url(self) -> str:
        return f"tcp:127.0.0.1:{self.port}"

    def stop(self, timeout_s: float = 60.0) -> dict:
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
        out = self.proc.stdout.read()           # stderr is drained by the reader thread
        self.proc.wait(timeout_s)
        self._t.join(5)
        assert self.proc.returncode == 0, "".join(self.err)
        return json.loads(out)

    def stats(self) -> dict:
        text = "".join(self.err)
        m = re.search(r"(\d+) messages received, (\d+) undecodable chunks, (\d+) ignored, "
                      r"(\d+) handler errors", text)
        return dict(zip(("received", "undecodable", "ignored", "errors"), map(int, m.groups()))) if m else {}

    def kill(self):
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait(10)


def connect(url: str, sysid: int = 255, **kw):
    from pymavlink import mavutil
    m = mavutil.mavlink_connection(url, source_system=sysid, source_component=190,
                                   dialect="ardupilotmega", **kw)
    assert m.wait_heartbeat(timeout=15) is not None
    return m


def wait_for(m, kind, timeout_s=10.0, cond=lambda msg: True):
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        msg = m.recv_match(type=kind, blocking=True, timeout=0.2)
        if msg is not None and cond(msg):
            return msg
    return None


def command(m, cmd, *params, target=(1, 1), timeout_s=5.0):
    p = list(params) + [0.0] * (7 - len(params))
    m.mav.command_long_send(target[0], target[1], cmd, 0, *p)
    return wait_for(m, "COMMAND_ACK", timeout_s, lambda a: a.command == cmd)


def arm_and_auto(m, timeout_s=60.0):
    """Wait until the vehicle accepts arming (navigation aligned), then mode AUTO."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        ack = command(m, 400, 1)
        if ack is not None and ack.result == 0:
            break
        time.sleep(0.5)
    else:
        raise AssertionError("never armed")
    ack = command(m, 176, 1, 10)
    assert ack is not None and ack.result == 0
