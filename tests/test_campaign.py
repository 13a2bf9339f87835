"""sitl campaign: campaign files, trial resolution, a small campaign end to end on a
LocalCluster (resume, reproduce command)."""
from __future__ import annotations

import json
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from tools.campaign.criteria import flatten, parse_criterion
from tools.campaign.spec import CampaignError, parse_campaign_text
from tools.campaign.trials import resolve
from tools.summary import without_timing

REPO = Path(__file__).resolve().parent.parent

HEAD = """[campaign]
name = "t"
trials = 10
seed = 1
duration_s = 30
"""


def _error(text: str) -> CampaignError:
    with pytest.raises(CampaignError) as e:
        parse_campaign_text(text, "c.toml")
    return e.value


# --- bad files: every kind of mistake names its line ----------------------------------
@pytest.mark.parametrize("body, line, words", [
    # unknown keys: of [campaign], of [dispersion], a parameter, a table, an event key
    ('durations_s = 3\n', 6, "unknown key 'durations_s'"),
    ('[dispersion]\nwind_sped_mps = { uniform = [0.0, 5.0] }\n', 7, "unknown key 'wind_sped_mps'"),
    ('[dispersion]\n"param.NAVL1_PERIODX" = 3.0\n', 7, "unknown parameter 'NAVL1_PERIODX'"),
    ('[dispersal]\nx = 1\n', 6, "unknown top-level key 'dispersal'"),
    ('[[event]]\nat_s = 10.0\nunit = "gps"\ntype = "off"\nseverity = 2\n', 10, "unknown key 'severity'"),
    # bad distributions
    ('[dispersion]\nwind_speed_mps = { gauss = [1.0, 2.0] }\n', 7, "a distribution is one of"),
    ('[dispersion]\nwind_speed_mps = { uniform = [5.0, 1.0] }\n', 7, "reversed"),
    ('[dispersion]\nwind_speed_mps = { uniform = [1.0] }\n', 7, "two numbers"),
    ('[dispersion]\nwind_speed_mps = { normal = [5.0, 2.0] }\n', 7, "truncate it"),
    ('[dispersion]\nwind_speed_mps = { normal = [5.0, -2.0], min = 0.0 }\n', 7, "standard deviation"),
    ('[dispersion]\nwind_speed_mps = { uniform = [0.0, 80.0] }\n', 7, "outside [0, 60]"),
    ('[dispersion]\nwind_speed_mps = { loguniform = [0.0, 8.0] }\n', 7, "0 < low"),
    ('[dispersion]\nturbulence = { choice = ["none", "heavy"] }\n', 7, "'heavy' is not one of"),
    ('[dispersion]\nturbulence = { choice = [] }\n', 7, "choice of nothing"),
    ('[dispersion]\nturbulence = { choice = ["none", "light"], weights = [1.0] }\n', 7, "weights"),
    ('[dispersion]\n"param.NAVL1_PERIOD" = { uniform = [1.0, 500.0] }\n', 7, "parameter's range"),
    ('[[event]]\nat_s = { uniform = [10.0, 20.0] }\nunit = "servo"\ntype = "wrong"\ninstance = 1\n'
     'effectiveness = { uniform = [0.2, 1.5] }\n', 11, "effectiveness"),
    ('[[event]]\nat_s = { normal = [10.0, 5.0] }\nunit = "gps"\ntype = "off"\n', 7, "negative time"),
    # criteria that do not parse, or name no summary key
    ('[criteria]\nxtrack = "xtrack_max_m <="\n', 7, "does not parse"),
    ('[criteria]\nxtrack = "__import__(\'os\').system(\'true\')"\n', 7, "functions are"),
    ('[criteria]\nxtrack = "xtrak_max_m < 30"\n', 7, "did you mean xtrack_max_m"),
    ('[criteria]\nok = "1 < 2"\n', 7, "names no summary key"),
    ('[criteria]\nid = "faults[0].identified_10s.effectiveness < input.event.0.effectiveness"\n', 7,
     "'input.event.0.effectiveness', which is no input of this campaign"),
    ('[[event]]\nafter_s = 10.0\nunit = "gps"\ntype = "off"\n', 7, "no previous event"),
    ('[[event]]\nunit = "gps"\ntype = "off"\n', 6, "needs one of 'at_s'"),
])
def test_bad_campaign_file_names_the_line(body, line, words):
    e = _error(HEAD + body)
    assert str(e).startswith(f"c.toml:{line}: "), str(e)
    assert words in str(e)


def test_fault_only_and_nested_keys_are_known():
    # GIVEN criteria over keys a fault-free dry flight lacks (fault detection, mission
    # invariants): no false "unknown key"
    c = parse_campaign_text(HEAD + '[criteria]\n'
                            'detected = "faults[0].delay_s <= 2.0 and faults.0.isolated == \'gps_pos\'"\n'
                            'orbits = "invariants.orbits.passed"\n'
                            'mission = "xtrack_mission_max_m < 30"\n', "c.toml")
    assert c.criteria["detected"].keys == ("faults.0.delay_s", "faults.0.isolated")


def test_criterion_values_unknown_fails():
    c = parse_criterion("x", "xtrack_max_m <= 30 and not crashed", "c", 1)
    flat = flatten({"xtrack_max_m": 12.0, "crashed": False, "invariants": {"orbits": {"passed": True}}})
    assert c.holds(flat)
    assert not c.holds({**flat, "xtrack_max_m": 31.0})
    assert not c.holds({**flat, "xtrack_max_m": None})      # no figure: not passed
    assert not c.holds({"crashed": False})                  # no key: not passed
    assert flat["invariants.orbits.passed"] is True
    assert parse_criterion("o", "invariants.orbits.passed", "c", 1).holds(flat)
    assert parse_criterion("c", "1 < abs(xtrack_max_m - 20) < 9", "c", 1).holds(flat)


# --- trials are pure functions of (file, index) ---------------------------------------
DISPERSED = HEAD.replace("trials = 10", "trials = 300") + """
[dispersion]
wind_speed_mps = { uniform = [2.0, 8.0] }
wind_from_deg = { loguniform = [10.0, 350.0] }
turbulence = { choice = ["none", "light", "moderate"], weights = [1.0, 0.0, 1.0] }
"param.NAVL1_PERIOD" = { normal = [17.0, 4.0], min = 15.0, max = 19.0 }
home_heading_deg = { randint = [0, 3] }
home_lat_deg = -35.36
home_lon_deg = 149.16
home_alt_m = 584.0
mission = "random:plane:{seed}"

[[event]]
at_s = { uniform = [10.0, 20.0] }
unit = "gps"
type = { choice = ["off", "garbage"] }
"""


def test_trial_is_a_function_of_file_and_index():
    c = parse_campaign_text(DISPERSED, "c.toml", check_keys=False)
    trials = [resolve(c, i) for i in range(c.trials)]
    again = parse_campaign_text(DISPERSED, "c.toml", check_keys=False)
    assert [resolve(again, i).command() for i in (0, 17, 299)] == [trials[i].command() for i in (0, 17, 299)]
    assert len({t.seed for t in trials}) == c.trials
    for t in trials:
        x = t.inputs
        assert 2.0 <= x["wind_speed_mps"] <= 8.0 and 10.0 <= x["wind_from_deg"] <= 350.0
        assert x["turbulence"] in ("none", "moderate")                     # weight 0: never light
        assert 15.0 <= x["param.NAVL1_PERIOD"] <= 19.0
        assert x["home_heading_deg"] in (0, 1, 2, 3)
        assert f"--home=-35.36,149.16,584,{x['home_heading_deg']}" in t.command()
        assert x["mission"] == f"random:plane:{t.seed}"
        assert f"--mission random:plane:{t.seed}" in t.command()
        assert 10.0 <= x["event.0.at_s"] <= 20.0
    # the truncated normal is the normal's middle: roughly uniform-looking, mean 17
    periods = [t.inputs["param.NAVL1_PERIOD"] for t in trials]
    assert abs(sum(periods) / len(periods) - 17.0) < 0.25
    # a new dispersion leaves every other draw of every trial as it was
    more = parse_campaign_text(DISPERSED.replace("[dispersion]\n", "[dispersion]\nduration_s_x = 1\n")
                               .replace("duration_s_x = 1\n", 'gps = { choice = ["standard", "rtk"] }\n'),
                               "c.toml", check_keys=False)
    t5 = resolve(more, 5)
    assert {k: v for k, v in t5.inputs.items() if k != "gps"} == trials[5].inputs


@pytest.mark.parametrize("path", sorted((REPO / "missions" / "campaigns").glob("*.toml")), ids=lambda p: p.name)
def test_shipped_campaigns_load_and_resolve(path):
    from tools.campaign.spec import load_campaign
    c = load_campaign(path)
    assert c.criteria and c.trials >= 20
    for i in (0, c.trials - 1):
        t = resolve(c, i)
        assert t.error is None and t.command().startswith("sitl run --vehicle ")


def test_event_after_the_previous_one_and_criteria_over_inputs():
    c = parse_campaign_text(HEAD + """
[[event]]
at_s = { uniform = [100.0, 200.0] }
unit = "servo"
type = "wrong"
instance = 1
effectiveness = { uniform = [0.3, 0.7] }

[[event]]
after_s = { uniform = [20.0, 90.0] }
unit = "servo"
type = "ok"
instance = 1

[criteria]
identified = "abs(faults[0].identified_10s.effectiveness - input.event.0.effectiveness) <= 0.2 * input.event.0.effectiveness"
""", "c.toml")
    for i in range(c.trials):
        t = resolve(c, i)
        x = t.inputs
        assert x["event.1.at_s"] == x["event.0.at_s"] + x["event.1.after_s"]
        assert 120.0 <= x["event.1.at_s"] <= 290.0
        from sim_bridge.scenario import parse_scenario_text
        sc = parse_scenario_text(t.scenario_text)
        assert [(e.at_s, e.type) for e in sc.events] == [(x["event.0.at_s"], "wrong"), (x["event.1.at_s"], "ok")]
        assert sc.events[0].magnitudes == {"effectiveness": x["event.0.effectiveness"]}
    crit = c.criteria["identified"]
    flat = {"faults.0.identified_10s.effectiveness": 0.55, "input.event.0.effectiveness": 0.5}
    assert crit.holds(flat) and not crit.holds({**flat, "faults.0.identified_10s.effectiveness": 0.61})


# --- a small campaign end to end ------------------------------------------------------
SMALL = """[campaign]
name = "small"
trials = 4
seed = 3
duration_s = 20
keep_worst = 1
figures = ["nav_pos_h_err_max_m"]

[dispersion]
wind_speed_mps = { uniform = [0.0, 8.0] }
wind_from_deg = { uniform = [0.0, 360.0] }
turbulence = { choice = ["none", "light"] }
"param.NAVL1_PERIOD" = { normal = [17.0, 2.0], min = 12.0, max = 25.0 }

[[event]]
at_s = { uniform = [8.0, 15.0] }
unit = "gps"
type = "off"

[criteria]
flying = "not crashed"
tight = "nav_pos_h_err_max_m < 1.5"
"""


def stored_rows(folder: Path) -> list[dict]:
    from tools.campaign.store import Store
    s = Store(folder, read_only=True)
    try:
        return s.rows()
    finally:
        s.close()


@pytest.fixture(scope="module")
def client():
    """Two single-threaded worker processes, as ``sitl campaign run --workers 2``."""
    import logging
    from distributed import Client, LocalCluster
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                      silence_logs=logging.ERROR) as cluster, Client(cluster) as c:
        yield c


@pytest.fixture(scope="module")
def small_campaign(tmp_path_factory, client):
    """The SMALL campaign run twice: its first 2 trials (--trials 2), then the rest."""
    from tools.campaign.execute import run_campaign
    from tools.campaign.spec import load_campaign
    d = tmp_path_factory.mktemp("camp")
    path = d / "small.toml"
    path.write_text(SMALL)
    c = load_campaign(path)
    first = run_campaign(c, d / "out", trials=2, progress=False, client=client)
    second = run_campaign(c, d / "out", progress=False, client=client)
    return path, d / "out", first, second


def test_small_campaign_stores_each_trial_once_and_resumes(small_campaign):
    path, out, first, second = small_campaign
    assert (first["ran"], second["ran"]) == (2, 2)
    rows = stored_rows(out)
    assert [r["trial"] for r in rows] == [0, 1, 2, 3]
    c = parse_campaign_text(SMALL, str(path))
    for r in rows:
        t = resolve(c, r["trial"])
        assert r["error"] == "", r["error"]
        assert r["seed"] == t.seed and json.loads(r["inputs_json"]) == t.inputs
        assert r["input.wind_speed_mps"] == t.inputs["wind_speed_mps"]
        summ = json.loads(r["summary_json"])
        assert r["criterion.tight"] == (summ["nav_pos_h_err_max_m"] < 1.5)
        assert r["passed"] == (r["criterion.flying"] and r["criterion.tight"])
        assert r["faults.0.unit"] == "gps" and abs(r["faults.0.at_s"] - t.inputs["event.0.at_s"]) < 0.01
        assert r["sim_s"] == pytest.approx(20.0, abs=0.02)
    # run folders: the failed trials and the worst navigation error one, nothing else
    worst = max(rows, key=lambda r: r["nav_pos_h_err_max_m"])["trial"]
    keep = {r["trial"] for r in rows if not r["passed"]} | {worst}
    kept = {int(p.name[6:]) for p in (out / "runs").iterdir()}
    assert kept == keep
    for t in kept:
        assert (out / "runs" / f"trial_{t:05d}" / "flight.npz").exists()
    # the same command once more: nothing to run, nothing stored twice
    from tools.campaign.execute import run_campaign
    from tools.campaign.spec import load_campaign
    assert run_campaign(load_campaign(path), out, progress=False)["ran"] == 0
    assert len(stored_rows(out)) == 4


def test_reproduce_command_gives_the_stored_summary(small_campaign, tmp_path):
    _path, out, _f, _s = small_campaign
    row = stored_rows(out)[3]
    argv = shlex.split(row["command"])
    assert argv[:2] == ["sitl", "run"] and "--scenario" in argv
    r = subprocess.run([sys.executable, "-m", "tools.sitl", "run", *argv[2:], "--json",
                        "--log-dir", str(tmp_path / "rerun")], capture_output=True, text=True, cwd=REPO,
                       timeout=120)
    assert r.returncode == 0, r.stderr
    assert without_timing(json.loads(r.stdout)) == without_timing(json.loads(row["summary_json"]))


def test_show_prints_the_command_the_campaign_stored(small_campaign):
    path, out, _f, _s = small_campaign
    r = subprocess.run([sys.executable, "-m", "tools.sitl", "campaign", "show", str(path), "--trial", "2",
                        "--out", str(out), "--json"], capture_output=True, text=True, cwd=REPO, timeout=60)
    assert r.returncode == 0, r.stderr
    shown = json.loads(r.stdout)
    assert shown["command"] == stored_rows(out)[2]["command"]


def test_bad_file_on_the_command_line(tmp_path):
    p = tmp_path / "bad.toml"
    p.write_text(HEAD + '[dispersion]\nwind_speed_mps = { uniform = [5.0, 1.0] }\n')
    r = subprocess.run([sys.executable, "-m", "tools.sitl", "campaign", "run", str(p), "--out",
                        str(tmp_path / "o")], capture_output=True, text=True, cwd=REPO, timeout=60)
    assert r.returncode == 2
    assert f"{p}:7: wind_speed_mps: uniform range [5.0, 1.0] is reversed" in r.stderr
    assert not (tmp_path / "o").exists()       # nothing ran, nothing stored


def test_export_parquet_and_csv_one_row_per_trial(small_campaign, tmp_path):
    import duckdb
    from tools.campaign.export import export
    _path, out, _f, _s = small_campaign
    rows = stored_rows(out)
    for fmt in ("parquet", "csv"):
        f = export(out, fmt, tmp_path / f"t.{fmt}")
        rel = duckdb.sql(f"SELECT * FROM '{f}' ORDER BY trial")
        cols = rel.columns
        got = rel.fetchall()
        assert cols[:4] == ["trial", "seed", "passed", "error"]
        assert {"criterion.flying", "criterion.tight", "nav_pos_h_err_max_m", "input.wind_speed_mps"} <= set(cols)
        assert [g[0] for g in got] == [r["trial"] for r in rows]
        assert [g[2] for g in got] == [r["passed"] for r in rows]
        assert [g[3] or "" for g in got] == ["" for _ in rows]
        i = cols.index("nav_pos_h_err_max_m")
        assert [g[i] for g in got] == pytest.approx([r["nav_pos_h_err_max_m"] for r in rows], rel=1e-12)


def _chromium() -> str | None:
    import shutil
    return shutil.which("chromium") or shutil.which("chromium-browser")


def test_report_page_renders_in_headless_chromium(small_campaign, tmp_path):
    # GIVEN the report of the small campaign
    from tools.campaign.report import make_report, wilson
    _path, out, _f, _s = small_campaign
    page = make_report(out)
    html = page.read_text()
    rows = stored_rows(out)
    k = sum(1 for r in rows if r["passed"])
    lo, hi = wilson(k, len(rows))
    assert f"<td>{k}</td><td>{len(rows)}</td><td>{100 * k / len(rows):.1f} %</td>" \
           f"<td>{100 * lo:.1f} - {100 * hi:.1f} %</td>" in html
    for r in rows:                                  # every trial's command is on the page
        assert r["command"].split(" --scenario")[0] in html
    chromium = _chromium()
    if chromium is None:
        pytest.skip("Debian's chromium is not installed (.ci/run installs it)")
    # WHEN Debian's Chromium loads it headless
    flags = [chromium, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
             "--disable-background-networking", "--disable-component-update", "--disable-sync",
             f"--user-data-dir={tmp_path / 'profile'}"]
    dom = subprocess.run(flags + ["--dump-dom", page.as_uri()], capture_output=True, text=True, timeout=60)
    shot = tmp_path / "report.png"
    subprocess.run(flags + [f"--screenshot={shot}", "--window-size=1200,2000", page.as_uri()],
                   capture_output=True, timeout=60)
    # THEN the page rendered, every picture loaded (the page's own onload check), and
    # the screenshot is a picture of it
    n_img = html.count("<img ")
    assert n_img >= 2
    assert f'data-images-loaded="{n_img}/{n_img}"' in dom.stdout, dom.stdout[-500:]
    assert shot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and shot.stat().st_size > 20000


def test_a_trial_that_raises_or_runs_too_long_is_an_error_row(client, tmp_path):
    from tools.campaign.execute import run_campaign
    from tools.campaign.spec import load_campaign
    # GIVEN a campaign whose first trial's mission file does not exist and whose others
    # run past a wall-time limit of 0.3 s
    p = tmp_path / "e.toml"
    p.write_text(HEAD.replace("trials = 10", "trials = 3").replace("seed = 1", "seed = 3") + 'trial_timeout_s = 0.3\n'
                 '[dispersion]\nmission = { choice = ["missions/default.waypoints", "missions/nope.waypoints"], '
                 'weights = [1.0, 1.0] }\n')
    c = load_campaign(p)
    missions = [resolve(c, i).inputs["mission"] for i in range(3)]
    assert set(missions) == {"missions/default.waypoints", "missions/nope.waypoints"}
    # WHEN it runs
    res = run_campaign(c, tmp_path / "out", progress=False, client=client)
    # THEN every trial is stored, as an error with its traceback, and the campaign went on
    rows = stored_rows(tmp_path / "out")
    assert res["ran"] == 3 and [r["trial"] for r in rows] == [0, 1, 2]
    for r, m in zip(rows, missions):
        assert r["passed"] is None and r["summary_json"] is None
        if m.endswith("nope.waypoints"):
            assert r["error"].startswith("Traceback") and "nope.waypoints" in r["error"]
        else:
            assert r["error"].startswith("TrialTimeout: the trial ran past its wall-time limit of 0.3 s")
    from tools.campaign.report import pass_rates
    from tools.campaign.store import Store
    s = Store(tmp_path / "out", read_only=True)
    try:
        assert pass_rates(s)[0][:3] == ("all", 0, 3)
    finally:
        s.close()
