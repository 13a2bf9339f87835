"""WGS-84 geodetic <-> ECEF <-> local NED (seed eqs 1.15-1.17).

The seed's eqs 1.15-1.17 lost their subscripts in extraction; rebuilt here from
Beard & McLain (2012) and the WGS-84 definition (NIMA TR8350.2):

    N(lat) = a / sqrt(1 - e^2 sin^2 lat)                 (prime-vertical radius, eq 1.16)
    e^2    = 1 - b^2 / a^2                               (eccentricity, eq 1.17)
    x = (N + h) cos lat cos lon
    y = (N + h) cos lat sin lon                          (eq 1.15)
    z = ((1 - e^2) N + h) sin lat

ECEF -> geodetic uses Bowring's closed form followed by one Newton refinement (exact to
well under a millimetre for aircraft altitudes). The local NED frame is the tangent
plane at an origin; longitudes are differenced through ECEF, so nothing breaks at the
180-degree meridian. Returned longitudes are wrapped to [-pi, pi).
"""
from __future__ import annotations

import math

import numpy as np

from ..jit import kernel
from .rotations import PI, TWO_PI, wrap_pi

A_M = 6378137.0                      # semi-major axis [m]
B_M = 6356752.314245                 # semi-minor axis [m]
E2 = 1.0 - (B_M * B_M) / (A_M * A_M)  # first eccentricity squared
EP2 = (A_M * A_M) / (B_M * B_M) - 1.0  # second eccentricity squared
G0 = 9.80665                         # standard gravity [m/s^2]


def prime_vertical_radius(lat_rad: float) -> float:
    s = math.sin(lat_rad)
    return A_M / math.sqrt(1.0 - E2 * s * s)


def meridian_radius(lat_rad: float) -> float:
    s = math.sin(lat_rad)
    return A_M * (1.0 - E2) / (1.0 - E2 * s * s) ** 1.5


def geodetic_to_ecef(lat_rad: float, lon_rad: float, alt_m: float) -> np.ndarray:
    n = prime_vertical_radius(lat_rad)
    cl = math.cos(lat_rad)
    return np.array([
        (n + alt_m) * cl * math.cos(lon_rad),
        (n + alt_m) * cl * math.sin(lon_rad),
        ((1.0 - E2) * n + alt_m) * math.sin(lat_rad),
    ])


def ecef_to_geodetic(r_ecef: np.ndarray) -> tuple[float, float, float]:
    x, y, z = float(r_ecef[0]), float(r_ecef[1]), float(r_ecef[2])
    lon = math.atan2(y, x)
    p = math.hypot(x, y)
    # Bowring's initial guess
    theta = math.atan2(z * A_M, p * B_M)
    st, ct = math.sin(theta), math.cos(theta)
    lat = math.atan2(z + EP2 * B_M * st ** 3, p - E2 * A_M * ct ** 3)
    for _ in range(2):  # Newton-like refinement on the latitude
        n = prime_vertical_radius(lat)
        if abs(math.cos(lat)) > 1e-9:
            alt = p / math.cos(lat) - n
        else:
            alt = abs(z) - B_M
        lat = math.atan2(z, p * (1.0 - E2 * n / (n + alt)))
    n = prime_vertical_radius(lat)
    if abs(math.cos(lat)) > 1e-9:
        alt = p / math.cos(lat) - n
    else:
        alt = abs(z) - B_M
    return lat, wrap_pi(lon), alt


def ecef_to_ned_matrix(lat_rad: float, lon_rad: float) -> np.ndarray:
    """R_ne: rotates ECEF vectors into the NED frame at (lat, lon)."""
    sl, cl = math.sin(lat_rad), math.cos(lat_rad)
    so, co = math.sin(lon_rad), math.cos(lon_rad)
    return np.array([
        [-sl * co, -sl * so, cl],
        [-so, co, 0.0],
        [-cl * co, -cl * so, -sl],
    ])


class LocalFrame:
    """A local tangent-plane NED frame anchored at an origin (lat, lon, alt)."""

    __slots__ = ("lat0_rad", "lon0_rad", "alt0_m", "_r0", "_R_ne", "_rm", "_rn0", "_bend")

    def __init__(self, lat0_rad: float, lon0_rad: float, alt0_m: float):
        self.lat0_rad = float(lat0_rad)
        self.lon0_rad = float(lon0_rad)
        self.alt0_m = float(alt0_m)
        self._r0 = geodetic_to_ecef(lat0_rad, lon0_rad, alt0_m)
        self._R_ne = ecef_to_ned_matrix(lat0_rad, lon0_rad)
        self._rm = meridian_radius(lat0_rad) + alt0_m
        self._rn0 = prime_vertical_radius(lat0_rad) + alt0_m
        self._bend = 0.5 * math.tan(lat0_rad) / self._rn0

    @classmethod
    def from_degrees(cls, lat_deg: float, lon_deg: float, alt_m: float) -> "LocalFrame":
        return cls(math.radians(lat_deg), math.radians(lon_deg), alt_m)

    def to_ned(self, lat_rad: float, lon_rad: float, alt_m: float) -> np.ndarray:
        """Exact: through ECEF."""
        return self._R_ne @ (geodetic_to_ecef(lat_rad, lon_rad, alt_m) - self._r0)

    def to_geodetic(self, p_ned: np.ndarray) -> tuple[float, float, float]:
        """Exact: through ECEF."""
        return ecef_to_geodetic(self._r0 + self._R_ne.T @ np.asarray(p_ned, dtype=float))

    def ned_fast(self, lat_rad: float, lon_rad: float, alt_m: float) -> tuple[float, float, float]:
        """Small-area approximation used in the per-step loop (the vehicle stays within
        tens of km of the origin): north from the meridian radius at the origin, east
        from the parallel's radius at the point's own latitude, plus the second-order
        bend of the parallel in the tangent plane (e^2 tan(lat0) / 2N). Agrees with the
        exact tangent plane to centimetres at 5 km. Longitude difference is wrapped, so
        the 180-degree meridian is safe. A tuple (north, east, down) [m]: for the code
        that reads it element by element (a numpy element costs more than a float)."""
        e = wrap_pi(lon_rad - self.lon0_rad) * self._rn0 * math.cos(lat_rad)
        return ((lat_rad - self.lat0_rad) * self._rm + e * e * self._bend,
                e,
                self.alt0_m - alt_m)

    def to_ned_fast(self, lat_rad: float, lon_rad: float, alt_m: float) -> np.ndarray:
        """``ned_fast`` as an array."""
        return np.array(self.ned_fast(lat_rad, lon_rad, alt_m))

    def fast_constants(self) -> tuple[float, ...]:
        """(lat0, lon0, alt0, R_M, R_N, bend): the arguments of :func:`geodetic_fast`
        before the position."""
        return self.lat0_rad, self.lon0_rad, self.alt0_m, self._rm, self._rn0, self._bend

    def to_geodetic_fast(self, p_ned: np.ndarray) -> tuple[float, float, float]:
        """The inverse of ``ned_fast`` (:func:`geodetic_fast`)."""
        return _geodetic_fast(self.lat0_rad, self.lon0_rad, self.alt0_m, self._rm, self._rn0,
                              self._bend, p_ned[0], float(p_ned[1]), p_ned[2])


@kernel
def geodetic_fast(lat0, lon0, alt0, rm, rn0, bend, n, e, d):
    """(lat, lon, alt) of the NED point (n, e, d) of the frame whose constants are
    ``LocalFrame.fast_constants()``: the inverse of ``LocalFrame.ned_fast`` (the
    navigation filters' output kernel calls it; ``to_geodetic_fast`` runs the same
    source interpreted, where a kernel's call would cost more than the arithmetic)."""
    lat = lat0 + (n - e * e * bend) / rm
    return lat, (lon0 + e / (rn0 * math.cos(lat)) + PI) % TWO_PI - PI, alt0 - d   # wrap_pi


_geodetic_fast = geodetic_fast.py_func


def gravity_m_s2(lat_rad: float, alt_m: float) -> float:
    """Normal gravity (Somigliana) with a free-air height correction [m/s^2]."""
    s2 = math.sin(lat_rad) ** 2
    g0 = 9.7803253359 * (1.0 + 0.00193185265241 * s2) / math.sqrt(1.0 - 0.00669437999013 * s2)
    return g0 - 3.086e-6 * alt_m
