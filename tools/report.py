"""``sitl report RUN_DIR``: PNG pictures of a run.

* ``track.png``     top view of the true track and the estimate over the waypoints
* ``alt_speed.png`` altitude and airspeed against their targets
* ``xtrack.png``    cross-track error on the straight legs (counted part highlighted)
* ``nav_error.png`` estimate error of each state with its +-3 sigma bound (when the
                    log carries the filter's sigmas)

Quadrotor runs: ``track.png``, ``alt.png`` (height, distance from the reference and the
hold points), ``attitude.png`` (roll, pitch, yaw against the attitude loops'
references), ``motors.png`` (the four motor commands and the effective inputs of eq
3.30) and ``nav_error.png``.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np


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
    ax.set_title(f"xtrack RMS {summary.get('xtrack_rms_m')}, max {summary.get('xtrack_max_m')}")
    ax.legend()
    ax.grid(True, alpha=0.3)
    p = run_dir / "xtrack.png"
    fig.savefig(p, dpi=110, bbox_inches="tight")
    plt.close(fig)
    out.append(p)

    if "sig_pn_m" in a:
        out.append(_nav_error(plt, run_dir, a, armed))
    return out


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
    return out


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
