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

``xtrack_mission_rms_m`` / ``xtrack_mission_max_m`` score the same true position against
the lines of the mission as written instead of the legs the guidance drew, and
``invariants`` / ``invariants_passed`` check the flight (both in tools/invariants.py).
"""
from __future__ import annotations

import math

import numpy as np

from autopilot.mission.items import TERRAIN_FRAMES
from sim_bridge.faults.catalogue import MAX_DEFLECTION_RAD

CAPTURE_M = 10.0
KIND_LINE, KIND_LOITER, KIND_TAKEOFF, KIND_DIRECT = 2, 3, 1, 4


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
    flying = (a["armed"] > 0) & np.isin(a["kind"], (KIND_LINE, KIND_LOITER, KIND_DIRECT))
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


def attitude_error_ned(a: dict, mask: np.ndarray) -> np.ndarray:
    """Estimate-minus-truth attitude error as a NED-frame rotation vector [rad]:
    q_true = Exp(err) (x) q_est, the navigation filter's own error definition."""
    from scipy.spatial.transform import Rotation
    est = Rotation.from_euler("ZYX", np.column_stack([a["est_yaw_rad"][mask], a["est_pitch_rad"][mask],
                                                     a["est_roll_rad"][mask]]))
    tru = Rotation.from_euler("ZYX", np.column_stack([a["truth_yaw_rad"][mask], a["truth_pitch_rad"][mask],
                                                     a["truth_roll_rad"][mask]]))
    return (tru * est.inv()).as_rotvec()


def _wrap(x):
    return (x + np.pi) % (2 * np.pi) - np.pi


def nav_figures(a: dict, gps_latency_s: float, fault_log=()) -> dict:
    """Estimate against truth over the flight (armed, aligned), and the GPS receiver's
    own horizontal error in the same run (each fix against truth at its time of
    validity, ``gps_latency_s`` before its arrival)."""
    out: dict = {}
    m = (a["armed"] > 0) & (a["nav_aligned"] > 0) & np.isfinite(a["truth_n_m"])
    if not m.any():
        return out
    en, ee = a["est_n_m"] - a["truth_n_m"], a["est_e_m"] - a["truth_e_m"]
    eh = np.hypot(en, ee)
    ev = a["est_alt_m"] - a["truth_alt_m"]
    evel = np.column_stack([a["est_vn_mps"] - a["truth_vn_mps"], a["est_ve_mps"] - a["truth_ve_mps"],
                            a["est_vd_mps"] - a["truth_vd_mps"]])
    droll = _wrap(a["est_roll_rad"] - a["truth_roll_rad"])
    dpitch = _wrap(a["est_pitch_rad"] - a["truth_pitch_rad"])
    dyaw = _wrap(a["est_yaw_rad"] - a["truth_yaw_rad"])
    out["nav_pos_h_rms_m"] = float(np.sqrt(np.mean(eh[m] ** 2)))
    out["nav_pos_h_err_max_m"] = float(np.max(eh[m]))
    out["nav_pos_v_rms_m"] = float(np.sqrt(np.mean(ev[m] ** 2)))
    out["nav_vel_rms_mps"] = float(np.sqrt(np.mean(np.sum(evel[m] ** 2, axis=1))))
    out["nav_roll_pitch_rms_deg"] = float(np.degrees(np.sqrt(np.mean(np.concatenate([droll[m], dpitch[m]]) ** 2))))
    out["nav_yaw_rms_deg"] = float(np.degrees(np.sqrt(np.mean(dyaw[m] ** 2))))
    if np.isfinite(a["sig_pn_m"][m]).all():
        att = attitude_error_ned(a, m)
        errs = np.column_stack([en[m], ee[m], ev[m], evel[m], att])
        sig = np.column_stack([a[c][m] for c in ("sig_pn_m", "sig_pe_m", "sig_pd_m", "sig_vn_mps", "sig_ve_mps",
                                                 "sig_vd_mps", "sig_att_n_rad", "sig_att_e_rad", "sig_att_d_rad")])
        out["nav_consistency_3sigma"] = float(np.mean(np.all(np.abs(errs) <= 3.0 * sig, axis=1)))
    # the receiver's own error
    g = m & np.isfinite(a["gps_n_m"])
    if g.any():
        t = a["t_s"]
        tv = t[g] - gps_latency_s
        tn = np.interp(tv, t, a["truth_n_m"])
        te = np.interp(tv, t, a["truth_e_m"])
        out["gps_pos_h_rms_m"] = float(np.sqrt(np.mean((a["gps_n_m"][g] - tn) ** 2 + (a["gps_e_m"][g] - te) ** 2)))
    # GPS outages (scenario or MAVLink "gps off" ... "gps ok")
    outages = []
    start = None
    for r in fault_log:
        if r.unit != "gps":
            continue
        if r.type == "off" and start is None:
            start = r.at_s
        elif r.type == "ok" and start is not None:
            outages.append((start, r.at_s))
            start = None
    res = []
    t = a["t_s"]
    for s0, s1 in outages:
        i_end = min(np.searchsorted(t, s1), len(t) - 1)
        after = np.flatnonzero((t >= s1) & m & (eh < 3.0))
        res.append({"start_s": round(s0, 3), "end_s": round(s1, 3),
                    "pos_h_err_at_end_m": float(eh[i_end]),
                    "pos_h_err_max_m": float(np.max(eh[(t >= s0) & (t <= s1)])) if ((t >= s0) & (t <= s1)).any() else None,
                    "reconverge_s": float(t[after[0]] - s1) if after.size else None})
    out["gps_outages"] = res
    return out


# --- fault monitor (autopilot/monitor) ----------------------------------------------
FAULT_GRACE_S = 10.0   # a detection this soon after a fault's "ok" is its aftermath
DEPART_NORM = 0.02 / MAX_DEFLECTION_RAD   # a command this far from a stuck servo has left it (0.02 rad)


def _fault_spans(fault_log, end_s: float) -> list[tuple]:
    """(record, start_s, end_s) of every accepted non-"ok" injection; it lasts until
    the "ok" of its unit (and instance, for servo / motor) or the end of the run."""
    spans = []
    for i, r in enumerate(fault_log):
        if r.type == "ok" or not r.accepted:
            continue
        stop = end_s
        for q in fault_log[i + 1:]:
            if q.unit == r.unit and (q.unit not in ("servo", "motor") or q.instance == r.instance):
                stop = q.at_s
                break
        spans.append((r, r.at_s, stop))
    return spans


def fault_figures(fault_log, episodes, end_s: float, t_s=None, eh=None, h=None, ctl=None) -> dict:
    """``faults``: one entry per injected event with ``at_s``, ``unit``, ``type``,
    ``instance``, ``detected_s`` (start of the first monitor detection at or after the
    injection and before the fault ended, or one already running; null if none),
    ``delay_s``, ``isolated`` (channel named by that detection's episode, the most to
    blame), ``isolated_all`` (every channel the episode found over its isolation
    threshold at the isolation, or over its detection threshold later, the most to
    blame first) and ``isolated_s``, ``kind`` (the monitor's classification: sensor, inertial or
    actuator), ``identified`` (actuator fault parameters, latest estimate, e.g.
    ``{"effectiveness": 0.52}`` or ``{"stuck_rad": 0.049}``; null if none) and
    ``identified_10s`` (the estimate 10 s after the injection).
    ``ok`` events get ``cleared_s`` (end of the episode running at the ok, if any).
    ``false_alarms``: detections that start while no fault is active and not within
    FAULT_GRACE_S after one ended. With ``t_s``/``eh`` (horizontal estimate error per
    log sample): ``nav_pos_h_rms_during_fault_m`` over the sensor-fault spans. With
    ``h`` (true height above home per log sample) an actuator fault (servo, motor) gets
    ``height_at_onset_m`` and ``height_lost_m`` (that height less the lowest one until
    the fault ended or the flight did). With ``ctl`` (the commanded servo channels per
    log sample, normalised) a stuck servo gets ``departed_s``: seconds from the onset to
    the first command DEPART_NORM (0.02 rad of surface) or more away from where the
    servo is held, null if the command never left it (a surface stuck where it is
    being flown acts as commanded: nothing to detect until the command moves away),
    and ``delay_departed_s``, the detection that long after that departure (0 if
    before it)."""
    spans = _fault_spans(fault_log, end_s)
    out = []
    for r in fault_log:
        e = {"at_s": round(r.at_s, 3), "unit": r.unit, "type": r.type, "instance": r.instance,
             "detected_s": None, "delay_s": None, "isolated": None, "isolated_all": None,
             "isolated_s": None, "identified": None, "kind": None, "identified_10s": None}
        if r.type == "ok":
            e.pop("detected_s"), e.pop("delay_s")
            e["cleared_s"] = None
            for ep in episodes:
                if ep.start_s <= r.at_s + 1e-9 and (ep.end_s is None or ep.end_s >= r.at_s):
                    e["cleared_s"] = ep.end_s
        elif r.accepted:
            stop = next(s1 for q, _s0, s1 in spans if q is r)
            for ep in episodes:
                running = ep.start_s <= r.at_s and (ep.end_s is None or ep.end_s >= r.at_s)
                if running or r.at_s <= ep.start_s <= stop:
                    e["detected_s"] = ep.start_s
                    e["delay_s"] = round(max(ep.start_s - r.at_s, 0.0), 3)
                    e["isolated"] = ep.isolated
                    e["isolated_all"] = list(getattr(ep, "isolated_all", None) or
                                             ([ep.isolated] if ep.isolated else []))
                    e["isolated_s"] = ep.isolated_s
                    e["kind"] = getattr(ep, "kind", None)
                    e["identified"] = getattr(ep, "identified", None)
                    for t_id, ident in getattr(ep, "ident_log", None) or ():
                        if t_id <= r.at_s + 10.0 + 1e-9:
                            e["identified_10s"] = ident
                    break
            if ctl is not None and t_s is not None and r.unit == "servo" and r.type == "stuck" \
                    and r.instance < len(ctl) and len(t_s):
                i0 = int(np.searchsorted(t_s, r.at_s))
                i1 = int(np.searchsorted(t_s, stop, side="right"))
                cmd = np.asarray(ctl[r.instance][i0:i1], dtype=float)
                held = r.held if getattr(r, "held", None) is not None else (cmd[0] if len(cmd) else None)
                e["departed_s"] = e["delay_departed_s"] = None
                if held is not None:
                    away = np.flatnonzero(np.abs(cmd - held) >= DEPART_NORM)
                    if away.size:
                        t_dep = float(t_s[i0 + away[0]])
                        e["departed_s"] = round(t_dep - r.at_s, 3)
                        if e["detected_s"] is not None:
                            e["delay_departed_s"] = round(max(e["detected_s"] - t_dep, 0.0), 3)
            if h is not None and t_s is not None and r.unit in ("servo", "motor") and len(t_s):
                i0 = int(np.searchsorted(t_s, r.at_s))
                i1 = int(np.searchsorted(t_s, stop, side="right"))
                seg = h[i0:i1]
                seg = seg[np.isfinite(seg)]
                if len(seg):
                    e["height_at_onset_m"] = round(float(seg[0]), 2)
                    e["height_lost_m"] = round(float(seg[0] - seg.min()), 2)
        out.append(e)
    false_alarms = 0
    for ep in episodes:
        if not any(s0 <= ep.start_s <= s1 + FAULT_GRACE_S for _r, s0, s1 in spans):
            false_alarms += 1
    res = {"faults": out, "false_alarms": false_alarms,
           "fdi_episodes": [{"start_s": ep.start_s, "trigger": ep.trigger, "isolated": ep.isolated,
                             "isolated_s": ep.isolated_s, "end_s": ep.end_s} for ep in episodes]}
    if t_s is not None and eh is not None:
        m = np.zeros(len(t_s), dtype=bool)
        for r, s0, s1 in spans:
            if r.unit not in ("servo", "motor"):
                m |= (t_s >= s0) & (t_s <= s1)
        m &= np.isfinite(eh)
        res["nav_pos_h_rms_during_fault_m"] = float(np.sqrt(np.mean(eh[m] ** 2))) if m.any() else None
    return res


def okf_replay(cfg) -> float | None:
    """``nav_pos_h_rms_during_fault_okf_m``: the same run (same seed, scenario, mission)
    replayed with R adaptation off (FDI_RADAPT = 0), the plain EKF."""
    import dataclasses

    from .runner import Session
    cfg2 = dataclasses.replace(cfg, param_overrides={**cfg.param_overrides, "FDI_RADAPT": 0},
                               log_dir=None, progress=False, gcs=None)
    s = Session(cfg2)
    s.run()
    return run_summary(s).get("nav_pos_h_rms_during_fault_m")


# --- quadrotor (autopilot/vehicle_quad.py log) ---------------------------------------
QUAD_MOVE, QUAD_HOLD, QUAD_LAND = 2, 3, 4
QUAD_FLYING = (1, 2, 3, 4, 6)      # takeoff, move, hold, land, manual


def quad_figures(a: dict, home_truth_alt_m: float | None, home_est_alt_m: float | None) -> dict:
    """The quadrotor's figures, from truth in home's NED frame as the fixed-wing's:

    * ``xtrack_rms_m`` / ``xtrack_max_m``: horizontal distance of the true position from
      the straight leg being flown (from where the leg started to its goal; legs
      shorter than 1 m, e.g. vertical ones, are left out);
    * ``alt_rms_m``: true height above home against the reference height above home
      (the fixed-wing's convention: a constant navigation altitude offset at arming
      does not count), over legs and holds;
    * ``hold_pos_rms_m`` / ``hold_alt_rms_m``: horizontal distance from the hold point,
      and the height error as above, while a timed hold or loiter runs;
    * ``land_error_m``: horizontal distance of the touchdown (the true position when the
      skids reached the ground) from the land point (the last landing);
    * ``max_tilt_deg``: largest true tilt (angle of the body z axis from the vertical)
      in flight.

    These absolute figures include the navigation solution's own error (standard GPS:
    a few decimetres horizontally, wandering with a 60 s correlation time; see the nav_*
    figures).
    The ``*_ctl`` figures are the same quantities measured with the navigation solution
    instead of truth: what guidance and control achieve on the position they are given
    (for the hold and the landing, the difference is the navigation error)."""
    out: dict = {}
    armed = a["armed"] > 0
    kind = a["kind"]
    if not armed.any():
        return out
    tn, te = a["truth_n_m"], a["truth_e_m"]
    en, ee = a["est_n_m"], a["est_e_m"]
    gn, ge = a["goal_n_m"], a["goal_e_m"]

    def rms(x):
        return float(np.sqrt(np.mean(x ** 2)))

    # straight legs
    move = armed & (kind == QUAD_MOVE)
    dn, de = gn - a["leg_a_n_m"], ge - a["leg_a_e_m"]
    length = np.hypot(dn, de)
    ok = move & (length > 1.0)
    if ok.any():
        ln = np.where(ok, length, 1.0)
        xt = ((tn - a["leg_a_n_m"]) * (-de) + (te - a["leg_a_e_m"]) * dn) / ln
        out["xtrack_rms_m"] = rms(xt[ok])
        out["xtrack_max_m"] = float(np.max(np.abs(xt[ok])))
    else:
        out["xtrack_rms_m"] = out["xtrack_max_m"] = None
    # heights
    h_ok = home_truth_alt_m is not None and home_est_alt_m is not None
    dh = dh_ctl = None
    if h_ok:
        dh = (a["truth_alt_m"] - home_truth_alt_m) - (a["tgt_alt_m"] - home_est_alt_m)
        dh_ctl = a["est_alt_m"] - a["tgt_alt_m"]
    fly = armed & np.isin(kind, (QUAD_MOVE, QUAD_HOLD))
    out["alt_rms_m"] = rms(dh[fly]) if h_ok and fly.any() else None
    out["alt_max_err_m"] = float(np.max(np.abs(dh[fly]))) if h_ok and fly.any() else None
    # holds and loiters
    hold = armed & (a["hold"] > 0)
    if hold.any():
        out["hold_time_s"] = float(np.sum(np.diff(a["t_s"], prepend=a["t_s"][0])[hold]))
        out["hold_pos_rms_m"] = rms(np.hypot(tn - gn, te - ge)[hold])
        out["hold_pos_ctl_rms_m"] = rms(np.hypot(en - gn, ee - ge)[hold])
        out["hold_alt_rms_m"] = rms(dh[hold]) if h_ok else None
        out["hold_alt_ctl_rms_m"] = rms(dh_ctl[hold]) if h_ok else None
    else:
        out["hold_time_s"] = 0.0
        out["hold_pos_rms_m"] = out["hold_pos_ctl_rms_m"] = None
        out["hold_alt_rms_m"] = out["hold_alt_ctl_rms_m"] = None
    # the last landing: the touchdown is the first sample of the last descent at which
    # the true height has reached its final value (the vehicle stays put afterwards)
    land = np.flatnonzero(armed & (kind == QUAD_LAND))
    if land.size:
        gaps = np.flatnonzero(np.diff(land) > 1)
        if gaps.size:
            land = land[gaps[-1] + 1:]
        h = a["truth_alt_m"][land]
        down = np.flatnonzero(np.abs(h - h[-1]) < 0.01) if np.isfinite(h[-1]) else []
        i = land[down[0]] if len(down) else land[-1]
        out["land_error_m"] = float(math.hypot(tn[i] - gn[i], te[i] - ge[i]))
        out["land_error_ctl_m"] = float(math.hypot(en[i] - gn[i], ee[i] - ge[i]))
    else:
        out["land_error_m"] = out["land_error_ctl_m"] = None
    flying = armed & np.isin(kind, QUAD_FLYING)
    if flying.any():
        c = np.cos(a["truth_roll_rad"][flying]) * np.cos(a["truth_pitch_rad"][flying])
        out["max_tilt_deg"] = float(np.degrees(np.max(np.arccos(np.clip(c, -1.0, 1.0)))))
    else:
        out["max_tilt_deg"] = None
    return out


def fence_figures(v, a: dict) -> list[dict]:
    """The vehicle's fence breaches ({at_s, type, action, cleared_s}, autopilot/fence), each
    with ``truth_at_s``: the first flight-log row, from 5 s before the breach (or the end
    of the one before) to 2 s after, where the truth was outside an enabled fence (the
    same check, FENCE_ALT_MIN included, on the true position); null if none."""
    g = getattr(v, "geofence", None)
    if g is None or not g.breaches:
        return []
    hf, h0 = v.home_frame, getattr(v, "home_truth_alt_m", None)
    out = []
    prev_clear = -math.inf
    for b in g.breaches:
        b = dict(b)
        truth_at = None
        if hf is not None and h0 is not None and len(a["t_s"]):
            home = (math.degrees(hf.lat0_rad), math.degrees(hf.lon0_rad))
            t = a["t_s"]
            w = np.flatnonzero(np.isfinite(a["truth_n_m"]) & (t >= max(b["at_s"] - 5.0, prev_clear))
                               & (t <= b["at_s"] + 2.0))
            for k in w:
                lat, lon, _ = hf.to_geodetic_fast(np.array([a["truth_n_m"][k], a["truth_e_m"][k], 0.0]))
                d = g.distances(math.degrees(lat), math.degrees(lon), a["truth_alt_m"][k] - h0, home)
                if any(x > 0.0 for x in d.values()):
                    truth_at = round(float(t[k]), 3)
                    break
        b["truth_at_s"] = truth_at
        prev_clear = b["cleared_s"] if b["cleared_s"] is not None else math.inf
        out.append(b)
    return out


def terrain_figures(a: dict, mission, frame, terrain, home_truth_alt_m) -> dict:
    """``agl_min_m`` / ``agl_rms_err_m``: the true height above the terrain while a
    terrain-frame item (MAV_FRAME_GLOBAL_TERRAIN_ALT(_INT)) is flown, its lowest and its
    RMS error against the item's commanded height. The terrain is the simulator's (the
    ``--terrain`` tiles, else flat at the true home altitude). None without such items."""
    out = {"agl_min_m": None, "agl_rms_err_m": None}
    if mission is None or frame is None or not len(a["t_s"]):
        return out
    cmd = np.full(len(mission), np.nan)
    for it in mission.items[1:]:
        if it.frame in TERRAIN_FRAMES:
            cmd[it.seq] = it.z_alt_m
    if not np.isfinite(cmd).any():
        return out
    seq = a["seq"].astype(int)
    ok = (seq > 0) & (seq < len(mission)) & (a["armed"] > 0) & np.isfinite(a["truth_alt_m"])
    idx = np.flatnonzero(ok)
    idx = idx[np.isfinite(cmd[seq[idx]])]
    if not idx.size:
        return out
    ground = np.empty(idx.size)
    for k, i in enumerate(idx):
        h = None
        if terrain is not None:
            lat, lon, _ = frame.to_geodetic_fast((a["truth_n_m"][i], a["truth_e_m"][i], 0.0))
            h = terrain(math.degrees(lat), math.degrees(lon))
        ground[k] = h if h is not None else (home_truth_alt_m if home_truth_alt_m is not None
                                             else frame.alt0_m)
    agl = a["truth_alt_m"][idx] - ground
    err = agl - cmd[seq[idx]]
    out["agl_min_m"] = float(np.min(agl))
    out["agl_rms_err_m"] = float(np.sqrt(np.mean(err ** 2)))
    return out


def run_summary(session) -> dict:
    """summary.json of a finished in-process session (tools.runner.Session)."""
    v = session.vehicle
    a = session.log.arrays()
    seq = v.sequencer
    reached = len(seq.reached_seqs) if seq else 0
    total = seq.total_items if seq else max(len(session.mission) - 1, 0)
    # DO items a condition still held back when their navigation item ended, dropped
    # as AP_Mission drops them (the quad's sequencer says so in a STATUSTEXT)
    skipped = len(getattr(seq, "skipped_seqs", set()) - seq.reached_seqs) if seq else 0
    # completed: every mission item reached (or so skipped), then the end of the mission
    # flown (the RTL loiter established; the quad landed) -- an RTL or LAND commanded
    # halfway (a failsafe, a ground station) is not a completed mission
    ended = seq is not None and (seq.rtl_established or getattr(seq, "land_complete", False))
    completed = bool(seq is not None and seq.finished and ended and not session.crashed
                     and reached + skipped >= total)
    home_est = v.home_frame.alt0_m if v.home_frame is not None else None
    if session.cfg.vehicle == "quad":
        figs = quad_figures(a, v.home_truth_alt_m, home_est)
    else:
        figs = flight_figures(a, v.home_truth_alt_m, home_est)
    sim_time = session.t_s
    wall = session.wall_loop_s
    s = {
        "vehicle": session.cfg.vehicle,
        "airframe": session.cfg.airframe,
        "nav_source": v.nav_source,
        "gps": session.cfg.gps,
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
        # geofence breaches (autopilot/fence): when, which fence, the action, when cleared,
        # and when the truth crossed the fence (scoring the detection on the estimate)
        "fence_breaches": fence_figures(v, a),
        "faults_injected": [
            {"at_s": round(r.at_s, 3), "unit": r.unit, "type": r.type, "instance": r.instance,
             "accepted": r.accepted, "source": r.source} for r in session.bridge.fault_log],
    }
    s.update(figs)
    score = getattr(session, "landing_score", None)
    s["landing"] = score.figures(v) if score is not None else None
    latency = session.params["EK_GPS_DELAY"] if "EK_GPS_DELAY" in session.params else 0.15
    s.update(nav_figures(a, latency, session.bridge.fault_log))
    mon = getattr(v, "monitor", None)
    if mon is not None and len(a["t_s"]):
        eh = np.hypot(a["est_n_m"] - a["truth_n_m"], a["est_e_m"] - a["truth_e_m"])
        home = getattr(v, "home_truth_alt_m", None)
        h = a["truth_alt_m"] - home if home is not None else None
        ctl = tuple(a[k] for k in ("ctl_aileron", "ctl_elevator", "ctl_rudder", "ctl_throttle")) \
            if "ctl_elevator" in a else None
        s.update(fault_figures(session.bridge.fault_log, mon.episodes, sim_time, a["t_s"], eh, h, ctl))
        # the healthy margin: largest detection statistic / threshold per channel while
        # no fault was detected (> 1 would have been a detection)
        s["fdi_peak_ratio"] = {k: round(v, 3) for k, v in sorted(getattr(mon, "peaks", {}).items())}
    s.update(terrain_figures(a, v.mission if v.mission is not None else session.mission,
                             v.home_frame, getattr(session, "terrain", None), v.home_truth_alt_m))
    # the cross-track error against the mission as written, and the flight invariants
    # (tools/invariants.py)
    from .invariants import run_invariants
    mission_figs, invariants = run_invariants(session, s, a)
    s.update(mission_figs)
    s["invariants"] = invariants
    s["invariants_passed"] = all(i["passed"] for i in invariants.values())
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
            "xtrack_rms_m", "xtrack_max_m", "xtrack_mission_rms_m", "xtrack_mission_max_m",
            "invariants_passed", "alt_rms_m", "airspeed_rms_mps",
            "hold_pos_rms_m", "hold_alt_rms_m", "land_error_m", "max_tilt_deg",
            "nav_pos_h_rms_m", "gps_pos_h_rms_m", "nav_pos_v_rms_m", "nav_vel_rms_mps",
            "nav_roll_pitch_rms_deg", "nav_yaw_rms_deg", "nav_consistency_3sigma"]
    lines = [f"{k:>24}: {_fmt(s.get(k))}" for k in keys if k in s]
    rest = [k for k in sorted(s) if k not in keys and not isinstance(s[k], (list, dict))]
    lines += [f"{k:>24}: {_fmt(s[k])}" for k in rest]
    return "\n".join(lines)
