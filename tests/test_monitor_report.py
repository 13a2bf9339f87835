"""``sitl report``'s fault-monitor picture (tools/report.py ``fault_monitor_picture``):
GIVEN a flight log with the monitor's columns, THEN fdi.png is drawn with the statistics
against their thresholds, the detected span, the injections and the Q-fading span."""
from __future__ import annotations

import numpy as np

from autopilot.monitor import LOG_COLUMNS


def test_fdi_picture_from_the_monitor_columns(tmp_path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from tools.report import _event_spans, _spans, fault_monitor_picture
    t = np.arange(0.0, 60.0, 0.1)
    a = {"t_s": t}
    for c in LOG_COLUMNS:
        a[c] = np.full_like(t, 0.3)
    on = (t >= 20.0) & (t < 35.0)
    a["fdi_detected"] = on.astype(float)
    a["fdi_gps_pos"] = np.where(on, 12.0, 0.3)
    a["fdi_rscale_gps"] = np.where(on, 40.0, 1.0)
    a["event_t_s"] = np.array([20.0, 21.0, 30.0, 35.0])
    a["event_text"] = np.array(["FDI: fault detected on gps_vel", "FDI: velocity innovations drift: "
                                "inertial fault suspected, gyro bias fading on (Q adaptation)",
                                "FDI: gyro bias absorbed, fading off", "FDI: fault cleared (gyro_y)"])
    assert _spans(t, on) == [(t[200], t[350])]
    assert _event_spans(a, "fading on", ("fading off",), 60.0) == [(21.0, 30.0)]
    summary = {"faults_injected": [{"at_s": 20.0, "unit": "gps", "type": "garbage", "instance": 0},
                                   {"at_s": 30.0, "unit": "gps", "type": "ok", "instance": 0}],
               "false_alarms": 0}
    p = fault_monitor_picture(plt, tmp_path, a, summary)
    assert p == tmp_path / "fdi.png" and p.stat().st_size > 20_000


def test_quad_fdi_picture_from_the_motor_monitor_columns(tmp_path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from tools.report import _quad_fdi_picture
    # GIVEN the motor monitor's columns of a quad flight log (autopilot/vehicle_quad.py)
    t = np.arange(0.0, 30.0, 0.016)
    on = t >= 10.0
    a = {"t_s": t, "fdi_motor_det": np.where(on, 9.0, 0.1), "fdi_motor_iso": np.where(on, 90.0, 0.01),
         "fdi_gamma_1": np.where(on, 0.72, 1.0), "fdi_motor_lam": np.where((t > 10) & (t < 11), 80.0, 1.0)}
    for k in (2, 3, 4):
        a[f"fdi_gamma_{k}"] = np.ones_like(t)
    summary = {"faults_injected": [{"at_s": 10.0, "unit": "motor", "type": "wrong", "instance": 0}],
               "faults": [{"isolated": "motor_1", "identified": {"effectiveness": 0.72}}]}
    # THEN fdi.png is drawn
    p = _quad_fdi_picture(plt, tmp_path, a, summary)
    assert p == tmp_path / "fdi.png" and p.stat().st_size > 20_000


def test_innovation_log_columns_and_picture(tmp_path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from autopilot.nav.records import InnovationLog, InnovationRecord
    from tools.report import innovations_picture
    # GIVEN GPS position records with a 5-sigma gate, one of them rejected
    log = InnovationLog()
    for k in range(50):
        y = np.array([0.3, -0.2, 3.0 if k == 10 else 0.1])
        S = np.array([0.25, 0.25, 0.04])
        tr = y * y / (25.0 * S)
        yt = tuple(y.tolist())
        log.add([InnovationRecord(k * 200_000, "gps_pos", yt, yt, tuple(S.tolist()), tuple(tr.tolist()),
                                  bool(tr.max() > 1.0), True)])
    a = log.arrays()
    # THEN one row per component, the gate recovered from the test ratio, rejected marked
    assert len(a["innov_t_s"]) == 150
    assert np.allclose(a["innov_gate"], 5.0) and np.allclose(a["innov_sd"][:3], (0.5, 0.5, 0.2))
    assert a["innov_rejected"].sum() == 3 and a["innov_value"][32] == 3.0
    p = innovations_picture(plt, tmp_path, a)
    assert p == tmp_path / "innovations.png" and p.stat().st_size > 20_000
