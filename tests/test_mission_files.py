"""Mission items, .waypoints / .plan files, and the missions the project ships."""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from autopilot.mission.files import (
    MissionFileError,
    dumps_plan,
    dumps_waypoints,
    load_mission,
    loads_plan,
    loads_waypoints,
    save_plan,
    save_waypoints,
)
from autopilot.mission.items import (
    NAV_LAND,
    DO_CHANGE_SPEED,
    DO_JUMP,
    DO_SET_HOME,
    FRAME_GLOBAL,
    FRAME_GLOBAL_INT,
    FRAME_GLOBAL_RELATIVE_ALT,
    FRAME_MISSION,
    NAV_LOITER_TURNS,
    NAV_RETURN_TO_LAUNCH,
    NAV_TAKEOFF,
    NAV_WAYPOINT,
    POSITION_COMMANDS,
    Mission,
    MissionItem,
    validate_item,
    validate_mission,
)

ROOT = Path(__file__).resolve().parent.parent
MISSIONS = ROOT / "missions"
DATA = Path(__file__).resolve().parent / "data"
MISSION_FILES = sorted(MISSIONS.glob("*.waypoints")) + sorted(MISSIONS.glob("*.plan"))

CMAC = (-35.363262, 149.165237, 584.0)
R_EARTH_M = 6371008.8


# --- a little spherical geometry of our own (autopilot.geo is someone else's) ----------

def haversine_m(a: tuple[float, float], b: tuple[float, float]) -> float:
    p1, p2 = math.radians(a[0]), math.radians(b[0])
    dl = math.radians(b[1] - a[1])
    h = math.sin((p2 - p1) / 2) ** 2 + math.cos(p1) * math.cos(p2) * math.sin(dl / 2) ** 2
    return 2 * R_EARTH_M * math.asin(math.sqrt(h))


def bearing_deg(a: tuple[float, float], b: tuple[float, float]) -> float:
    p1, p2 = math.radians(a[0]), math.radians(b[0])
    dl = math.radians(b[1] - a[1])
    y = math.sin(dl) * math.cos(p2)
    x = math.cos(p1) * math.sin(p2) - math.sin(p1) * math.cos(p2) * math.cos(dl)
    return math.degrees(math.atan2(y, x)) % 360.0


def turn_deg(b_in: float, b_out: float) -> float:
    return abs((b_out - b_in + 180.0) % 360.0 - 180.0)


def flown_path(mission: Mission) -> list[tuple[MissionItem | None, tuple[float, float]]]:
    """Positions in the order they are flown (DO_JUMP followed); None = home after RTL."""
    path = []
    jumps_left: dict[int, int] = {}
    seq = 1
    while seq < len(mission):
        item = mission[seq]
        if item.command == DO_JUMP:
            left = jumps_left.setdefault(seq, int(item.param2))
            if left > 0:
                jumps_left[seq] -= 1
                seq = int(item.param1)
                continue
        elif item.command == NAV_RETURN_TO_LAUNCH:
            path.append((None, (mission.home.x_lat_deg, mission.home.y_lon_deg)))
            break
        elif item.command in POSITION_COMMANDS:
            path.append((item, (item.x_lat_deg, item.y_lon_deg)))
        seq += 1
    return path


def waypoint_legs_and_turns(mission: Mission) -> tuple[list[float], list[float], float]:
    """Lengths of NAV_WAYPOINT->NAV_WAYPOINT legs, turn angles at NAV_WAYPOINTs that have a
    NAV_WAYPOINT on both sides, and the total flown length from home back to home."""
    path = [(mission.home, (mission.home.x_lat_deg, mission.home.y_lon_deg))] + flown_path(mission)
    total = sum(haversine_m(a, b) for (_, a), (_, b) in zip(path, path[1:]))
    is_wp = [it is not None and it.command == NAV_WAYPOINT and it.seq != 0 for it, _ in path]
    legs = [haversine_m(path[i][1], path[i + 1][1])
            for i in range(len(path) - 1) if is_wp[i] and is_wp[i + 1]]
    turns = []
    for i in range(1, len(path) - 1):
        if is_wp[i - 1] and is_wp[i] and is_wp[i + 1]:
            turns.append(turn_deg(bearing_deg(path[i - 1][1], path[i][1]),
                                  bearing_deg(path[i][1], path[i + 1][1])))
    return legs, turns, total


def wp(seq: int, cmd: int = NAV_WAYPOINT, frame: int = FRAME_GLOBAL_RELATIVE_ALT,
       p: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0),
       lat: float = -35.36, lon: float = 149.17, alt: float = 100.0) -> MissionItem:
    return MissionItem(seq, frame, cmd, 0, 1, *p, lat, lon, alt)


HOME = MissionItem(0, FRAME_GLOBAL, NAV_WAYPOINT, 1, 1, 0, 0, 0, 0, *CMAC)


# --- every shipped mission -------------------------------------------------------------

def test_missions_folder_holds_the_expected_files():
    names = {p.name for p in MISSION_FILES}
    assert {"default.waypoints", "default.plan", "acute_short.waypoints",
            "southern_dateline.waypoints"} <= names


@pytest.mark.parametrize("path", MISSION_FILES, ids=lambda p: p.name)
def test_every_shipped_mission_loads_valid_and_ends_in_rtl_or_land(path):
    mission = load_mission(path)
    assert validate_mission(mission.items) is None
    assert all(validate_item(it) is None for it in mission)
    assert mission.home.seq == 0 and mission.home.command == NAV_WAYPOINT
    assert mission.home.frame == FRAME_GLOBAL
    assert mission[1].command == NAV_TAKEOFF
    assert mission[-1].command in (NAV_RETURN_TO_LAUNCH, NAV_LAND)
    assert [it.seq for it in mission] == list(range(len(mission)))


def test_default_waypoints_content():
    m = load_mission(MISSIONS / "default.waypoints")
    assert len(m) == 13
    assert (m.home.x_lat_deg, m.home.y_lon_deg, m.home.z_alt_m) == CMAC
    assert [it.command for it in m] == [
        NAV_WAYPOINT, NAV_TAKEOFF, DO_CHANGE_SPEED,
        NAV_WAYPOINT, NAV_WAYPOINT, NAV_WAYPOINT, NAV_WAYPOINT, NAV_WAYPOINT, NAV_WAYPOINT,
        DO_JUMP, NAV_WAYPOINT, NAV_WAYPOINT, NAV_RETURN_TO_LAUNCH]
    takeoff = m[1]
    assert (takeoff.param1, takeoff.z_alt_m) == (12.0, 60.0)
    assert takeoff.frame == FRAME_GLOBAL_RELATIVE_ALT
    speed = m[2]
    assert (speed.param1, speed.param2) == (0.0, 25.0)  # airspeed 25 m/s
    jump = m[9]
    assert (jump.param1, jump.param2) == (5.0, 1.0)
    assert m[int(jump.param1)].command == NAV_WAYPOINT
    waypoints = [it for it in m if it.command == NAV_WAYPOINT and it.seq > 0]
    assert len(waypoints) >= 8
    assert all(it.frame == FRAME_GLOBAL_RELATIVE_ALT and 80.0 <= it.z_alt_m <= 120.0
               for it in waypoints)


def test_default_geometry_legs_turns_and_length():
    legs, turns, total = waypoint_legs_and_turns(load_mission(MISSIONS / "default.waypoints"))
    assert len(legs) >= 10  # the DO_JUMP repeats four legs
    assert all(350.0 <= leg <= 600.0 for leg in legs), legs
    assert all(turn >= 89.0 for turn in turns), turns
    assert any(120.0 <= turn <= 150.0 for turn in turns), turns
    assert total <= 12_000.0
    assert total / 22.0 <= 12 * 60


def test_default_plan_is_the_same_mission_as_default_waypoints():
    assert load_mission(MISSIONS / "default.plan") == load_mission(MISSIONS / "default.waypoints")


def test_acute_short_content_and_geometry():
    m = load_mission(MISSIONS / "acute_short.waypoints")
    loiters = [it for it in m if it.command == NAV_LOITER_TURNS]
    assert len(loiters) == 1
    assert (loiters[0].param1, abs(loiters[0].param3)) == (2.0, 80.0)
    alts = [it.z_alt_m for it in m if it.command in (NAV_WAYPOINT, NAV_LOITER_TURNS) and it.seq > 0]
    assert min(alts) == 60.0 and max(alts) == 120.0
    legs, turns, _ = waypoint_legs_and_turns(m)
    assert len(legs) >= 5
    assert all(abs(leg - 150.0) < 1.0 for leg in legs), legs
    assert max(turns) == pytest.approx(150.0, abs=1.0)
    assert all(turn <= 151.0 for turn in turns)
    assert sum(turn > 90.0 for turn in turns) >= 3


def test_southern_dateline_crosses_the_antimeridian():
    m = load_mission(MISSIONS / "southern_dateline.waypoints")
    assert (m.home.x_lat_deg, m.home.y_lon_deg, m.home.z_alt_m) == (-41.0, 179.95, 10.0)
    lons = [it.y_lon_deg for it in m if it.command == NAV_WAYPOINT and it.seq > 0]
    assert any(-180.0 < lon < -179.99 for lon in lons)
    assert any(179.9 < lon <= 180.0 for lon in lons)
    legs, _, total = waypoint_legs_and_turns(m)
    assert all(leg >= 300.0 for leg in legs), legs
    # A naive longitude difference would make the crossing legs ~30 000 km long.
    assert max(legs) < 2000.0
    assert total < 15_000.0


# --- round trips -----------------------------------------------------------------------

@pytest.mark.parametrize("path", sorted(MISSIONS.glob("*.waypoints")), ids=lambda p: p.name)
def test_round_trip_waypoints_plan_waypoints(path):
    original = load_mission(path)
    via_plan = loads_plan(dumps_plan(original))
    assert via_plan == original
    text = dumps_waypoints(via_plan)
    assert loads_waypoints(text) == original
    assert text == path.read_text()  # shipped files are written by save_waypoints


def test_round_trip_through_files_on_disk(tmp_path):
    original = load_mission(MISSIONS / "default.waypoints")
    save_plan(original, tmp_path / "m.plan")
    save_waypoints(load_mission(tmp_path / "m.plan"), tmp_path / "m.waypoints")
    assert load_mission(tmp_path / "m.waypoints") == original


def test_plan_null_params_are_nan_and_survive_a_round_trip():
    m = load_mission(DATA / "good_nan.plan")
    assert math.isnan(m[1].param4)
    assert m[4].command == DO_JUMP and m[4].param1 == 2.0  # doJumpId 2 -> seq 2
    again = loads_waypoints(dumps_waypoints(loads_plan(dumps_plan(m))))
    assert again == m
    assert "nan" in dumps_waypoints(m)


def test_plan_do_jump_maps_do_jump_id_to_seq():
    # Renumber the doJumpIds so they differ from seq: param1 must follow the id.
    doc = json.loads((DATA / "good_nan.plan").read_text())
    items = doc["mission"]["items"]
    for item in items:
        item["doJumpId"] += 100
    assert items[3]["command"] == DO_JUMP
    items[3]["params"][0] = items[2]["doJumpId"]  # jump to items[2], i.e. seq 3
    m = loads_plan(json.dumps(doc))
    assert m[4].param1 == 3.0
    items[3]["params"][0] = 3  # a seq, not a doJumpId: no item has id 3
    with pytest.raises(MissionFileError, match="item 4: DO_JUMP to missing doJumpId 3"):
        loads_plan(json.dumps(doc))


def test_load_mission_sniffs_content_without_a_known_extension(tmp_path):
    src = load_mission(MISSIONS / "default.waypoints")
    (tmp_path / "a.mission").write_text(dumps_plan(src))
    (tmp_path / "b.mission").write_text(dumps_waypoints(src))
    assert load_mission(tmp_path / "a.mission") == src
    assert load_mission(tmp_path / "b.mission") == src
    (tmp_path / "c.mission").write_text("hello\n")
    with pytest.raises(MissionFileError, match="unknown mission file format"):
        load_mission(tmp_path / "c.mission")


# --- bad files -------------------------------------------------------------------------

BAD_FILES = [
    ("bad_header.waypoints", 1, "bad header 'QGC WPL 100'"),
    ("empty_file.waypoints", 1, "missing header"),
    ("header_only.waypoints", None, "empty mission"),
    ("home_only.waypoints", None, "empty mission"),
    ("field_count.waypoints", 5, "expected 12 fields, got 9"),
    ("not_a_number.waypoints", 4, "'149.16x' is not a number"),
    ("not_an_integer.waypoints", 5, "'16.5' is not an integer"),
    ("unknown_command.waypoints", 5, "unknown command 999 (MAV_MISSION_UNSUPPORTED)"),
    ("bad_frame.waypoints", 4, "MAV_MISSION_UNSUPPORTED_FRAME"),
    ("bad_lat.waypoints", 5, "latitude 95.0 outside [-90, 90] (MAV_MISSION_INVALID_PARAM5_X)"),
    ("bad_lon.waypoints", 3, "MAV_MISSION_INVALID_PARAM6_Y"),
    ("bad_alt.waypoints", 5, "MAV_MISSION_INVALID_PARAM7"),
    ("jump_missing.waypoints", 6, "DO_JUMP to missing item 42"),
    ("jump_home.waypoints", 5, "MAV_MISSION_INVALID_PARAM1"),
    ("jump_negative_repeat.waypoints", 5, "MAV_MISSION_INVALID_PARAM2"),
    ("seq_gap.waypoints", 5, "expected seq 2, got 3"),
    ("home_not_waypoint.waypoints", 2, "item 0 (home) must be NAV_WAYPOINT"),
    ("invalid_json.plan", 4, "invalid JSON"),
    ("not_an_object.plan", None, "not a plan"),
    ("wrong_filetype.plan", None, "wrong fileType 'GeoFence'"),
    ("wrong_version.plan", None, "unsupported plan version 2"),
    ("empty_items.plan", None, "empty mission"),
    ("no_home.plan", "item 0", "plannedHomePosition"),
    ("home_bad_lat.plan", "item 0", "MAV_MISSION_INVALID_PARAM5_X"),
    ("complex_item.plan", "item 3", "ComplexItem survey (mission.items[2]) has no stored mission items"),
    ("unknown_command.plan", "item 2", "unknown command 31337"),
    ("bad_frame.plan", "item 3", "unsupported frame 1"),
    ("params_count.plan", "item 2", "expected 7 params, got 6"),
    ("param_string.plan", "item 3", "param5"),
    ("bad_lon.plan", "item 2", "longitude 190.0 outside [-180, 180]"),
    ("jump_missing.plan", "item 4", "DO_JUMP to missing doJumpId 9"),
    ("duplicate_jump_id.plan", "item 3", "doJumpId 2 used twice"),
]


def test_every_bad_file_is_covered():
    covered = {name for name, _, _ in BAD_FILES} | {"good_nan.plan"}
    assert {p.name for p in DATA.iterdir() if p.suffix in (".waypoints", ".plan")} == covered


@pytest.mark.parametrize("name, where, text", BAD_FILES, ids=[b[0] for b in BAD_FILES])
def test_bad_file_raises_with_place_and_reason(name, where, text):
    path = DATA / name
    with pytest.raises(MissionFileError) as info:
        load_mission(path)
    err = info.value
    assert err.where == where
    prefix = f"{path}: " if where is None else f"{path}:{where}: "
    assert str(err).startswith(prefix), str(err)
    assert text in str(err)


def test_error_text_reads_like_a_compiler_message():
    err = MissionFileError("missions/x.waypoints", 7, "expected 12 fields, got 9")
    assert str(err) == "missions/x.waypoints:7: expected 12 fields, got 9"
    assert str(MissionFileError("m.plan", "item 3", "bad")) == "m.plan:item 3: bad"
    assert str(MissionFileError("m.plan", None, "bad")) == "m.plan: bad"


def test_missing_file_is_an_os_error(tmp_path):
    with pytest.raises(FileNotFoundError):
        load_mission(tmp_path / "nope.waypoints")


# --- item and mission validation -------------------------------------------------------

@pytest.mark.parametrize("item, code", [
    (wp(1), None),
    (wp(1, frame=FRAME_GLOBAL_INT, alt=700.0), None),
    (wp(1, lat=90.0, lon=-180.0), None),
    (wp(1, cmd=NAV_RETURN_TO_LAUNCH, frame=FRAME_MISSION, lat=0.0, lon=0.0, alt=0.0), None),
    (wp(1, cmd=DO_SET_HOME, frame=FRAME_MISSION, p=(1, 0, 0, 0), lat=0, lon=0, alt=0), None),
    (wp(1, cmd=DO_SET_HOME, frame=FRAME_MISSION, p=(0, 0, 0, 0)), "MAV_MISSION_UNSUPPORTED_FRAME"),
    (wp(1, cmd=31000), "MAV_MISSION_UNSUPPORTED"),
    (wp(1, cmd=mavlink2.MAV_CMD_DO_SET_SERVO), "MAV_MISSION_UNSUPPORTED"),
    (wp(1, frame=mavlink2.MAV_FRAME_LOCAL_NED), "MAV_MISSION_UNSUPPORTED_FRAME"),
    (wp(1, frame=FRAME_MISSION), "MAV_MISSION_UNSUPPORTED_FRAME"),  # a waypoint needs a place
    (wp(1, lat=90.5), "MAV_MISSION_INVALID_PARAM5_X"),
    (wp(1, lat=-91.0), "MAV_MISSION_INVALID_PARAM5_X"),
    (wp(1, lat=math.nan), "MAV_MISSION_INVALID_PARAM5_X"),
    (wp(1, lon=180.001), "MAV_MISSION_INVALID_PARAM6_Y"),
    (wp(1, lon=-200.0), "MAV_MISSION_INVALID_PARAM6_Y"),
    (wp(1, alt=50001.0), "MAV_MISSION_INVALID_PARAM7"),
    (wp(1, alt=-1001.0), "MAV_MISSION_INVALID_PARAM7"),
    (wp(1, alt=math.inf), "MAV_MISSION_INVALID_PARAM7"),
    (wp(1, cmd=DO_JUMP, frame=FRAME_MISSION, p=(3, 1, 0, 0), lat=0, lon=0, alt=0), None),
    (wp(1, cmd=DO_JUMP, frame=FRAME_MISSION, p=(0, 1, 0, 0), lat=0, lon=0, alt=0),
     "MAV_MISSION_INVALID_PARAM1"),
    (wp(1, cmd=DO_JUMP, frame=FRAME_MISSION, p=(2.5, 1, 0, 0), lat=0, lon=0, alt=0),
     "MAV_MISSION_INVALID_PARAM1"),
    (wp(4, cmd=DO_JUMP, frame=FRAME_MISSION, p=(4, 1, 0, 0), lat=0, lon=0, alt=0),
     "MAV_MISSION_INVALID_PARAM1"),  # to itself
    (wp(1, cmd=DO_JUMP, frame=FRAME_MISSION, p=(3, -1, 0, 0), lat=0, lon=0, alt=0), None),
    (wp(1, cmd=DO_JUMP, frame=FRAME_MISSION, p=(3, -2, 0, 0), lat=0, lon=0, alt=0),
     "MAV_MISSION_INVALID_PARAM2"),  # -1 is "for ever", nothing below
    (wp(1, cmd=DO_CHANGE_SPEED, frame=FRAME_MISSION, p=(0, 22, -1, 0), lat=0, lon=0, alt=0), None),
    (wp(1, cmd=DO_CHANGE_SPEED, frame=FRAME_MISSION, p=(7, 22, -1, 0), lat=0, lon=0, alt=0),
     "MAV_MISSION_INVALID_PARAM1"),
    (wp(1, cmd=DO_CHANGE_SPEED, frame=FRAME_MISSION, p=(0, 500, -1, 0), lat=0, lon=0, alt=0),
     "MAV_MISSION_INVALID_PARAM2"),
    (wp(1, cmd=NAV_LOITER_TURNS, p=(0, 0, 80, 0)), "MAV_MISSION_INVALID_PARAM1"),
    (wp(1, cmd=NAV_LOITER_TURNS, p=(2, 0, 80, 0)), None),
    (wp(1, cmd=NAV_TAKEOFF, p=(95, 0, 0, 0)), "MAV_MISSION_INVALID_PARAM1"),
    (dataclasses.replace(wp(1), current=2), "MAV_MISSION_INVALID"),
    (dataclasses.replace(wp(1), mission_type=mavlink2.MAV_MISSION_TYPE_FENCE),
     "MAV_MISSION_UNSUPPORTED"),
])
def test_validate_item_codes(item, code):
    assert validate_item(item) == code


def test_validate_item_codes_are_real_mav_mission_result_names():
    names = {e.name for e in mavlink2.enums["MAV_MISSION_RESULT"].values()}
    bad = [wp(1, cmd=31000), wp(1, lat=95.0), wp(1, lon=200.0), wp(1, alt=1e6),
           wp(1, frame=1), dataclasses.replace(wp(1), current=3)]
    codes = [validate_item(it) for it in bad]
    assert None not in codes and set(codes) <= names


def test_validate_mission():
    jump = wp(2, cmd=DO_JUMP, frame=FRAME_MISSION, p=(1, 1, 0, 0), lat=0, lon=0, alt=0)
    assert validate_mission([HOME, wp(1), jump]) is None
    assert validate_mission([]).code == "MAV_MISSION_INVALID"
    gap = validate_mission([HOME, wp(2)])
    assert (gap.seq, gap.code) == (1, "MAV_MISSION_INVALID_SEQUENCE")
    far = validate_mission([HOME, wp(1), dataclasses.replace(jump, param1=3.0)])
    assert (far.seq, far.code) == (2, "MAV_MISSION_INVALID_PARAM1")
    relative_home = validate_mission([dataclasses.replace(HOME, frame=FRAME_GLOBAL_RELATIVE_ALT)])
    assert (relative_home.seq, relative_home.code) == (0, "MAV_MISSION_UNSUPPORTED_FRAME")
    bad_item = validate_mission([HOME, wp(1, lat=100.0)])
    assert (bad_item.seq, bad_item.code) == (1, "MAV_MISSION_INVALID_PARAM5_X")


def test_mission_is_immutable_and_checked():
    m = Mission([HOME, wp(1)])
    assert isinstance(m.items, tuple) and m.home is m.items[0] and len(m) == 2
    with pytest.raises(dataclasses.FrozenInstanceError):
        m.items = ()
    with pytest.raises(dataclasses.FrozenInstanceError):
        m.home.x_lat_deg = 0.0
    with pytest.raises(ValueError, match="MAV_MISSION_INVALID_SEQUENCE"):
        Mission([HOME, wp(3)])
    with pytest.raises(ValueError):
        Mission([])


def test_item_int_round_trip_through_real_mavlink_bytes():
    item = MissionItem(7, FRAME_GLOBAL_RELATIVE_ALT, NAV_LOITER_TURNS, 0, 1,
                       2.0, 0.0, 80.0, 0.0, -41.0061234, -179.9912345, 120.0)
    fields = item.to_int()
    assert (fields["x"], fields["y"]) == (-410061234, -1799912345)
    mav = mavlink2.MAVLink(None, srcSystem=1, srcComponent=1)
    msg = mavlink2.MAVLink_mission_item_int_message(1, 1, **fields)
    decoded = mav.decode(bytearray(msg.pack(mav)))
    assert decoded.get_type() == "MISSION_ITEM_INT"
    assert MissionItem.from_int(decoded) == item


def test_item_int_field_names_match_pymavlink():
    names = set(mavlink2.MAVLink_mission_item_int_message.fieldnames)
    assert set(wp(1).to_int()) == names - {"target_system", "target_component"}


def test_items_with_nan_params_compare_equal():
    a = wp(1, p=(0, 0, 0, math.nan))
    b = wp(1, p=(0, 0, 0, float("nan")))
    assert a == b
    assert a != wp(1)
