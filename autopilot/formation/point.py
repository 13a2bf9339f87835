"""The point aerial vehicle of the seed's sec. 3.6.1 / 3.7.2: a single velocity
integrator (eq 3.18, P' = V) driven by the formation law (3.20, 3.22), with the seed's
disturbances (sec. 3.7.2):

* bounded random noise, uniform in +-``noise_deg``, on the angles of the applied
  velocity. A point's velocity has two angles, its heading psi = atan2(V_e, V_n) and
  its climb angle theta = atan2(-V_d, |V_ne|); both get an independent draw every step.
  (The seed also names the roll angle phi; a rotation about the velocity itself does
  not change a point's velocity, so it has no effect here.)
* a transport delay of ``delay_s`` between the command and its application (the
  "measurement and processing delays in the actuators"), a FIFO of whole steps.

Random draws come from the injected ``numpy.random.Generator`` (one per vehicle).
"""
from __future__ import annotations

import math
from collections import deque

import numpy as np


class PointVehicle:
    def __init__(self, p0, dt_s: float, rng: np.random.Generator, noise_deg: float = 10.0,
                 delay_s: float = 0.02):
        self.p = [float(c) for c in p0]
        self.v = [0.0, 0.0, 0.0]            # the applied velocity [m/s]
        self.dt = dt_s
        self.rng = rng
        self.noise_rad = math.radians(noise_deg)
        n_delay = int(round(delay_s / dt_s))
        self._fifo: deque = deque([(0.0, 0.0, 0.0)] * n_delay)

    def _disturb(self, v) -> tuple:
        vn, ve, vd = v
        h = math.hypot(vn, ve)
        speed = math.sqrt(h * h + vd * vd)
        if speed < 1e-12 or self.noise_rad == 0.0:
            return (vn, ve, vd)
        d_psi, d_theta = self.rng.uniform(-self.noise_rad, self.noise_rad, 2).tolist()
        psi = math.atan2(ve, vn) + d_psi
        theta = math.atan2(-vd, h) + d_theta
        return (speed * math.cos(theta) * math.cos(psi), speed * math.cos(theta) * math.sin(psi),
                -speed * math.sin(theta))

    def step(self, v_cmd) -> tuple:
        """Apply a velocity command; advance one step; the new position."""
        self._fifo.append(self._disturb(tuple(v_cmd)))
        v = self._fifo.popleft()
        self.v = list(v)
        p = self.p
        self.p = [p[0] + v[0] * self.dt, p[1] + v[1] * self.dt, p[2] + v[2] * self.dt]   # eq 3.18
        return tuple(self.p)
