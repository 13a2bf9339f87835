"""Ctrl-C as a request the flight loops answer between two steps.

A flight loop stopped by ``KeyboardInterrupt`` stops wherever the signal lands. Python
raises it at the next bytecode of the main thread, and when that is inside a compiled
kernel's call (numba's dispatcher, :mod:`autopilot.jit`) the exception comes out of the
C call as a ``SystemError`` instead, an ordinary error: a run stopped by Ctrl-C then
failed with a traceback, and once a ground-station handler, which keeps the vehicle up
whatever a message does, swallowed it and the run went on until it was killed (the
suite's vehicles, stopped with SIGINT, under load). Here the first SIGINT only sets a
flag that the loop reads after each step, so the run ends cleanly and writes what it
writes at its end; a second one raises ``KeyboardInterrupt`` as before (a loop stuck
somewhere is still stopped by a second Ctrl-C). ArduPilot's SITL stops on its signal
handler's flag the same way.

Installed only where SIGINT has Python's default handler and in the main thread: a
process started with SIGINT ignored (a shell's background job) keeps ignoring it.
"""
from __future__ import annotations

import signal
import threading


class StopOnInterrupt:
    """``with StopOnInterrupt() as stop: while ... and not stop.requested: ...``"""

    def __init__(self) -> None:
        self.requested = False
        self._previous = None

    def _handler(self, signum, frame) -> None:
        if self.requested:
            raise KeyboardInterrupt
        self.requested = True

    def __enter__(self) -> "StopOnInterrupt":
        if (threading.current_thread() is threading.main_thread()
                and signal.getsignal(signal.SIGINT) is signal.default_int_handler):
            self._previous = signal.signal(signal.SIGINT, self._handler)
        return self

    def __exit__(self, *exc) -> None:
        if self._previous is not None:
            signal.signal(signal.SIGINT, self._previous)
            self._previous = None
