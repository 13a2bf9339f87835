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
