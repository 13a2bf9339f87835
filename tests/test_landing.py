"""Fixed-wing automatic landing (autopilot/guidance/landing.py): the Aerosonde flown by
JSBSim through missions/default_land.plan, scored on truth (summary.json ``landing``,
tools/landing_score.py). A small sample of the acceptance in docs/status.md: landings in
crosswind and light turbulence, a go-around on short final, an RTL with RTL_AUTOLAND;
plus the go-around command's protocol exchange and the landing's geometry."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from autopilot.gcs import GCS_PARAMS
from autopilot.gcs.core import GcsCore
from autopilot.guidance.landing import Landing, flare_overshoot_m
from autopilot.guidance.mission import MissionSequencer
from autopilot.geo import LocalFrame
from autopilot.link.codec import MAV, Codec
from autopilot.mission.files import load_mission
from autopilot.mission.items import DO_LAND_START, NAV_LAND, Mission
from autopilot.modes.plane import PlaneMode
from autopilot.params import ParamStore
from autopilot.vehicle import PlaneVehicle, plane_param_declarations
from tools.runner import REPO_ROOT, RunConfig, Session
from tools.summary import run_summary

LAND_PLAN = REPO_ROOT / "missions" / "default_land.plan"
FAST = {"LAND_DISARMDELAY": 2.0}      # disarm 2 s after stopping (ArduPlane's default is 20 s)


def fly(seed, wind=None, params=None, during=None, turbulence="light"):
    """Fly default_land.plan headless; ``during(session)`` is called after every step.
    Returns (summary, session)."""
    cfg = RunConfig(mission=Path(LAND_PLAN), seed=seed, wind=wind, turbulence=turbulence,
                    param_overrides={**FAST, **(params or {})}, duration_s=900.0)
    s = Session(cfg)
    while s.t_s < cfg.duration_s and not s.done():
        s.step()
        if during is not None:
            during(s)
    return run_summary(s), s


def assert_landed(summary, along_m=25.0, cross_m=3.0, sink_mps=1.0):
    land = summary["landing"]
    assert land is not None and not summary["crashed"]
    assert abs(land["touchdown_along_m"]) <= along_m, land
    assert abs(land["touchdown_cross_m"]) <= cross_m, land
    assert 0.0 <= land["sink_rate_mps"] <= sink_mps, land
    assert land["bounce_m"] <= 0.5, land
    assert land["disarmed"] is True, land


# --- flights ------------------------------------------------------------------------------

@pytest.mark.parametrize("seed", [6, 8, 9])
def test_landing_in_crosswind_and_light_turbulence(seed):
    # the acceptance's own winds (docs/status.md): (N - 1) 8/9 m/s, from 180 deg on odd N
    wind = ((seed - 1) * 8 / 9, 180.0 if seed % 2 else 0.0)
    summary, s = fly(seed, wind)
    assert summary["completed"] is True               # every item, the NAV_LAND last
    assert summary["invariants_passed"] is True
    assert summary["mission_items_reached"] == summary["mission_items_total"]
    # along the approach: within issue 16's 25 m, with the Aerosonde's rangefinder flying
    # the landing's height (RNGFND_LANDING 1): 15.0 / -4.6 / 12.7 m; on the navigation's
    # height alone 13.5 / -31.8 / 24.3 m (at d49a4cb: seed 8 fails)
    assert_landed(summary, along_m=25.0)
    assert summary["landing"]["go_arounds"] == 0
    assert not s.vehicle.armed and s.vehicle.land_done
    texts = [t for _, _, t in s.vehicle.notices]
    assert any(t.startswith("Flare ") for t in texts) and "Landing complete: disarming" in texts
    assert any(t.startswith("Rangefinder engaged at ") for t in texts)


def test_go_around_on_short_final_climbs_away_and_lands_on_the_second_approach():
    state = {"t_ga": None, "h_max_after": 0.0}

    def during(s):
        v = s.vehicle
        seq = v.sequencer
        if seq is None or v.nav_state is None:
            return
        if state["t_ga"] is None and seq.landing is not None and seq.landing.phase == "approach" \
                and v.nav_state.alt_m - seq.landing.alt_b < 12.0:
            assert v.go_around(0.0, s.bridge.t_us) is None      # what DO_GO_AROUND calls
            state["t_ga"] = s.t_s
        elif state["t_ga"] is not None:
            st = s.bridge.state
            state["h_max_after"] = max(state["h_max_after"], st.alt_m - s.home[2])

    summary, s = fly(1, (4.0, 180.0), during=during)
    assert state["t_ga"] is not None
    # climbed away to the abort altitude (LAND_ABORT_ALT 30 m above home), then landed
    assert state["h_max_after"] >= 25.0
    assert summary["landing"]["go_arounds"] == 1
    assert summary["landing"]["touchdown_s"] > state["t_ga"] + 60.0   # on the second approach
    # (the second approach's touchdown in this turbulence is scored in docs/status.md;
    # here: on the runway's line, soft enough, and disarmed)
    assert_landed(summary, along_m=50.0, sink_mps=1.5)
    texts = [t for _, _, t in s.vehicle.notices]
    assert "Go around (commanded): climbing to 30 m" in texts
    assert "Go around complete: landing again from item #12" in texts


def test_rtl_autoland_1_lands_after_reaching_home():
    def during(s):
        v = s.vehicle
        if v.mode == PlaneMode.AUTO and s.t_s > 150.0 and v.sequencer.current < 12:
            assert v.set_mode(PlaneMode.RTL, s.bridge.t_us) is None

    summary, s = fly(1, (4.0, 180.0), params={"RTL_AUTOLAND": 1}, during=during)
    texts = [t for _, _, t in s.vehicle.notices]
    assert "RTL_AUTOLAND: landing sequence from item #12" in texts
    seq = s.vehicle.sequencer
    assert 12 in seq.reached_seqs and seq.land_complete
    assert_landed(summary, along_m=40.0, sink_mps=1.5)


def test_rtl_with_rtl_autoland_lands_through_the_do_land_start_sequence():
    def during(s):
        v = s.vehicle
        if v.mode == PlaneMode.AUTO and s.t_s > 120.0 and v.sequencer.current < 12:
            assert v.set_mode(PlaneMode.RTL, s.bridge.t_us) is None

    summary, s = fly(3, (3.0, 180.0), params={"RTL_AUTOLAND": 2}, during=during)
    seq = s.vehicle.sequencer
    assert 12 in seq.reached_seqs and 15 in seq.reached_seqs     # DO_LAND_START ... NAV_LAND
    assert 10 not in seq.reached_seqs                            # the rest of the survey skipped
    assert summary["completed"] is False                         # an RTL is not the mission
    assert_landed(summary, along_m=40.0, sink_mps=1.5)
    assert "RTL_AUTOLAND: landing sequence from item #12" in [t for _, _, t in s.vehicle.notices]


# --- approaches that start high or fast: flown down, not gone around forever ----------

HOME = (-35.363262, 149.165237, 584.0)


def _wpl(tmp_path, rows, name):
    """A QGC WPL mission at HOME: rows of (command, frame, params 1-4, north, east,
    altitude), positions in metres NE of home (frame 2: none)."""
    fr = LocalFrame.from_degrees(*HOME)
    lines = ["QGC WPL 110", f"0\t1\t0\t16\t0\t0\t0\t0\t{HOME[0]}\t{HOME[1]}\t{HOME[2]}\t1"]
    for i, (cmd, frame, p1, p2, p3, p4, n, e, h) in enumerate(rows, 1):
        lat, lon = (0.0, 0.0)
        if frame != 2:
            la, lo, _ = fr.to_geodetic_fast((n, e, 0.0))
            lat, lon = math.degrees(la), math.degrees(lo)
        lines.append(f"{i}\t0\t{frame}\t{cmd}\t{p1}\t{p2}\t{p3}\t{p4}\t{lat:.7f}\t{lon:.7f}\t{h}\t1")
    path = tmp_path / name
    path.write_text("\n".join(lines) + "\n")
    return path


def _fly_file(path, seed, wind, during=None, turbulence="light"):
    cfg = RunConfig(mission=path, seed=seed, wind=wind, turbulence=turbulence,
                    param_overrides=dict(FAST), duration_s=900.0)
    s = Session(cfg)
    while s.t_s < cfg.duration_s and not s.done():
        s.step()
        if during is not None:
            during(s)
    return run_summary(s), s


def test_an_approach_started_far_above_its_glide_slope_loses_the_height_first(tmp_path):
    """The random-plane campaign's class (trials 107, 276, 337, 379, ...): the landing's
    base leg too short to descend on, the approach starts 60-100 m above its slope; it
    used to go around at LAND_AB_CHK_ALT and fly the same sequence again, 5-18 times,
    until the run ended. Here the base leg descends 105 m over 300 m."""
    path = _wpl(tmp_path, [
        (22, 3, 12, 0, 0, 0, 300.0, -40.0, 60.0),        # takeoff
        (16, 3, 0, 0, 0, 0, 700.0, 500.0, 150.0),
        (189, 2, 0, 0, 0, 0, 0.0, 0.0, 0.0),             # DO_LAND_START
        (16, 3, 0, 0, 0, 0, 300.0, 1000.0, 150.0),       # abeam the approach's start
        (16, 3, 0, 0, 0, 0, 0.0, 1000.0, 45.0),          # the approach's start A
        (21, 3, 0, 0, 0, 0, 0.0, -50.0, -1.5),           # NAV_LAND
    ], "high.waypoints")
    summary, s = _fly_file(path, 2, (3.0, 270.0))
    texts = [t for _, _, t in s.vehicle.notices]
    circle = [t for t in texts if t.startswith("Landing: ") and "descending on a" in t]
    assert circle and int(circle[0].split()[1]) >= 50, texts     # tens of metres high at A
    assert summary["completed"] is True
    assert summary["landing"]["go_arounds"] == 0, [t for t in texts if "Go around" in t]
    assert summary["invariants_passed"] is True, summary["invariants"]
    assert_landed(summary, along_m=60.0, sink_mps=1.5)


def test_a_ground_speed_minimum_does_not_raise_the_approach_airspeed():
    """DO_CHANGE_SPEED type 1 (MIN_GNDSPD) earlier in the mission raised the airspeed on
    the landing's approach to hold the ground speed into the wind (30 m/s against 25),
    and the overspeed abort took it around (random-plane trials 117, 383)."""
    seen = {"approach": 0, "other": []}

    def during(s):
        v = s.vehicle
        seq = v.sequencer
        if seq is None or s.t_s < 5.0:
            return
        if s.t_s < 6.0 and seq.min_groundspeed_mps == 0.0:
            assert seq.change_speed(s.bridge.t_us, 1, 27.0) is None      # MIN_GNDSPD 27 m/s
        tgt = v.target
        if tgt is not None and tgt.land == "approach":
            seen["approach"] += 1
            if abs(tgt.airspeed_mps - seq.landing.airspeed_mps) > 1e-6:
                seen["other"].append(round(tgt.airspeed_mps, 2))

    summary, s = fly(4, (6.0, 270.0), during=during)                 # a headwind on final
    assert s.vehicle.sequencer.min_groundspeed_mps == 27.0
    assert seen["approach"] > 1000 and not seen["other"], seen["other"][:5]
    assert summary["landing"]["go_arounds"] == 0
    assert_landed(summary, along_m=40.0, sink_mps=1.5)


# --- the go-around command on the wire -------------------------------------------------

def test_do_go_around_is_refused_by_name_when_no_landing_is_flown():
    params = ParamStore(list(plane_param_declarations()) + list(GCS_PARAMS))
    v = PlaneVehicle(params, load_mission(LAND_PLAN), "truth", autostart=False)
    core = GcsCore(v, lambda: 1000.0, relay=None)
    core.add_client(1, "a")
    tx = Codec(255, 190)
    (msg,) = Codec(1, 1).decode(tx.encode(MAV.MAVLink_command_long_message(
        1, 1, MAV.MAV_CMD_DO_GO_AROUND, 0, 0, 0, 0, 0, 0, 0, 0)))
    core.receive(1, msg, 0)
    out = [m for _, m, _ in core.outbox]
    acks = [m for m in out if m.get_type() == "COMMAND_ACK"]
    assert [(a.command, a.result) for a in acks] == [(MAV.MAV_CMD_DO_GO_AROUND, MAV.MAV_RESULT_FAILED)]
    texts = [m.text for m in out if m.get_type() == "STATUSTEXT"]
    assert texts == ["Go around refused: not flying a landing in AUTO"]


def test_extended_sys_state_says_landing_while_a_landing_is_flown():
    from autopilot.gcs.telemetry import Telemetry
    params = ParamStore(list(plane_param_declarations()) + list(GCS_PARAMS))
    v = PlaneVehicle(params, load_mission(LAND_PLAN), "truth", autostart=False)
    tm = Telemetry.__new__(Telemetry)
    tm.vehicle = v
    assert tm.extended_sys_state().landed_state == MAV.MAV_LANDED_STATE_ON_GROUND
    h = v.mission.home
    v.home_frame = LocalFrame(math.radians(h.x_lat_deg), math.radians(h.y_lon_deg), h.z_alt_m)
    v.sequencer = MissionSequencer(v.mission, v.home_frame, params)
    v.sequencer.launched = v.armed = True
    v.nav_state = type("Nav", (), {"alt_m": h.z_alt_m + 30.0})()
    assert tm.extended_sys_state().landed_state == MAV.MAV_LANDED_STATE_IN_AIR
    v.sequencer.landing = Landing(params, (0.0, 1000.0), (0.0, -50.0), h.z_alt_m + 45, h.z_alt_m - 1.5, 20.0)
    assert tm.extended_sys_state().landed_state == MAV.MAV_LANDED_STATE_LANDING
    v.sequencer.landing.phase = "ground"                       # stopped: on the ground
    assert tm.extended_sys_state().landed_state == MAV.MAV_LANDED_STATE_ON_GROUND


# --- geometry ----------------------------------------------------------------------------

def test_the_glide_slope_is_aimed_short_by_the_flare_overshoot():
    # r = s_app / s_td = 4: gs tau (ln 4 - 3/4) = 20 * 2 * 0.6363 = 25.45 m
    assert flare_overshoot_m(20.0, 1.0, 0.25, 2.0) == pytest.approx(25.452, abs=1e-3)
    assert flare_overshoot_m(20.0, 0.2, 0.25, 2.0) == 0.0          # no flare to fly
    # the integrated flare without lag is the closed form; from higher on the slope, the
    # same (the law holds s_app down to tau (s_app - s_td)); a lag shortens the float
    assert flare_overshoot_m(20.0, 1.0, 0.25, 2.0, 1.5, 0.0) == pytest.approx(25.452, abs=0.2)
    assert flare_overshoot_m(20.0, 1.0, 0.25, 2.0, 3.0, 0.0) == pytest.approx(25.452, abs=0.2)
    lagged = flare_overshoot_m(20.0, 1.0, 0.25, 2.0, 3.0, 0.4)
    assert 12.0 < lagged < 18.0
    params = ParamStore(plane_param_declarations())
    land = Landing(params, (0.0, 0.0), (0.0, -1000.0), 650.0, 600.0, 20.0)
    # flare at LAND_FLARE_ALT 3 m (above the 2 m the 1 m/s sink gives LAND_FLARE_SEC),
    # lag LAND_FLR_LAG 0.4 s
    assert land.shift_m == pytest.approx(lagged)
    assert land.glide_alt(0.0) == 650.0 and land.glide_alt(1000.0 - land.shift_m) == 600.0
    assert land.along((10.0, -400.0)) == pytest.approx(400.0)
    assert land.cross((10.0, -400.0)) == pytest.approx(10.0)      # + right of the approach (west-bound)
    assert land.airspeed_mps == 22.5                               # midway ARSPD_FBW_MIN..TRIM_ARSPD


def test_the_nearest_do_land_start_is_chosen():
    mission = load_mission(LAND_PLAN)
    assert [it.command for it in mission][12] == DO_LAND_START and mission[-1].command == NAV_LAND
    h = mission.home
    frame = LocalFrame(math.radians(h.x_lat_deg), math.radians(h.y_lon_deg), h.z_alt_m)
    seq = MissionSequencer(mission, frame, ParamStore(plane_param_declarations()))
    assert seq.landing_start_seq((0.0, 0.0)) == 12
    assert seq.landing_start_seq((0.0, 0.0), before=12) is None    # none before item 12
    # a second sequence nearer to a point in the north-west is chosen from there
    items = list(mission.items)
    extra = [items[12].replace(seq=len(items)), items[13].replace(seq=len(items) + 1,
                                                                  x_lat_deg=h.x_lat_deg + 0.01,
                                                                  y_lon_deg=h.y_lon_deg - 0.01),
             items[15].replace(seq=len(items) + 2)]
    seq.load(Mission(items + extra))
    assert seq.landing_start_seq((1100.0, -900.0)) == len(items)
    assert seq.landing_start_seq((0.0, 0.0)) == 12
    assert np.isfinite(seq.item_ne(extra[1])[0])


def test_the_flare_is_steered_to_the_land_point():
    from autopilot.guidance.landing import FLARE_TAU_MAX, FLARE_TAU_MIN, flare_tau
    # the time constant whose exponential reaches the ground from h in t_go
    tau = flare_tau(2.0, 4.0, 0.25, 0.5, 8.0)
    assert tau * math.log1p(2.0 / (tau * 0.25)) == pytest.approx(4.0, abs=1e-3)
    assert flare_tau(2.0, 5.0, 0.25, 0.5, 8.0) > tau                 # more time: gentler
    assert flare_tau(2.0, 0.1, 0.25, 0.5, 8.0) == 0.5                # clamped
    assert flare_tau(2.0, 60.0, 0.25, 0.5, 8.0) == 8.0
    params = ParamStore(plane_param_declarations())
    s_td, tau0 = params["TECS_LAND_SINK"], params["LAND_FLARE_SEC"]

    def demand(along_m, h_m=1.0, gs=25.0):
        # a flare at h_m above the land point, along_m from A on a 1 km approach
        land = Landing(params, (0.0, 0.0), (0.0, -1000.0), 650.0, 600.0, gs)
        land._sink_mean = 1.25
        v = np.array([0.0, -gs, 1.0])
        land.step(0, (0.0, -along_m), 600.0 + h_m, v, gs)
        assert land.phase == "flare"
        _, climb = land.step(20000, (0.0, -along_m - 0.5), 600.0 + h_m, v, gs)
        return -climb, land.flare_tau_s

    # the same height nearer the point (a float): more sink; farther (early): less
    far, mid, near = demand(900.0), demand(950.0), demand(985.0)
    assert far[0] < mid[0] < near[0]
    assert FLARE_TAU_MIN * tau0 <= near[1] < mid[1] < far[1] <= FLARE_TAU_MAX * tau0
    # past the point: TECS_LAND_SRC more per metre, on top of the shortest time constant's
    past = demand(1020.0, h_m=0.3)
    assert past[1] == FLARE_TAU_MIN * tau0
    assert past[0] > s_td + params["TECS_LAND_SRC"] * 15.0


def test_the_speed_priority_fades_out_along_the_approach():
    params = ParamStore(plane_param_declarations())
    land = Landing(params, (0.0, 0.0), (0.0, -1000.0), 650.0, 600.0, 25.0)
    assert [land.speed_weight(x) for x in (0.0, 500.0, 1000.0, 1100.0)] == [1.0, 0.5, 0.0, 0.0]
    params["TECS_LAND_SPDWGT"] = 0.3
    assert land.speed_weight(100.0) == 0.3



def _fly_flare(land, along0_m, h0_m, sink0_mps, gs, lag_s=0.4, dt=0.02):
    """The flare law closed on a point mass whose sink rate follows the demand through a
    first-order lag (LAND_FLR_LAG's model) at a constant ground speed, from ``h0_m`` above
    the land point ``along0_m`` metres along the approach: (touchdown along past B [m],
    sink at touchdown [m/s])."""
    along, h, sink, t = along0_m, h0_m, sink0_mps, 0
    while h > 0.0 and t < 60_000_000:
        _, climb = land.step(t, (0.0, -along), land.alt_b + h, np.array([0.0, -gs, sink]), gs)
        if climb is not None:
            sink += (-climb - sink) * min(dt / lag_s, 1.0)
        h -= sink * dt
        along += gs * dt
        t += int(dt * 1e6)
    return along - land.length, sink


def test_a_flare_begun_from_an_updrafts_slow_sink_still_reaches_the_land_point():
    # issue 16's long floats (the landing campaign's trial 15 at c26d19e, 42.9 m long): an
    # updraft just above the flare height held the aircraft level, so its 1 s mean sink
    # (the flare's cap) was 0.6 m/s, and the flare, begun 53 m before B (1.4 m high on the
    # slope), glided down from 3 m at 0.6 m/s. The cap now tracks the distance: the sink
    # that reaches the glide slope's ground point, up to FLARE_CAP_MAX times the slope's.
    # Flown on a point mass lagging the demand by LAND_FLR_LAG: at c26d19e 62.0 m long
    # (high) and 31.0 m (on the slope); now 18.8 m and -1.7 m
    from autopilot.guidance.landing import FLARE_CAP_MAX
    params = ParamStore(plane_param_declarations())
    gs = 23.0

    def landing(sink_mean):
        land = Landing(params, (0.0, 0.0), (0.0, -1051.0), 44.5, -1.5, gs)
        land._sink_mean = sink_mean
        return land

    def flight(sink_mean, to_go_m, h0=3.0):
        return _fly_flare(landing(sink_mean), 1051.0 - to_go_m, h0, sink_mean, gs)

    on_slope = 84.0                                     # 3 m on the slope: 16.8 m + 3 / 0.0445
    high = flight(0.6, 53.0)
    assert high[0] <= 22.0 and high[1] <= 0.7, high
    slow = flight(0.6, on_slope)
    assert abs(slow[0]) <= 8.0 and slow[1] <= 0.5, slow
    nominal = flight(1.0, on_slope)                     # the slope's own sink: as before
    assert abs(nominal[0]) <= 8.0 and nominal[1] <= 0.5, nominal
    # the cap: the slope's sink on the slope, at most FLARE_CAP_MAX times it when high,
    # the mean below the slope (an early flare is not pushed down)
    def cap(sink_mean, to_go_m):
        land = landing(sink_mean)
        v = np.array([0.0, -gs, sink_mean])
        land.step(0, (0.0, -(1051.0 - to_go_m)), land.alt_b + 3.0, v, gs)
        land.step(20000, (0.0, -(1051.0 - to_go_m + 0.46)), land.alt_b + 3.0, v, gs)
        return land.flare_cap_mps, land.slope * gs
    c, s_gs = cap(0.6, on_slope)
    assert c == pytest.approx(s_gs, rel=0.1)
    c, s_gs = cap(0.6, 53.0)
    assert c == pytest.approx(FLARE_CAP_MAX * s_gs)
    assert cap(0.6, 150.0)[0] == pytest.approx(0.6)
