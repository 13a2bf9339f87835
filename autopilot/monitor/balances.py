"""The fixed-wing actuator balances' step in one compiled call (FaultMonitor.observe_controls,
50 Hz): the elevator's moment balance (:mod:`.actuator`), the lateral balance
(:mod:`.lateral`) and the thrust balance (:mod:`.throttle`) low-pass their signals in
their own kernels (``pitch_front``, ``lateral_front``, ``throttle_front``), called here
from one (a kernel's call costs more than their work at 50 Hz); each identifier's 10 Hz
sample then runs where it is due (their ``sample``). An identifier alone steps through its
own ``step``, the same kernels and sample."""
from __future__ import annotations

import numpy as np

from autopilot.geo import G0
from autopilot.jit import kernel, preload

from .actuator import MAX_DEFLECTION_RAD, lowpass_state, pitch_front
from .lateral import NO_BIAS, NO_FORCE, lateral_front
from .throttle import throttle_front

# balances_front's answer: the elevator's sample due, the lateral balance's, the thrust
# balance stepped (flying), its sample due
DUE_PITCH, DUE_LATERAL, THR_STEPPED, DUE_THRUST = 1, 2, 4, 8


@kernel
def balances_front(t_us, V, w, flying, f_on, f_b, controls, n, throttle, alt_m, ba,
                   el_lp, el_st, pc, lat_on, la_lp, la_st, hc, two,
                   thr_on, th_lp, th_st, mode, rotor, cp_j, cp, cp_rpm, cp_rpm_k):
    """One 50 Hz step of the balances present (``lat_on``, ``thr_on``; the elevator's
    always): the commands ``controls`` (aileron, elevator, rudder, throttle), the body
    rates ``w``, the specific force ``f_b`` (``f_on`` False: none this step), the load
    factor ``n``, the throttle the thrust balance takes (the command, or a piston's through
    its lag), the height, the accelerometer bias the lateral balance adds. The DUE_* bits."""
    due = 0
    if pitch_front(el_lp, el_st, t_us, V, flying, controls[3], controls[1] * MAX_DEFLECTION_RAD, n, w[1], w[2],
                   pc):
        due |= DUE_PITCH
    flying = flying and f_on
    if lat_on and lateral_front(la_lp, la_st, t_us, V, flying, w, f_b, ba, controls[0], controls[2],
                                controls[3], hc, two):
        due |= DUE_LATERAL
    if thr_on:
        d = throttle_front(th_lp, th_st, t_us, V, flying, f_b, controls[1], throttle, alt_m, mode, rotor, cp_j,
                           cp, cp_rpm, cp_rpm_k)
        if d >= 0:
            due |= THR_STEPPED
        if d > 0:
            due |= DUE_THRUST
    return due


class Balances:
    """``Balances(elevator, lateral, throttle)`` (the last two may be None);
    ``step(t_us, nav, controls, flying, f_b)`` once per 50 Hz step with the four commands:
    True where a statistic was renewed (as the identifiers' ``step``)."""

    def __init__(self, elevator, lateral=None, throttle=None):
        self.elevator, self.lateral, self.throttle = elevator, lateral, throttle
        b = elevator.balance
        la, th = lateral, throttle
        # balances_front's arguments after the step's own: the identifiers' arrays (an absent
        # one's of the types its would have, unused)
        la_arrays = ((la._lp, la._st, la._hc) if la is not None
                     else (np.zeros(12), lowpass_state(), np.zeros(6)))
        th_arrays = ((th._lp, th._st, th._mode, *th._model_arrays) if th is not None
                     else (np.zeros(14), np.concatenate((lowpass_state(), (0, -1, 0))), 0, np.zeros(16),
                           np.zeros(1), np.zeros(1), np.zeros(1), np.zeros(1)))
        self._arrays = (b._lp, b._st, b._pc, la is not None, *la_arrays, 2.0, th is not None, *th_arrays)
        self._raw = la if la is not None and la._nav is not None else None   # (LateralAero.raw_accel)
        self._piston = th is not None and th.model.engine is not None
        # (autopilot.jit.preload: the kernel loaded now, not on leaving the ground)
        preload(balances_front, 0, 20.0, np.zeros(3), True, True, NO_FORCE, (0.0, 0.0, 0.0, 0.5), 1.0, 0.5, 0.0,
                NO_BIAS if self._raw is None else np.zeros(3),
                *(a.copy() if isinstance(a, np.ndarray) else a for a in self._arrays))

    def step(self, t_us: int, nav, controls: tuple, flying: bool, f_b) -> bool:
        th = self.throttle
        V = nav.airspeed_mps
        f_on = f_b is not None
        thr = controls[3]
        if th is not None:
            tested = th.axes["throttle"]
            if self._piston and flying and f_on and not V < 10.0:
                thr = th._piston(t_us, nav, controls, float(f_b[2]))
        due = balances_front(t_us, V, nav.omega_b, flying, f_on, f_b if f_on else NO_FORCE, controls,
                             -float(f_b[2]) / G0 if f_on else self.elevator.load_factor(nav), thr, nav.alt_m,
                             NO_BIAS if self._raw is None else self._raw.accel_bias(), *self._arrays)
        renewed = False
        if due & DUE_LATERAL:
            renewed = self.lateral.sample(t_us)
        if due & THR_STEPPED and th.sample(t_us, tested, 1 if due & DUE_THRUST else 0):
            renewed = True
        if due & DUE_PITCH and self.elevator.sample(t_us, V):
            renewed = True
        return renewed
