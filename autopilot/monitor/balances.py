"""The fixed-wing actuator balances' 50 Hz step in one compiled call
(FaultMonitor.observe_controls): the elevator's moment balance (:mod:`.actuator`), the
lateral balance (:mod:`.lateral`) and the thrust balance (:mod:`.throttle`) low-pass their
signals in their own kernels (``pitch_front``, ``lateral_front``, ``throttle_front``),
called here from one; each identifier's 10 Hz sample then runs where it is due (their
``sample``). Why one call: numba's dispatch costs more per call and per array argument
than the three fronts' arithmetic, and the three calls took fifteen arrays and two tuples;
here their low-passes and states are one array each (the identifiers keep views of their
parts), their constants at the low-passes' end, the specific force three floats.
An identifier alone (another airframe's set, the tests) steps through its own ``step``,
the same kernels and sample."""
from __future__ import annotations

import numpy as np

from autopilot.geo import G0
from autopilot.jit import kernel, preload

from .actuator import MAX_DEFLECTION_RAD, pitch_front
from .lateral import NO_BIAS, lateral_front
from .throttle import throttle_front

# the low-passes' arrays (the identifiers' ``_lp``, ``_st``) end to end: the elevator's,
# the lateral balance's, the thrust balance's
_LP_EL, _LP_LA, _LP_TH, _LP_END = 0, 13, 35, 57
_ST_EL, _ST_LA, _ST_TH, _ST_END = 0, 5, 10, 18
# the constants, after the low-passes in the same array (``lp[_LP_END:]``, ``k``): the
# propeller's numbers of the pitch balance (airframe.PitchAero.gyro_coefs) and of the
# lateral one (its ``_hc``, 6 or 9 of them), the thrust balance's (ThrustModel._rotor), the
# exponent lateral_front takes at run time (2.0), the lengths of the propeller's C_P(J) and
# rpm-factor tables, the thrust balance's mode (ThrottleIdentifier._mode), then the four
# tables. (One array, not two and the mode: each array argument of a compiled call costs
# about 1.1 k instructions of dispatch, a float's 0.2 k, the call 50 times a second)
_K_PC, _K_HC, _K_ROTOR, _K_TWO, _K_NJ, _K_NR, _K_MODE, _K_TABLES = 0, 9, 18, 34, 35, 36, 37, 38
# balances_front's answer: the elevator's sample due, the lateral balance's, the thrust
# balance stepped (flying), its sample due
DUE_PITCH, DUE_LATERAL, THR_STEPPED, DUE_THRUST = 1, 2, 4, 8


@kernel
def balances_front(t_us, V, w, fx, fy, fz, f_on, flying, aileron, elevator, rudder, throttle, thr, n, alt_m, ba,
                   lp, st):
    """One 50 Hz step of the three balances: the commands (aileron, elevator, rudder,
    throttle), the body rates ``w``, the specific force (``f_on`` False: none this step),
    the load factor ``n`` where there is none (else -f_z / g), the throttle the thrust
    balance takes (the command, or a piston's through its lag), the height, the
    accelerometer bias the lateral balance adds (empty: none); ``lp``, ``st``: their
    low-passes and constants, their states (module constants). The DUE_* bits."""
    k = lp[_LP_END:]
    f_b = (fx, fy, fz)
    due = 0
    if pitch_front(lp[_LP_EL:_LP_LA], st[_ST_EL:_ST_LA], t_us, V, flying, throttle, elevator * MAX_DEFLECTION_RAD,
                   -fz / G0 if f_on else n, w[1], w[2], k[_K_PC:_K_HC]):
        due |= DUE_PITCH
    flying = flying and f_on
    if lateral_front(lp[_LP_LA:_LP_TH], st[_ST_LA:_ST_TH], t_us, V, flying, w, f_b, ba, aileron, rudder, throttle,
                     k[_K_HC:_K_ROTOR], k[_K_TWO]):
        due |= DUE_LATERAL
    nj, nr = int(k[_K_NJ]), int(k[_K_NR])
    a = _K_TABLES
    d = throttle_front(lp[_LP_TH:_LP_END], st[_ST_TH:_ST_END], t_us, V, flying, f_b, elevator, thr, alt_m,
                       int(k[_K_MODE]),
                       k[_K_ROTOR:_K_TWO], k[a:a + nj], k[a + nj:a + 2 * nj], k[a + 2 * nj:a + 2 * nj + nr],
                       k[a + 2 * nj + nr:a + 2 * nj + 2 * nr])
    if d >= 0:
        due |= THR_STEPPED
    if d > 0:
        due |= DUE_THRUST
    return due


class Balances:
    """``Balances(elevator, lateral, throttle)``: the three identifiers' 50 Hz step,
    ``step(t_us, nav, controls, flying, f_b)`` with the four commands: True where a
    statistic was renewed (as the identifiers' ``step``). Built where all three balances
    run on an airframe's model with a propeller (:meth:`fits`)."""

    def __init__(self, elevator, lateral, throttle):
        self.elevator, self.lateral, self.throttle = elevator, lateral, throttle
        b = elevator.balance
        rotor, cp_j, cp, cp_rpm, cp_rpm_k = throttle._model_arrays
        hc = np.zeros(9)
        hc[:len(lateral._hc)] = lateral._hc
        # the identifiers' low-pass arrays become views of one (none has stepped yet), the
        # constants after them
        self._lp = np.concatenate((b._lp, lateral._lp, throttle._lp, b._pc, hc, rotor,
                                   (2.0, len(cp_j), len(cp_rpm), throttle._mode), cp_j, cp, cp_rpm, cp_rpm_k))
        self._st = np.concatenate((b._st, lateral._st, throttle._st))
        b._lp, lateral._lp, throttle._lp = (self._lp[_LP_EL:_LP_LA], self._lp[_LP_LA:_LP_TH],
                                            self._lp[_LP_TH:_LP_END])
        b._st, lateral._st, throttle._st = (self._st[_ST_EL:_ST_LA], self._st[_ST_LA:_ST_TH],
                                            self._st[_ST_TH:_ST_END])
        # (autopilot.jit.preload: the kernel loaded now, not on leaving the ground)
        preload(balances_front, 0, 20.0, np.zeros(3), 0.0, 0.0, -9.8, True, True, 0.0, 0.0, 0.0, 0.5, 0.5, 1.0,
                100.0, NO_BIAS if lateral._nav is None else np.zeros(3), self._lp.copy(), self._st.copy())

    @staticmethod
    def fits(elevator, lateral, throttle) -> bool:
        """Whether the three identifiers can step together: all there, and the pitch and
        lateral balances with a propeller's numbers (a model's)."""
        return (elevator is not None and lateral is not None and throttle is not None
                and elevator.balance._pc is not None and lateral._hc is not None)

    def step(self, t_us: int, nav, controls: tuple, flying: bool, f_b) -> bool:
        th = self.throttle
        V = nav.airspeed_mps
        tested = th.axes["throttle"]
        f_on = f_b is not None
        fx, fy, fz = f_b if f_on else (0.0, 0.0, 0.0)
        aileron, elevator, rudder, throttle = controls[:4]
        due = balances_front(t_us, V, nav.omega_b, fx, fy, fz, f_on, flying, aileron, elevator,
                             rudder, throttle, th.throttle_in(t_us, nav, controls, flying and f_on, f_b),
                             0.0 if f_on else self.elevator.load_factor(nav), nav.alt_m,
                             self.lateral.accel_bias(), self._lp, self._st)
        renewed = False
        if due & DUE_LATERAL and self.lateral.sample(t_us):
            renewed = True
        if due & THR_STEPPED and th.sample(t_us, tested, (due & DUE_THRUST) != 0):
            renewed = True
        if due & DUE_PITCH and self.elevator.sample(t_us, V):
            renewed = True
        return renewed
