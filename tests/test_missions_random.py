"""Random missions (tools/missions_random.py): valid, deterministic, and as broad as
the distribution promises; the CLI and the random:VEHICLE:SEED source of sitl run."""
from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from autopilot.geo import LocalFrame
from autopilot.mission.files import dumps_waypoints, load_mission, loads_waypoints
from autopilot.mission.items import (DO_CHANGE_SPEED, DO_JUMP, DO_LAND_START, NAV_LAND, NAV_LOITER_TIME,
                                     NAV_LOITER_TURNS, NAV_RETURN_TO_LAUNCH, NAV_TAKEOFF,
                                     NAV_WAYPOINT)
from tools.missions_random import (LAND_APPROACH_M, LAND_NEAR_HOME_M, LAND_POINT_H_M, LAND_SLOPE,
                                   LEG_MAX_M, PLANE_R_MIN_M, TIME_BUDGET_S, estimate_time_s,
                                   mission_for_seed, random_mission, resolve_order)

REPO = Path(__file__).resolve().parent.parent
SEEDS = range(150)


def _sample(vehicle):
    return [mission_for_seed(vehicle, s)[0] for s in SEEDS]


@pytest.fixture(scope="module")
def planes():
    return _sample("plane")


@pytest.fixture(scope="module")
def quads():
    return _sample("quad")


def _positions(m):
    """(seq, north, east) of the items with a position, in home's NED frame."""
    h = m.home
    f = LocalFrame.from_degrees(h.x_lat_deg, h.y_lon_deg, h.z_alt_m)
    out = []
    for it in m.items[1:]:
        if it.command in (NAV_WAYPOINT, NAV_LOITER_TURNS, NAV_LOITER_TIME, NAV_LAND, NAV_TAKEOFF) \
                and (it.x_lat_deg, it.y_lon_deg) != (0.0, 0.0):
            p = f.to_ned_fast(math.radians(it.x_lat_deg), math.radians(it.y_lon_deg), f.alt0_m)
            out.append((it.seq, float(p[0]), float(p[1])))
    return out


@pytest.mark.parametrize("vehicle", ["plane", "quad"])
def test_valid_bounded_and_deterministic(vehicle, planes, quads):
    sample = planes if vehicle == "plane" else quads
    for seed, m in zip(SEEDS, sample):
        text = dumps_waypoints(m)
        assert loads_waypoints(text, vehicle=vehicle) == m    # the loader accepts it for the vehicle
        assert 2 <= len(m) - 1 <= 20
        ground = m[1].command == NAV_WAYPOINT and m[1].z_alt_m == m.home.z_alt_m
        assert m[2 if ground else 1].command == NAV_TAKEOFF
        assert estimate_time_s(m, vehicle) <= TIME_BUDGET_S[vehicle] + 1e-6
        order = resolve_order(m)
        assert order[0] == 1 and len(order) < 2000             # the jumps end
        pos = _positions(m)
        for (_, n0, e0), (s1, n1, e1) in zip(pos, pos[1:]):
            if any(m[k].command == DO_LAND_START for k in range(1, s1)):
                continue     # the way back to the landing is a return home's, any length
            assert math.hypot(n1 - n0, e1 - e0) <= LEG_MAX_M + 1.0
        if vehicle == "plane" and any(it.command == NAV_LAND for it in m):
            # the plane's landing: DO_LAND_START, a line-up, the approach's first point, NAV_LAND
            # on home's ground near home, last, on a glide slope it can fly
            assert [it.command for it in m.items[-4:]] == [DO_LAND_START, NAV_WAYPOINT, NAV_WAYPOINT, NAV_LAND]
            d, a, b = _positions(m)[-3:]
            # joined from the mission's last height by a base leg square to the final, at
            # most a 6 % slope to the approach's first point
            u = ((b[1] - a[1]), (b[2] - a[2]))
            dist_da = math.hypot(a[1] - d[1], a[2] - d[2])
            assert abs((a[1] - d[1]) * u[0] + (a[2] - d[2]) * u[1]) < 1e-3 * dist_da * math.hypot(*u) + 1.0
            assert abs(_h(m, a[0]) - _h(m, d[0])) <= 0.06 * dist_da + 0.2
            length = math.hypot(b[1] - a[1], b[2] - a[2])
            assert LAND_APPROACH_M[0] - 1.0 <= length <= LAND_APPROACH_M[1] + 1.0
            assert m[-1].z_alt_m == LAND_POINT_H_M and math.hypot(b[1], b[2]) <= LAND_NEAR_HOME_M + 1.0
            slope = (_h(m, a[0]) - m[-1].z_alt_m) / length
            assert LAND_SLOPE[0] - 1e-3 <= slope <= LAND_SLOPE[1] + 1e-3
            assert sum(it.command == NAV_LAND for it in m) == 1
    # a pure function of (vehicle, seed)
    assert dumps_waypoints(mission_for_seed(vehicle, 17)[0]) == dumps_waypoints(sample[17])
    texts = {dumps_waypoints(m) for m in sample}
    assert len(texts) == len(sample)
    rng_a, rng_b = np.random.default_rng(5), np.random.default_rng(5)
    assert random_mission(vehicle, rng_a)[0] == random_mission(vehicle, rng_b)[0]


def test_the_distribution_is_broad(planes, quads):
    """Every class the issue names occurs in 150 seeds of each vehicle."""
    seen = set()
    for vehicle, sample in (("plane", planes), ("quad", quads)):
        for m in sample:
            home = m.home
            if abs(home.x_lat_deg) > 70:
                seen.add("high latitude")
            pos = _positions(m)
            lats = [m[s].x_lat_deg for s, _, _ in pos] + [home.x_lat_deg]
            lons = [m[s].y_lon_deg for s, _, _ in pos] + [home.y_lon_deg]
            if min(lats) < 0 < max(lats):
                seen.add("across the equator")
            if min(lons) < -179 and max(lons) > 179:
                seen.add("across the 180 meridian")
            track = [(0.0, 0.0)] + [(n, e) for s, n, e in pos if m[s].command != NAV_TAKEOFF]
            lengths = [math.hypot(b[0] - a[0], b[1] - a[1]) for a, b in zip(track, track[1:])]
            if any(L > 2000 for L in lengths):
                seen.add("long leg")
            if any(L < 40 for L in lengths[1:] if L > 0.5):
                seen.add("short leg")
            if any(L < 0.5 for L in lengths[1:]):
                seen.add("duplicate")
            if lengths and lengths[0] < 0.5:
                seen.add("first waypoint at home")
            for a, b, c in zip(track, track[1:], track[2:]):
                u = (b[0] - a[0], b[1] - a[1])
                w = (c[0] - b[0], c[1] - b[1])
                if math.hypot(*u) > 1 and math.hypot(*w) > 1:
                    cos = (u[0] * w[0] + u[1] * w[1]) / (math.hypot(*u) * math.hypot(*w))
                    if cos < -0.999:
                        seen.add("reversal")
            if m[1].command == NAV_WAYPOINT and m[1].frame == 0 and m[1].z_alt_m == home.z_alt_m:
                seen.add("ground waypoint before the takeoff")
            takeoff = [it for it in m if it.command == NAV_TAKEOFF][0]
            if (takeoff.x_lat_deg, takeoff.y_lon_deg) != (0.0, 0.0) and len(pos) > 1:
                t = [p for p in pos if p[0] == takeoff.seq][0]
                first = [p for p in pos if p[0] > takeoff.seq][0]
                if t[1] * first[1] + t[2] * first[2] < 0:
                    seen.add("first waypoint behind the launch")
            for it in m.items[1:]:
                if it.command in (NAV_LOITER_TURNS, NAV_LOITER_TIME) and vehicle == "plane":
                    r = it.param3
                    seen.add("loiter cw" if r > 0 else "loiter ccw")
                    if abs(r) < PLANE_R_MIN_M:
                        seen.add("loiter radius below the minimum turn radius")
                    if abs(r) > 500:
                        seen.add("loiter radius over 500 m")
                    if it.command == NAV_LOITER_TURNS:
                        seen.add("loiter turns")
                    else:
                        seen.add("loiter time")
                if it.command == DO_JUMP:
                    seen.add(f"jump repeat {int(it.param2)}")
                    if any(j.command == DO_JUMP for j in m.items[int(it.param1):it.seq]):
                        seen.add("jump over a jump")
                if it.command == DO_CHANGE_SPEED and vehicle == "plane" and it.param2 > 0:
                    seen.add("speed within limits" if 20 <= it.param2 <= 30 else "speed outside limits")
            for it in m.items[1:]:
                if vehicle == "quad" and it.command in (112, 114, 115, 93, 31):
                    seen.add(it.command_name)
                if vehicle == "quad" and it.command == NAV_WAYPOINT and it.x_lat_deg == 0.0:
                    seen.add("quad waypoint 'here'")
                if vehicle == "quad" and it.command == DO_CHANGE_SPEED and it.param1 in (2.0, 3.0):
                    seen.add("quad climb or descent speed")
            last = m.items[-1].command
            end = {NAV_RETURN_TO_LAUNCH: "rtl", NAV_LAND: "land"}.get(last, "none")
            if vehicle == "plane" and end == "land":
                end = "landing"   # a landing sequence (DO_LAND_START, approach, NAV_LAND)
            seen.add(f"{vehicle} ends {end}")
            h_rel = [it.z_alt_m - (0 if it.frame in (3, 6) else home.z_alt_m)
                     for it in m.items[1:] if it.command in (NAV_WAYPOINT,)]
            for (s0, n0, e0), (s1, n1, e1) in zip(pos, pos[1:]):
                if m[s0].command == NAV_WAYPOINT and m[s1].command == NAV_WAYPOINT:
                    dh = abs(_h(m, s1) - _h(m, s0))
                    if vehicle == "plane" and dh > 0.1 * max(math.hypot(n1 - n0, e1 - e0), 1.0) + 1:
                        seen.add("height step steeper than the plane climbs")
            del h_rel
    expected = {"high latitude", "across the equator", "across the 180 meridian", "long leg",
                "short leg", "duplicate", "first waypoint at home", "reversal",
                "first waypoint behind the launch", "loiter cw", "loiter ccw",
                "loiter radius below the minimum turn radius", "loiter radius over 500 m",
                "loiter turns", "loiter time", "jump repeat 0", "jump repeat 3",
                "jump over a jump", "speed within limits", "speed outside limits",
                "plane ends rtl", "plane ends none", "plane ends landing", "quad ends rtl", "quad ends land",
                "quad ends none", "height step steeper than the plane climbs",
                "CONDITION_DELAY", "CONDITION_DISTANCE", "CONDITION_YAW", "NAV_DELAY",
                "NAV_LOITER_TO_ALT", "quad waypoint 'here'", "quad climb or descent speed",
                "ground waypoint before the takeoff"}
    assert expected - seen == set()


def _h(m, seq):
    it = m[seq]
    return it.z_alt_m if it.frame in (3, 6) else it.z_alt_m - m.home.z_alt_m


def test_resolve_order_follows_jumps():
    from autopilot.mission.files import loads_waypoints as lw
    text = ("QGC WPL 110\n"
            "0\t1\t0\t16\t0\t0\t0\t0\t-35.0\t149.0\t500\t1\n"
            "1\t0\t3\t22\t0\t0\t0\t0\t0\t0\t50\t1\n"
            "2\t0\t3\t16\t0\t0\t0\t0\t-35.001\t149.0\t50\t1\n"
            "3\t0\t3\t16\t0\t0\t0\t0\t-35.002\t149.0\t50\t1\n"
            "4\t0\t2\t177\t3\t1\t0\t0\t0\t0\t0\t1\n"       # 3 once more
            "5\t0\t3\t16\t0\t0\t0\t0\t-35.003\t149.0\t50\t1\n"
            "6\t0\t2\t177\t2\t2\t0\t0\t0\t0\t0\t1\n"       # over the first jump, twice
            "7\t0\t2\t20\t0\t0\t0\t0\t0\t0\t0\t1\n")
    # counts are never reset: the inner jump is spent on the first pass
    assert resolve_order(lw(text)) == [1, 2, 3, 3, 5, 2, 3, 5, 2, 3, 5, 7]


def _sitl(*args, cwd):
    return subprocess.run([sys.executable, "-m", "tools.sitl", *args], cwd=cwd, capture_output=True,
                          text=True, timeout=300)


def test_cli_writes_the_mission_and_sitl_run_flies_the_same(tmp_path):
    out = tmp_path / "q.waypoints"
    r = _sitl("missions", "random", "--vehicle", "quad", "--seed", "11", "-o", str(out), cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert r.stdout.startswith("# random quad mission, seed 11")
    assert load_mission(out) == mission_for_seed("quad", 11)[0]
    run = tmp_path / "run"
    r = _sitl("run", "--vehicle", "quad", "--mission", "random:quad:11", "--duration", "15",
              "--json", "--log-dir", str(run), cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert (run / "mission.waypoints").read_text() == out.read_text()
    s = json.loads(r.stdout)
    assert s["mission_items_total"] == len(load_mission(out)) - 1
    # malformed sources and a source for the other vehicle: clear errors
    # a budget shortens the mission: the same draw as mission_for_seed(..., budget)
    short = tmp_path / "short.waypoints"
    r = _sitl("missions", "random", "--vehicle", "quad", "--seed", "11", "--max-time", "90",
              "-o", str(short), cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert load_mission(short) == mission_for_seed("quad", 11, 90.0)[0]
    assert estimate_time_s(load_mission(short), "quad") <= 90.0 or len(load_mission(short)) <= 4
    for spec, vehicle in (("random:plane", "plane"), ("random:boat:3", "plane"),
                          ("random:plane:x", "plane"), ("random:plane:3", "quad"),
                          ("random:plane:3:0", "plane"), ("random:plane:3:x", "plane"),
                          ("random:plane:3:1:2", "plane")):
        r = _sitl("run", "--vehicle", vehicle, "--mission", spec, "--duration", "1", cwd=tmp_path)
        assert r.returncode == 2 and "random" in r.stderr, (spec, r.stderr)


@pytest.mark.parametrize("vehicle", ["plane", "quad"])
def test_campaign_files_draw_a_new_valid_mission_per_trial(vehicle):
    """missions/campaigns/random_VEHICLE.toml: a valid campaign whose trials fly the
    random mission of their own seed, in the issue's wind, judged by the invariants."""
    from tools.campaign.spec import load_campaign
    from tools.campaign.trials import resolve
    from tools.missions_random import load_source
    c = load_campaign(REPO / "missions" / "campaigns" / f"random_{vehicle}.toml")
    assert c.trials >= 500
    missions = set()
    for i in range(5):
        t = resolve(c, i)
        assert t.inputs["mission"] == f"random:{vehicle}:{t.seed}"
        assert 0.0 <= t.inputs["wind_speed_mps"] <= (12.0 if vehicle == "plane" else 8.0)
        m, _ = load_source(t.inputs["mission"])
        assert loads_waypoints(dumps_waypoints(m), vehicle=vehicle) == m
        missions.add(dumps_waypoints(m))
    assert len(missions) == 5
    assert any("invariants_passed" in cr.keys for cr in c.criteria.values())


def test_sitl_missions_sample_flies_and_counts(tmp_path):
    """sitl missions sample: one JSON line per flight (figures, each invariant, the command
    that flies it again), counts and percentiles on stderr, exit 0 when all held."""
    out = tmp_path / "s.jsonl"
    r = _sitl("missions", "sample", "--vehicle", "quad", "--seeds", "1-1", "--max-time", "90",
              "--jsonl", str(out), cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    rec = json.loads(r.stdout.splitlines()[0])
    assert json.loads(out.read_text()) == rec
    assert rec["seed"] == 1 and rec["invariants_passed"] is True
    assert set(rec["invariants"]) >= {"mission_order", "no_orbit", "time_bound", "finite_log"}
    assert rec["command"].startswith("sitl run --vehicle quad --mission random:quad:1:90 ")
    assert "quad: 1 flights, every invariant held on 1" in r.stderr
    assert "xtrack_mission_rms_m" in r.stderr and "p95" in r.stderr
    bad = _sitl("missions", "sample", "--seeds", "5-2", cwd=tmp_path)
    assert bad.returncode == 2 and "--seeds" in bad.stderr


def test_the_planes_landing_ending_has_its_own_stream():
    # a plane seed that does not draw a landing is the mission it was before landings
    # existed: the generator without the landing stream draws the same mission
    import numpy as np
    from tools.missions_random import VEHICLES
    landing = no_landing = 0
    for seed in range(40):
        m, notes = mission_for_seed("plane", seed)
        rng = np.random.default_rng([seed, VEHICLES.index("plane")])
        ground = np.random.default_rng([seed, VEHICLES.index("plane"), 2])
        without = random_mission("plane", rng, None, ground, None)[0]
        if any(it.command == NAV_LAND for it in m):
            landing += 1
            assert m[1] == without[1]                 # the same take-off, home and start
        else:
            no_landing += 1
            assert m == without
    assert landing >= 8 and no_landing >= 20
