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
