"""The airframe-independent parts of a flight-log row (autopilot/vehicle_base.py,
``_truth_row`` and ``_nav_row``): one tuple each in their columns' order, value for
value the formulas they replaced (quat_to_euler of truth's attitude, the filter's
sigmas, the fix in home's NED)."""
import math
from types import SimpleNamespace

from autopilot.geo import LocalFrame, quat_to_euler
from autopilot.vehicle_base import NAV_COLUMNS, TRUTH_COLUMNS, VehicleBase

HOME = LocalFrame(math.radians(47.4), math.radians(8.5), 430.0)
TRUTH = SimpleNamespace(lat_rad=math.radians(47.401), lon_rad=math.radians(8.502), alt_m=512.5,
                        q_nb=(0.9, 0.1, -0.2, 0.37), v_ned=(21.0, -3.5, 0.75),
                        airspeed_mps=22.25)
GPS = SimpleNamespace(lat_rad=math.radians(47.4012), lon_rad=math.radians(8.5017), alt_m=511.0)
SIG = tuple(0.1 * k for k in range(1, 10))


def same(a, b):
    return len(a) == len(b) and all(x == y or (math.isnan(x) and math.isnan(y))
                                    for x, y in zip(a, b))


def test_truth_row_in_its_columns_order():
    row = VehicleBase._truth_row(HOME, TRUTH)
    p = HOME.ned_fast(TRUTH.lat_rad, TRUTH.lon_rad, TRUTH.alt_m)
    want = (p[0], p[1], TRUTH.alt_m, *quat_to_euler(TRUTH.q_nb), *TRUTH.v_ned,
            TRUTH.airspeed_mps)
    assert len(row) == len(TRUTH_COLUMNS)
    assert row == want
    assert same(VehicleBase._truth_row(HOME, None), (math.nan,) * len(TRUTH_COLUMNS))


def test_nav_row_in_its_columns_order():
    nav = SimpleNamespace(aligned=True, healthy=False)
    v = VehicleBase()
    v.nav = SimpleNamespace(output_sigmas9=lambda: SIG)
    g = HOME.ned_fast(GPS.lat_rad, GPS.lon_rad, GPS.alt_m)
    row = v._nav_row(HOME, nav, GPS)
    assert len(row) == len(NAV_COLUMNS)
    assert row == (*SIG, True, False, g[0], g[1], GPS.alt_m)
    # truth navigation (no sigmas) and a step without a fix: NaN there
    v.nav = SimpleNamespace()
    assert same(v._nav_row(HOME, nav, None), ((math.nan,) * 9 + (True, False)
                                                 + (math.nan,) * 3))
