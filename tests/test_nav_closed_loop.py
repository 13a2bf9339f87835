"""Issue 3's navigation figures in the real closed loop: the EKF flies the default
mission (JSBSim Aerosonde, sensor suite, HIL lockstep on the memory pipe, 5 m/s
crosswind, light turbulence) and the GPS-outage scenario, scored from truth by
tools/summary.py -- what ``sitl run --json`` and ``sitl run --scenario
missions/gps_outage.toml --json`` print.

Position: the issue asks nav_pos_h_rms <= 0.7 gps_pos_h_rms. The receiver's error
(sim_bridge/sensors/params.py) is a white part (0.3 m per axis), which the filter
averages out, and a minute-scale Gauss-Markov wander (0.2 m per axis, tau 60 s), which
a filter can only average out over windows longer than tau, through its velocity; so
the bound is met with a margin of tenths, not more (the ratios of seeds 1-3:
docs/status.md, "Navigation"). Beside the issue's bound the filter is held within 25 %
of what an ideal filter that knew the trajectory's shape exactly could do with this
draw of the receiver's error.
"""
from __future__ import annotations

import numpy as np
import pytest

from tools.runner import DEFAULT_SCENARIO, MISSIONS_DIR, RunConfig, Session
from tools.summary import run_summary


def fly(**kw):
    s = Session(RunConfig(**kw))
    s.run()
    return s, run_summary(s)


def position_floor_rms(a: dict, latency_s: float, gm_sd: float, tau_s: float, white_sd: float) -> float:
    """RMS horizontal error of the best causal estimate of position from this run's
    GPS fixes by a filter that knew the trajectory's shape exactly: per axis a Kalman
    filter over [position offset, Gauss-Markov error] fed the receiver's actual errors
    (each fix against the truth at its time of validity). Over the samples that
    tools/summary.py scores."""
    t = a["t_s"]
    g = np.isfinite(a["gps_n_m"])
    tv = t[g] - latency_s
    errs = [a["gps_n_m"][g] - np.interp(tv, t, a["truth_n_m"]),
            a["gps_e_m"][g] - np.interp(tv, t, a["truth_e_m"])]
    dt = float(np.median(np.diff(t[g])))
    phi = np.exp(-dt / tau_s)
    F = np.diag([1.0, phi])
    Q = np.diag([0.0, gm_sd ** 2 * (1.0 - phi * phi)])
    H = np.array([1.0, 1.0])
    est = []
    for e in errs:
        x, P, out = np.zeros(2), np.diag([1e6, gm_sd ** 2]), []
        for k, y in enumerate(e):
            if k:
                x, P = F @ x, F @ P @ F.T + Q
            # x += K (y - H x), P -= K H P;  K = P H^T / (H P H^T + R)
            K = P @ H / (H @ P @ H + white_sd ** 2)
            x = x + K * (y - H @ x)
            P = P - np.outer(K, H @ P)
            out.append(x[0])
        est.append(np.array(out))
    m = (a["armed"] > 0) & (a["nav_aligned"] > 0)
    i = np.searchsorted(t[g], t[m], side="right") - 1
    i = i[i >= 0]
    return float(np.sqrt(np.mean(est[0][i] ** 2 + est[1][i] ** 2)))


@pytest.fixture(scope="module")
def default_mission(flown):
    # GIVEN the default mission in a 5 m/s crosswind with light turbulence, seed 1,
    # WHEN the EKF navigates it (the closed loop's own sensors, latency, launch; the
    # flight tests/test_e2e_plane.py scores too: flown once, tests/conftest.py)
    return flown(RunConfig(nav="ekf", scenario=DEFAULT_SCENARIO, seed=1), across_files=True)


def test_default_mission_navigation_figures(default_mission):
    s, summary = default_mission
    # THEN the mission is flown to the end with the tracking figures,
    assert summary["completed"] is True and summary["lockstep_missed"] == 0
    assert summary["mission_items_reached"] == summary["mission_items_total"]
    assert summary["xtrack_rms_m"] <= 2.0 and summary["xtrack_max_m"] <= 15.0
    assert summary["alt_rms_m"] <= 3.0
    # attitude within the figures (roll/pitch 0.5 deg, yaw 2 deg RMS),
    assert summary["nav_roll_pitch_rms_deg"] <= 0.5
    assert summary["nav_yaw_rms_deg"] <= 2.0
    # every position, velocity and attitude component inside its own 3 sigma together
    # in >= 95 % of the samples,
    assert summary["nav_consistency_3sigma"] >= 0.95
    # and the position within 0.7 of the GPS's own, and within 25 % of what any filter
    # could do with this draw of the GPS error (module docstring)
    p = s.params
    floor = position_floor_rms(s.log.arrays(), p["EK_GPS_DELAY"], p["EK_GPSB_SD"], p["EK_GPSB_TAU"],
                               p["EK_GPS_P_NSE"])
    assert summary["nav_pos_h_rms_m"] <= 0.7 * summary["gps_pos_h_rms_m"], summary
    assert summary["nav_pos_h_rms_m"] <= 1.25 * floor, (summary["nav_pos_h_rms_m"], floor)


def test_ukf_flies_the_default_mission_with_the_same_bounds():
    # GIVEN the default mission, seed 1, WHEN the UKF navigates it (--nav ukf)
    s, summary = fly(nav="ukf", scenario=DEFAULT_SCENARIO, seed=1)
    # THEN the mission and navigation figures are the EKF's bounds (issue 3)
    assert summary["nav_source"] == "ukf"
    assert summary["completed"] is True and summary["lockstep_missed"] == 0
    assert summary["mission_items_reached"] == summary["mission_items_total"]
    assert summary["xtrack_rms_m"] <= 2.0
    assert summary["nav_roll_pitch_rms_deg"] <= 0.5 and summary["nav_yaw_rms_deg"] <= 2.0
    assert summary["nav_consistency_3sigma"] >= 0.95
    assert summary["nav_pos_h_rms_m"] <= 0.7 * summary["gps_pos_h_rms_m"], summary


def test_gps_outage_in_flight():
    # GIVEN a steady 6 m/s wind and no GPS fixes from 120 s to 150 s, default parameters
    #       (the fault monitor's GPS-lost failsafe comes after FDI_DR_TIME = 60 s of
    #       dead reckoning: a 30 s outage is flown through)
    s, summary = fly(nav="ekf", scenario=MISSIONS_DIR / "gps_outage.toml", seed=1)
    # THEN the vehicle keeps flying the mission to its end,
    assert summary["completed"] is True
    assert summary["mission_items_reached"] == summary["mission_items_total"]
    assert summary["xtrack_max_m"] <= 15.0
    # dead-reckons to within 30 m over the 30 s, is back within 3 m of the truth less
    # than 10 s after the GPS returns,
    (outage,) = summary["gps_outages"]
    assert (outage["start_s"], outage["end_s"]) == (120.0, 150.0)
    assert outage["pos_h_err_at_end_m"] <= 30.0
    assert outage["reconverge_s"] is not None and outage["reconverge_s"] <= 10.0
    # and says how much it knows: the error inside the grown 3 sigma at the outage's end
    a = s.log.arrays()
    k = int(np.searchsorted(a["t_s"], 150.0)) - 1
    err = np.hypot(a["est_n_m"][k] - a["truth_n_m"][k], a["est_e_m"][k] - a["truth_e_m"][k])
    assert err <= 3.0 * np.hypot(a["sig_pn_m"][k], a["sig_pe_m"][k])
    assert summary["nav_consistency_3sigma"] >= 0.95
