"""The figures of a run, computed from its flight log (truth against targets).

Scoring uses truth (HIL_STATE_QUATERNION) in home's NED frame:

* cross-track error: for every straight leg, the signed distance of the true position
  from the leg's line, counted from the leg's first capture (the first sample within
  ``CAPTURE_M`` of the line) to the leg's end; ``xtrack_rms_m`` / ``xtrack_max_m`` over
  all legs;
* altitude error: true height above home against the commanded height above home
  (so a constant navigation altitude offset at arming does not count), over the
  flight after the takeoff item, legs and loiters alike;
* airspeed error: true airspeed against the commanded airspeed, same samples.
"""
from __future__ import annotations

import math

import numpy as np

CAPTURE_M = 10.0
KIND_LINE, KIND_LOITER, KIND_TAKEOFF = 2, 3, 1


def leg_xtrack(a: dict) -> tuple[np.ndarray, np.ndarray]:
    """Per-sample true cross-track error on straight legs, and the mask of samples
    that count (after capture)."""
    n = len(a["t_s"])
    xt = np.full(n, np.nan)
    use = np.zeros(n, dtype=bool)
    line = (a["kind"] == KIND_LINE) & (a["armed"] > 0)
    if not line.any():
        return xt, use
    an, ae, bn, be = a["leg_a_n_m"], a["leg_a_e_m"], a["leg_b_n_m"], a["leg_b_e_m"]
    dn, de = bn - an, be - ae
    length = np.hypot(dn, de)
    ok = line & (length > 1.0)
    tn = np.where(ok, dn / np.where(length > 0, length, 1.0), 0.0)
    te = np.where(ok, de / np.where(length > 0, length, 1.0), 0.0)
    pn, pe = a["truth_n_m"] - an, a["truth_e_m"] - ae
    xt = np.where(ok, pn * (-te) + pe * tn, np.nan)
    leg = a["leg_id"]
    for lid in np.unique(leg[ok]):
        idx = np.flatnonzero(ok & (leg == lid))
        captured = np.flatnonzero(np.abs(xt[idx]) <= CAPTURE_M)
        if captured.size:
            use[idx[captured[0]:]] = True
    return xt, use


def flight_figures(a: dict, home_truth_alt_m: float | None, home_est_alt_m: float | None) -> dict:
    xt, use = leg_xtrack(a)
    out: dict = {}
    if use.any():
        out["xtrack_rms_m"] = float(np.sqrt(np.mean(xt[use] ** 2)))
        out["xtrack_max_m"] = float(np.max(np.abs(xt[use])))
    else:
        out["xtrack_rms_m"] = None
        out["xtrack_max_m"] = None
    flying = (a["armed"] > 0) & ((a["kind"] == KIND_LINE) | (a["kind"] == KIND_LOITER))
    if flying.any() and home_truth_alt_m is not None and home_est_alt_m is not None:
        h_true = a["truth_alt_m"][flying] - home_truth_alt_m
        h_cmd = a["tgt_alt_m"][flying] - home_est_alt_m
        out["alt_rms_m"] = float(np.sqrt(np.mean((h_true - h_cmd) ** 2)))
        out["alt_max_err_m"] = float(np.max(np.abs(h_true - h_cmd)))
        dv = a["truth_airspeed_mps"][flying] - a["tgt_airspeed_mps"][flying]
        out["airspeed_rms_mps"] = float(np.sqrt(np.mean(dv ** 2)))
    else:
        out["alt_rms_m"] = out["alt_max_err_m"] = out["airspeed_rms_mps"] = None
    return out


def run_summary(session) -> dict:
    """summary.json of a finished in-process session (tools.runner.Session)."""
    v = session.vehicle
    a = session.log.arrays()
    seq = v.sequencer
    reached = len(seq.reached_seqs) if seq else 0
    total = seq.total_items if seq else max(len(session.mission) - 1, 0)
    completed = bool(seq is not None and seq.finished and seq.rtl_established and not session.crashed)
    home_est = v.home_frame.alt0_m if v.home_frame is not None else None
    figs = flight_figures(a, v.home_truth_alt_m, home_est)
    sim_time = session.t_s
    wall = session.wall_loop_s
    s = {
        "vehicle": session.cfg.vehicle,
        "airframe": session.cfg.airframe,
        "nav_source": v.nav_source,
        "seed": session.cfg.seed,
        "completed": completed,
        "crashed": session.crashed,
        "mission_items_reached": reached,
        "mission_items_total": total,
        "sim_time_s": round(sim_time, 6),
        "wall_time_s": round(wall, 3),
        "realtime_factor": round(sim_time / wall, 2) if wall > 0 else None,
        "wind_speed_mps": session.wind.speed_mps,
        "wind_from_deg": session.wind.from_deg,
        "turbulence": session.wind.turbulence,
        "lockstep_missed": session.sim_end.missed,
        "faults_injected": [
            {"at_s": round(r.at_s, 3), "unit": r.unit, "type": r.type, "instance": r.instance,
             "accepted": r.accepted, "source": r.source} for r in session.bridge.fault_log],
    }
    s.update(figs)
    return s


TIMING_KEYS = ("wall_time_s", "realtime_factor")


def without_timing(summary: dict) -> dict:
    return {k: v for k, v in summary.items() if k not in TIMING_KEYS}


def _fmt(v):
    if isinstance(v, float):
        return f"{v:.3f}" if math.isfinite(v) else str(v)
    return str(v)


def format_summary(s: dict) -> str:
    keys = ["vehicle", "nav_source", "seed", "completed", "mission_items_reached",
            "mission_items_total", "sim_time_s", "wall_time_s", "realtime_factor",
            "xtrack_rms_m", "xtrack_max_m", "alt_rms_m", "airspeed_rms_mps"]
    lines = [f"{k:>24}: {_fmt(s.get(k))}" for k in keys if k in s]
    rest = [k for k in sorted(s) if k not in keys and not isinstance(s[k], (list, dict))]
    lines += [f"{k:>24}: {_fmt(s[k])}" for k in rest]
    return "\n".join(lines)
