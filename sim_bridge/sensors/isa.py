"""ICAO / ISO 2533 International Standard Atmosphere, troposphere and lower stratosphere.

    troposphere (h < 11 km):  T = T0 - L h,  p = p0 (T / T0)^(g0 / (R L))
    stratosphere (11-20 km):  T = T11,       p = p11 exp(-g0 (h - 11000) / (R T11))

``h`` is taken as the geopotential altitude; treating the geometric MSL altitude as
geopotential errs by 0.03 % at 2 km, far below any barometer's noise. Above 20 km the
stratosphere formula is simply extended (no vehicle of this project gets there).
These are scalar float functions because the barometer calls them every sample.
"""
from __future__ import annotations

import math

P0_PA = 101325.0         # sea-level standard pressure [Pa]
T0_K = 288.15            # sea-level standard temperature [K]
RHO0_KGM3 = 1.225        # sea-level standard density [kg/m^3]
LAPSE_K_PER_M = 0.0065   # tropospheric lapse rate [K/m]
R_AIR = 287.05287        # specific gas constant of dry air [J/(kg K)]
G0 = 9.80665             # standard gravity [m/s^2]
H_TROPOPAUSE_M = 11000.0

_EXP = G0 / (R_AIR * LAPSE_K_PER_M)   # 5.25588
_T11_K = T0_K - LAPSE_K_PER_M * H_TROPOPAUSE_M
_P11_PA = P0_PA * (_T11_K / T0_K) ** _EXP


def temperature_k(alt_m: float) -> float:
    """ISA static temperature at altitude [K]."""
    if alt_m < H_TROPOPAUSE_M:
        return T0_K - LAPSE_K_PER_M * alt_m
    return _T11_K


def pressure_pa(alt_m: float) -> float:
    """ISA static pressure at altitude [Pa]."""
    if alt_m < H_TROPOPAUSE_M:
        return P0_PA * (1.0 - LAPSE_K_PER_M * alt_m / T0_K) ** _EXP
    return _P11_PA * math.exp(-G0 * (alt_m - H_TROPOPAUSE_M) / (R_AIR * _T11_K))


def density_kgm3(alt_m: float) -> float:
    """ISA density at altitude [kg/m^3] (ideal gas)."""
    return pressure_pa(alt_m) / (R_AIR * temperature_k(alt_m))


def pressure_altitude_m(p_pa: float) -> float:
    """Inverse of :func:`pressure_pa`: the ISA altitude of a static pressure [m]."""
    if p_pa <= 0.0:
        return float("inf")
    if p_pa > _P11_PA:
        return T0_K / LAPSE_K_PER_M * (1.0 - (p_pa / P0_PA) ** (1.0 / _EXP))
    return H_TROPOPAUSE_M - R_AIR * _T11_K / G0 * math.log(p_pa / _P11_PA)
