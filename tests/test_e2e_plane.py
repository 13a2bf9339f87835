"""End to end: the fixed-wing flies missions headless over the memory-pipe HIL link,
scored from truth; same seed, same flight; the two programs as two processes over TCP."""
import json
import os
import socket
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from tools.runner import DEFAULT_SCENARIO, MISSIONS_DIR, RunConfig, Session, write_run
from tools.summary import run_summary, without_timing

REPO = Path(__file__).resolve().parent.parent


def fly(**kw):
    cfg = RunConfig(**kw)
    s = Session(cfg)
    s.run()
    return s, run_summary(s)


@pytest.mark.parametrize("nav", ["truth", "ekf"])
def test_default_mission_meets_the_tracking_figures(nav, flown):
    # GIVEN the default mission in a 5 m/s crosswind with light turbulence (the EKF's
    # flight is also tests/test_nav_closed_loop.py's: flown once, tests/conftest.py)
    s, summary = flown(RunConfig(nav=nav, scenario=DEFAULT_SCENARIO, seed=1), across_files=nav == "ekf")
    # THEN it completes with the figures
    assert summary["completed"] is True
    assert summary["mission_items_reached"] == summary["mission_items_total"] == 12
    assert summary["xtrack_rms_m"] <= 2.0
    assert summary["xtrack_max_m"] <= 15.0
    assert summary["alt_rms_m"] <= 3.0
    assert summary["airspeed_rms_mps"] <= 2.0
    assert summary["lockstep_missed"] == 0
    assert summary["nav_source"] == nav


def test_same_seed_same_flight_log_and_summary(tmp_path):
    runs = []
    for k, seed in enumerate((5, 5, 6)):
        s, summary = fly(seed=seed, scenario=DEFAULT_SCENARIO, duration_s=60.0)
        d = write_run(s, summary, tmp_path / f"run{k}")
        runs.append((np.load(d / "flight.npz"), json.loads((d / "summary.json").read_text())))
    (a, sa), (b, sb), (c, sc) = runs
    cols = [str(x) for x in a["columns"]]
    assert cols == [str(x) for x in b["columns"]]
    for col in cols:
        np.testing.assert_array_equal(a[col], b[col], err_msg=col)   # bit-identical
    assert without_timing(sa) == without_timing(sb)
    # a different seed gives a different flight (noise, turbulence)
    assert not np.array_equal(a["truth_n_m"][-100:], c["truth_n_m"][-100:])


def test_acute_turns_short_legs_and_strong_wind_fly_to_the_end():
    s, summary = fly(mission=MISSIONS_DIR / "acute_short.waypoints", wind=(8.0, 200.0),
                     turbulence="light", nav="truth", seed=2)
    assert summary["completed"] is True and not summary["crashed"]
    assert summary["mission_items_reached"] == summary["mission_items_total"]
    assert summary["alt_rms_m"] <= 4.0


def test_southern_hemisphere_across_the_180_meridian():
    s, summary = fly(mission=MISSIONS_DIR / "southern_dateline.waypoints", wind=(6.0, 300.0),
                     turbulence="light", nav="truth", seed=3)
    assert summary["completed"] is True
    assert summary["xtrack_rms_m"] <= 2.0 and summary["xtrack_max_m"] <= 15.0
    assert summary["alt_rms_m"] <= 3.0
    a = s.log.arrays()
    # the log's positions are continuous through the meridian (no 40 000 km jumps)
    assert np.max(np.abs(np.diff(a["truth_e_m"]))) < 1.0


def _free_port():
    with socket.socket() as k:
        k.bind(("127.0.0.1", 0))
        return k.getsockname()[1]


def test_two_processes_over_tcp(tmp_path):
    # GIVEN sim-bridge listening and the autopilot connecting, as users start them
    port = _free_port()
    env = dict(os.environ, PYTHONPATH=str(REPO))
    sim = subprocess.Popen([sys.executable, "-m", "sim_bridge.cli", "--listen", f"tcpin:127.0.0.1:{port}",
                            "--duration", "40"], cwd=tmp_path, env=env,
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        ap = subprocess.run([sys.executable, "-m", "autopilot.cli", "--sim", f"tcp:127.0.0.1:{port}",
                             "--duration", "40", "--log-dir", str(tmp_path / "ap")],
                            cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300)
        assert ap.returncode == 0, ap.stderr
        _, sim_err = sim.communicate(timeout=60)
    finally:
        if sim.poll() is None:
            sim.kill()
    # THEN the autopilot armed, launched and climbed in lockstep, nothing missed
    z = np.load(tmp_path / "ap" / "flight.npz")
    assert z["armed"].max() == 1.0
    assert z["truth_alt_m"][-1] - z["truth_alt_m"][0] > 20.0
    assert np.all(np.diff(z["t_s"]) > 0)
    assert "missed 0" in sim_err


def test_stock_c172p_stays_selectable_and_flies_its_circuit():
    # the c172p takes off from the runway on its wheels with its own parameter file
    s, summary = fly(airframe="c172p", mission=MISSIONS_DIR / "c172p_circuit.waypoints",
                     nav="truth", seed=4, duration_s=900.0)
    assert summary["airframe"] == "c172p"
    assert summary["completed"] is True and not summary["crashed"]
    assert summary["alt_rms_m"] <= 5.0
    assert s.params["TRIM_ARSPD"] == 45.0
    # its take-off roll (about 18 s on the wheels) is no ground contact: that is scored
    # from the lift-off (it was scored from 5 s after the start, on the runway: 0.01 m)
    inv = summary["invariants"]["no_ground_contact"]
    assert inv["passed"], inv
