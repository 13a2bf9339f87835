"""Terrain heights: flat, or SRTM ``.hgt`` tiles (1 or 3 arc-second), bilinear.

An SRTM tile (NASA's Shuttle Radar Topography Mission format, as ArduPilot's terrain
server and MAVProxy's terrain module read it) covers one degree of latitude and
longitude and is named after its south-west corner: ``S36E149.hgt`` covers latitudes
-36..-35 and longitudes 149..150. It holds N x N big-endian signed 16-bit heights in
metres above mean sea level, rows from north to south, columns from west to east, the
first and last rows and columns on the tile's edges (shared with the neighbours):
N = 3601 for 1 arc-second tiles, 1201 for 3 arc-second ones (the size tells which);
-32768 marks a void. A tile may also be given zipped (``S36E149.hgt.zip``, as the SRTM
archives ship them).

``height_m(lat_deg, lon_deg)`` is the bilinear interpolation of the four posts around
the point, or None where no tile covers it or a post is void: "no data", which the
autopilot treats as ArduPilot does (terrain-frame items cannot be flown there).

Used by both sides: the simulator's ground (``sim_bridge``), and the autopilot's
terrain-relative altitudes when it reads the same tiles itself.
"""
from __future__ import annotations

import math
import os
import zipfile

import numpy as np

VOID = -32768
SIZES = {3601: 1, 1201: 3}      # posts per side -> arc-seconds between posts


class FlatTerrain:
    """The same height everywhere (the simulator's default: home's altitude)."""

    def __init__(self, alt_m: float) -> None:
        self.alt_m = float(alt_m)

    def height_m(self, lat_deg: float, lon_deg: float) -> float | None:
        return self.alt_m

    def __call__(self, lat_deg: float, lon_deg: float) -> float | None:
        return self.alt_m


def height_or(terrain, lat_deg: float, lon_deg: float, default_m: float) -> float:
    """The terrain's height [m MSL] there from ``terrain`` (a callable (lat_deg, lon_deg)
    -> metres or None), else ``default_m`` (no terrain, no data there, or latitude and
    longitude 0, "here")."""
    if terrain is not None and not (lat_deg == 0.0 and lon_deg == 0.0):
        h = terrain(lat_deg, lon_deg)
        if h is not None:
            return float(h)
    return default_m


def tile_name(lat_deg: float, lon_deg: float) -> str:
    """The name of the tile holding the point, e.g. 'S36E149'."""
    la, lo = math.floor(lat_deg), math.floor(lon_deg)
    return f"{'N' if la >= 0 else 'S'}{abs(la):02d}{'E' if lo >= 0 else 'W'}{abs(lo):03d}"


def read_hgt(path: str) -> np.ndarray:
    """The posts of one tile as a float array (NaN for voids); ValueError if the size
    is not that of a 1 or 3 arc-second tile."""
    if path.endswith(".zip"):
        with zipfile.ZipFile(path) as z:
            names = [n for n in z.namelist() if n.lower().endswith(".hgt")]
            if not names:
                raise ValueError(f"{path}: no .hgt file inside")
            raw = z.read(names[0])
    else:
        with open(path, "rb") as f:
            raw = f.read()
    n = int(round(math.sqrt(len(raw) // 2)))
    if n not in SIZES or n * n * 2 != len(raw):
        raise ValueError(f"{path}: {len(raw)} bytes is not a 1 or 3 arc-second SRTM tile "
                         "(3601 x 3601 or 1201 x 1201 heights)")
    a = np.frombuffer(raw, dtype=">i2").reshape(n, n)
    out = a.astype(np.float64)
    out[a == VOID] = np.nan
    return out


def write_hgt(path: str, heights: np.ndarray) -> None:
    """Write N x N heights [m] (rows north to south) as an SRTM tile."""
    h = np.asarray(heights)
    if h.ndim != 2 or h.shape[0] != h.shape[1] or h.shape[0] not in SIZES:
        raise ValueError(f"a tile is 3601 x 3601 or 1201 x 1201 heights, not {h.shape}")
    v = np.where(np.isfinite(h), np.round(h), VOID).astype(">i2")
    with open(path, "wb") as f:
        f.write(v.tobytes())


class TerrainTiles:
    """Heights from the SRTM tiles in a folder (read when first needed, then kept)."""

    def __init__(self, folder: str) -> None:
        if not os.path.isdir(folder):
            raise FileNotFoundError(f"terrain folder {folder} does not exist")
        self.folder = folder
        self._tiles: dict[str, np.ndarray | None] = {}

    def tile(self, name: str) -> np.ndarray | None:
        if name not in self._tiles:
            grid = None
            for fn in (name + ".hgt", name + ".hgt.zip"):
                p = os.path.join(self.folder, fn)
                if os.path.exists(p):
                    grid = read_hgt(p)
                    break
            self._tiles[name] = grid
        return self._tiles[name]

    def covers(self, lat_deg: float, lon_deg: float) -> bool:
        return self.height_m(lat_deg, lon_deg) is not None

    def height_m(self, lat_deg: float, lon_deg: float) -> float | None:
        la0, lo0 = math.floor(lat_deg), math.floor(lon_deg)
        # a point on a tile's south or west edge is also on its neighbour's north or
        # east edge (the posts are shared): either tile gives it
        for la in ((la0, la0 - 1) if lat_deg == la0 else (la0,)):
            for lo in ((lo0, lo0 - 1) if lon_deg == lo0 else (lo0,)):
                grid = self.tile(tile_name(la + 0.5, lo + 0.5))
                if grid is not None:
                    return self._interp(grid, la, lo, lat_deg, lon_deg)
        return None

    @staticmethod
    def _interp(grid: np.ndarray, la0: int, lo0: int, lat_deg: float, lon_deg: float) -> float | None:
        n = grid.shape[0] - 1
        y = (la0 + 1 - lat_deg) * n          # rows from the north edge
        x = (lon_deg - lo0) * n              # columns from the west edge
        i, j = min(int(y), n - 1), min(int(x), n - 1)
        fy, fx = y - i, x - j
        h = ((1 - fy) * ((1 - fx) * grid[i, j] + fx * grid[i, j + 1])
             + fy * ((1 - fx) * grid[i + 1, j] + fx * grid[i + 1, j + 1]))
        return None if math.isnan(h) else float(h)

    __call__ = height_m
