"""A small hilly SRTM tile for terrain-following flights, generated (not downloaded).

``python -m tools.terrain_tile DIR`` writes ``DIR/S36E149.hgt``: the 3 arc-second tile
(1201 x 1201 heights, about 90 m between posts) that holds ArduPilot's SITL home at
Canberra (CMAC, -35.363262 149.165237, 584 m), the home of the shipped missions. The
ground is rolling hills: ``hills_m(north, east)`` of the distance from that home, a sum
of three crossed sine waves (wavelengths 2.4 to 4.1 km, amplitudes 12 to 25 m: slopes
up to about 10 %), zero at home so that home stays at 584 m; then each post is rounded
to the metre as SRTM stores it. Deterministic: no random numbers.

Fly it: ``sitl run --mission missions/terrain_plane.plan --terrain DIR`` (or
``--vehicle quad --mission missions/terrain_quad.plan``); ``python -m tools.terrain_tile
DIR --fly`` writes the tile if needed and flies the fixed-wing's mission in one command.
"""
from __future__ import annotations

import math
import os
import subprocess
import sys

import numpy as np

from autopilot.geo import meridian_radius, prime_vertical_radius
from autopilot.geo.terrain import tile_name, write_hgt

HOME = (-35.363262, 149.165237, 584.0)
N_POSTS = 1201
WAVES = ((25.0, 3100.0, 4100.0, 0.3), (18.0, 2400.0, 2900.0, 1.1), (12.0, 3700.0, 2600.0, 2.0))


def hills_m(north_m, east_m):
    """Height above home's altitude [m] at (north, east) metres from home."""
    h = 0.0
    for amp, lam_n, lam_e, phase in WAVES:
        h = h + amp * (np.sin(2 * np.pi * north_m / lam_n + phase) * np.cos(2 * np.pi * east_m / lam_e)
                       - math.sin(phase))
    return h


def hilly_tile(home=HOME) -> tuple[str, np.ndarray]:
    """(tile name, heights rows north to south) of the tile holding ``home``."""
    la0, lo0 = math.floor(home[0]), math.floor(home[1])
    lats = la0 + 1 - np.arange(N_POSTS) / (N_POSTS - 1)
    lons = lo0 + np.arange(N_POSTS) / (N_POSTS - 1)
    # north / east of home along the meridian and the parallel (WGS-84 radii of
    # curvature at home: within a few km of it, where the missions fly, exact to cm)
    lat0 = math.radians(home[0])
    north = np.radians(lats - home[0]) * meridian_radius(lat0)
    east = np.radians(lons - home[1]) * prime_vertical_radius(lat0) * math.cos(lat0)
    heights = home[2] + hills_m(north[:, None], east[None, :])
    return tile_name(*home[:2]), heights


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if not argv or argv[0].startswith("-"):
        print("usage: python -m tools.terrain_tile DIR [--fly]", file=sys.stderr)
        return 2
    folder = argv[0]
    os.makedirs(folder, exist_ok=True)
    name, heights = hilly_tile()
    path = os.path.join(folder, name + ".hgt")
    if not os.path.exists(path):
        write_hgt(path, heights)
        print(f"wrote {path} ({N_POSTS} x {N_POSTS}, {np.nanmin(heights):.0f}-"
              f"{np.nanmax(heights):.0f} m)", file=sys.stderr)
    if "--fly" in argv[1:]:
        mission = os.path.join(os.path.dirname(__file__), "..", "missions", "terrain_plane.plan")
        return subprocess.call([sys.executable, "-m", "tools.sitl", "run", "--mission",
                                os.path.normpath(mission), "--terrain", folder])
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
