"""Rotations, WGS-84 / ECEF / NED, units at the boundary (a leaf package: it imports
nothing else of the project but autopilot.jit, for its rotation kernels)."""
from .rotations import (  # noqa: F401
    dcm_to_quat, euler_to_quat, from_scipy, quat_conjugate, quat_from_rotvec,
    quat_integrate, quat_multiply, quat_normalize, quat_to_dcm, quat_to_euler,
    quat_to_rotvec, rotate, skew, to_scipy, wrap_2pi, wrap_pi,
)
from .wgs84 import (  # noqa: F401
    A_M, B_M, E2, G0, LocalFrame, ecef_to_geodetic, ecef_to_ned_matrix,
    geodetic_to_ecef, gravity_m_s2, meridian_radius, prime_vertical_radius,
)
