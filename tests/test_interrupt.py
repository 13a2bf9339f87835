"""Ctrl-C stops a flight after its step (autopilot/interrupt.py): the run ends cleanly
instead of wherever the signal lands (inside a compiled kernel's call a
KeyboardInterrupt came out as a SystemError: a run stopped by Ctrl-C failed, or hung
once a ground-station handler swallowed it)."""
import os
import signal
import threading

import pytest

from autopilot.interrupt import StopOnInterrupt
from tools.runner import RunConfig, Session


@pytest.fixture(autouse=True)
def python_sigint():
    """Python's own SIGINT handler for the test (a suite started as a shell's background
    job inherits SIGINT ignored), the process's restored after."""
    prev = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, prev)


def test_sigint_stops_the_flight_after_its_step_and_the_handler_is_restored():
    # GIVEN the default mission flown in process (it ends at about 430 s)
    s = Session(RunConfig(duration_s=1e9, seed=1))
    for _ in range(200):
        s.step()
    before = signal.getsignal(signal.SIGINT)
    assert before is signal.default_int_handler
    # WHEN SIGINT arrives 0.3 s into the run (by the wall clock, from another thread)
    timer = threading.Timer(0.3, os.kill, (os.getpid(), signal.SIGINT))
    timer.start()
    s.run()
    timer.join()
    # THEN the run returns normally, marked interrupted, long before the mission's end,
    #      and Python's own handler is back
    assert s.interrupted
    assert 2.0 < s.t_s < 400.0, s.t_s
    assert signal.getsignal(signal.SIGINT) is before


def test_a_second_sigint_raises_and_an_ignored_sigint_stays_ignored():
    with StopOnInterrupt() as stop:
        os.kill(os.getpid(), signal.SIGINT)
        assert stop.requested
        try:
            os.kill(os.getpid(), signal.SIGINT)
            raised = False
        except KeyboardInterrupt:
            raised = True
    assert raised
    prev = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        with StopOnInterrupt() as stop:
            assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN
            os.kill(os.getpid(), signal.SIGINT)
        assert not stop.requested
    finally:
        signal.signal(signal.SIGINT, prev)
