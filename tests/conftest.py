"""Suite-wide guard: a test that runs past TEST_TIMEOUT_S (default 600 s, ten times the
slowest test on a two-core machine) is taken to have hung. The guard prints which test,
every thread's stack and the processes it started, kills those processes and ends the
run with status 1, so a hang costs ten minutes and says where it is instead of using up
CI's whole time in silence.

Parallel runs (``pytest -n 2 --dist loadgroup``, pytest-xdist, what the README and
``.ci/run`` run): the tests that time the vehicle against the wall clock over real sockets
(real-time pacing, telemetry rates in Hz, sim/real ratios, MAVProxy / MAVSDK sessions
with their own timeouts) are one group, ``realtime``: they run one after another on one
worker, in file order, never two of them at once; the other worker meanwhile runs the
headless flights and the unit tests, which time nothing against the wall clock. The
group is made by the scheduler below, not by ``xdist_group`` marks: pytest-xdist 3.8 marks
a test's group by rewriting ``item._nodeid``, which pytest 9's nodes no longer read, so
with pytest 9 a marked test is scheduled like any other."""
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


# the modules whose tests time real-time behaviour (see the docstring)
REALTIME_MODULES = frozenset({
    "test_gcs_flood", "test_gcs_fuzz", "test_gcs_links", "test_gcs_signing", "test_gcs_mavproxy",
    "test_gcs_mavsdk", "test_gcs_fence_clients", "test_fault_mavsdk", "test_mission_mavsdk",
    "test_plans_mavsdk", "test_terrain_mavproxy",
})


def _module(nodeid: str) -> str:
    return nodeid.split("::", 1)[0].rsplit("/", 1)[-1].removesuffix(".py")


@pytest.hookimpl(optionalhook=True)          # a pytest-xdist hook: only called under -n
def pytest_xdist_make_scheduler(config, log):
    """``--dist loadgroup``: xdist's own, with every test of REALTIME_MODULES in one group."""
    if config.getvalue("dist") != "loadgroup":
        return None
    from xdist.scheduler import LoadGroupScheduling

    class RealtimeGroup(LoadGroupScheduling):
        def _split_scope(self, nodeid: str) -> str:
            return "realtime" if _module(nodeid) in REALTIME_MODULES else super()._split_scope(nodeid)

    return RealtimeGroup(config, log)


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item, nextitem):
    timer = threading.Timer(LIMIT_S, _hung, args=(item,))
    timer.daemon = True
    timer.start()
    try:
        yield
    finally:
        timer.cancel()
