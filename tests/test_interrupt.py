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
    # WHEN SIGINT arrives 0.3 s (by the wall clock, from another thread) after the run's
    #      first step (not after run() is called: settling the heap before the first step
    #      takes longer than that on a loaded host)
    timer = threading.Timer(0.3, os.kill, (os.getpid(), signal.SIGINT))
    step = s.step

    def first_step_starts_the_timer():
        if not timer.is_alive() and not timer.finished.is_set():
            timer.start()
        step()

    s.step = first_step_starts_the_timer
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


def _interrupt_while_settling(monkeypatch, module) -> None:
    """``module``'s ``settled_heap`` sends SIGINT to this process before it settles (a
    loaded host's collection there takes up to a second: a Ctrl-C lands in it)."""
    from contextlib import contextmanager
    settled = module.settled_heap

    @contextmanager
    def interrupted_while_settling():
        os.kill(os.getpid(), signal.SIGINT)
        with settled():
            yield

    monkeypatch.setattr(module, "settled_heap", interrupted_while_settling)


def test_sigint_while_the_heap_is_settled_stops_the_run_before_its_first_step(monkeypatch):
    # GIVEN a flight whose run is interrupted while its heap is being settled (before the
    #       loop: a loaded host's collection takes a second, and the signal landed there
    #       as a KeyboardInterrupt out of run())
    import tools.runner as runner
    _interrupt_while_settling(monkeypatch, runner)
    s = Session(RunConfig(duration_s=1e9, seed=1))
    s.step()
    t_before = s.t_s
    # WHEN it runs: THEN run() returns normally, marked interrupted, no step flown
    s.run()
    assert s.interrupted
    assert s.t_s == t_before
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_sigint_stops_a_quadrotor_formation_cleanly(monkeypatch):
    # GIVEN the seed's 5-quad formation asked for 60 s after its start, SIGINT arriving
    #       while its heap is settled (before the loop) and again 0.5 s into its flight
    import tools.formation as formation
    from pathlib import Path
    settled = formation.settled_heap
    _interrupt_while_settling(monkeypatch, formation)
    # WHEN it flies: THEN it returns its summary without a step flown, and Python's
    #      handler is back
    path = Path(__file__).parent.parent / "missions" / "formation_seed_quad.toml"
    out = formation.run_formation(path, seed=1, duration_s=60.0)
    assert out["sim_time_s"] == 0.0, out["sim_time_s"]
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    # AND flown again with SIGINT from another thread once 100 of its steps are flown
    #     (the quadrotors' control is compiled kernels, where a KeyboardInterrupt came out
    #     as a SystemError), it stops early with its summary. (Counted in steps, not by
    #     the wall clock: the formation completes 14.6 s into its flight, which a fast
    #     loop flies in under 0.5 s, and a signal timed after that landed on the test.)
    monkeypatch.setattr(formation, "settled_heap", settled)
    timer = threading.Timer(0.0, os.kill, (os.getpid(), signal.SIGINT))
    step = formation.QuadMember.step
    steps = []

    def the_500th_member_step_starts_the_timer(member):
        steps.append(1)
        if len(steps) == 500:          # (five members: 100 steps of the formation)
            timer.start()
        step(member)

    monkeypatch.setattr(formation.QuadMember, "step", the_500th_member_step_starts_the_timer)
    out = formation.run_formation(path, seed=1, duration_s=60.0)
    timer.join()
    assert 0.0 < out["sim_time_s"] < 60.0, out["sim_time_s"]
    assert not out["completed"], out["completed_at_s"]     # (stopped, not flown to its end)
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
