"""sitl campaign under faults of its own machinery: the driver killed with kill -9,
then interrupted with Ctrl-C, then rerun, a worker process killed mid-trial, a cluster started with Dask's own commands
(``dask scheduler``, ``dask worker``) and a worker of another version refused. Every
campaign is compared with the same campaign run without trouble: each trial stored
once, figures equal (timing aside)."""
from __future__ import annotations

import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from tools.summary import without_timing

REPO = Path(__file__).resolve().parent.parent

CAMPAIGN = """[campaign]
name = "faults"
trials = 8
seed = 11
duration_s = 15
keep_worst = 0

[dispersion]
wind_speed_mps = { uniform = [0.0, 8.0] }
wind_from_deg = { uniform = [0.0, 360.0] }
"param.NAVL1_PERIOD" = { uniform = [15.0, 19.0] }

[criteria]
navigation = "nav_pos_h_err_max_m < 2.0"
"""


N = 8      # the campaign's trials: after kill -9 at most 4 are stored, so a Ctrl-C after
           # one more leaves at least 3 to fly


def rows_of(folder: Path) -> list[dict]:
    from tools.campaign.store import Store
    s = Store(folder, read_only=True)
    try:
        return s.rows()
    finally:
        s.close()


class _Lines:
    """A child's stderr read by a thread, so that no wait on it can outlast its deadline."""

    def __init__(self, proc: subprocess.Popen):
        self.lines: list[str] = []
        self.cond = threading.Condition()
        self.eof = False
        self.thread = threading.Thread(target=self._read, args=(proc.stderr,), daemon=True)
        self.thread.start()

    def _read(self, stream) -> None:
        for line in stream:
            with self.cond:
                self.lines.append(line)
                self.cond.notify_all()
        with self.cond:
            self.eof = True
            self.cond.notify_all()

    def until(self, pred, timeout_s: float, what: str) -> str:
        """The first line (of all read so far or later) for which pred holds."""
        t_end = time.monotonic() + timeout_s
        seen = 0
        with self.cond:
            while True:
                for line in self.lines[seen:]:
                    if pred(line):
                        return line
                seen = len(self.lines)
                left = t_end - time.monotonic()
                assert not self.eof and left > 0, f"{what}: not within {timeout_s:.0f} s; stderr:\n{self.text()}"
                self.cond.wait(min(left, 1.0))

    def text(self) -> str:
        return "".join(self.lines)


def _done(line: str) -> int:
    """How many trials a progress line says are done."""
    return int(line.split("]")[1].split("/")[0])


def _end(proc: subprocess.Popen, group: bool = False) -> None:
    """The child (and its process group) killed if still there; the reading thread ends at
    the pipe's end, when the last process holding it is gone."""
    try:
        if group:
            os.killpg(proc.pid, signal.SIGKILL)
        elif proc.poll() is None:
            proc.kill()
    except ProcessLookupError:
        pass
    try:
        proc.wait(timeout=10)
    except subprocess.TimeoutExpired:
        pass


def figures(rows: list[dict]) -> dict:
    """trial -> (seed, summary without timing, criteria, passed)"""
    return {r["trial"]: (r["seed"], without_timing(json.loads(r["summary_json"])), r["criteria_json"],
                         r["passed"]) for r in rows}


@pytest.fixture(scope="module")
def client():
    import logging
    from distributed import Client, LocalCluster
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                      silence_logs=logging.ERROR) as cluster, Client(cluster) as c:
        yield c


@pytest.fixture(scope="module")
def reference(tmp_path_factory, client):
    """The campaign run once without trouble."""
    from tools.campaign.execute import run_campaign
    from tools.campaign.spec import load_campaign
    d = tmp_path_factory.mktemp("ref")
    path = d / "faults.toml"
    path.write_text(CAMPAIGN)
    res = run_campaign(load_campaign(path), d / "out", progress=False, client=client)
    assert res["ran"] == N
    rows = rows_of(d / "out")
    assert [r["error"] for r in rows] == [""] * N
    return path, figures(rows)


def test_driver_killed_with_kill_9_or_ctrl_c_then_rerun_completes_each_trial_once(reference, client, tmp_path):
    path, ref = reference
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "tools.sitl", "campaign", "run", str(path), "--out", str(out),
           "--scheduler", client.scheduler.address]
    # GIVEN a campaign driver that has stored some trials
    drv = subprocess.Popen(cmd, cwd=REPO, stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True)
    err = _Lines(drv)
    try:
        done = err.until(lambda line: " done " in line and _done(line) >= 2, 90, "the driver stored 2 trials")
        done = _done(done)
        # WHEN it is killed with SIGKILL half-way
        os.kill(drv.pid, signal.SIGKILL)
        drv.wait(timeout=10)
    finally:
        _end(drv)
    assert 2 <= done < N - 2
    stored_after_kill = rows_of(out)
    assert 2 <= len(stored_after_kill) < 5
    # WHEN the same command (on its own local cluster) is interrupted by Ctrl-C, which
    # reaches its worker processes too (they leave it to the driver)
    local = cmd[:-2] + ["--workers", "2"]
    # (in a session of its own, with SIGINT's default action: a shell starts background
    # jobs with SIGINT ignored, and the test may be one)
    drv = subprocess.Popen(local, cwd=REPO, stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True,
                           start_new_session=True,
                           preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    err = _Lines(drv)
    try:
        err.until(lambda line: " done " in line and _done(line) > len(stored_after_kill), 120,
                  "the local cluster stored one more trial")
        os.killpg(drv.pid, signal.SIGINT)             # what a terminal's Ctrl-C does
        assert drv.wait(timeout=60) == 130, err.text()
        # (the worker processes may hold the pipe a moment longer than the driver)
        err.until(lambda line: "the same command resumes" in line, 10, "the interruption's message")
        rest = err.text()
    finally:
        _end(drv, group=True)
    assert "interrupted;" in rest and "the same command resumes" in rest
    assert "Traceback" not in rest and "KeyboardInterrupt" not in rest, rest
    stored_after_ctrl_c = rows_of(out)
    assert len(stored_after_kill) < len(stored_after_ctrl_c) < N
    # no flight cut short by the interruption was stored
    assert all(r["error"] == "" and abs(r["sim_s"] - 15.0) < 0.02 for r in stored_after_ctrl_c)
    # THEN the same command again runs the missing trials only and completes
    r = subprocess.run(cmd, cwd=REPO, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    rows = rows_of(out)
    assert sorted(x["trial"] for x in rows) == list(range(N))           # each stored once
    from tools.campaign.store import Store
    s = Store(out, read_only=True)
    try:
        last_run = s.runs()[-1]
    finally:
        s.close()
    assert last_run["trials"] == N - len(stored_after_ctrl_c)
    # the rows stored before are untouched, and all figures are the uninterrupted
    # campaign's
    assert figures(rows) == ref
    before = {x["trial"]: x["finished"] for x in stored_after_ctrl_c}
    assert {x["trial"]: x["finished"] for x in rows if x["trial"] in before} == before


def test_ctrl_c_after_the_last_trial_ends_the_driver_with_130_and_every_trial_stored(tmp_path):
    # GIVEN a campaign of two short trials on the driver's own local cluster
    path = tmp_path / "two.toml"
    path.write_text(CAMPAIGN.replace("trials = 8", "trials = 2").replace("duration_s = 15", "duration_s = 5"))
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "tools.sitl", "campaign", "run", str(path), "--out", str(out),
           "--workers", "2"]
    drv = subprocess.Popen(cmd, cwd=REPO, stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True,
                           start_new_session=True,
                           preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    err = _Lines(drv)
    try:
        # WHEN Ctrl-C comes as the last trial is stored: the driver is storing its run's
        # record or closing its cluster
        err.until(lambda line: " done " in line and _done(line) == 2, 120, "both trials stored")
        os.killpg(drv.pid, signal.SIGINT)
        # THEN it ends with status 130, says so and shows no traceback (before, a Ctrl-C in
        # the closing went unreported, the cluster was left to Python's exit handlers and
        # the workers died with Dask's tracebacks)
        assert drv.wait(timeout=60) == 130, err.text()
        err.until(lambda line: "interrupted;" in line, 10, "the interruption's message")
        text = err.text()
    finally:
        _end(drv, group=True)
    assert "2 trials stored" in text and "Traceback" not in text, text
    rows = rows_of(out)
    assert sorted(r["trial"] for r in rows) == [0, 1] and [r["error"] for r in rows] == ["", ""]


def test_a_ctrl_c_is_held_while_the_driver_stores_and_a_second_one_while_closing_ends_it():
    from tools.campaign.execute import DriverInterrupt
    # GIVEN the driver's Ctrl-C handling, not waiting for a result
    with DriverInterrupt() as ctrl_c:
        # WHEN SIGINT comes: nothing is raised there (a store's insert goes on) ...
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(0.01)
        assert ctrl_c.requested
        # ... and the next wait raises it
        with pytest.raises(KeyboardInterrupt):
            ctrl_c.raise_if_requested()
        # WHEN it waits: SIGINT raises at once
        ctrl_c.requested = False
        ctrl_c.waiting = True
        with pytest.raises(KeyboardInterrupt):
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(1.0)
        assert ctrl_c.requested and not ctrl_c.waiting
    # THEN Python's handler is back
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    # AND a second Ctrl-C while closing ends the process with status 130
    code = ("import os, signal, time\n"
            "from tools.campaign.execute import DriverInterrupt\n"
            "with DriverInterrupt() as c:\n"
            "    c.closing = True\n"
            "    os.kill(os.getpid(), signal.SIGINT); time.sleep(0.05)\n"
            "    print('noted', c.requested, flush=True)\n"
            "    os.kill(os.getpid(), signal.SIGINT); time.sleep(5)\n"
            "print('not ended')\n")
    r = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, timeout=60,
                       preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    assert (r.returncode, r.stdout) == (130, "noted True\n"), r
    assert "interrupted again" in r.stderr


def test_worker_killed_mid_trial_campaign_completes(reference, client, tmp_path):
    from tools.campaign.execute import run_campaign
    from tools.campaign.spec import load_campaign
    path, ref = reference
    pids = client.run(os.getpid)                  # worker address -> process id
    result = {}

    def drive():
        result["res"] = run_campaign(load_campaign(path), tmp_path / "out", progress=False, client=client)

    th = threading.Thread(target=drive)
    th.start()
    # GIVEN a trial running on a worker for half a second
    victim = None
    t_end = time.monotonic() + 60
    while victim is None and time.monotonic() < t_end:
        busy = {a: ks for a, ks in client.processing().items() if ks}
        if busy:
            time.sleep(0.5)
            busy = {a: ks for a, ks in client.processing().items() if ks and a in pids}
            if busy:
                victim = sorted(busy)[0]
        time.sleep(0.05)
    assert victim is not None
    # WHEN that worker process is killed (its nanny starts a new one)
    os.kill(pids[victim], signal.SIGKILL)
    th.join(timeout=120)
    assert not th.is_alive()
    # THEN every trial is stored once, none of them as an error, with the figures of
    # the undisturbed campaign; none was stored by the killed worker after its death
    rows = rows_of(tmp_path / "out")
    assert sorted(r["trial"] for r in rows) == list(range(N))
    assert [r["error"] for r in rows] == [""] * N
    assert figures(rows) == ref
    assert result["res"]["ran"] == N


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _dask(*args, env=None, log=None) -> subprocess.Popen:
    exe = Path(sys.executable).parent / "dask"
    cmd = [str(exe)] if exe.exists() else [sys.executable, "-m", "dask"]
    return subprocess.Popen(cmd + list(args), cwd=REPO, env=env, stdout=log, stderr=log)


def test_campaign_on_dask_scheduler_and_workers_started_by_hand(reference, tmp_path):
    path, ref = reference
    port = _free_port()
    addr = f"tcp://127.0.0.1:{port}"
    # a copy of the package where one source file differs: another version
    other = tmp_path / "other"
    for pkg in ("autopilot", "sim_bridge", "tools", "missions"):
        shutil.copytree(REPO / pkg, other / pkg, ignore=shutil.ignore_patterns("__pycache__"))
    with open(other / "tools" / "summary.py", "a") as f:
        f.write("\n# another version\n")
    log = open(tmp_path / "dask.log", "w")
    worker = ("worker", addr, "--nthreads", "1", "--no-dashboard", "--host", "127.0.0.1")
    procs = [_dask("scheduler", "--host", "127.0.0.1", "--port", str(port), "--dashboard-address", ":0",
                   env=dict(os.environ, PYTHONPATH=str(REPO)), log=log)]
    try:
        # GIVEN `dask scheduler` and two `dask worker` processes on loopback, and a third
        # worker that runs another version
        for _ in range(2):
            procs.append(_dask(*worker, env=dict(os.environ, PYTHONPATH=str(REPO)), log=log))
        stranger = _dask(*worker, env=dict(os.environ, PYTHONPATH=str(other)), log=log)
        procs.append(stranger)
        from distributed import Client
        with Client(addr, timeout=30) as c:
            c.wait_for_workers(3, timeout=60)
        out = tmp_path / "out"
        cmd = [sys.executable, "-m", "tools.sitl", "campaign", "run", str(path), "--out", str(out),
               "--scheduler", addr, "--trials", "3"]
        # WHEN a campaign runs through --scheduler: the stranger is refused, nothing runs
        r = subprocess.run(cmd, cwd=REPO, capture_output=True, text=True, timeout=120)
        assert r.returncode == 2
        assert "refusing workers that run another version of pysitl" in r.stderr
        assert str(other) in r.stderr and r.stderr.count(" runs pysitl ") == 1
        assert rows_of(out) == []
        # WHEN the stranger is gone: the first 3 trials run
        stranger.terminate()
        stranger.wait(timeout=20)
        with Client(addr, timeout=30) as c:
            t_end = time.monotonic() + 30
            while len(c.scheduler_info()["workers"]) != 2 and time.monotonic() < t_end:
                time.sleep(0.1)
        r = subprocess.run(cmd, cwd=REPO, capture_output=True, text=True, timeout=120)
        assert r.returncode == 0, r.stderr
        # THEN they are the campaign's first 3 trials, as the LocalCluster flew them
        rows = rows_of(out)
        assert figures(rows) == {i: ref[i] for i in range(3)}
        assert all(row["worker"].startswith("tcp://127.0.0.1:") for row in rows)
    finally:
        for p in reversed(procs):
            p.terminate()
        for p in procs:
            try:
                p.wait(timeout=10)
            except subprocess.TimeoutExpired:
                p.kill()
        log.close()
