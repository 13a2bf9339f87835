"""Which lockstep steps get a flight-log row (autopilot.log.flightlog.RowSchedule), and
the simulator's truth pacing that the rows follow (sim_bridge.hil, truth_div)."""
import numpy as np

from autopilot.link.hil import AutopilotHilEnd
from autopilot.link.transports import memory_pair
from autopilot.log.flightlog import RowSchedule
from sim_bridge.bridge import SimBridge
from sim_bridge.hil import SimulatorHilEnd
from tests.test_hil_link import CountingPlant, FixedSensors


def rows(sched, steps, truth_steps, gps_steps=()):
    return [k for k in steps if sched.take(k, k in truth_steps, k in gps_steps)]


def test_rows_on_the_step_divisor_without_truth():
    # GIVEN a simulator that sends no truth, WHEN steps 1..12 run, a fix at step 5
    got = rows(RowSchedule(4), range(1, 13), set(), {5})
    # THEN rows every 4th step (the fix goes with the next one)
    assert got == [4, 8, 12]


def test_rows_follow_truth_when_the_simulator_paces_it():
    # GIVEN truth every 2nd step and with the fix at step 7
    truth = {2, 4, 6, 7, 8, 10, 12}
    # THEN a row at every truth step on the divisor and at the fix, none elsewhere
    assert rows(RowSchedule(2), range(1, 13), truth, {7}) == [2, 4, 6, 7, 8, 10, 12]
    # and at every 4th step with truth every step (the debugging aid, another simulator)
    assert rows(RowSchedule(4), range(1, 13), set(range(1, 13)), {7}) == [4, 7, 8, 12]


def test_a_due_row_waits_for_truth_out_of_phase():
    # GIVEN truth on the odd steps (the simulator's count is one off ours)
    truth = set(range(1, 20, 2))
    got = rows(RowSchedule(2), range(1, 20), truth)
    # THEN every row has truth and the rate is kept
    assert got and all(k in truth for k in got)
    assert len(got) >= 8


def test_simulator_sends_truth_every_nth_step_and_with_every_fix():
    sim_pipe, ap_pipe = memory_pair()
    link = SimulatorHilEnd(sim_pipe)
    link.truth_div = 4
    bridge = SimBridge(CountingPlant(), FixedSensors(), link, None, ())   # a fix every 20th step
    ap = AutopilotHilEnd(ap_pipe)
    with_truth, with_gps = [], []
    for k in range(1, 41):
        bridge.send_current()
        (frame, truth), = ap.poll()
        if truth is not None:
            assert truth.t_us == frame.t_us
            with_truth.append(k)
        if frame.gps is not None:
            with_gps.append(k)
        bridge.advance(link.poll_answer(bridge.t_us))
    assert with_gps == [1, 21]
    assert with_truth == sorted({4, 8, 12, 16, 20, 24, 28, 32, 36, 40} | set(with_gps))
    # every HIL_SENSOR still went out and was decoded
    assert np.isfinite(frame.imu.f_b).all()
