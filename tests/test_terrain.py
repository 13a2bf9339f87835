"""Terrain (issue 17): SRTM tiles read as SRTM writes them, the hilly tile of
tools/terrain_tile.py, terrain-frame items flown above the ground, arming refused while
a terrain-frame item has no data under it, and a real flight over the tiles."""
import json
import math
import zipfile

import numpy as np
import pytest

from autopilot.geo.terrain import FlatTerrain, TerrainTiles, read_hgt, tile_name, write_hgt
from autopilot.link.codec import MAV
from autopilot.mission.files import loads_plan
from autopilot.mission.items import NAV_WAYPOINT, terrain_problem
from test_gcs_protocol import cmd_long, give_nav, make_core, make_quad, take, wire
import test_sequencer as ps


def ramp_tile(folder, name="S36E149", n=1201):
    """A tile whose height is 500 + 0.5 row + 0.25 column (rows from the north), one void."""
    i, j = np.mgrid[0:n, 0:n]
    h = 500.0 + 0.5 * i + 0.25 * j
    h[10, 10] = np.nan
    write_hgt(str(folder / f"{name}.hgt"), h)
    return h


def test_a_tile_reads_back_bilinear_with_voids_and_edges_as_srtm_lays_them_out(tmp_path):
    ramp_tile(tmp_path)
    t = TerrainTiles(str(tmp_path))
    assert tile_name(-35.36, 149.17) == "S36E149" and tile_name(12.5, -0.5) == "N12W001"
    # the north-west corner is post (0, 0); rows run south, columns east (3 arc-seconds)
    assert t(-35.0, 149.0) == pytest.approx(500.0)
    assert t(-36.0, 150.0) == pytest.approx(500.0 + 0.5 * 1200 + 0.25 * 1200)
    lat, lon = -35.0 - 100.5 / 1200, 149.0 + 300.25 / 1200     # between posts: bilinear
    assert t(lat, lon) == pytest.approx(500.0 + 0.5 * 100.5 + 0.25 * 300.25, abs=0.3)
    assert t(-35.0 - 10.5 / 1200, 149.0 + 10.5 / 1200) is None  # next to the void
    assert t(-34.5, 149.5) is None                             # no tile there
    # zipped as the SRTM archives ship them
    z = tmp_path / "zipped"
    z.mkdir()
    with zipfile.ZipFile(z / "S36E149.hgt.zip", "w") as f:
        f.write(tmp_path / "S36E149.hgt", "S36E149.hgt")
    assert TerrainTiles(str(z))(lat, lon) == t(lat, lon)
    (tmp_path / "bad.hgt").write_bytes(b"\0" * 1000)
    with pytest.raises(ValueError, match="not a 1 or 3 arc-second SRTM tile"):
        read_hgt(str(tmp_path / "bad.hgt"))


def test_the_hilly_tile_keeps_home_at_584_m_and_has_hills(tmp_path):
    from tools.terrain_tile import main
    assert main([str(tmp_path)]) == 0
    t = TerrainTiles(str(tmp_path))
    assert t(-35.363262, 149.165237) == pytest.approx(584.0, abs=1.0)
    hs = [t(-35.363262 + dn, 149.165237 + de) for dn in np.linspace(-0.03, 0.03, 13)
          for de in np.linspace(-0.03, 0.03, 13)]
    assert max(hs) - min(hs) > 50.0


def _terrain_mission(lat, lon):
    items = [{"type": "SimpleItem", "command": 22, "frame": 3, "autoContinue": True,
              "params": [0, 0, 0, None, -35.363262, 149.165237, 30], "doJumpId": 1},
             {"type": "SimpleItem", "command": 16, "frame": 10, "autoContinue": True,
              "params": [0, 0, 0, None, lat, lon, 50], "doJumpId": 2},
             {"type": "SimpleItem", "command": 20, "frame": 2, "autoContinue": True,
              "params": [0, 0, 0, 0, 0, 0, 0], "doJumpId": 3}]
    doc = {"fileType": "Plan", "version": 1, "mission": {
        "version": 2, "plannedHomePosition": [-35.363262, 149.165237, 584], "items": items}}
    return loads_plan(json.dumps(doc), "t.plan")


@pytest.mark.parametrize("quad", [False, True])
def test_arming_is_refused_while_a_terrain_item_has_no_data_under_it(tmp_path, quad):
    ramp_tile(tmp_path)
    tiles = TerrainTiles(str(tmp_path))
    outside = _terrain_mission(-34.99, 149.2)        # the tile S35E149 is not there
    assert terrain_problem(outside, tiles) == "terrain data missing for item 2"
    assert terrain_problem(outside, None) is None     # flat terrain: data everywhere
    core, v, _, _ = make_core(make_quad() if quad else None)
    v.terrain = tiles
    v.mission = outside
    give_nav(v)
    core.receive(1, wire(cmd_long(MAV.MAV_CMD_COMPONENT_ARM_DISARM, 1)), 0)
    out = take(core, 1)
    ack = [m for m in out if m.get_type() == "COMMAND_ACK"]
    said = [m.text for m in out if m.get_type() == "STATUSTEXT"]
    assert ack[-1].result == MAV.MAV_RESULT_FAILED and not v.armed
    assert said == ["PreArm: terrain data missing for item 2"]
    v.mission = _terrain_mission(-35.37, 149.17)      # inside the tile: arms
    core.receive(1, wire(cmd_long(MAV.MAV_CMD_COMPONENT_ARM_DISARM, 1)), 0)
    ack = [m for m in take(core, 1) if m.get_type() == "COMMAND_ACK"]
    assert ack[-1].result == MAV.MAV_RESULT_ACCEPTED and v.armed


def test_the_plane_demands_its_height_above_the_ground_ahead_on_a_terrain_leg():
    s = ps.seq_for(ps.mission(ps.item(1, NAV_WAYPOINT, 500, 0, alt=100.0),
                              ps.item(2, NAV_WAYPOINT, 2000, 0, alt=50.0, frame=10)))
    ground = lambda lat, lon: 500.0 + 2000.0 * (lat + 35.0)   # rises northwards  # noqa: E731
    s.terrain = ground
    s._prev_wp_ne = (0.0, 0.0)
    t = s.update(0, np.array([600.0, 0.0, -100.0]), np.array([25.0, 0.0, 0.0]), 0.0, 600.0)
    assert t.seq == 2 and t.kind == "line"
    lat, lon, _ = ps.HOME.to_geodetic_fast((600.0 + 2.0 * 25.0, 0.0, 0.0))
    assert t.alt_m == pytest.approx(ground(math.degrees(lat), 0.0) + 50.0, abs=1e-6)
    t2 = s.update(10_000, np.array([1200.0, 0.0, -100.0]), np.array([25.0, 0.0, 0.0]), 0.0, 600.0)
    assert t2.alt_m - t.alt_m == pytest.approx(2000.0 * math.degrees(600.0 / 6356000.0), rel=0.01)
    # a flat terrain model is the relative frame
    s = ps.seq_for(ps.mission(ps.item(1, NAV_WAYPOINT, 2000, 0, alt=50.0, frame=10)))
    s.terrain = FlatTerrain(500.0)
    s._prev_wp_ne = (0.0, 0.0)
    t = s.update(0, np.array([600.0, 0.0, -100.0]), np.array([25.0, 0.0, 0.0]), 0.0, 600.0)
    assert t.alt_m == pytest.approx(550.0)


def test_the_quad_flies_50_m_above_the_hilly_tile(tmp_path):
    """A real flight (tools.sitl run --terrain): take off to 50 m, a terrain-frame leg of
    about 460 m over ground falling 29 m, land at home; AGL on the leg against 50 m."""
    import subprocess
    import sys

    from test_gcs_support import REPO
    from tools.terrain_tile import main
    main([str(tmp_path / "tiles")])
    doc = json.loads((REPO / "missions" / "terrain_quad.plan").read_text())
    items = doc["mission"]["items"]
    doc["mission"]["items"] = [items[0], items[2] | {"params": items[2]["params"][:4] + [
        -35.366, 149.169, 50]}, items[-1]]
    for k, it in enumerate(doc["mission"]["items"], start=1):
        it["doJumpId"] = k
    plan = tmp_path / "t.plan"
    plan.write_text(json.dumps(doc))
    out = subprocess.run([sys.executable, "-m", "tools.sitl", "run", "--vehicle", "quad",
                          "--mission", str(plan), "--terrain", str(tmp_path / "tiles"),
                          "--json", "--log-dir", str(tmp_path / "run")],
                         cwd=REPO, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    s = json.loads(out.stdout)
    assert s["completed"] and not s["crashed"] and s["invariants_passed"]
    assert s["agl_rms_err_m"] < 2.0 and s["agl_min_m"] > 45.0


def test_with_terrain_gcs_the_vehicle_asks_the_ground_station_and_arms_once_answered(tmp_path):
    """``--terrain gcs`` over real TCP: the vehicle sends TERRAIN_REQUEST for the blocks
    under its terrain-frame items and itself; arming is refused until they are answered
    (PreArm: terrain data missing for item 2); this client answers as MAVProxy's terrain
    module does (TERRAIN_DATA per requested 4 x 4 sub-block, from the hilly tile); then
    TERRAIN_REPORT has nothing pending, the tile's height under the vehicle, and arming
    is accepted."""
    import time

    from autopilot.gcs.terrain import answer_request
    from test_gcs_support import MISSIONS, Sitl, command, connect
    from tools.terrain_tile import main
    main([str(tmp_path / "tiles")])
    tiles = TerrainTiles(str(tmp_path / "tiles"))
    sitl = Sitl(tmp_path / "run", "--vehicle", "quad", "--terrain", "gcs",
                "--mission", str(MISSIONS / "terrain_quad.plan"))
    try:
        m = connect(sitl.url)
        req = m.recv_match(type="TERRAIN_REQUEST", blocking=True, timeout=15)
        assert req is not None and req.grid_spacing == 100 and req.mask == (1 << 56) - 1
        refused = None
        deadline = time.monotonic() + 40
        while refused is None and time.monotonic() < deadline:   # until navigation is aligned
            m.mav.command_long_send(1, 1, 400, 0, 1, 0, 0, 0, 0, 0, 0)
            got = []
            while (x := m.recv_match(type=["COMMAND_ACK", "STATUSTEXT"], blocking=True,
                                     timeout=0.5)) is not None:
                got.append(x)
            texts = [x.text for x in got if x.get_type() == "STATUSTEXT"]
            if "PreArm: terrain data missing for item 2" in texts:
                refused = next(x for x in got if x.get_type() == "COMMAND_ACK")
        assert refused is not None and refused.result == MAV.MAV_RESULT_FAILED
        served, report = set(), None
        deadline = time.monotonic() + 30
        while time.monotonic() < deadline:
            msg = m.recv_match(type=["TERRAIN_REQUEST", "TERRAIN_REPORT"], blocking=True, timeout=0.5)
            if msg is None:
                continue
            if msg.get_type() == "TERRAIN_REQUEST":
                for d in answer_request(msg, tiles):
                    m.mav.send(d)
                served.add((msg.lat, msg.lon))
            elif served and msg.pending == 0 and msg.loaded >= len(served):
                report = msg
                break
        assert report is not None, served
        here = tiles(report.lat * 1e-7, report.lon * 1e-7)
        assert report.spacing == 100 and abs(report.terrain_height - here) < 1.0
        ack = command(m, 400, 1)
        assert ack is not None and ack.result == MAV.MAV_RESULT_ACCEPTED
    finally:
        sitl.stop()
