"""``settled_heap()``: the flight loop runs with everything built before it kept out of
Python's cyclic garbage collector.

Why: the loop allocates and frees a few dozen small objects per step, nearly all freed
by reference counting; the cyclic collector still runs now and then, and its full
collections walk every container object of the process: pymavlink's dialect, numba,
scipy, the vehicle (about 150 000 objects in a quadrotor run). One full collection
costs tens of milliseconds, which spread over the steps is several microseconds a step
(``sitl bench`` measures it: docs/status.md, "Speed"). ``gc.freeze()`` (CPython 3.7+)
moves the objects that exist when the flight starts to a permanent generation the
collector skips; what the loop allocates is collected as before.

Scoped, not global: on leaving the block ``gc.unfreeze()`` hands the frozen objects
back to the collector, so a process that flies many runs one after another (a campaign
worker, the test suite) still reclaims each run's reference cycles. Nesting is harmless
(the inner block's exit unfreezes early: only the saving is lost). Nothing a flight
computes depends on when memory is collected, so flight logs are bit-identical with and
without it.
"""
from __future__ import annotations

import gc
from contextlib import contextmanager


def settle() -> None:
    """Collect once and freeze every object that exists now (module docstring)."""
    gc.collect()
    gc.freeze()


def release() -> None:
    """Hand the frozen objects back to the collector."""
    gc.unfreeze()


@contextmanager
def settled_heap():
    """``settle()``, the block, ``release()``."""
    settle()
    try:
        yield
    finally:
        release()
