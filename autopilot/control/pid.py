"""A small PID law with the habits of every control law here (docs/architecture.md,
"Conventions"): derivative on a measured rate of the measurement instead of the error,
so a reference step does not kick, explicit output saturation and
conditional-integration anti-windup (the integrator only moves when the output is not
saturated in the direction the error would push it).

A compiled kernel (autopilot/jit.py) called from the kernels of the loops that use it
(control/fixed_wing.py): a loop's gains are a row of ``gains`` (columns KP .. I_MAX),
its integrator an element of the loops' state array, so that all the loops of a step
run in one compiled call. Every min(max(x, lo), hi) of a per-step path is spelt out as
two comparisons, in the kernels as in the Python (where the builtins' argument tuple
and iterator cost more than the rest of the line): ``lo if lo > x else x`` is max's
answer, ties and all.
"""
from __future__ import annotations

from ..jit import kernel

KP, KI, KD, OUT_MIN, OUT_MAX, I_MAX = range(6)    # a loop's row of ``gains``


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
    out = lo if lo > unsat else unsat
    out = hi if hi < out else out
    # anti-windup: integrate unless saturated and the error pushes further out
    ki = gains[j, KI]
    if ki > 0.0 and dt > 0.0:
        pushing_out = (unsat >= hi and err > 0) or (unsat <= lo and err < 0)
        if not pushing_out:
            i, i_max = integ[j] + ki * err * dt, gains[j, I_MAX]
            i = -i_max if -i_max > i else i
            integ[j] = i_max if i_max < i else i
    return out
