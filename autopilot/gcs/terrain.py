"""Terrain heights from a ground station: ArduPilot's terrain protocol.

With ``sitl run --gcs ... --terrain gcs`` the autopilot has no terrain of its own and
asks the ground station for it, as ArduPilot's AP_Terrain does (MAVProxy's terrain
module answers): it sends TERRAIN_REQUEST for the grid blocks it needs (where the
mission's terrain-frame items are, and where the vehicle is), the ground station
answers each requested 4 x 4 sub-block with a TERRAIN_DATA, and the autopilot reports
TERRAIN_REPORT (what is loaded and pending, the terrain height under the vehicle and its
height above it). TERRAIN_CHECK (a point) is answered with a TERRAIN_REPORT for that
point. Until the data is there, a mission with terrain-frame items is refused at arming
(``autopilot.mission.items.terrain_problem``).

The grid (AP_Terrain.h, the ArduPilot wire convention MAVProxy computes the same way):
posts ``TERRAIN_SPACING_M`` = 100 m apart; a block is 28 posts north by 32 east,
placed every 25 x 29 posts from the integer-degree corner south-west of the point (the
blocks overlap by 3 posts, so a point is always inside one with its neighbours);
TERRAIN_REQUEST names a block by its south-west corner (lat, lon in degE7) and a 56-bit
mask of its 4 x 4 sub-blocks (bit = 8 * row + column, rows north, columns east);
TERRAIN_DATA carries one sub-block, ``data[4 * i + j]`` the height [m] of the post i
north and j east of the sub-block's corner. Offsets in metres use ArduPilot's Location
convention: 0.011131884502145034 m per 1e-7 degree of latitude, and that times the
cosine of the latitude for longitude.
"""
from __future__ import annotations

import math

import numpy as np

from ..link.codec import MAV

TERRAIN_SPACING_M = 100
BLOCK_X, BLOCK_Y = 28, 32              # posts north, east
STEP_X, STEP_Y = BLOCK_X - 3, BLOCK_Y - 3
LATLON_TO_M = 0.011131884502145034     # metres per 1e-7 degree
ALL_BITS = (1 << 56) - 1
REQUEST_PERIOD_US = 1_000_000          # ask again for what is missing, once a second


def _offset(lat_e7: int, lon_e7: int, north_m: float, east_m: float) -> tuple[int, int]:
    dlat = north_m / LATLON_TO_M
    lat = lat_e7 + dlat
    scale = max(math.cos(math.radians(0.5 * (lat_e7 + lat) * 1e-7)), 0.01)
    return int(round(lat)), int(round(lon_e7 + east_m / LATLON_TO_M / scale))


def _distance_ne(lat0_e7: int, lon0_e7: int, lat_e7: float, lon_e7: float) -> tuple[float, float]:
    scale = max(math.cos(math.radians(0.5 * (lat0_e7 + lat_e7) * 1e-7)), 0.01)
    return (lat_e7 - lat0_e7) * LATLON_TO_M, (lon_e7 - lon0_e7) * LATLON_TO_M * scale


class GridTerrain:
    """The heights the ground station sent (TERRAIN_DATA), by grid block; ``height_m``
    is None where they have not come yet, and such a point's block is then wanted."""

    def __init__(self, spacing_m: int = TERRAIN_SPACING_M) -> None:
        self.spacing = spacing_m
        self.blocks: dict[tuple[int, int], np.ndarray] = {}
        self.wanted: set[tuple[int, int]] = set()

    def block_of(self, lat_deg: float, lon_deg: float) -> tuple[tuple[int, int], float, float]:
        """(the block's south-west corner (lat, lon degE7), the point's post index north
        and east inside it, fractional)."""
        lat_e7, lon_e7 = lat_deg * 1e7, lon_deg * 1e7
        ref = (math.floor(lat_deg) * 10_000_000, math.floor(lon_deg) * 10_000_000)
        n, e = _distance_ne(*ref, lat_e7, lon_e7)
        ix, iy = n / self.spacing, e / self.spacing
        gx, gy = int(ix // STEP_X), int(iy // STEP_Y)
        corner = _offset(*ref, gx * STEP_X * self.spacing, gy * STEP_Y * self.spacing)
        n0, e0 = _distance_ne(*corner, lat_e7, lon_e7)
        return corner, n0 / self.spacing, e0 / self.spacing

    def height_m(self, lat_deg: float, lon_deg: float) -> float | None:
        corner, x, y = self.block_of(lat_deg, lon_deg)
        grid = self.blocks.get(corner)
        i, j = min(max(int(x), 0), BLOCK_X - 2), min(max(int(y), 0), BLOCK_Y - 2)
        if grid is None:
            self.wanted.add(corner)
            return None
        fx, fy = x - i, y - j
        h = ((1 - fx) * ((1 - fy) * grid[i, j] + fy * grid[i, j + 1])
             + fx * ((1 - fy) * grid[i + 1, j] + fy * grid[i + 1, j + 1]))
        if math.isnan(h):
            self.wanted.add(corner)
            return None
        return float(h)

    __call__ = height_m

    def missing_mask(self, corner: tuple[int, int]) -> int:
        grid = self.blocks.get(corner)
        if grid is None:
            return ALL_BITS
        mask = 0
        for bit in range(56):
            r, c = divmod(bit, 8)
            if np.isnan(grid[4 * r:4 * r + 4, 4 * c:4 * c + 4]).any():
                mask |= 1 << bit
        return mask

    def take(self, msg) -> bool:
        """A TERRAIN_DATA; False if it is not for our grid."""
        if msg.grid_spacing != self.spacing or not 0 <= msg.gridbit < 56:
            return False
        corner = (int(msg.lat), int(msg.lon))
        grid = self.blocks.setdefault(corner, np.full((BLOCK_X, BLOCK_Y), np.nan))
        r, c = divmod(int(msg.gridbit), 8)
        grid[4 * r:4 * r + 4, 4 * c:4 * c + 4] = np.asarray(msg.data, dtype=float).reshape(4, 4)
        if self.missing_mask(corner) == 0:
            self.wanted.discard(corner)
        return True

    @property
    def pending(self) -> int:
        return sum(1 for c in self.wanted if self.missing_mask(c))

    @property
    def loaded(self) -> int:
        return sum(1 for c in self.blocks if self.missing_mask(c) == 0)


def answer_request(msg, heights) -> list:
    """What a ground station's terrain server sends for a TERRAIN_REQUEST: a TERRAIN_DATA
    for every sub-block in its mask, from ``heights`` (lat_deg, lon_deg) -> metres or
    None (a sub-block with a point without data is not sent)."""
    out = []
    for bit in range(56):
        if not (msg.mask >> bit) & 1:
            continue
        r, c = divmod(bit, 8)
        data = []
        for i in range(4):
            for j in range(4):
                lat, lon = _offset(msg.lat, msg.lon, (4 * r + i) * msg.grid_spacing,
                                   (4 * c + j) * msg.grid_spacing)
                h = heights(lat * 1e-7, lon * 1e-7)
                if h is None:
                    break
                data.append(int(round(h)))
            else:
                continue
            break
        if len(data) == 16:
            out.append(MAV.MAVLink_terrain_data_message(msg.lat, msg.lon, msg.grid_spacing, bit, data))
    return out


class TerrainServer:
    """The autopilot's end of the protocol (module docstring), for the ground-station
    service: ``handle`` takes TERRAIN_DATA / TERRAIN_CHECK, ``tick`` asks for what is
    missing, ``report`` is the TERRAIN_REPORT."""

    def __init__(self, vehicle, send, broadcast) -> None:
        self.vehicle = vehicle
        self._send = send
        self._broadcast = broadcast
        self._next_us = 0

    @property
    def grid(self) -> GridTerrain | None:
        t = getattr(self.vehicle, "terrain", None)
        return t if isinstance(t, GridTerrain) else None

    def handle(self, cid: int, msg, t_us: int) -> bool:
        name = msg.get_type()
        if name == "TERRAIN_DATA":
            if self.grid is not None:
                self.grid.take(msg)
            return True
        if name == "TERRAIN_CHECK":
            self._send(cid, self.report(msg.lat * 1e-7, msg.lon * 1e-7))
            return True
        return False

    def tick(self, t_us: int) -> None:
        grid = self.grid
        if grid is None or t_us < self._next_us:
            return
        self._next_us = t_us + REQUEST_PERIOD_US
        m = getattr(self.vehicle, "mission", None)
        if m is not None:
            for it in m.items[1:]:
                if it.frame in (10, 11) and (it.x_lat_deg, it.y_lon_deg) != (0.0, 0.0):
                    grid.height_m(it.x_lat_deg, it.y_lon_deg)
        here = self._here()
        if here is not None:
            grid.height_m(*here[:2])
        for corner in sorted(grid.wanted):
            mask = grid.missing_mask(corner)
            if mask:
                self._broadcast(MAV.MAVLink_terrain_request_message(corner[0], corner[1],
                                                                    grid.spacing, mask))

    def _here(self):
        nav = getattr(self.vehicle, "nav_state", None)
        if nav is None or not getattr(nav, "aligned", True) \
                or (nav.lat_rad == 0.0 and nav.lon_rad == 0.0):
            return None     # no position yet (a filter still aligning reports 0, 0)
        return math.degrees(nav.lat_rad), math.degrees(nav.lon_rad), float(nav.alt_m)

    def report(self, lat_deg: float | None = None, lon_deg: float | None = None):
        """TERRAIN_REPORT for a point (default: the vehicle's position), or None when
        the vehicle has no position yet."""
        here = self._here()
        if lat_deg is None:
            if here is None:
                return None
            lat_deg, lon_deg = here[0], here[1]
        t = getattr(self.vehicle, "terrain", None)
        h = None
        if t is not None:
            h = t(lat_deg, lon_deg)
        else:
            home = getattr(self.vehicle, "home_frame", None)
            h = home.alt0_m if home is not None else None
        grid = self.grid
        current = (here[2] - h) if (here is not None and h is not None) else 0.0
        return MAV.MAVLink_terrain_report_message(
            int(round(lat_deg * 1e7)), int(round(lon_deg * 1e7)),
            grid.spacing if grid is not None else 0, float(h) if h is not None else 0.0,
            float(current), grid.pending if grid is not None else 0,
            grid.loaded if grid is not None else 0)
