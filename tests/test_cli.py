"""The ``sitl`` command line: what a user types is what runs."""
import pytest

from tools.sitl import _config, _join_signed_values, build_parser


def _args(*argv):
    return build_parser().parse_args(_join_signed_values(list(argv)))


def test_southern_home_with_a_leading_minus_parses_as_the_value_of_home():
    # GIVEN the README's example, a southern latitude right after --home
    cfg = _config(_args("run", "--home", "-41.0,179.95,10,90", "--wind", "8,200"))
    # THEN it is the home, not an unknown option
    assert cfg.home == pytest.approx((-41.0, 179.95, 10.0, 90.0))
    assert cfg.wind == pytest.approx((8.0, 200.0))
    # AND the = form still works
    assert _config(_args("run", "--home=-33.5,-70.6,500,0")).home == pytest.approx((-33.5, -70.6, 500.0, 0.0))


def test_a_real_option_after_home_is_not_swallowed():
    with pytest.raises(SystemExit):
        _args("run", "--home", "--json")


def test_run_with_a_gps_fault_replays_the_seed_on_the_plain_filter(tmp_path, capsys):
    import json

    from tools.sitl import main
    # GIVEN a scenario with 10 s of GPS noise x7
    sc = tmp_path / "noise.toml"
    sc.write_text('[[event]]\nat_s = 15.0\nunit = "gps"\ntype = "garbage"\ninstance = 0\n'
                  'noise_scale = 7.0\nvel_noise_scale = 1.0\n\n'
                  '[[event]]\nat_s = 25.0\nunit = "gps"\ntype = "ok"\ninstance = 0\n')
    # WHEN `sitl run` flies it
    argv = ["run", "--scenario", str(sc), "--duration", "30", "--json"]
    assert main(argv + ["--log-dir", str(tmp_path / "a")]) == 0
    out = capsys.readouterr()
    s = json.loads(out.out)
    # THEN the summary carries the fault-time error of the robust filter and of the same
    #      seed replayed with R adaptation off, and says so on stderr
    assert s["nav_pos_h_rms_during_fault_m"] > 0.0
    assert s["nav_pos_h_rms_during_fault_okf_m"] > 0.0
    assert s["nav_pos_h_rms_during_fault_okf_m"] != s["nav_pos_h_rms_during_fault_m"]
    assert "FDI_RADAPT=0" in out.err
    saved = json.loads((tmp_path / "a" / "summary.json").read_text())
    assert saved["nav_pos_h_rms_during_fault_okf_m"] == s["nav_pos_h_rms_during_fault_okf_m"]
    # AND --no-okf-replay leaves it out
    assert main(argv + ["--no-okf-replay", "--log-dir", str(tmp_path / "b")]) == 0
    assert "nav_pos_h_rms_during_fault_okf_m" not in json.loads(capsys.readouterr().out)


def test_gps_receiver_model_option():
    assert _config(_args("run")).gps == "standard"
    assert _config(_args("run", "--gps", "rtk")).gps == "rtk"
    with pytest.raises(SystemExit):
        _args("run", "--gps", "perfect")
