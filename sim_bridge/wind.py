"""Turbulence for both plants: :class:`DrydenGusts`, MIL-F-8785C low-altitude Dryden
turbulence. The plant passes its height above the terrain and its speed relative to the
steady wind; the quadrotor adds the returned gust (NED, m/s) to the steady wind itself,
the fixed-wing writes it into JSBSim's gust input (``sim_bridge/plants/jsbsim_plane.py``,
which says why JSBSim's own turbulence is not used).

Scale lengths and intensities (h = height above the terrain, clipped to 3..300 m, the
band of the low-altitude model; W20 = wind speed at 6 m):

    L_w = h,  L_u = L_v = h / (0.177 + 0.000823 h_ft)^1.2
    sigma_w = 0.1 W20,  sigma_u = sigma_v = sigma_w / (0.177 + 0.000823 h_ft)^0.4

Each component is a first-order Gauss-Markov process over the distance flown through
the air mass (MIL-STD-1797A form: the lateral and vertical components with half the
scale length), exact at any step. The distance uses the speed relative to the steady
wind floored at 5 m/s (frozen-turbulence hypothesis; a hovering vehicle still sees the
air mass drift past at the wind speed, and the floor keeps the correlation time finite
in calm air). u is along the steady wind (north when there is none), w is down. The
rotational gust terms of the specification are not modelled.
Random numbers come from the injected generator, drawn in blocks.

One step of the law is the kernel :func:`dryden_step`.
"""
from __future__ import annotations

import math

import numpy as np

from autopilot.jit import kernel, preload

FT_M = 0.3048
KT_MPS = 1852.0 / 3600.0
# turbulence name -> MIL-F-8785C wind speed at 20 ft [kt] (light, moderate, severe)
TURBULENCE_W20_KT = {"none": 0.0, "light": 15.0, "moderate": 30.0, "severe": 45.0}
MIN_SPEED_MPS = 5.0
_BLOCK = 1024


@kernel
def dryden_step(x_u, x_v, x_w, h_agl_m, speed_mps, dt_s, n_steps, sigma_w, nu_u, nu_v, nu_w,
                axis_n, axis_e):
    """The gust filters (x_u, x_v, x_w) [m/s] advanced ``n_steps`` steps of ``dt_s``
    (module docstring: h clipped to 3..300 m, the speed floored at 5 m/s), driven by
    the standard normals nu; returns the new (x_u, x_v, x_w) and the gust's north and
    east components (u along the unit (axis_n, axis_e), v 90 deg right of it)."""
    h_m = 3.0 if h_agl_m < 3.0 else (300.0 if h_agl_m > 300.0 else h_agl_m)
    speed = speed_mps if speed_mps > MIN_SPEED_MPS else MIN_SPEED_MPS
    shape = 0.177 + 0.000823 * (h_m / FT_M)
    length_u = h_m / shape ** 1.2                 # L_u = L_v
    sigma_u = sigma_w / shape ** 0.4              # sigma_u = sigma_v
    step_m = speed * dt_s * n_steps
    # x_k+1 = a x_k + sigma sqrt(1 - a^2) nu, a = exp(-distance / scale length)
    a = math.exp(-step_m / length_u)
    x_u = a * x_u + sigma_u * math.sqrt(1.0 - a * a) * nu_u
    a = math.exp(-2.0 * step_m / length_u)
    x_v = a * x_v + sigma_u * math.sqrt(1.0 - a * a) * nu_v
    a = math.exp(-2.0 * step_m / h_m)
    x_w = a * x_w + sigma_w * math.sqrt(1.0 - a * a) * nu_w
    return x_u, x_v, x_w, axis_n * x_u - axis_e * x_v, axis_e * x_u + axis_n * x_v


# The gusts' state array (``DrydenGusts.s``), which :func:`gust_advance` updates in
# place: the filters x_u, x_v, x_w, the gust (NED), the law's sigma_w, the u axis (north,
# east components) and the time step; then the block of standard normals that drives
# them, ``_BLOCK`` rows of three (``DrydenGusts.noise``: in the one array, so that a
# kernel takes the gusts whole)
_X, _GUST, _SIGMA_W, _AXIS, _DT, _NOISE = 0, 3, 6, 7, 9, 10
GUST_STATE_N = _NOISE + 3 * _BLOCK


@kernel
def gust_advance(s, row, h_agl_m, speed_mps, n_steps):
    """:func:`dryden_step` on the state array ``s`` (``_X`` ... ``_DT``), driven by row
    ``row`` of its block of standard normals (``_NOISE``); the new filters and gust are
    written into ``s`` and the gust (north, east, down) [m/s] returned."""
    k = _NOISE + 3 * row
    x_u, x_v, x_w, gust_n, gust_e = dryden_step(
        s[0], s[1], s[2], h_agl_m, speed_mps, s[9], n_steps, s[6],
        s[k], s[k + 1], s[k + 2], s[7], s[8])
    s[0], s[1], s[2] = x_u, x_v, x_w
    s[3], s[4], s[5] = gust_n, gust_e, x_w
    return gust_n, gust_e, x_w


class DrydenGusts:
    """The gusts' state and their noise, the array ``s``: once per plant step while
    ``active``, a plant advances ``s`` with :func:`gust_advance` (``n_steps`` time steps
    of ``dt_s``, one draw of the noise), on this step's row of ``noise`` from
    :meth:`next_row`. ``configure`` changes the intensity and the steady wind on the
    way. ``s``: where to keep them (``GUST_STATE_N`` floats: a plant's own array, whose
    kernels then take one array), else a new array."""

    def __init__(self, rng: np.random.Generator, dt_s: float, turbulence: str = "none",
                 wind_ned=(0.0, 0.0, 0.0), s: np.ndarray | None = None):
        if turbulence not in TURBULENCE_W20_KT:
            raise ValueError(f"turbulence must be one of {sorted(TURBULENCE_W20_KT)}")
        self._rng = rng
        self.s = np.zeros(GUST_STATE_N) if s is None else s
        self.s[_DT] = float(dt_s)
        sigma_w = 0.1 * TURBULENCE_W20_KT[turbulence] * KT_MPS
        self.s[_SIGMA_W] = sigma_w
        self.active = sigma_w > 0.0
        h = math.hypot(wind_ned[0], wind_ned[1])
        self.s[_AXIS:_DT] = (wind_ned[0] / h, wind_ned[1] / h) if h > 0.1 else (1.0, 0.0)
        # standard normals, one row per step, drawn in place a block at a time (the first
        # at the first row taken)
        self.noise = self.s[_NOISE:].reshape(_BLOCK, 3)
        self._k = _BLOCK
        # the kernel loaded now, not at the take-off (autopilot.jit.preload)
        preload(gust_advance, self.s.copy(), 0, 10.0, 5.0, 1)

    @property
    def gust_ned(self) -> tuple[float, float, float]:
        """The gust of the last step (NED, m/s)."""
        return tuple(self.s[_GUST:_SIGMA_W].tolist())

    def reset(self) -> None:
        """Calm air: the gust filters start again from zero."""
        self.s[_X:_SIGMA_W] = 0.0

    def configure(self, w20_mps: float, wind_ned) -> None:
        """The wind speed at 20 ft ``w20_mps`` (0: no turbulence) and the steady wind
        (NED, m/s: the u axis); the filters start from zero when turbulence starts or
        stops."""
        s = self.s
        s[_SIGMA_W] = 0.1 * w20_mps
        was_active, self.active = self.active, w20_mps > 0.0
        if not self.active:
            self.reset()
        elif not was_active:
            s[_X:_GUST] = 0.0
        wn, we = float(wind_ned[0]), float(wind_ned[1])
        horizontal = math.hypot(wn, we)
        s[_AXIS:_DT] = (wn / horizontal, we / horizontal) if horizontal > 0.1 else (1.0, 0.0)

    def next_row(self) -> int:
        """The row of ``noise`` for this step (a new block drawn when the last is used up)."""
        k = self._k
        if k == _BLOCK:
            self._rng.standard_normal(out=self.noise)
            k = 0
        self._k = k + 1
        return k
