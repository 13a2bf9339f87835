"""Issue 15, failure 3, with the real client: MAVSDK 4.1 imports the repository's
default mission from its Mission Planner file and uploads it. For an ArduPilot
autopilot MAVSDK puts its own item 0 (home) in front, so the file's home line arrives
as item 1: a NAV_WAYPOINT at home at ground level (frame 0, 584 m), before the takeoff.
The vehicle is on that waypoint when it arms; the waypoint counts at once (ArduPlane
counts a waypoint it is within WP_RADIUS of) and the mission is flown to its end: every
item reached in order, the DO_JUMP's repeat included, no crash."""
import asyncio
import time

import mavsdk  # noqa: F401  the real client, from the test extra: missing is a failure, not a skip

from mavsdk.asyncio import ComponentType, Configuration, Mavsdk
from mavsdk.asyncio.plugins.action import ActionAsync
from mavsdk.asyncio.plugins.mission_raw import MissionRawAsync
from mavsdk.asyncio.plugins.telemetry import TelemetryAsync

from test_gcs_support import MISSIONS, Sitl


async def _until(gen, pred):
    async for x in gen:
        if pred(x):
            return x


async def _fly_default_waypoints(sitl, fig: dict) -> None:
    cfg = Configuration.create_with_component_type(ComponentType.GROUND_STATION)
    async with Mavsdk(cfg) as sdk:
        await sdk.add_any_connection(f"tcpout://127.0.0.1:{sitl.port}")
        system = await sdk.first_autopilot(timeout_s=20)
        assert system is not None
        tel, action, mission = TelemetryAsync(system), ActionAsync(system), MissionRawAsync(system)
        texts: list[str] = []

        async def collect_texts():
            async for st in tel.subscribe_status_text():
                texts.append(st.text)

        task = asyncio.create_task(collect_texts())
        try:
            imported = await mission.import_mission_planner_mission(str(MISSIONS / "default.waypoints"))
            items = imported.mission_items
            fig["uploaded"] = [(it.seq, it.command, it.frame) for it in items]
            await mission.upload_mission(items)
            for _ in range(120):                                  # until navigation is aligned
                try:
                    await action.arm()
                    break
                except Exception:                                 # noqa: BLE001 - PreArm: not yet
                    await asyncio.sleep(0.25)
            await asyncio.wait_for(_until(tel.subscribe_armed(), bool), 10)
            await mission.start_mission()
            progress = []

            def done(p):
                progress.append((p.current, p.total))
                return p.total > 0 and p.current >= p.total

            await asyncio.wait_for(_until(mission.subscribe_mission_progress(), done), 150)
            fig["progress"] = progress
            await asyncio.sleep(3.0)              # the loiter over home that ends it (sim time runs fast)
            fig["texts"] = list(texts)
        finally:
            task.cancel()


def test_mavsdk_uploads_default_waypoints_and_the_mission_completes(tmp_path):
    sitl = Sitl(tmp_path / "run")
    fig: dict = {}
    t0 = time.monotonic()
    try:
        asyncio.run(asyncio.wait_for(_fly_default_waypoints(sitl, fig), 240))
    finally:
        summary = sitl.stop()
    print("MAVSDK default.waypoints:", fig.get("progress", [])[-3:], f"wall {time.monotonic() - t0:.1f} s")
    # what MAVSDK sent: its own home at 0, the file's home line as item 1 (frame 0, a
    # waypoint), then the file's items 1.. as 2..
    assert fig["uploaded"][1] == (1, 16, 0) and fig["uploaded"][2][1] == 22
    assert fig["progress"][-1][0] == fig["progress"][-1][1] == len(fig["uploaded"])
    reached = [int(t.split("#")[1]) for t in fig["texts"] if t.startswith("Reached waypoint #")]
    assert reached[:3] == [1, 2, 3]                # item 1 (home, ground level) counted first
    assert not any(t.startswith("Crash detected") for t in fig["texts"])
    assert summary["completed"] is True and not summary["crashed"]
    assert summary["mission_items_reached"] == summary["mission_items_total"] == 13
