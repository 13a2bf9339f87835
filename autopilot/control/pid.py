"""A small PID law with the habits of every control law here (docs/architecture.md,
"Conventions"): derivative on a measured rate of the measurement instead of the error,
so a reference step does not kick, explicit output saturation and
conditional-integration anti-windup (the integrator only moves when the output is not
saturated in the direction the error would push it).

A compiled kernel (autopilot/jit.py) called from the kernels of the loops that use it
(control/fixed_wing.py): a loop's gains are a row of ``gains`` (columns KP .. I_MAX),
its integrator an element of the loops' state array, so that all the loops of a step
run in one compiled call.

``max2``, ``min2`` and ``clamp`` are Python's max(a, b), min(a, b) and min(max(x, lo),
hi) for the kernels, ties and all (the first of equals); the per-step Python paths spell
them out the same way (``lo if lo > x else x``), where the builtins' argument tuple and
iterator cost more than the rest of the line. (One call each, rather than the
comparisons written out in a kernel: numba's type inference takes several times longer
over the branches.)
"""
from __future__ import annotations

from ..jit import kernel

KP, KI, KD, OUT_MIN, OUT_MAX, I_MAX = range(6)    # a loop's row of ``gains``


@kernel
def max2(a, b):
    """Python's max(a, b)."""
    return b if b > a else a


@kernel
def min2(a, b):
    """Python's min(a, b)."""
    return b if b < a else a


@kernel
def clamp(x, lo, hi):
    """Python's min(max(x, lo), hi)."""
    x = lo if lo > x else x
    return hi if hi < x else x


@kernel
def pid_update(gains, integ, j, kp, setpoint, measurement, dt, rate, feedforward, scale):
    """Loop ``j``'s output; its integrator ``integ[j]`` advanced in place. ``kp`` the
    proportional gain flown (``gains[j, KP]`` unless scheduled), ``rate``
    d(measurement)/dt as measured (e.g. a gyro; 0.0 where the loop has no derivative
    term), ``scale`` multiplies the feedback terms (gain scheduling, e.g. with dynamic
    pressure)."""
    err = setpoint - measurement
    unsat = feedforward + scale * (kp * err + integ[j] - gains[j, KD] * rate)
    lo, hi = gains[j, OUT_MIN], gains[j, OUT_MAX]
    out = clamp(unsat, lo, hi)
    # anti-windup: integrate unless saturated and the error pushes further out
    ki = gains[j, KI]
    if ki > 0.0 and dt > 0.0:
        pushing_out = (unsat >= hi and err > 0) or (unsat <= lo and err < 0)
        if not pushing_out:
            i_max = gains[j, I_MAX]
            integ[j] = clamp(integ[j] + ki * err * dt, -i_max, i_max)
    return out
