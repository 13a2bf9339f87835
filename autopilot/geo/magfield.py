"""The Earth's main magnetic field from IGRF-13 by spherical-harmonic synthesis.

    V(r, theta, phi) = a * sum_{n=1}^{13} (a/r)^(n+1)
                           sum_{m=0}^{n} (g_n^m cos m phi + h_n^m sin m phi) P_n^m(cos theta)

with ``P_n^m`` the Schmidt quasi-normalised associated Legendre functions, ``a`` the
reference radius 6371.2 km, ``theta`` the geocentric colatitude and ``phi`` the
longitude. The field is ``B = -grad V``:

    B_r     = sum (n+1) (a/r)^(n+2) sum (g cos + h sin) P_n^m
    B_theta = -sum (a/r)^(n+2) sum (g cos + h sin) dP_n^m/dtheta
    B_phi   = (1 / sin theta) sum (a/r)^(n+2) sum m (g sin - h cos) P_n^m

north X = -B_theta, east Y = B_phi, down Z = -B_r (geocentric), then rotated by the
geodetic-geocentric latitude difference into the local geodetic NED frame.
Reference: Alken et al. (2021), Earth Planets Space 73:49 (IGRF-13); the recursion for
P_n^m and its derivative follows Langel (1987), "The main field", in Geomagnetism vol. 1.

The field changes by well under a degree over a flight area of tens of kilometres, so
the sensor model evaluates it once at home (``SensorSuite``); this module is not on
the per-step path.
"""
from __future__ import annotations

import math

from . import igrf13_coeffs as igrf

_A_WGS84_KM = 6378.137
_B_WGS84_KM = 6356.752314245
NT_PER_GAUSS = 1.0e5


def _coefficients(decimal_year: float) -> dict[tuple[int, int], tuple[float, float]]:
    if not igrf.VALID_FROM_YEAR <= decimal_year <= igrf.VALID_UNTIL_YEAR:
        raise ValueError(
            f"IGRF-13 is valid for {igrf.VALID_FROM_YEAR}..{igrf.VALID_UNTIL_YEAR}, "
            f"not {decimal_year}")
    dt = decimal_year - igrf.EPOCH_YEAR
    return {(n, m): (g + g_sv * dt, h + h_sv * dt)
            for n, m, g, h, g_sv, h_sv in igrf.COEFFS}


def igrf_field_ned_nt(lat_rad: float, lon_rad: float, alt_m: float,
                      decimal_year: float = 2025.0,
                      nmax: int = igrf.NMAX) -> tuple[float, float, float]:
    """IGRF-13 main field at a geodetic position: (north, east, down) [nT]."""
    coeffs = _coefficients(decimal_year)
    h_km = alt_m / 1000.0

    # Geodetic -> geocentric: radius r and geocentric colatitude theta.
    slat, clat = math.sin(lat_rad), math.cos(lat_rad)
    a2, b2 = _A_WGS84_KM ** 2, _B_WGS84_KM ** 2
    rho2 = a2 * clat * clat + b2 * slat * slat
    rho = math.sqrt(rho2)
    r = math.sqrt(h_km * (h_km + 2.0 * rho) + (a2 * a2 * clat * clat + b2 * b2 * slat * slat) / rho2)
    cd = (h_km + rho) / r                      # cos of geodetic-geocentric difference
    sd = (a2 - b2) / rho * slat * clat / r     # sin of the same
    cos_t = slat * cd - clat * sd              # cos(colatitude) = sin(geocentric lat)
    sin_t = clat * cd + slat * sd
    sin_t = max(sin_t, 1e-10)                  # the poles: keep B_phi finite

    # Schmidt quasi-normalised P_n^m(cos theta) and dP/dtheta by recursion.
    P = [[0.0] * (nmax + 1) for _ in range(nmax + 1)]
    dP = [[0.0] * (nmax + 1) for _ in range(nmax + 1)]
    P[0][0] = 1.0
    for n in range(1, nmax + 1):
        # sectoral term P_n^n
        k = 1.0 if n == 1 else math.sqrt((2.0 * n - 1.0) / (2.0 * n))
        P[n][n] = k * sin_t * P[n - 1][n - 1]
        dP[n][n] = k * (cos_t * P[n - 1][n - 1] + sin_t * dP[n - 1][n - 1])
        for m in range(n):
            # P_n^m = ((2n-1) cos P_{n-1}^m - sqrt((n-1)^2 - m^2) P_{n-2}^m) / sqrt(n^2 - m^2)
            k1 = 2.0 * n - 1.0
            k2 = math.sqrt(max((n - 1) ** 2 - m * m, 0))
            k3 = math.sqrt(n * n - m * m)
            p2 = P[n - 2][m] if n >= 2 else 0.0
            dp2 = dP[n - 2][m] if n >= 2 else 0.0
            P[n][m] = (k1 * cos_t * P[n - 1][m] - k2 * p2) / k3
            dP[n][m] = (k1 * (cos_t * dP[n - 1][m] - sin_t * P[n - 1][m]) - k2 * dp2) / k3

    ratio = igrf.REFERENCE_RADIUS_KM / r
    b_r = b_t = b_p = 0.0
    for n in range(1, nmax + 1):
        rn = ratio ** (n + 2)
        sr = st = sp = 0.0
        for m in range(n + 1):
            g, h = coeffs[(n, m)]
            cm, sm = math.cos(m * lon_rad), math.sin(m * lon_rad)
            gh = g * cm + h * sm
            sr += gh * P[n][m]
            st += gh * dP[n][m]
            sp += m * (g * sm - h * cm) * P[n][m]
        b_r += (n + 1) * rn * sr
        b_t -= rn * st
        b_p += rn * sp
    b_p /= sin_t

    x, y, z = -b_t, b_p, -b_r              # geocentric north, east, down
    # rotate into the geodetic local frame
    x_geod = x * cd + z * sd
    z_geod = z * cd - x * sd
    return x_geod, y, z_geod


def igrf_field_ned_gauss(lat_rad: float, lon_rad: float, alt_m: float,
                         decimal_year: float = 2025.0) -> tuple[float, float, float]:
    """IGRF-13 main field (north, east, down) [gauss]."""
    n, e, d = igrf_field_ned_nt(lat_rad, lon_rad, alt_m, decimal_year)
    return n / NT_PER_GAUSS, e / NT_PER_GAUSS, d / NT_PER_GAUSS


def declination_inclination_rad(b_ned) -> tuple[float, float]:
    """Declination (east of true north, positive east) and inclination (positive
    down) [rad] of a field vector given in NED."""
    n, e, d = float(b_ned[0]), float(b_ned[1]), float(b_ned[2])
    return math.atan2(e, n), math.atan2(d, math.hypot(n, e))
