"""The c172p's elevator watched from the climb-out on, with its own model as the prior
(FDI_EL_MODEL 2 in missions/params/c172p.parm; autopilot/monitor/airframe.py C172P):
no alarm on its circuit (nor on its throttle's: tests/test_monitor_throttle_c172p.py),
and an elevator stuck in the climb-out found within seconds."""
from __future__ import annotations

from pathlib import Path

from tools.runner import MISSIONS_DIR, RunConfig, Session
from tools.summary import run_summary

CIRCUIT = MISSIONS_DIR / "c172p_circuit.waypoints"
STUCK = MISSIONS_DIR / "fault_elevator_stuck_c172p.toml"


def _fly(duration_s: float, scenario: Path | None = None, **params) -> tuple[Session, dict]:
    s = Session(RunConfig(airframe="c172p", mission=CIRCUIT, scenario=scenario, seed=1,
                          duration_s=duration_s, param_overrides=params))
    s.run()
    return s, run_summary(s)


def test_c172p_circuit_raises_no_elevator_alarm_with_its_model(flown):
    # GIVEN the c172p's circuit (take-off, full-throttle climb-out, turns, the descent),
    #       its parameter file giving the monitor the c172p's model (the flight whose first
    #       70 s tests/test_crash_detect.py checks: flown once, tests/conftest.py)
    s, summ = flown(RunConfig(airframe="c172p", mission=CIRCUIT, seed=1, duration_s=300.0), across_files=True)
    assert s.params["FDI_EL_MODEL"] == 2.0
    assert s.vehicle.monitor.airframe.name == "c172p"
    # THEN no alarm, and the elevator's statistic stays far under its threshold (seeds
    #      1-3: peak 0.115 / 0.113 / 0.115; the residual 0.004 rad rms, 0.016 at most,
    #      at the level-off after the climb)
    assert summ["completed"] and not summ["crashed"]
    assert summ["false_alarms"] == 0 and summ["fdi_episodes"] == []
    assert summ["fdi_peak_ratio"]["elevator"] <= 0.3
    # AND its throttle watched from the take-off roll on the tachometer's rpm with its
    #     own thrust model (autopilot/monitor/throttle.py C172P_THRUST), its statistic
    #     far under the threshold too (seeds 1-3, turbulence none / light / moderate:
    #     peak 0.13-0.35; the largest at full throttle in the climb-out, where the
    #     manifold pressure hardly moves with the throttle)
    assert s.vehicle.monitor.throttle.model.name == "c172p" and s.vehicle.monitor.throttle.rotor_measured
    assert summ["fdi_peak_ratio"]["throttle"] <= 0.6


def test_c172p_elevator_stuck_in_the_climb_out_found_with_its_model():
    # GIVEN the elevator stuck at -0.07 rad 35.5 s after the brake release, in the
    #       full-throttle climb-out 67 m up (missions/fault_elevator_stuck_c172p.toml)
    s, summ = _fly(51.0, STUCK)
    f = summ["faults"][0]
    # THEN detected within 3 s (measured 1.51 s), an actuator fault of the elevator,
    #      identified stuck within 0.015 rad 10 s after the onset (measured -0.0783:
    #      the slipstream at full throttle, 7 % over the cruise's the model carries)
    assert f["kind"] == "actuator" and f["isolated"] == "elevator"
    assert f["delay_s"] is not None and f["delay_s"] <= 3.0, f
    assert abs(f["identified_10s"].get("stuck_rad", 1.0) - (-0.07)) <= 0.015, f
    assert not s.crashed
    # AND without the model (the balance learnt in flight, armed ~100 s after launch)
    #     the same flight sees nothing (it flies into the ground 41 s after the onset)
    s0, summ0 = _fly(51.0, STUCK, FDI_EL_MODEL=0)
    assert summ0["faults"][0]["delay_s"] is None
