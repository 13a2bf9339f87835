"""Fence and rally points over the mission protocol (sans-IO core, real MAVLink bytes):
upload, download, clear with mission_type; malformed fences refused with the right
MISSION_ACK and the fence in force kept; the mission, pre-arm, FENCE_STATUS and the
SYS_STATUS geofence bit held to the fence."""
import pytest

from autopilot.link.codec import MAV
from autopilot.mission.items import MissionItem
from tests.test_gcs_protocol import give_nav, items_of, make_core, make_plane, make_quad, take, wire

FENCE, RALLY = MAV.MAV_MISSION_TYPE_FENCE, MAV.MAV_MISSION_TYPE_RALLY
HOME = (-35.3632620, 149.1652370)
BOX = [(-35.350, 149.150), (-35.350, 149.180), (-35.375, 149.180), (-35.375, 149.150)]


def fence_items(poly=BOX, declared=None, extra=()):
    n = len(poly) if declared is None else declared
    its = [MissionItem(k, 0, 5001, 0, 1, n, 0, 0, 0, la, lo, 0, FENCE) for k, (la, lo) in enumerate(poly)]
    its.append(MissionItem(len(its), 0, 5004, 0, 1, 50.0, 0, 0, 0, -35.357, 149.170, 0, FENCE))
    its.append(MissionItem(len(its), 3, 5000, 0, 1, 0, 0, 0, 0, -35.362, 149.165, 90, FENCE))
    return its + [it.replace(seq=len(its) + k) for k, it in enumerate(extra)]


def item_msg(it: MissionItem):
    f = it.to_int()
    return MAV.MAVLink_mission_item_int_message(1, 1, f["seq"], f["frame"], f["command"], f["current"],
                                                f["autocontinue"], f["param1"], f["param2"], f["param3"],
                                                f["param4"], f["x"], f["y"], f["z"], f["mission_type"])


def upload(core, items, mtype, cid=1):
    """The whole exchange; returns the MISSION_ACKs the client got."""
    take(core)
    core.receive(cid, wire(MAV.MAVLink_mission_count_message(1, 1, len(items), mtype)), 0)
    acks = []
    for _ in range(len(items) + 1):
        out = take(core, cid)
        acks += [m for m in out if m.get_type() == "MISSION_ACK"]
        reqs = [m for m in out if m.get_type() == "MISSION_REQUEST_INT"]
        if not reqs:
            break
        assert reqs[-1].mission_type == mtype
        core.receive(cid, wire(item_msg(items[reqs[-1].seq])), 0)
    return acks


def download(core, mtype, cid=1):
    take(core)
    core.receive(cid, wire(MAV.MAVLink_mission_request_list_message(1, 1, mtype)), 0)
    (cnt,) = take(core, cid, "MISSION_COUNT")
    assert cnt.mission_type == mtype
    got = []
    for k in range(cnt.count):
        core.receive(cid, wire(MAV.MAVLink_mission_request_int_message(1, 1, k, mtype)), 0)
        (m,) = take(core, cid, "MISSION_ITEM_INT")
        assert m.mission_type == mtype and m.seq == k
        got.append((m.command, m.param1, m.x, m.y, m.z))
    return got


@pytest.mark.parametrize("make", [make_plane, make_quad], ids=["plane", "quad"])
def test_fence_and_rally_upload_download_clear(make):
    core, v, _, _ = make_core(make())
    items = fence_items()
    acks = upload(core, items, FENCE)
    assert [(a.type, a.mission_type) for a in acks] == [(MAV.MAV_MISSION_ACCEPTED, FENCE)]
    assert download(core, FENCE) == [(it.command, it.param1, it.to_int()["x"], it.to_int()["y"], it.z_alt_m)
                                     for it in items]
    rally = [MissionItem(k, 3, 5100, 0, 1, 0, 0, 0, 0, -35.36 - 0.001 * k, 149.17, 80 + k, RALLY)
             for k in range(2)]
    assert [a.type for a in upload(core, rally, RALLY)] == [MAV.MAV_MISSION_ACCEPTED]
    assert [r[0] for r in download(core, RALLY)] == [5100, 5100]
    # the plain mission is untouched by either
    assert len(v.mission) == 13 if make is make_plane else True
    # clear the fence only; then everything (MAV_MISSION_TYPE_ALL)
    core.receive(1, wire(MAV.MAVLink_mission_clear_all_message(1, 1, FENCE)), 0)
    (ack,) = take(core, 1, "MISSION_ACK")
    assert (ack.type, ack.mission_type) == (MAV.MAV_MISSION_ACCEPTED, FENCE)
    assert download(core, FENCE) == [] and len(download(core, RALLY)) == 2
    core.receive(1, wire(MAV.MAVLink_mission_clear_all_message(1, 1, MAV.MAV_MISSION_TYPE_ALL)), 0)
    assert download(core, RALLY) == [] and len(v.mission) == 1


@pytest.mark.parametrize("bad, code, why", [
    (fence_items(BOX[:2]), MAV.MAV_MISSION_INVALID_PARAM1, "at least 3 vertices"),
    (fence_items(BOX, declared=5), MAV.MAV_MISSION_INVALID_PARAM1, "5 vertices declared, 4 given"),
    (fence_items(BOX[:3], declared=4) , MAV.MAV_MISSION_INVALID_PARAM1, "4 vertices declared, 3 given"),
    (fence_items(extra=[MissionItem(0, 3, 5000, 0, 1, 0, 0, 0, 0, -35.36, 149.16, 90, FENCE)]),
     MAV.MAV_MISSION_INVALID, "a second return point"),
    (fence_items(extra=[MissionItem(0, 0, 5003, 0, 1, -5.0, 0, 0, 0, -35.36, 149.16, 0, FENCE)]),
     MAV.MAV_MISSION_INVALID_PARAM1, "circle radius"),
    (fence_items(extra=[MissionItem(0, 0, 16, 0, 1, 0, 0, 0, 0, -35.36, 149.16, 0, FENCE)]),
     MAV.MAV_MISSION_UNSUPPORTED, "not a fence item"),
    (fence_items(extra=[MissionItem(0, 2, 5003, 0, 1, 40, 0, 0, 0, -35.36, 149.16, 0, FENCE)]),
     MAV.MAV_MISSION_UNSUPPORTED_FRAME, "not a global frame"),
])
def test_a_malformed_fence_is_refused_and_the_fence_in_force_kept(bad, code, why):
    core, v, _, _ = make_core()
    good = fence_items()
    assert [a.type for a in upload(core, good, FENCE)] == [MAV.MAV_MISSION_ACCEPTED]
    core.receive(1, wire(MAV.MAVLink_mission_count_message(1, 1, len(bad), FENCE)), 0)
    out = []
    for _ in range(len(bad) + 1):
        msgs = [m for c, m, _ in core.outbox]
        core.outbox = []
        out += msgs
        reqs = [m for m in msgs if m.get_type() == "MISSION_REQUEST_INT"]
        if not reqs:
            break
        core.receive(1, wire(item_msg(bad[reqs[-1].seq])), 0)
    acks = [m for m in out if m.get_type() == "MISSION_ACK"]
    assert [(a.type, a.mission_type) for a in acks] == [(code, FENCE)]
    text = "".join(m.text for m in out if m.get_type() == "STATUSTEXT")   # (50-character chunks)
    assert text.startswith("Fence refused: ") and why in text
    # the fence in force is the one accepted before, and nothing is left half done
    assert v.geofence.fence_items == tuple(good)
    assert core.missions.upload is None


def test_a_bad_rally_point_is_refused():
    core, v, _, _ = make_core(make_quad())
    bad = [MissionItem(0, 3, 5100, 0, 1, 0, 0, 0, 0, 95.0, 149.17, 80, RALLY)]
    acks = upload(core, bad, RALLY)
    assert [a.type for a in acks] == [MAV.MAV_MISSION_INVALID_PARAM5_X]
    assert v.geofence.rally_items == ()


def test_enabled_fence_refuses_an_outside_mission_and_arming_outside():
    core, v, _, _ = make_core()
    assert [a.type for a in upload(core, fence_items(), FENCE)] == [MAV.MAV_MISSION_ACCEPTED]
    assert v.set_param("FENCE_ENABLE", 1) is None and v.set_param("FENCE_TYPE", 4) is None
    before = v.mission
    # GIVEN a mission whose item 3 lies north of the box
    items = items_of(6)
    items[3] = items[3].replace(x_lat_deg=-35.340)
    acks = upload(core, items, 0)
    assert [a.type for a in acks] == [MAV.MAV_MISSION_DENIED]
    assert v.mission is before                         # the active mission kept
    # inside the exclusion circle: refused too; a mission inside: accepted
    items[3] = items[3].replace(x_lat_deg=-35.357, y_lon_deg=149.170)
    assert [a.type for a in upload(core, items, 0)] == [MAV.MAV_MISSION_DENIED]
    assert [a.type for a in upload(core, items_of(6), 0)] == [MAV.MAV_MISSION_ACCEPTED]
    # pre-arm: outside the box refused with the reason, inside accepted
    give_nav(v, lat=-35.345)
    take(core)
    core.receive(1, wire(MAV.MAVLink_command_long_message(1, 1, 400, 0, 1, 0, 0, 0, 0, 0, 0)), 0)
    out = take(core, 1)
    (ack,) = [m for m in out if m.get_type() == "COMMAND_ACK"]
    assert ack.result == MAV.MAV_RESULT_FAILED
    assert "PreArm: outside the fence (polygon)" in [m.text for m in out if m.get_type() == "STATUSTEXT"]
    give_nav(v)
    core.receive(1, wire(MAV.MAVLink_command_long_message(1, 1, 400, 0, 1, 0, 0, 0, 0, 0, 0)), 0)
    (ack,) = take(core, 1, "COMMAND_ACK")
    assert ack.result == MAV.MAV_RESULT_ACCEPTED and v.armed


def test_fence_status_and_the_sys_status_bit_follow_a_breach():
    core, v, _, _ = make_core(make_quad())
    upload(core, fence_items(), FENCE)
    G = MAV.MAV_SYS_STATUS_GEOFENCE
    st = core.tm.build("SYS_STATUS", 0)
    assert st.onboard_control_sensors_present & G and not st.onboard_control_sensors_enabled & G
    assert core.tm.build("FENCE_STATUS", 0) is None            # only while enabled
    v.set_param("FENCE_ENABLE", 1)
    v.set_param("FENCE_TYPE", 4)                                # the uploaded zones only
    give_nav(v)
    assert v.arm(0) is None
    v.on_ground = False
    # in the exclusion circle, 20 m up
    give_nav(v, lat=-35.357, lon=149.170, alt=604.0)
    from autopilot.fence.actions import fence_step
    fence_step(v, 5_000_000, flying=True)
    fs = core.tm.build("FENCE_STATUS", 0)
    assert (fs.breach_status, fs.breach_count, fs.breach_type, fs.breach_time) == \
        (1, 1, MAV.FENCE_BREACH_BOUNDARY, 5000)
    st = core.tm.build("SYS_STATUS", 0)
    assert st.onboard_control_sensors_enabled & G and not st.onboard_control_sensors_health & G
    assert v.mode.name == "RTL" and v.notices[-1][2] == "Fence breach: polygon, RTL"
    # back out by more than FENCE_MARGIN: cleared, healthy
    give_nav(v, lat=-35.362, lon=149.165, alt=604.0)
    fence_step(v, 6_000_000, flying=True)
    assert core.tm.build("FENCE_STATUS", 0).breach_status == 0
    assert core.tm.build("SYS_STATUS", 0).onboard_control_sensors_health & G
    assert v.geofence.breaches == [{"at_s": 5.0, "type": "polygon", "action": "RTL", "cleared_s": 6.0}]


def test_fence_action_values_the_vehicle_cannot_fly_are_refused():
    plane, quad = make_plane(), make_quad()
    assert "not available" in plane.set_param("FENCE_ACTION", 2)     # the plane does not land
    assert plane.params["FENCE_ACTION"] == 1
    assert quad.set_param("FENCE_ACTION", 2) is None
    assert "not available" in quad.set_param("FENCE_ACTION", 4)


def test_fence_and_rally_uploads_may_overlap_as_mavproxy_sends_them():
    # GIVEN one client that starts the rally upload while its fence upload is under way
    core, v, _, _ = make_core(make_quad())
    fence = fence_items()
    rally = [MissionItem(k, 3, 5100, 0, 1, 0, 0, 0, 0, -35.36 - 0.001 * k, 149.17, 80, RALLY) for k in range(2)]
    take(core)
    core.receive(1, wire(MAV.MAVLink_mission_count_message(1, 1, len(fence), FENCE)), 0)
    core.receive(1, wire(MAV.MAVLink_mission_count_message(1, 1, len(rally), RALLY)), 0)
    acks = []
    for _ in range(len(fence) + len(rally) + 2):
        out = take(core, 1)
        acks += [(a.type, a.mission_type) for a in out if a.get_type() == "MISSION_ACK"]
        reqs = [m for m in out if m.get_type() == "MISSION_REQUEST_INT"]
        if not reqs:
            break
        for r in reqs:
            core.receive(1, wire(item_msg((fence if r.mission_type == FENCE else rally)[r.seq])), 0)
    # THEN both complete, each acknowledged with its type
    assert sorted(acks) == [(MAV.MAV_MISSION_ACCEPTED, FENCE), (MAV.MAV_MISSION_ACCEPTED, RALLY)]
    assert v.geofence.fence_items == tuple(fence) and v.geofence.rally_items == tuple(rally)


def test_fence_status_streams_while_enabled_and_the_breach_is_announced():
    core, v, _, _ = make_core(make_quad())
    upload(core, fence_items(), FENCE)
    core.tick(1_000_000)
    core.tick(2_100_000)
    assert take(core, 1, "FENCE_STATUS") == []                 # fence off: not sent
    v.set_param("FENCE_ENABLE", 1)
    v.set_param("FENCE_TYPE", 4)
    give_nav(v)
    assert v.arm(0) is None
    v.on_ground = False
    give_nav(v, lat=-35.357, lon=149.170, alt=604.0)
    from autopilot.fence.actions import fence_step
    fence_step(v, 3_000_000, flying=True)
    core.tick(3_200_000)
    out = take(core, 1)
    (fs,) = [m for m in out if m.get_type() == "FENCE_STATUS"]
    assert (fs.breach_status, fs.breach_count) == (1, 1)
    texts = [m.text for m in out if m.get_type() == "STATUSTEXT"]
    assert "Fence breach: polygon, RTL" in texts and "Mode RTL" in texts
