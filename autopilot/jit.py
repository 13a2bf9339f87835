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
numba checks only the kernel's own file: a kernel that calls a kernel or reads a
constant of another module keeps its machine code when only that module changes (a
changed callee or layout constant then gives wrong numbers, or an error, until the
caller is compiled again), so after such an edit clear the ``__pycache__`` folders.
``fastmath`` is off: the kernels keep IEEE semantics (no reassociation), so a kernel's
result depends only on its own order of operations.
"""
from __future__ import annotations

import math
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


def preload(kernel_fn, *args) -> None:
    """Call ``kernel_fn`` once on ``args`` (values of the types its calls in flight pass;
    copies of anything it writes into) and drop the result, so that numba loads its
    machine code from the on-disk cache now, at start-up, rather than at that first call
    in flight. A load takes a few milliseconds, a stalled step: on the default missions
    the fault monitor's kernels loaded on leaving the ground, when the elevator's test
    armed and when the balances' fits started, the join planner's at the first planned
    join (21 s), the quadrotor's attitude loops and mixer at its take-off, all inside
    ``sitl bench``'s window (9 of the monitor's 24 us a step from 5 to 25 s after
    arming). Whoever owns a kernel called only in flight calls this when it is built
    (tests/test_kernel_preload.py checks that none loads after arming)."""
    kernel_fn(*args)


# ------------------------------------------------- shared linear algebra kernels --
# (numba's own np.linalg binds LAPACK at compile time: about ten seconds of a fresh
# install's first run for one call of np.linalg.solve; these loops compile in a second)

@kernel
def cholesky_lower(S, r, L):
    """L with L L^T = S + diag(r) (the innovation covariance of a Kalman update, S = H P
    H^T, r the measurement variances), written into ``L`` (m x m, zeros above the
    diagonal). False when S + diag(r) is not positive definite (L is then unfinished)."""
    m = S.shape[0]
    for j in range(m):
        d = S[j, j] + r[j]
        for k in range(j):
            d -= L[j, k] * L[j, k]
        if not d > 0.0:
            return False
        d = math.sqrt(d)
        L[j, j] = d
        for i in range(j + 1, m):
            t = S[i, j]
            for k in range(j):
                t -= L[i, k] * L[j, k]
            L[i, j] = t / d
    return True


@kernel
def cholesky_gain(L, PHt, KT):
    """K^T = (L L^T)^-1 (P H^T)^T, the Kalman gain transposed (m x n), by forward then
    back substitution, one column of K^T (one state) at a time."""
    m = L.shape[0]
    for c in range(PHt.shape[0]):
        for i in range(m):
            t = PHt[c, i]
            for k in range(i):
                t -= L[i, k] * KT[k, c]
            KT[i, c] = t / L[i, i]
        for i in range(m - 1, -1, -1):
            t = KT[i, c]
            for k in range(i + 1, m):
                t -= L[k, i] * KT[k, c]
            KT[i, c] = t / L[i, i]
