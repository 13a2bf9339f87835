"""``sitl report RUN_DIR``: PNG pictures of a run.

* ``track.png``     top view of the true track and the estimate over the waypoints and
                    the mission's lines as written (what xtrack_mission_* scores)
* ``alt_speed.png`` altitude and airspeed against their targets
* ``xtrack.png``    cross-track error on the straight legs (counted part highlighted)
* ``nav_error.png`` estimate error of each state with its +-3 sigma bound (when the
                    log carries the filter's sigmas)
* ``innovations.png`` every fused measurement's innovation against +-gate x sqrt(S)
* ``fdi.png``       the fault monitor (autopilot/monitor, LOG_COLUMNS there): each
                    statistic divided by its chi-square threshold (1 = threshold) and
                    the noise scale factor over time, injected faults, detected
                    episodes and Q-fading spans marked (seed figs 2.3-2.5, 2.12-2.17)

Quadrotor runs: ``track.png``, ``alt.png`` (height, distance from the reference and the
hold points), ``attitude.png`` (roll, pitch, yaw against the attitude loops'
references), ``motors.png`` (the four motor commands and the effective inputs of eq
3.30), ``nav_error.png`` and ``fdi.png`` (the motor fault monitor).
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np


def _num(v) -> str:
    return f"{v:.2f}" if isinstance(v, (int, float)) else str(v)


def _load(run_dir: Path) -> dict:
    with np.load(run_dir / "flight.npz", allow_pickle=False) as z:
        return {k: z[k] for k in z.files}


def make_report(run_dir: Path) -> list[Path]:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .summary import leg_xtrack

    if (run_dir / "formation.npz").exists() and not (run_dir / "flight.npz").exists():
        return formation_pictures(plt, run_dir)
    a = _load(run_dir)
    summary = {}
    if (run_dir / "summary.json").exists():
        summary = json.loads((run_dir / "summary.json").read_text())
    out = []
    t = a["t_s"]
    armed = a["armed"] > 0

    fig, ax = plt.subplots(figsize=(8, 8))
    ax.plot(a["truth_e_m"][armed], a["truth_n_m"][armed], lw=1.2, label="true track")
    ax.plot(a["est_e_m"][armed], a["est_n_m"][armed], lw=0.6, ls="--", label="estimate")
    lines = a.get("mission_lines")
    if lines is not None and len(lines):
        # the mission as written: the lines xtrack_mission_* are scored against
        for k, (_seq, an, ae, bn, be) in enumerate(lines):
            ax.plot([ae, be], [an, bn], color="k", lw=0.8, ls=":",
                    label="mission lines (as written)" if k == 0 else None)
    wp = a.get("mission_wp")
    if wp is not None and len(wp):
        ax.plot(wp[:, 2], wp[:, 1], "k^", ms=7, label="mission items")
        for seq, n, e in wp:
            ax.annotate(str(int(seq)), (e, n), textcoords="offset points", xytext=(5, 5))
    ax.plot([0], [0], "rs", label="home")
    ax.set_xlabel("east of home [m]")
    ax.set_ylabel("north of home [m]")
    ax.set_aspect("equal", "datalim")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best")
    ax.set_title(f"Track ({summary.get('nav_source', '?')} navigation, seed {summary.get('seed', '?')})")
    p = run_dir / "track.png"
    fig.savefig(p, dpi=110, bbox_inches="tight")
    plt.close(fig)
    out.append(p)

    if "motor_1" in a:           # the quadrotor's log (autopilot/vehicle_quad.py)
        out += _quad_pictures(plt, run_dir, a, armed, summary)
        if "sig_pn_m" in a:
            out.append(_nav_error(plt, run_dir, a, armed))
        return out

    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(10, 7), sharex=True)
    ax1.plot(t[armed], a["truth_alt_m"][armed], label="true altitude")
    ax1.plot(t[armed], a["tgt_alt_m"][armed], "--", label="target")
    ax1.set_ylabel("altitude MSL [m]")
    ax1.legend()
    ax1.grid(True, alpha=0.3)
    ax2.plot(t[armed], a["truth_airspeed_mps"][armed], label="true airspeed")
    ax2.plot(t[armed], a["tgt_airspeed_mps"][armed], "--", label="target")
    ax2.set_ylabel("airspeed [m/s]")
    ax2.set_xlabel("time [s]")
    ax2.legend()
    ax2.grid(True, alpha=0.3)
    p = run_dir / "alt_speed.png"
    fig.savefig(p, dpi=110, bbox_inches="tight")
    plt.close(fig)
    out.append(p)

    xt, use = leg_xtrack(a)
    fig, ax = plt.subplots(figsize=(10, 4))
    ax.plot(t, xt, lw=0.6, color="0.6", label="all straight-leg samples")
    ax.plot(t[use], xt[use], ".", ms=1.5, label="counted (after capture)")
    ax.axhline(0, color="k", lw=0.5)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("cross-track error [m]")
    ax.set_title(f"xtrack RMS {_num(summary.get('xtrack_rms_m'))}, max {_num(summary.get('xtrack_max_m'))} m "
                 f"(flown legs); against the mission's lines RMS "
                 f"{_num(summary.get('xtrack_mission_rms_m'))}, max {_num(summary.get('xtrack_mission_max_m'))} m")
    ax.legend()
    ax.grid(True, alpha=0.3)
    p = run_dir / "xtrack.png"
    fig.savefig(p, dpi=110, bbox_inches="tight")
    plt.close(fig)
    out.append(p)

    if "sig_pn_m" in a:
        out.append(_nav_error(plt, run_dir, a, armed))
    if "fdi_gps_pos" in a:
        out.append(fault_monitor_picture(plt, run_dir, a, summary))
    if "innov_t_s" in a and len(a["innov_t_s"]):
        out.append(innovations_picture(plt, run_dir, a))
    return out


_INNOV_PANELS = (("gps_pos", 0, "GPS position N [m]"), ("gps_pos", 1, "GPS position E [m]"),
                 ("gps_pos", 2, "GPS position D [m]"), ("gps_vel", 0, "GPS velocity N [m/s]"),
                 ("gps_vel", 1, "GPS velocity E [m/s]"), ("gps_vel", 2, "GPS velocity D [m/s]"),
                 ("baro", 0, "baro altitude [m]"), ("mag", 0, "magnetic heading [rad]"),
                 ("airspeed", 0, "airspeed [m/s]"), ("sideslip", 0, "sideslip (body-y air velocity) [m/s]"))


def innovations_picture(plt, run_dir: Path, a: dict) -> Path:
    """``innovations.png``: every fused measurement's innovation (autopilot/nav/records.py,
    the flight log's ``innov_*`` columns) against its gate, +-gate x sqrt(S) (the
    filter's innovation standard deviation times the gate in standard deviations);
    rejected measurements in red."""
    from autopilot.nav.records import SOURCES
    t, src, comp = a["innov_t_s"], a["innov_source"], a["innov_comp"]
    y, sd, gate, rej = a["innov_value"], a["innov_sd"], a["innov_gate"], a["innov_rejected"] > 0
    fig, axes = plt.subplots(5, 2, figsize=(13, 13), sharex=True)
    for ax, (name, k, label) in zip(axes.T.ravel(), _INNOV_PANELS):
        m = (src == SOURCES.index(name)) & (comp == k)
        if m.any():
            ax.plot(t[m], y[m], ".", ms=1.2, color="tab:blue", label="innovation")
            g = np.nan_to_num(gate[m], nan=0.0)
            ax.plot(t[m], g * sd[m], lw=0.7, color="k", label="+- gate x sqrt(S)")
            ax.plot(t[m], -g * sd[m], lw=0.7, color="k")
            r = m & rej
            if r.any():
                ax.plot(t[r], y[r], "x", ms=3, color="red", label=f"rejected ({int(r.sum())})")
            ax.legend(loc="upper right", fontsize=6)
        ax.set_title(label, fontsize=9)
        ax.grid(True, alpha=0.3)
    for ax in axes[-1]:
        ax.set_xlabel("time [s]")
    fig.suptitle("Navigation filter innovations against their gates", fontsize=11)
    p = run_dir / "innovations.png"
    fig.savefig(p, dpi=100, bbox_inches="tight")
    plt.close(fig)
    return p


def _spans(t: np.ndarray, on: np.ndarray) -> list[tuple[float, float]]:
    """(start, end) times of the runs of True in ``on``."""
    spans, start = [], None
    for ti, x in zip(t, on):
        if x and start is None:
            start = ti
        elif not x and start is not None:
            spans.append((start, ti))
            start = None
    if start is not None:
        spans.append((start, t[-1]))
    return spans


def _event_spans(a: dict, on_text: str, off_texts: tuple, end_s: float) -> list[tuple[float, float]]:
    """Spans between an event whose text contains ``on_text`` and the next one
    containing any of ``off_texts`` (the monitor's STATUSTEXT-ready events)."""
    if "event_t_s" not in a:
        return []
    spans, start = [], None
    for ti, text in zip(a["event_t_s"], a["event_text"]):
        text = str(text)
        if start is None and on_text in text:
            start = float(ti)
        elif start is not None and any(o in text for o in off_texts):
            spans.append((start, float(ti)))
            start = None
    if start is not None:
        spans.append((start, end_s))
    return spans


def fault_monitor_picture(plt, run_dir: Path, a: dict, summary: dict) -> Path:
    """``fdi.png``: the monitor's statistics against their thresholds, as logged
    (LOG_COLUMNS of autopilot/monitor/monitor.py: every statistic is already divided by
    its threshold, so the threshold is the line at 1):

    1. the window detection statistic beta (2.12) of each aiding channel (a silent
       channel logs age / FDI_TOUT);
    2. the gyro bias-change statistics (gyro_x|y|z);
    3. the largest per-step statistic chi (2.41-2.43) and the largest isolation
       statistic gamma (2.16-2.17);
    4. the largest R noise scale factor applied to gps_pos (MMNSF, 2.30-2.34) and the
       spans where the gyro-bias Q fading (2.35-2.40) was on.

    Injected faults are dashed vertical lines (red: a fault, green: its ``ok``);
    detected episodes are shaded."""
    t = a["t_s"]
    end_s = float(t[-1]) if len(t) else 0.0
    fig, axes = plt.subplots(4, 1, figsize=(12, 12), sharex=True)
    floor = 1e-3

    def show(ax, col, label, **kw):
        ax.plot(t, np.maximum(a[col], floor), lw=0.8, label=label, **kw)

    for col, lab in (("fdi_gps_pos", "gps_pos"), ("fdi_gps_vel", "gps_vel"), ("fdi_baro", "baro"),
                     ("fdi_mag", "mag"), ("fdi_airspeed", "airspeed")):
        show(axes[0], col, lab)
    axes[0].set_ylabel("beta / chi2_{a,Ms}")
    axes[0].set_title("window detection statistic (2.12) / threshold, per aiding channel")
    for col, lab in (("fdi_gyro_x", "gyro_x"), ("fdi_gyro_y", "gyro_y"), ("fdi_gyro_z", "gyro_z")):
        show(axes[1], col, lab)
    axes[1].set_ylabel("gamma_b / chi2_{a_B,1}")
    axes[1].set_title("gyro bias-change statistic / threshold")
    show(axes[2], "fdi_step_max", "largest per-step statistic chi (2.41) / chi2_{a,s}", alpha=0.5)
    show(axes[2], "fdi_iso_max", "largest isolation statistic (2.17) / its threshold")
    axes[2].set_ylabel("statistic / threshold")
    for ax in axes[:3]:
        ax.set_yscale("log")
        ax.axhline(1.0, color="k", lw=1.0, ls="-", label="threshold")
        ax.legend(loc="upper right", fontsize=7, ncol=3)
    axes[3].plot(t, a["fdi_rscale_gps"], lw=0.9, label="largest R scale factor, gps_pos (MMNSF)")
    for k, (s0, s1) in enumerate(_event_spans(a, "fading on", ("fading off", "absorbed", "cleared"), end_s)):
        axes[3].axvspan(s0, s1, color="tab:orange", alpha=0.25, lw=0,
                        label="gyro-bias Q fading on" if k == 0 else None)
    axes[3].set_ylabel("scale factor")
    axes[3].set_yscale("log")
    axes[3].legend(loc="upper right", fontsize=7)
    axes[3].set_xlabel("time [s]")
    for ax in axes:
        for s0, s1 in _spans(t, a["fdi_detected"] > 0):
            ax.axvspan(s0, s1, color="0.85", lw=0, zorder=0)
        for f in summary.get("faults_injected", ()):
            ax.axvline(f["at_s"], color="green" if f["type"] == "ok" else "red", ls="--", lw=0.8)
        ax.grid(True, alpha=0.3)
    faults = [f"{f['unit']} {f['type']} at {f['at_s']:g} s" for f in summary.get("faults_injected", ())]
    fig.suptitle("Fault monitor (grey: fault detected; dashed: injections)"
                 + (": " + ", ".join(faults) if faults else "")
                 + f"; false_alarms {summary.get('false_alarms', '?')}", fontsize=10)
    p = run_dir / "fdi.png"
    fig.savefig(p, dpi=100, bbox_inches="tight")
    plt.close(fig)
    return p


def _quad_pictures(plt, run_dir: Path, a: dict, armed: np.ndarray, summary: dict) -> list[Path]:
    """Quadrotor: ``alt.png`` height against its reference; ``attitude.png`` roll,
    pitch and yaw (true and estimated) against the references of the attitude loops;
    ``motors.png`` the four motor commands and the total thrust command."""
    t = a["t_s"]
    out = []
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(10, 7), sharex=True)
    ax1.plot(t[armed], a["truth_alt_m"][armed], label="true altitude")
    ax1.plot(t[armed], a["est_alt_m"][armed], lw=0.6, label="estimate")
    ax1.plot(t[armed], a["tgt_alt_m"][armed], "--", label="reference")
    ax1.set_ylabel("altitude MSL [m]")
    ax1.legend()
    ax1.grid(True, alpha=0.3)
    hold = armed & (a["hold"] > 0)
    ax2.plot(t[armed], np.hypot(a["truth_n_m"] - a["tgt_n_m"], a["truth_e_m"] - a["tgt_e_m"])[armed],
             lw=0.6, label="true distance from the reference")
    ax2.plot(t[hold], np.hypot(a["truth_n_m"] - a["goal_n_m"], a["truth_e_m"] - a["goal_e_m"])[hold],
             ".", ms=1.5, label="from the hold point (holds)")
    ax2.set_ylabel("horizontal [m]")
    ax2.set_xlabel("time [s]")
    ax2.set_title(f"hold_pos_rms_m {_fmt(summary.get('hold_pos_rms_m'))}, "
                  f"land_error_m {_fmt(summary.get('land_error_m'))}")
    ax2.legend()
    ax2.grid(True, alpha=0.3)
    p = run_dir / "alt.png"
    fig.savefig(p, dpi=110, bbox_inches="tight")
    plt.close(fig)
    out.append(p)

    fig, axes = plt.subplots(3, 1, figsize=(11, 9), sharex=True)
    for ax, name in zip(axes, ("roll", "pitch", "yaw")):
        series = [a[f"truth_{name}_rad"][armed], a[f"est_{name}_rad"][armed], a[f"cmd_{name}_rad"][armed]]
        if name == "yaw":        # continuous through +-180 deg, all on the truth's branch
            base = np.unwrap(np.nan_to_num(series[0]))
            series = [base] + [base + (s_ - series[0] + np.pi) % (2 * np.pi) - np.pi for s_ in series[1:]]
        ax.plot(t[armed], np.degrees(series[0]), lw=0.8, label="true")
        ax.plot(t[armed], np.degrees(series[1]), lw=0.6, ls=":", label="estimate")
        ax.plot(t[armed], np.degrees(series[2]), "--", lw=0.8, label="reference")
        ax.set_ylabel(f"{name} [deg]")
        ax.grid(True, alpha=0.3)
    axes[0].legend(loc="upper right")
    axes[0].set_title(f"Attitude against its references (max tilt {_fmt(summary.get('max_tilt_deg'))} deg)")
    axes[-1].set_xlabel("time [s]")
    p = run_dir / "attitude.png"
    fig.savefig(p, dpi=110, bbox_inches="tight")
    plt.close(fig)
    out.append(p)

    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(11, 7), sharex=True)
    names = ("1 aft", "2 left", "3 front", "4 right")
    for k in range(4):
        ax1.plot(t[armed], a[f"motor_{k + 1}"][armed], lw=0.7, label=f"motor {names[k]}")
    ax1.set_ylabel("command 0..1")
    ax1.set_ylim(-0.02, 1.02)
    ax1.legend(loc="upper right", ncol=4)
    ax1.grid(True, alpha=0.3)
    ax2.plot(t[armed], a["cmd_thrust_n"][armed], lw=0.7, label="total thrust u_z [N]")
    for col, lab in (("u_roll_n", "u_phi"), ("u_pitch_n", "u_theta"), ("u_yaw_n", "u_psi")):
        ax2.plot(t[armed], 10.0 * a[col][armed], lw=0.6, label=f"10 x {lab} [N]")
    ax2.set_xlabel("time [s]")
    ax2.legend(loc="upper right", ncol=4)
    ax2.grid(True, alpha=0.3)
    p = run_dir / "motors.png"
    fig.savefig(p, dpi=110, bbox_inches="tight")
    plt.close(fig)
    out.append(p)
    if "fdi_motor_det" in a:
        out.append(_quad_fdi_picture(plt, run_dir, a, summary))
    return out


def _quad_fdi_picture(plt, run_dir: Path, a: dict, summary: dict) -> Path:
    """``fdi.png`` of a quadrotor run: the motor fault monitor (autopilot/monitor/
    motors.py) -- its window detection statistic (2.12) and isolation statistic over
    their thresholds, the four rotor effectiveness estimates of the second stage, and
    the fading factor lambda of the Q adaptation (2.35-2.40)."""
    t = a["t_s"]
    fig, axes = plt.subplots(3, 1, figsize=(11, 9), sharex=True)
    axes[0].plot(t, np.maximum(a["fdi_motor_det"], 1e-3), lw=0.8, label="moment residual, window statistic")
    axes[0].plot(t, np.maximum(a["fdi_motor_iso"], 1e-3), lw=0.8, label="isolation: (k_j - mean of the others)^2 / (4/3 P_jj), largest")
    axes[0].axhline(1.0, color="k", lw=1.0, label="threshold")
    axes[0].set_yscale("log")
    axes[0].set_ylabel("statistic / threshold")
    axes[0].legend(loc="upper right", fontsize=7)
    names = ("1 aft", "2 left", "3 front", "4 right")
    for k in range(4):
        axes[1].plot(t, a[f"fdi_gamma_{k + 1}"], lw=0.8, label=f"k rotor {names[k]}")
    axes[1].set_ylabel("rotor effectiveness")
    axes[1].legend(loc="lower left", ncol=4, fontsize=7)
    axes[2].plot(t, a["fdi_motor_lam"], lw=0.8, label="fading factor lambda")
    axes[2].set_yscale("log")
    axes[2].set_ylabel("lambda")
    axes[2].set_xlabel("time [s]")
    axes[2].legend(loc="upper right", fontsize=7)
    for ax in axes:
        for f in summary.get("faults_injected", ()):
            ax.axvline(f["at_s"], color="green" if f["type"] == "ok" else "red", ls="--", lw=0.8)
        ax.grid(True, alpha=0.3)
    faults = [f"{f['unit']} {f['type']} {f['instance']} at {f['at_s']:g} s"
              for f in summary.get("faults_injected", ())]
    ident = [f"{f.get('isolated')}: {f.get('identified')}" for f in summary.get("faults", ())
             if f.get("identified")]
    fig.suptitle("Motor fault monitor" + (": " + ", ".join(faults) if faults else "")
                 + ("; " + ", ".join(ident) if ident else ""), fontsize=10)
    p = run_dir / "fdi.png"
    fig.savefig(p, dpi=100, bbox_inches="tight")
    plt.close(fig)
    return p


def _fmt(v) -> str:
    return f"{v:.3f}" if isinstance(v, float) else str(v)


def _nav_error(plt, run_dir: Path, a: dict, armed: np.ndarray) -> Path:
    t = a["t_s"]
    rows = [
        ("north [m]", a["est_n_m"] - a["truth_n_m"], a["sig_pn_m"]),
        ("east [m]", a["est_e_m"] - a["truth_e_m"], a["sig_pe_m"]),
        ("alt [m]", a["est_alt_m"] - a["truth_alt_m"], a["sig_pd_m"]),
        ("v north [m/s]", a["est_vn_mps"] - a["truth_vn_mps"], a["sig_vn_mps"]),
        ("v east [m/s]", a["est_ve_mps"] - a["truth_ve_mps"], a["sig_ve_mps"]),
        ("v down [m/s]", a["est_vd_mps"] - a["truth_vd_mps"], a["sig_vd_mps"]),
        ("attitude N [deg]", None, np.degrees(a["sig_att_n_rad"])),
        ("attitude E [deg]", None, np.degrees(a["sig_att_e_rad"])),
        ("attitude D (yaw) [deg]", None, np.degrees(a["sig_att_d_rad"])),
    ]
    from .summary import attitude_error_ned
    att = np.full((len(t), 3), np.nan)
    att[armed] = np.degrees(attitude_error_ned(a, armed))
    rows = [(n, att[:, k - 6] if e is None else e, sg) for k, (n, e, sg) in enumerate(rows)]
    fig, axes = plt.subplots(3, 3, figsize=(14, 9), sharex=True)
    for ax, (name, err, sig) in zip(axes.flat, rows):
        ax.plot(t[armed], err[armed], lw=0.7)
        ax.plot(t[armed], 3 * sig[armed], "r--", lw=0.6)
        ax.plot(t[armed], -3 * sig[armed], "r--", lw=0.6)
        ax.set_title(name)
        ax.grid(True, alpha=0.3)
    fig.suptitle("Estimate error (attitude: NED rotation vector) and +-3 sigma")
    p = run_dir / "nav_error.png"
    fig.savefig(p, dpi=100, bbox_inches="tight")
    plt.close(fig)
    return p


def _wrap(x):
    return (x + np.pi) % (2 * np.pi) - np.pi


def formation_pictures(plt, run_dir: Path) -> list[Path]:
    """``sitl formation`` run folders: the 3-D paths (seed figs 3.7, 3.9) and the
    constrained distances over time (figs 3.8, 3.10)."""
    with np.load(run_dir / "formation.npz", allow_pickle=False) as z:
        t, P, pairs, final = z["t_s"], z["p_ned"], z["pairs"], z["final_ned"]
        roles = [str(r) for r in z["roles"]]
        t0 = float(z["formation_start_s"])
    colours = {"leader": "red", "first": "blue", "second": "green"}
    fig = plt.figure(figsize=(8, 7))
    ax = fig.add_subplot(projection="3d")
    for k in range(P.shape[1]):
        c = colours.get(roles[k], "grey")
        # x north, y east, up = -down (the seed's axes, with altitude up)
        ax.plot(P[:, k, 0], P[:, k, 1], -P[:, k, 2], color=c, lw=1.2)
        ax.scatter(P[0, k, 0], P[0, k, 1], -P[0, k, 2], color=c, marker="o", s=14)
        ax.scatter(final[k, 0], final[k, 1], -final[k, 2], color=c, marker="x", s=30)
        ax.text(P[-1, k, 0], P[-1, k, 1], -P[-1, k, 2], str(k + 1), fontsize=8)
    ax.set_xlabel("north [m]")
    ax.set_ylabel("east [m]")
    ax.set_zlabel("up [m]")
    ax.set_title("formation paths (o start, x desired final; red leader, blue first, green second)")
    p1 = run_dir / "formation_paths.png"
    fig.savefig(p1, dpi=110)
    plt.close(fig)
    fig, ax = plt.subplots(figsize=(9, 5))
    for a, b, d in pairs:
        dd = np.linalg.norm(P[:, int(a) - 1] - P[:, int(b) - 1], axis=1)
        ax.plot(t, dd, lw=1.0, label=f"|p{int(a)} - p{int(b)}| (d = {d:g} m)")
    ax.axvline(t0, color="k", ls=":", lw=0.8)
    ax.axvline(t0 + 5.0, color="k", ls="--", lw=0.8)
    ax.set_xlabel("time [s] (dotted: formation start; dashed: figures from here)")
    ax.set_ylabel("distance [m]")
    ax.set_title("constrained distances")
    if len(pairs) <= 12:
        ax.legend(fontsize=7, ncol=3)
    p2 = run_dir / "formation_distances.png"
    fig.savefig(p2, dpi=110)
    plt.close(fig)
    return [p1, p2]
