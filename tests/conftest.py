"""Suite-wide guard: a test that runs past TEST_TIMEOUT_S (default 600 s, ten times the
slowest test on a two-core machine) is taken to have hung. The guard prints which test,
every thread's stack and the processes it started, kills those processes and ends the
run with status 1, so a hang costs ten minutes and says where it is instead of using up
CI's whole time in silence."""
from __future__ import annotations

import faulthandler
import os
import signal
import sys
import threading

import pytest

LIMIT_S = float(os.environ.get("TEST_TIMEOUT_S", "600"))


def _children() -> list:
    try:
        import psutil
    except ImportError:                                       # pragma: no cover
        return []
    try:
        return psutil.Process().children(recursive=True)
    except psutil.Error:                                      # pragma: no cover
        return []


def _hung(item) -> None:
    nodeid = item.nodeid
    capture = item.config.pluginmanager.getplugin("capturemanager")
    if capture is not None:                # pytest holds file descriptors 1 and 2 during a test
        try:
            capture.suspend_global_capture(in_=False)
        except Exception:                                     # pragma: no cover
            pass
    err = sys.__stderr__
    err.write(f"\n\nTEST HUNG: {nodeid} ran past {LIMIT_S:.0f} s (TEST_TIMEOUT_S); "
              f"the stacks of its threads:\n")
    err.flush()
    faulthandler.dump_traceback(file=err, all_threads=True)
    kids = _children()
    for p in kids:
        try:
            err.write(f"  child process {p.pid}: {' '.join(p.cmdline())[:200]}\n")
        except Exception:                                     # pragma: no cover
            pass
    err.flush()
    for p in kids:
        try:
            os.kill(p.pid, signal.SIGKILL)
        except OSError:
            pass
    os._exit(1)


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item, nextitem):
    timer = threading.Timer(LIMIT_S, _hung, args=(item,))
    timer.daemon = True
    timer.start()
    try:
        yield
    finally:
        timer.cancel()


# --- flights shared between tests ----------------------------------------------------------
# A headless flight (tools.runner.Session) is deterministic for its RunConfig: the same
# config flies the same flight, bit for bit (tests/test_e2e_plane.py checks it). Tests that
# assert different things of the same flight take it from here, flown once per test run.
# A flight may be asked for at several lengths (``until_s``): it is paused at each and its
# summary taken there, which is the summary a flight of that duration_s returns
# (duration_s is only where Session's loop stops; nothing else reads it).

_FLIGHTS: dict = {}
_ACROSS_FILES: set = set()


def _flight_key(cfg) -> str:
    import dataclasses
    d = dataclasses.asdict(cfg)
    d.pop("duration_s")
    d["param_overrides"] = sorted(d["param_overrides"].items())
    return repr(sorted((k, repr(v)) for k, v in d.items()))


@pytest.fixture(scope="session")
def flown():
    """``flown(cfg)`` -> (session, summary): ``cfg`` flown to its duration_s (or the end of
    its mission), once per test run; the same object to every test that asks.

    ``flown(cfg, until_s=T)``: (session, summary) of the same flight paused at T, the
    session flown on from there if a later test asks for a longer one (take the summary,
    and the session only where nothing asked later can have moved it).

    A flight is dropped at the end of the test file that flew it (a held flight is tens
    of megabytes), unless ``across_files=True``: kept for the tests of another file."""
    import dataclasses

    from tools.runner import Session
    from tools.summary import run_summary

    def fly(cfg, until_s=None, across_files=False):
        end = float(cfg.duration_s if until_s is None else until_s)
        key = _flight_key(cfg)
        if across_files:
            _ACROSS_FILES.add(key)
        runs = _FLIGHTS.setdefault(key, [])
        for run in runs:
            if end in run["at"]:
                return run["session"], run["at"][end]
            if run["ended"] and end >= run["session"].t_s:      # over before end: the same flight
                return run["session"], run["last"]
        # a run not yet past ``end`` (nor ended short of it) is flown on; else a new one
        run = next((r for r in runs if r["session"].t_s <= end and not r["ended"]), None)
        if run is None:
            run = {"session": Session(dataclasses.replace(cfg, duration_s=end)), "at": {}, "ended": False}
            runs.append(run)
        s = run["session"]
        s.cfg = dataclasses.replace(cfg, duration_s=end)
        s.run()
        # over: the loop stopped before end, or its last step ended the flight (done() again
        # on the state the loop's own call saw: the same answer, nothing changed)
        run["ended"] = s.t_s < end or s.done()
        run["at"][end] = run["last"] = run_summary(s)
        return s, run["at"][end]

    return fly


@pytest.fixture(scope="module", autouse=True)
def _drop_flights_of_the_file():
    yield
    for key in [k for k in _FLIGHTS if k not in _ACROSS_FILES]:
        del _FLIGHTS[key]
