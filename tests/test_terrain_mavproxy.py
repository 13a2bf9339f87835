"""The terrain protocol against MAVProxy's own terrain module (issue 17): the vehicle,
with ``--terrain gcs``, has no terrain of its own (its simulator's ground is flat at
home's altitude) and asks the ground station for it, as ArduPilot's AP_Terrain does.

MAVProxy answers from its SRTM cache, ``$HOME/.tilecache/SRTM3``: a ``filelist_python``
pickle mapping each 1-degree tile (lat, lon) to (folder, ``XnnYnnn.hgt.zip``), and the
zipped tiles beside it. The test builds such a cache in a temporary HOME from the
product's hilly tile (``tools/terrain_tile.py``), with every other tile of the list
absent, as a cache that has downloaded only one tile holds it; MAVProxy runs headless
with ``terrain set offline 1`` (no download), its commands staged with ``repeat add
PERIOD script FILE`` as in test_gcs_mavproxy.py. The list names every tile of latitudes
-60..59 so that MAVProxy takes it for a complete list (it asks the server for a new one
when it holds fewer than 14500 entries, before the offline setting is given).

What is checked: TERRAIN_REQUEST from the vehicle, MAVProxy's TERRAIN_DATA (at its own
rate, five sub-blocks a second), arming refused with the PreArm reason until the data is
in, then TERRAIN_REPORT with nothing pending; MAVProxy's ``terrain check`` (TERRAIN_CHECK)
at a mission item, answered by the vehicle's TERRAIN_REPORT with the hill's height there,
tens of metres off the flat ground the vehicle would otherwise assume: the height the
terrain-frame item is flown above. MAVProxy's heights are its bilinear interpolation of
the tile's posts, truncated to whole metres, on a 100 m grid that the vehicle interpolates
again: within 2 m of the tile's own bilinear height."""
import os
import pickle
import re
import threading
import time
import zipfile

from autopilot.geo.terrain import TerrainTiles, tile_name
from test_gcs_mavproxy import MavProxy
from test_gcs_support import MISSIONS, Sitl, connect

HOME = (-35.363262, 149.165237)       # the shipped missions' home (tools/terrain_tile.py)
HOME_ALT_M = 584.0
ITEM = (-35.3605579, 149.1751386)      # terrain_quad.plan's item 2 (the north-east corner)


def mavproxy_srtm_cache(home, tiles_dir, name):
    """``home/.tilecache/SRTM3`` as MAVProxy's SRTM downloader keeps it, holding the tile
    ``name`` (e.g. S36E149) of ``tiles_dir``."""
    cache = home / ".tilecache" / "SRTM3"
    cache.mkdir(parents=True)
    with zipfile.ZipFile(cache / f"{name}.hgt.zip", "w") as z:
        z.write(tiles_dir / f"{name}.hgt", f"{name}.hgt")
    files = {}
    for lat in range(-60, 60):
        for lon in range(-180, 180):
            files[(lat, lon)] = ("Offline/", f"{tile_name(lat, lon)}.hgt.zip")
    files[(-36, 149)] = ("Australia/", f"{name}.hgt.zip")
    files["server"], files["directory"] = "terrain.ardupilot.org", "/SRTM3/"
    with open(cache / "filelist_python", "wb") as f:
        pickle.dump(files, f)


def test_mavproxy_terrain_module_answers_from_its_srtm_cache(tmp_path):
    from tools.terrain_tile import main
    main([str(tmp_path / "tiles")])
    tiles = TerrainTiles(str(tmp_path / "tiles"))
    name = tile_name(*ITEM)
    home = tmp_path / "home"
    mavproxy_srtm_cache(home, tmp_path / "tiles", name)
    hill_m = tiles(*ITEM)
    assert abs(hill_m - HOME_ALT_M) > 10.0           # a hill (or a valley) there, not home's height

    check = tmp_path / "check.scr"
    check.write_text(f"terrain check {ITEM[0]} {ITEM[1]}\narm throttle\n")
    sitl = Sitl(tmp_path / "run", "--vehicle", "quad", "--terrain", "gcs",
                "--mission", str(MISSIONS / "terrain_quad.plan"))
    seen = {"requests": 0, "data": 0, "prearm": [], "reports": [], "armed": None}
    stop = threading.Event()

    def monitor():
        # a second client: sees what the vehicle sends every ground station
        m = connect(sitl.url, sysid=250)
        while not stop.is_set():
            msg = m.recv_match(type=["TERRAIN_REQUEST", "TERRAIN_REPORT", "STATUSTEXT", "HEARTBEAT"],
                               blocking=True, timeout=0.2)
            if msg is None:
                continue
            kind = msg.get_type()
            if kind == "TERRAIN_REQUEST":
                seen["requests"] += 1
            elif kind == "TERRAIN_REPORT":
                seen["reports"].append(msg)
            elif kind == "STATUSTEXT" and msg.text.startswith("PreArm: terrain"):
                seen["prearm"].append((time.monotonic(), msg.text))
            elif kind == "HEARTBEAT" and msg.get_srcSystem() == 1 and msg.base_mode & 128 \
                    and seen["armed"] is None:
                seen["armed"] = time.monotonic()
        m.close()

    mon = threading.Thread(target=monitor, daemon=True)
    mon.start()
    env = dict(os.environ, HOME=str(home))
    mp = MavProxy(sitl.url, tmp_path, "--daemon", "--non-interactive", "--load-module=terrain",
                  "--cmd", f"terrain set offline 1; repeat add 2 script {check.name}", env=env)
    try:
        # THEN MAVProxy answers the check with the vehicle's TERRAIN_REPORT, the hill's
        #      height at the item once its data has come (before: 0, pending)
        report = None
        deadline = time.monotonic() + 90
        while report is None and time.monotonic() < deadline:
            m = mp.expect(r"TERRAIN_REPORT \{(.*)\}", deadline - time.monotonic())
            fields = dict(re.findall(r"(\w+) : ([-\d.]+)", m.group(1)))
            if int(fields["pending"]) == 0 and float(fields["terrain_height"]) != 0.0:
                report = fields
        assert report is not None
        assert int(report["lat"]) == round(ITEM[0] * 1e7) and int(report["lon"]) == round(ITEM[1] * 1e7)
        assert int(report["spacing"]) == 100 and int(report["loaded"]) >= 1
        assert abs(float(report["terrain_height"]) - hill_m) <= 2.0, (report, hill_m)
        # AND arming was refused for want of terrain data, then accepted
        mp.expect(r"COMPONENT_ARM_DISARM: ACCEPTED", 30)
        deadline = time.monotonic() + 10
        while seen["armed"] is None and time.monotonic() < deadline:
            time.sleep(0.1)
        assert seen["armed"] is not None
        assert seen["prearm"] and seen["prearm"][0][0] < seen["armed"], seen["prearm"]
        assert seen["prearm"][0][1].startswith("PreArm: terrain data missing for item")
        # AND the requests went out, and the vehicle's own report (where it stands, at
        #     home) has nothing pending and home's height from MAVProxy's grid
        assert seen["requests"] >= 1
        own = [r for r in seen["reports"] if r.pending == 0 and r.loaded >= 1
               and abs(r.lat * 1e-7 - HOME[0]) < 1e-3 and abs(r.lon * 1e-7 - HOME[1]) < 1e-3]
        assert own and abs(own[-1].terrain_height - HOME_ALT_M) <= 2.0, own[-1:]
        assert mp.proc.poll() is None, "".join(mp.log[-20:])
    finally:
        stop.set()
        mp.close()
        sitl.stop()
        mon.join(5)
