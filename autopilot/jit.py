"""Compiled kernels for the numeric hot paths: ``@kernel`` is numba's ``njit`` with its
on-disk cache.

Why: the closed loop's cost per step is Python's per-call and per-array overhead, not
arithmetic (``sitl bench --profile``); a loop over a few dozen numbers compiled once
costs what one numpy call costs. A kernel reads like the equation it computes and is
the only implementation of it (the tests compare it with the equation written out in
numpy).

Cache: numba writes the machine code next to the module (``__pycache__``, or its own
user cache directory when that is read-only) the first time a kernel runs, and loads it
afterwards. Compiling is said on stderr while it happens (a fresh install's first run
compiles every kernel once: seconds, then never again for the same source and numba).
``fastmath`` is off: the kernels keep IEEE semantics (no reassociation), so a kernel's
result depends only on its own order of operations.
"""
from __future__ import annotations

import sys

import numba
from numba.core import event

_told = False


class _CompileNotice(event.Listener):
    """One line on stderr when the first kernel of this process starts compiling."""

    def on_start(self, ev):
        global _told
        if not _told:
            _told = True
            print("sitl: compiling numeric kernels (first run after install or change; "
                  "cached for the next runs) ...", file=sys.stderr, flush=True)

    def on_end(self, ev):
        pass


event.register("numba:compile", _CompileNotice())


def kernel(fn):
    """``numba.njit(cache=True)``: compiled at its first call, cached on disk."""
    return numba.njit(cache=True, fastmath=False, nogil=True)(fn)
