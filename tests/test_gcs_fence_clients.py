"""The real clients against the vehicle's fence and rally points: MAVProxy (headless,
its commands staged with ``repeat add PERIOD script FILE`` as tests/test_gcs_mavproxy.py
does) ``fence load`` / ``fence list`` / ``rally load`` / ``rally list``; MAVSDK
``geofence.upload_geofence``; what each uploaded is downloaded back by pymavlink."""
import asyncio
import pytest

from test_gcs_mavproxy import MAVPROXY, MavProxy
from test_gcs_support import MISSIONS, Sitl, connect, wait_for

FENCE, RALLY = 1, 2


def download(m, mtype, timeout_s=10.0):
    """(command, lat, lon, param1) of every item of ``mtype`` on the vehicle."""
    m.mav.mission_request_list_send(1, 1, mtype)
    cnt = wait_for(m, "MISSION_COUNT", timeout_s, lambda c: c.mission_type == mtype)
    assert cnt is not None
    out = []
    for k in range(cnt.count):
        m.mav.mission_request_int_send(1, 1, k, mtype)
        it = wait_for(m, "MISSION_ITEM_INT", timeout_s, lambda i: i.seq == k and i.mission_type == mtype)
        assert it is not None
        out.append((it.command, it.x * 1e-7, it.y * 1e-7, it.param1))
    return out


def test_mavproxy_fence_load_list_and_rally_load_list(tmp_path):
    assert MAVPROXY.exists()
    (tmp_path / "box.fence").write_text((MISSIONS / "default.fence").read_text())
    (tmp_path / "field.rally").write_text(
        "QGC WPL 110\n"
        "0\t0\t3\t5100\t0\t0\t0\t0\t-35.3600000\t149.1700000\t90\t1\n"
        "1\t0\t3\t5100\t0\t0\t0\t0\t-35.3660000\t149.1760000\t80\t1\n")
    stage2 = tmp_path / "stage2.scr"
    stage2.write_text("fence list\nrally list\n")
    stage1 = tmp_path / "stage1.scr"
    stage1.write_text(f"fence load box.fence\nrally load field.rally\nrepeat clean\n"
                      f"repeat add 4 script {stage2.name}\n")
    sitl = Sitl(tmp_path / "run", speedup="1")
    mp = MavProxy(sitl.url, tmp_path, "--daemon", "--non-interactive",
                  "--default-modules=fence,rally,misc,param", "--cmd", f"repeat add 3 script {stage1.name}")
    try:
        # both uploads run at once (MAVProxy sends them so); either may finish first
        done = {mp.expect(r"Got MISSION_ACK: TYPE_(FENCE|RALLY): ACCEPTED", 40).group(1) for _ in range(2)}
        assert done == {"FENCE", "RALLY"}
        mp.expect(r"Requesting 5 fence items", 30)
        # fence list prints the vehicle's items: the return point, then the polygon
        mp.expect(r"^5000 0 -35\.36326\d+ 149\.16523\d+", 20)
        first = mp.expect(r"^5001 0 (-35\.348\d+) (149\.15\d+) .* p1=4\.0", 20)
        mp.expect(r"Requesting 2 rally items", 30)
        mp.expect(r"^5100 3 -35\.36600\d+ 149\.17\d+ 80\.0", 20)
        m = connect(sitl.url, sysid=250)
        try:
            fence = download(m, FENCE)
            rally = download(m, RALLY)
        finally:
            m.close()
    finally:
        mp.close()
        summary = sitl.stop()
    assert [c for c, *_ in fence] == [5000, 5001, 5001, 5001, 5001]
    assert all(p1 == 4.0 for c, _, _, p1 in fence[1:])
    assert abs(float(first.group(1)) + 35.348) < 1e-6
    assert [(c, round(la, 4), round(lo, 4)) for c, la, lo, _ in rally] == \
        [(5100, -35.36, 149.17), (5100, -35.366, 149.176)]
    assert summary["fence_breaches"] == []
    assert sitl.stats()["errors"] == 0
    assert not any("fence breach" in line for line in mp.log)      # the health bit stayed up


async def _mavsdk_geofence(port):
    from mavsdk.asyncio import ComponentType, Configuration, Mavsdk
    from mavsdk.asyncio.plugins.geofence import Circle, FenceType, GeofenceAsync, GeofenceData, Point, Polygon
    cfg = Configuration.create_with_component_type(ComponentType.GROUND_STATION)
    async with Mavsdk(cfg) as sdk:
        await sdk.add_any_connection(f"tcpout://127.0.0.1:{port}")
        system = await sdk.first_autopilot(timeout_s=20)
        assert system is not None
        geo = GeofenceAsync(system)
        box = [Point(-35.3615, 149.1640), Point(-35.3615, 149.1675), Point(-35.3645, 149.1675),
               Point(-35.3645, 149.1640)]
        data = GeofenceData([Polygon(box, FenceType.INCLUSION)],
                            [Circle(Point(-35.3630, 149.1660), 8.0, FenceType.EXCLUSION)])
        await geo.upload_geofence(data)
        back = await geo.download_geofence()
        return back


async def _mavsdk_plan(port, plan):
    from mavsdk.asyncio import ComponentType, Configuration, Mavsdk
    from mavsdk.asyncio.plugins.mission_raw import MissionRawAsync
    cfg = Configuration.create_with_component_type(ComponentType.GROUND_STATION)
    async with Mavsdk(cfg) as sdk:
        await sdk.add_any_connection(f"tcpout://127.0.0.1:{port}")
        system = await sdk.first_autopilot(timeout_s=20)
        raw = MissionRawAsync(system)
        data = await raw.import_qgroundcontrol_mission(str(plan))
        await raw.upload_mission(data.mission_items)
        await raw.upload_geofence(data.geofence_items)
        await raw.upload_rally_points(data.rally_items)
        return (data, await raw.download_mission(), await raw.download_geofence(),
                await raw.download_rallypoints())


def test_mavsdk_uploads_a_plans_mission_fence_and_rally_points(tmp_path):
    # GIVEN a QGroundControl plan with a mission, an inclusion polygon, an exclusion
    # circle, a breach return point and two rally points, imported by MAVSDK's mission_raw
    from test_fence_flight import _plan_with_fence
    plan = _plan_with_fence(tmp_path, [{"inclusion": False, "version": 1,
                                        "circle": {"center": [-35.3583, 149.16987], "radius": 60}}])
    sitl = Sitl(tmp_path / "run", speedup="1")
    try:
        data, mission, fence, rally = asyncio.run(asyncio.wait_for(_mavsdk_plan(sitl.port, plan), 90))
        m = connect(sitl.url, sysid=250)
        try:
            on_vehicle = download(m, FENCE), download(m, RALLY)
        finally:
            m.close()
    finally:
        summary = sitl.stop()
    # THEN the vehicle holds all three as sent, and gives them back the same
    assert len(mission) == len(data.mission_items)
    assert [f.command for f in fence] == [f.command for f in data.geofence_items]
    # (MAVSDK's import leaves the plan's breachReturn out: polygon and circle only)
    assert [c for c, *_ in on_vehicle[0]] == [f.command for f in data.geofence_items] == [5001] * 4 + [5004]
    assert [(c, round(la, 4), round(lo, 4)) for c, la, lo, _ in on_vehicle[1]] == \
        [(5100, -35.3655, 149.1765), (5100, -35.35, 149.16)]
    assert [r.z for r in rally] == [90.0, 80.0]
    assert summary["fence_breaches"] == []


def test_mavsdk_upload_geofence_reaches_the_vehicle(tmp_path):
    sitl = Sitl(tmp_path / "run", "--vehicle", "quad", speedup="1")
    try:
        back = asyncio.run(asyncio.wait_for(_mavsdk_geofence(sitl.port), 90))
        m = connect(sitl.url, sysid=250)
        try:
            fence = download(m, FENCE)
        finally:
            m.close()
    finally:
        summary = sitl.stop()
    # the vehicle holds what MAVSDK sent: one inclusion polygon of 4, one exclusion circle
    assert [c for c, *_ in fence] == [5001] * 4 + [5004]
    assert all(p1 == 4.0 for _, _, _, p1 in fence[:4]) and fence[-1][3] == 8.0
    assert abs(fence[0][1] + 35.3615) < 1e-6 and abs(fence[-1][2] - 149.1660) < 1e-6
    # ... and MAVSDK downloads it back the same
    assert len(back.polygons) == 1 and len(back.polygons[0].points) == 4
    assert len(back.circles) == 1 and back.circles[0].radius == pytest.approx(8.0)
    assert summary["fence_breaches"] == []
