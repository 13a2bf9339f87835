"""Ground-station protocol core, sans-IO: messages in, messages out, on a fake wall clock.

Real message objects (encoded by one codec, decoded by another, as on the wire); the
vehicles are the real ones, not stepped (no navigation yet unless a test gives one).
"""
import math

import numpy as np
import pytest

from autopilot.gcs import GCS_PARAMS
from autopilot.gcs.core import GcsCore
from autopilot.link.codec import MAV, Codec
from autopilot.messages import NavState
from autopilot.mission.files import load_mission
from autopilot.mission.items import MissionItem
from autopilot.params import ParamStore
from autopilot.vehicle import PlaneVehicle, plane_param_declarations
from tools.runner import DEFAULT_MISSION, QUAD_DEFAULT_MISSION

GCS = (255, 190)


class Clock:
    def __init__(self):
        self.t = 1000.0

    def __call__(self):
        return self.t


class FakeRelay:
    """The HIL end as the core sees it: COMMAND_LONGs out, COMMAND_ACKs back."""

    def __init__(self):
        self.sent = []
        self.acks = []

    def relay_command(self, command, params):
        self.sent.append((command, params))

    def take_command_acks(self):
        a, self.acks = self.acks, []
        return a


def wire(msg, src=GCS, v1=False):
    """``msg`` as a ground station would send it (through real bytes)."""
    tx = Codec(*src)
    if v1:
        buf = msg.pack(tx.mav, force_mavlink1=True)
    else:
        buf = tx.encode(msg)
    (m,) = Codec(1, 1).decode(buf)
    return m


def make_plane(persist=None):
    params = ParamStore(list(plane_param_declarations()) + list(GCS_PARAMS))
    v = PlaneVehicle(params, load_mission(DEFAULT_MISSION), "truth", autostart=False)
    return v


def make_quad():
    from autopilot.vehicle_quad import QuadVehicle, quad_param_declarations
    params = ParamStore(list(quad_param_declarations()) + list(GCS_PARAMS))
    return QuadVehicle(params, load_mission(QUAD_DEFAULT_MISSION), "truth", autostart=False)


def make_core(vehicle=None, **kw):
    v = vehicle or make_plane()
    clock = Clock()
    relay = FakeRelay()
    core = GcsCore(v, clock, relay=relay, **kw)
    core.add_client(1, "a")
    core.add_client(2, "b")
    return core, v, clock, relay


def take(core, cid=None, kind=None):
    """Messages sent (to ``cid`` or broadcast) since the last call."""
    out, core.outbox = core.outbox, []
    return [m for c, m, _ in out if (cid is None or c in (cid, None))
            and (kind is None or m.get_type() == kind)]


def give_nav(v, lat=-35.3632620, lon=149.1652370, alt=584.0):
    """A healthy, aligned navigation solution with a 3D fix (as after a few steps)."""
    v.nav_state = NavState(0, np.zeros(3), np.zeros(3), np.array([1.0, 0, 0, 0]), np.zeros(3),
                           math.radians(lat), math.radians(lon), alt, 0.0, aligned=True, healthy=True)
    v.gps_fix_type = 3


def cmd_long(command, *params, target=(1, 1)):
    p = list(params) + [0.0] * (7 - len(params))
    return MAV.MAVLink_command_long_message(target[0], target[1], command, 0, *p)


def items_of(n, home=(-35.3632620, 149.1652370, 584.0)):
    lat, lon, alt = home
    items = [MissionItem(0, 0, 16, 0, 1, 0, 0, 0, 0, lat, lon, alt)]
    items.append(MissionItem(1, 3, 22, 0, 1, 12, 0, 0, 0, lat + 0.002, lon, 60))
    for k in range(2, n):
        items.append(MissionItem(k, 3, 16, 0, 1, 0, 0, 0, 0, lat + 0.002 + 0.001 * (k % 7),
                                 lon + 0.001 * (k % 5), 80 + k % 20))
    return items


def item_msg(it: MissionItem, target=(1, 1)):
    f = it.to_int()
    return MAV.MAVLink_mission_item_int_message(target[0], target[1], f["seq"], f["frame"], f["command"],
                                                f["current"], f["autocontinue"], f["param1"], f["param2"],
                                                f["param3"], f["param4"], f["x"], f["y"], f["z"], 0)


def upload(core, items, cid=1, t_us=0):
    core.receive(cid, wire(MAV.MAVLink_mission_count_message(1, 1, len(items), 0)), t_us)
    acks = []
    for _ in range(len(items) + 2):
        out = take(core, cid)
        reqs = [m for m in out if m.get_type() in ("MISSION_REQUEST_INT", "MISSION_REQUEST")]
        acks += [m for m in out if m.get_type() == "MISSION_ACK"]
        if acks or not reqs:
            break
        core.receive(cid, wire(item_msg(items[reqs[-1].seq])), t_us)
    return acks


def download(core, cid=1):
    core.receive(cid, wire(MAV.MAVLink_mission_request_list_message(1, 1, 0)), 0)
    (count,) = take(core, cid, "MISSION_COUNT")
    got = []
    for seq in range(count.count):
        core.receive(cid, wire(MAV.MAVLink_mission_request_int_message(1, 1, seq, 0)), 0)
        (m,) = take(core, cid, "MISSION_ITEM_INT")
        got.append(MissionItem.from_int(m))
    return got


# ------------------------------------------------------------------ mission service ---
def test_upload_then_download_gives_back_the_same_items_and_replaces_the_mission():
    core, v, clock, _ = make_core()
    items = items_of(30)
    acks = upload(core, items)
    assert [a.type for a in acks] == [MAV.MAV_MISSION_ACCEPTED]
    assert len(v.mission) == 30
    back = download(core, cid=2)  # another client sees the same mission
    assert [{**b.to_int(), "current": 0} for b in back] == [{**i.to_int(), "current": 0} for i in items]


def test_a_700_item_mission_uploads():
    core, v, _, _ = make_core()
    acks = upload(core, items_of(700))
    assert [a.type for a in acks] == [MAV.MAV_MISSION_ACCEPTED] and len(v.mission) == 700


def test_out_of_order_and_duplicate_items_are_ignored_and_the_expected_one_asked_again():
    core, v, _, _ = make_core()
    items = items_of(6)
    core.receive(1, wire(MAV.MAVLink_mission_count_message(1, 1, 6, 0)), 0)
    assert take(core, 1, "MISSION_REQUEST_INT")[0].seq == 0
    core.receive(1, wire(item_msg(items[0])), 0)
    core.receive(1, wire(item_msg(items[0])), 0)            # duplicate
    core.receive(1, wire(item_msg(items[3])), 0)            # from the future
    reqs = take(core, 1, "MISSION_REQUEST_INT")
    assert [r.seq for r in reqs] == [1, 1]                   # asked again for the expected one
    for k in range(1, 6):
        core.receive(1, wire(item_msg(items[k])), 0)
        core.receive(1, wire(item_msg(items[k])), 0)        # every item twice
    acks = take(core, 1, "MISSION_ACK")
    assert [a.type for a in acks] == [MAV.MAV_MISSION_ACCEPTED]
    assert [i.command for i in v.mission] == [i.command for i in items]


def test_a_client_that_stops_mid_upload_times_out_after_the_retries_and_the_old_mission_stays():
    core, v, clock, _ = make_core()
    old = v.mission
    items = items_of(10)
    core.receive(1, wire(MAV.MAVLink_mission_count_message(1, 1, 10, 0)), 0)
    for k in range(4):
        core.receive(1, wire(item_msg(items[k])), 0)
    take(core)
    requests = 0
    for _ in range(20):                       # 1.5 s request timeout, 5 retries
        clock.t += 0.5
        core.tick(0)
        out = take(core, 1)
        requests += sum(m.get_type().startswith("MISSION_REQUEST") and m.seq == 4 for m in out)
        acks = [m for m in out if m.get_type() == "MISSION_ACK"]
        if acks:
            break
    assert requests == 5
    assert acks[0].type == MAV.MAV_MISSION_OPERATION_CANCELLED
    assert v.mission is old
    assert core.missions.upload is None


@pytest.mark.parametrize("bad, code", [
    (dict(x_lat_deg=95.0), "MAV_MISSION_INVALID_PARAM5_X"),
    (dict(command=31000), "MAV_MISSION_UNSUPPORTED"),
    (dict(frame=1), "MAV_MISSION_UNSUPPORTED_FRAME"),
    (dict(z_alt_m=1e9), "MAV_MISSION_INVALID_PARAM7"),
])
def test_a_refused_item_ends_the_upload_with_its_code_and_keeps_the_old_mission(bad, code):
    core, v, _, _ = make_core()
    old = v.mission
    items = items_of(5)
    items[3] = items[3].replace(**bad)
    core.outbox = []
    acks = upload(core, items)
    assert [a.type for a in acks] == [getattr(MAV, code)]
    assert v.mission is old


def test_a_jump_to_a_missing_item_is_refused_when_the_mission_is_complete():
    core, v, _, _ = make_core()
    old = v.mission
    items = items_of(5)
    items[4] = MissionItem(4, 2, 177, 0, 1, 9, 1, 0, 0, 0, 0, 0)
    assert [a.type for a in upload(core, items)] == [MAV.MAV_MISSION_INVALID_PARAM1]
    assert v.mission is old


def test_an_unknown_mission_type_is_refused_cleanly():
    # fence and rally are served (tests/test_gcs_fence.py); a type that does not exist is not
    core, v, _, _ = make_core()
    core.receive(1, wire(MAV.MAVLink_mission_count_message(1, 1, 3, 7)), 0)
    core.receive(1, wire(MAV.MAVLink_mission_request_list_message(1, 1, 7)), 0)
    acks = take(core, 1, "MISSION_ACK")
    assert [(a.type, a.mission_type) for a in acks] == [(MAV.MAV_MISSION_UNSUPPORTED, 7)] * 2
    assert core.missions.upload is None


def test_legacy_mission_item_and_mission_request_are_answered():
    core, v, _, _ = make_core()
    items = items_of(4)
    core.receive(1, wire(MAV.MAVLink_mission_count_message(1, 1, 4, 0)), 0)
    for it in items:
        take(core)
        core.receive(1, wire(MAV.MAVLink_mission_item_message(
            1, 1, it.seq, it.frame, it.command, 0, 1, it.param1, it.param2, it.param3, it.param4,
            it.x_lat_deg, it.y_lon_deg, it.z_alt_m, 0)), 0)
    assert [a.type for a in take(core, 1, "MISSION_ACK")] == [MAV.MAV_MISSION_ACCEPTED]
    core.receive(1, wire(MAV.MAVLink_mission_request_message(1, 1, 2, 0)), 0)
    (m,) = take(core, 1, "MISSION_ITEM")
    assert m.seq == 2 and abs(m.x - items[2].x_lat_deg) < 1e-5


def test_a_second_clients_upload_is_denied_while_one_is_in_progress():
    core, v, _, _ = make_core()
    core.receive(1, wire(MAV.MAVLink_mission_count_message(1, 1, 5, 0)), 0)
    core.receive(2, wire(MAV.MAVLink_mission_count_message(1, 1, 5, 0)), 0)
    assert [a.type for a in take(core, 2, "MISSION_ACK")] == [MAV.MAV_MISSION_DENIED]


def test_mavsdk_style_clear_uploads_a_lone_relative_item_0_and_leaves_home_only():
    core, v, _, _ = make_core()
    give_nav(v)
    acks = upload(core, [MissionItem(0, 3, 16, 1, 1, 0, 0, 0, 0, 0, 0, 0)])
    assert [a.type for a in acks] == [MAV.MAV_MISSION_ACCEPTED]
    assert len(v.mission) == 1 and v.mission[0].frame == 0      # flown: a real home
    assert download(core)[0].frame == 3                          # shown: as uploaded


# ---------------------------------------------------------------- parameter service ---
def test_param_list_is_paced_and_complete():
    core, v, clock, _ = make_core()
    core.receive(1, wire(MAV.MAVLink_param_request_list_message(1, 1)), 0)
    first = take(core, 1, "PARAM_VALUE")
    assert 0 < len(first) < len(v.params)
    got = list(first)
    for _ in range(100):
        clock.t += 0.01
        core.tick(0)
        got += take(core, 1, "PARAM_VALUE")
    assert sorted(p.param_index for p in got) == list(range(len(v.params)))
    assert {p.param_count for p in got} == {len(v.params)}


def test_param_read_by_name_and_index_and_set_echo_new_or_old_value():
    saved = []
    core, v, _, _ = make_core(persist=lambda: saved.append(1))
    core.receive(1, wire(MAV.MAVLink_param_request_read_message(1, 1, b"NAVL1_PERIOD", -1)), 0)
    (p,) = take(core, 1, "PARAM_VALUE")
    core.receive(1, wire(MAV.MAVLink_param_request_read_message(1, 1, b"", p.param_index)), 0)
    assert take(core, 1, "PARAM_VALUE")[0].param_id == "NAVL1_PERIOD"
    core.receive(1, wire(MAV.MAVLink_param_set_message(1, 1, b"NAVL1_PERIOD", 18.5, 9)), 0)
    out = take(core)
    assert [m.param_value for m in out if m.get_type() == "PARAM_VALUE"] == [18.5]
    assert v.params["NAVL1_PERIOD"] == 18.5 and saved == [1]
    # out of range: refused, echoed with the old value, and said why
    core.receive(1, wire(MAV.MAVLink_param_set_message(1, 1, b"NAVL1_PERIOD", 1e6, 9)), 0)
    out = take(core)
    assert [m.param_value for m in out if m.get_type() == "PARAM_VALUE"] == [18.5]
    assert any("NAVL1_PERIOD" in m.text for m in out if m.get_type() == "STATUSTEXT")
    # an integer parameter refuses a fraction
    core.receive(1, wire(MAV.MAVLink_param_set_message(1, 1, b"FS_GCS_ENABL", 0.5, 9)), 0)
    assert [m.param_value for m in take(core, 1, "PARAM_VALUE")] == [1.0]
    assert v.params["NAVL1_PERIOD"] == 18.5 and saved == [1]


# ------------------------------------------------------------------------- commands ---
def test_every_command_gets_exactly_one_ack_and_unknown_ones_are_unsupported():
    core, v, _, relay = make_core()
    for command in (400, 176, 20, 21, 22, 300, 179, 178, 192, 410, 520, 512, 511, 246, 31000, 42424):
        core.receive(1, wire(cmd_long(command, 1.0, 10.0)), 0)
        core.tick(0)
        acks = take(core, 1, "COMMAND_ACK")
        if command == 420:
            continue
        assert [a.command for a in acks] == [command], command
        assert acks[0].target_system == 255 and acks[0].target_component == 190
    core.receive(1, wire(cmd_long(31000)), 0)
    assert take(core, 1, "COMMAND_ACK")[0].result == MAV.MAV_RESULT_UNSUPPORTED


def test_commands_to_another_system_are_ignored_and_broadcast_ones_accepted():
    core, v, _, _ = make_core()
    core.receive(1, wire(cmd_long(520, 1, target=(7, 1))), 0)
    core.receive(1, wire(cmd_long(520, 1, target=(1, 55))), 0)
    assert take(core) == []
    core.receive(1, wire(cmd_long(520, 1, target=(0, 0))), 0)
    out = take(core, 1)
    assert [m.get_type() for m in out] == ["COMMAND_ACK", "AUTOPILOT_VERSION"]
    assert out[1].capabilities & MAV.MAV_PROTOCOL_CAPABILITY_MISSION_INT
    assert not out[1].capabilities & MAV.MAV_PROTOCOL_CAPABILITY_SET_ATTITUDE_TARGET


def test_prearm_refusals_say_why():
    core, v, _, _ = make_core()
    core.receive(1, wire(cmd_long(400, 1)), 0)
    assert take(core, 1, "COMMAND_ACK")[0].result == MAV.MAV_RESULT_FAILED
    give_nav(v)
    v.mission = None
    core.receive(1, wire(cmd_long(400, 1)), 0)
    out = take(core)
    texts = [m.text for m in out if m.get_type() == "STATUSTEXT"]
    assert texts == ["PreArm: no valid mission"]
    v.mission = load_mission(DEFAULT_MISSION)
    v.gps_fix_type = 1
    core.receive(1, wire(cmd_long(400, 1)), 0)
    assert [m.text for m in take(core, 1, "STATUSTEXT")] == ["PreArm: no 3D fix"]
    v.gps_fix_type = 3
    core.receive(1, wire(cmd_long(400, 1)), 0)
    assert take(core, 1, "COMMAND_ACK")[0].result == MAV.MAV_RESULT_ACCEPTED and v.armed


def test_modes_are_ardupilot_numbers_and_unimplemented_ones_unsupported():
    core, v, _, _ = make_core()
    core.receive(1, wire(cmd_long(176, 1, 10)), 0)          # AUTO
    assert take(core, 1, "COMMAND_ACK")[0].result == MAV.MAV_RESULT_ACCEPTED and v.mode == 10
    for unimplemented in (5, 13, 99, float("nan")):         # FBWA, TAKEOFF, nonsense
        core.receive(1, wire(cmd_long(176, 1, unimplemented)), 0)
        assert take(core, 1, "COMMAND_ACK")[0].result == MAV.MAV_RESULT_UNSUPPORTED
    core.tick(10_000)
    hb = [m for m in take(core, 1) if m.get_type() == "HEARTBEAT"][0]
    assert (hb.autopilot, hb.type, hb.custom_mode) == (MAV.MAV_AUTOPILOT_ARDUPILOTMEGA,
                                                       MAV.MAV_TYPE_FIXED_WING, 10)


def test_failure_injection_is_relayed_and_the_simulators_answer_goes_to_the_asker():
    core, v, clock, relay = make_core()
    core.receive(2, wire(cmd_long(420, 0, 1, 0), src=(240, 7)), 0)
    assert relay.sent == [(420, (0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0))]
    assert take(core) == []                                  # no answer yet
    relay.acks.append(MAV.MAVLink_command_ack_message(420, MAV.MAV_RESULT_UNSUPPORTED, 0, 0, 1, 1))
    core.tick(0)
    out = core.outbox
    acks = [(c, m) for c, m, _ in out if m.get_type() == "COMMAND_ACK"]
    assert len(acks) == 1 and acks[0][0] == 2
    assert (acks[0][1].result, acks[0][1].target_system, acks[0][1].target_component) == (3, 240, 7)
    take(core)
    core.receive(1, wire(cmd_long(420, 5, 1, 0)), 0)        # the simulator never answers
    clock.t += 5.0
    core.tick(0)
    assert [a.result for a in take(core, 1, "COMMAND_ACK")] == [MAV.MAV_RESULT_FAILED]


def test_mavftp_gets_a_nak_at_once():
    core, v, _, _ = make_core()
    payload = [0] * 251
    payload[0], payload[3] = 7, 4                            # seq 7, OpenFileRO
    core.receive(1, wire(MAV.MAVLink_file_transfer_protocol_message(0, 1, 1, payload)), 0)
    (m,) = take(core, 1, "FILE_TRANSFER_PROTOCOL")
    assert m.payload[3] == 129 and m.payload[5] == 4 and m.payload[0] == 8


def test_set_message_interval_and_request_data_stream_change_one_clients_rates():
    core, v, _, _ = make_core()
    give_nav(v)
    core.receive(1, wire(cmd_long(511, MAV.MAVLINK_MSG_ID_ATTITUDE, 50_000)), 0)
    core.receive(2, wire(MAV.MAVLink_request_data_stream_message(1, 1, MAV.MAV_DATA_STREAM_ALL, 2, 1)), 0)
    take(core)
    counts = {1: 0, 2: 0}
    for k in range(100):                                     # one second of 10 ms steps
        core.tick(k * 10_000)
        for c, m, _ in core.outbox:
            if m.get_type() == "ATTITUDE":
                counts[c] += 1
        core.outbox = []
    assert counts == {1: 20, 2: 2}
    core.receive(1, wire(cmd_long(512, MAV.MAVLINK_MSG_ID_HOME_POSITION)), 0)
    assert [m.get_type() for m in take(core, 1)] == ["COMMAND_ACK", "HOME_POSITION"]


def test_a_mavlink1_client_is_understood():
    core, v, _, _ = make_core()
    core.receive(1, wire(cmd_long(520, 1), v1=True), 0, mavlink1=True)
    assert core.clients[1].v1
    assert [m.get_type() for m in take(core, 1)] == ["COMMAND_ACK", "AUTOPILOT_VERSION"]


# ------------------------------------------------------------------------- failsafe ---
@pytest.mark.parametrize("kind", ["plane", "quad"])
def test_heartbeat_loss_after_a_gcs_was_seen_triggers_rtl_and_recovery_hands_back(kind):
    v = make_plane() if kind == "plane" else make_quad()
    core, v, clock, _ = make_core(v)
    hb = wire(MAV.MAVLink_heartbeat_message(MAV.MAV_TYPE_GCS, MAV.MAV_AUTOPILOT_INVALID, 0, 0, 0, 3))
    core.receive(1, hb, 0)
    give_nav(v)
    assert v.arm(0) is None
    auto = v.modes.__members__["AUTO"]
    assert v.set_mode(auto, 0) is None
    v.__class__ = type("Flying", (v.__class__,), {"landed": property(lambda self: False)})
    clock.t += v.params["FS_GCS_TIMEOUT"] - 0.5
    core.tick(0)
    assert v.mode == auto
    clock.t += 1.0
    core.tick(0)
    assert v.mode.name == "RTL"
    assert any("GCS Failsafe On" in m.text for m in take(core, kind="STATUSTEXT"))
    core.tick(5_000_000)
    assert [m.system_status for m in take(core, 1, "HEARTBEAT")] == [MAV.MAV_STATE_CRITICAL]
    core.receive(1, hb, 0)
    assert v.mode == auto
    assert any("GCS Failsafe Off" in m.text for m in take(core, kind="STATUSTEXT"))


def test_no_failsafe_before_a_ground_station_was_seen():
    core, v, clock, _ = make_core()
    give_nav(v)
    v.arm(0)
    v.set_mode(v.modes.AUTO, 0)
    clock.t += 100
    core.tick(0)
    assert v.mode == v.modes.AUTO


# ------------------------------------------------------------------------- contract ---
@pytest.mark.parametrize("kind", ["plane", "quad"])
def test_both_vehicles_look_like_ardupilot_on_the_wire(kind):
    v = make_plane() if kind == "plane" else make_quad()
    core, v, clock, _ = make_core(v)
    give_nav(v)
    core.tick(0)
    msgs = {m.get_type(): m for m in take(core, 1)}
    hb = msgs["HEARTBEAT"]
    assert hb.autopilot == MAV.MAV_AUTOPILOT_ARDUPILOTMEGA
    assert hb.type == (MAV.MAV_TYPE_FIXED_WING if kind == "plane" else MAV.MAV_TYPE_QUADROTOR)
    assert {"SYS_STATUS", "EXTENDED_SYS_STATE", "ATTITUDE", "GLOBAL_POSITION_INT", "GPS_RAW_INT",
            "VFR_HUD", "NAV_CONTROLLER_OUTPUT", "MISSION_CURRENT", "EKF_STATUS_REPORT",
            "ESTIMATOR_STATUS", "HOME_POSITION"} <= set(msgs)
    st = msgs["SYS_STATUS"]
    assert st.onboard_control_sensors_present & MAV.MAV_SYS_STATUS_PREARM_CHECK
    assert st.onboard_control_sensors_health & MAV.MAV_SYS_STATUS_PREARM_CHECK  # ready to arm
    assert msgs["EXTENDED_SYS_STATE"].landed_state == MAV.MAV_LANDED_STATE_ON_GROUND
    rtl = v.modes.__members__["RTL"]
    core.receive(1, wire(cmd_long(20)), 0)
    assert take(core, 1, "COMMAND_ACK")[0].result == MAV.MAV_RESULT_ACCEPTED and v.mode == rtl
    core.receive(1, wire(cmd_long(21)), 0)
    land = take(core, 1, "COMMAND_ACK")[0].result
    assert land == (MAV.MAV_RESULT_UNSUPPORTED if kind == "plane" else MAV.MAV_RESULT_ACCEPTED)
