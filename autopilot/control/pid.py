"""A small PID block with the habits of every control law here (docs/architecture.md,
"Conventions"): derivative on a measured rate of the measurement instead of the error,
so a reference step does not kick, explicit output saturation and
conditional-integration anti-windup (the integrator only moves when the output is not
saturated in the direction the error would push it), and ``reset()``."""
from __future__ import annotations


class Pid:
    __slots__ = ("kp", "ki", "kd", "out_min", "out_max", "i_max", "integ")

    def __init__(self, kp: float, ki: float = 0.0, kd: float = 0.0,
                 out_min: float = -1.0, out_max: float = 1.0, i_max: float | None = None):
        self.kp, self.ki, self.kd = kp, ki, kd
        self.out_min, self.out_max = out_min, out_max
        self.i_max = i_max if i_max is not None else max(abs(out_min), abs(out_max))
        self.integ = 0.0

    def reset(self, integ: float = 0.0) -> None:
        self.integ = integ

    def update(self, setpoint: float, measurement: float, dt: float, rate: float,
               feedforward: float = 0.0, scale: float = 1.0) -> float:
        """``rate`` is d(measurement)/dt as measured (e.g. a gyro; 0.0 where the loop has
        no derivative term). ``scale`` multiplies the feedback terms (gain scheduling,
        e.g. with dynamic pressure). The arguments by position: the loops call this
        every step, and keywords cost the call more than its integrator."""
        err = setpoint - measurement
        unsat = feedforward + scale * (self.kp * err + self.integ - self.kd * rate)
        # min(max(unsat, lo), hi) spelt out, here and below: the same comparisons and
        # result, without the builtins' argument tuple and iterator (they cost more than
        # the rest of this call)
        lo, hi = self.out_min, self.out_max
        out = lo if lo > unsat else unsat
        out = hi if hi < out else out
        # anti-windup: integrate unless saturated and the error pushes further out
        if self.ki > 0.0 and dt > 0.0:
            pushing_out = (unsat >= hi and err > 0) or (unsat <= lo and err < 0)
            if not pushing_out:
                integ, i_max = self.integ + self.ki * err * dt, self.i_max
                integ = -i_max if -i_max > integ else integ
                self.integ = i_max if i_max < integ else integ
        return out
