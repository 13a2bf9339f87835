"""JSBSim fixed-wing plant: start at rest, trim, control signs, launch, crash, geography,
determinism, units and cost. Every test asserts numbers."""
from __future__ import annotations

import math
import warnings
from dataclasses import replace

import numpy as np
import pytest

from sim_bridge.plants.base import PlaneControls, PlantState
from sim_bridge.plants.jsbsim_plane import (
    LAUNCHER_HEIGHT_M,
    SPIN_UP_S,
    JSBSimPlane,
)

HOME = (47.0, 8.0, 400.0, 90.0)   # lat, lon [deg], ground altitude [m], heading [deg]
EARTH_RATE = 7.292115e-5           # [rad/s]
G = 9.806                          # [m/s^2], about 47 deg latitude
V_MIN_LEVEL = 15.3                 # Aerosonde minimum level-flight speed [m/s]


def rot_nb(q: np.ndarray) -> np.ndarray:
    """Rotation matrix of a scalar-first Hamilton quaternion (body -> NED)."""
    w, x, y, z = q
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])


def euler(q: np.ndarray) -> tuple[float, float, float]:
    """Roll, pitch, yaw [rad] (3-2-1) of a body->NED quaternion."""
    w, x, y, z = q
    phi = math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    theta = math.asin(max(-1.0, min(1.0, 2 * (w * y - z * x))))
    psi = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return phi, theta, psi


def fly(plant: JSBSimPlane, controls: PlaneControls, seconds: float) -> PlantState:
    return plant.step(controls, int(round(seconds / plant.dt_s)))


@pytest.fixture(scope="module")
def trimmed_22():
    """An Aerosonde trimmed at 22 m/s, 100 m above home, and its trim controls."""
    plant = JSBSimPlane(home=HOME)
    controls = plant.trim(airspeed_mps=22.0, height_m=100.0)
    return plant, controls


# ---------------------------------------------------------------- the airframe file

def test_aerosonde_mass_properties_are_the_books():
    plant = JSBSimPlane(home=HOME)
    fdm = plant._fdm
    slugft2_kgm2 = 1.35581795
    with warnings.catch_warnings():                 # the binding returns numpy.matrix
        warnings.simplefilter("ignore", PendingDeprecationWarning)
        inertia = np.asarray(fdm.get_mass_balance().get_J()) * slugft2_kgm2
    # Beard & McLain's inertia matrix: [[Jx, 0, -Jxz], [0, Jy, 0], [-Jxz, 0, Jz]]
    np.testing.assert_allclose(inertia, [[0.8244, 0.0, -0.1204],
                                         [0.0, 1.135, 0.0],
                                         [-0.1204, 0.0, 1.759]], atol=2e-4)
    assert fdm["inertia/mass-slugs"] * 14.5939029 == pytest.approx(13.5, abs=1e-3)
    assert fdm["metrics/Sw-sqft"] * 0.3048**2 == pytest.approx(0.55, abs=1e-4)
    assert fdm["metrics/bw-ft"] * 0.3048 == pytest.approx(2.8956, abs=1e-4)
    assert fdm["metrics/cbarw-ft"] * 0.3048 == pytest.approx(0.18994, abs=1e-5)


def test_surface_deflections_are_limited_to_0_35_rad():
    plant = JSBSimPlane(home=HOME)
    fly(plant, PlaneControls(aileron=3.0, elevator=-3.0, rudder=3.0), 0.01)
    fdm = plant._fdm
    assert fdm["fcs/aileron-pos-rad"] == pytest.approx(0.35)
    assert fdm["fcs/elevator-pos-rad"] == pytest.approx(0.35)     # nose down
    assert fdm["fcs/rudder-pos-rad"] == pytest.approx(-0.35)      # nose right


# ---------------------------------------------------------------- at rest on the launcher

def test_rests_on_the_launcher_with_specific_force_minus_g():
    plant = JSBSimPlane(home=HOME)
    s0 = plant.state()
    assert s0.t_us == 0
    assert s0.on_ground
    assert plant.on_launcher
    # resting on the deck 1.5 m up, CG about 0.17 m above the shoes
    assert s0.alt_m - HOME[2] == pytest.approx(LAUNCHER_HEIGHT_M + 0.17, abs=0.03)
    assert np.linalg.norm(s0.v_ned) < 1e-3
    assert np.max(np.abs(s0.omega_b)) < 1.5 * EARTH_RATE          # gyro sees Earth only
    assert s0.f_b[2] < -9.7
    assert np.linalg.norm(s0.f_b) == pytest.approx(G, abs=0.01)
    # the specific force rotated into NED is straight up: (0, 0, -g)
    np.testing.assert_allclose(rot_nb(s0.q_nb) @ s0.f_b, [0.0, 0.0, -G], atol=0.01)
    phi, theta, psi = euler(s0.q_nb)
    assert abs(phi) < 0.01
    assert math.degrees(theta) == pytest.approx(4.2, abs=1.0)      # cradle is nose-up
    assert math.degrees(psi) == pytest.approx(HOME[3], abs=0.1)
    assert s0.airspeed_mps < 0.01

    # part throttle does not release it: it stays put with the propeller running
    s = fly(plant, PlaneControls(throttle=0.4), 3.0)
    assert s.on_ground and plant.on_launcher
    assert np.linalg.norm(s.v_ned) < 0.01
    assert s.alt_m == pytest.approx(s0.alt_m, abs=0.01)


def test_clock_counts_exact_integer_microseconds():
    plant = JSBSimPlane(home=HOME)
    for n in (1, 2, 7):
        t0 = plant.t_us
        s = plant.step(PlaneControls(), n)
        assert s.t_us - t0 == 5000 * n
    assert isinstance(plant.t_us, int)
    odd = JSBSimPlane(home=HOME, dt_s=1.0 / 300.0)
    odd.step(PlaneControls(), 300)
    assert odd.t_us == 300 * 3333
    assert odd.dt_s == pytest.approx(3333e-6)


def test_no_files_are_written_to_the_working_directory(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    for airframe in ("aerosonde", "c172p"):
        plant = JSBSimPlane(airframe, home=HOME)
        plant.step(PlaneControls(throttle=0.2), 20)
    assert list(tmp_path.iterdir()) == []


# ---------------------------------------------------------------- trim and signs

def test_trim_at_22_mps_holds_altitude_and_airspeed_for_20_s(trimmed_22):
    plant, controls = trimmed_22
    s0 = plant.state()
    assert s0.airspeed_mps == pytest.approx(22.0, abs=1e-6)
    assert s0.alt_m - HOME[2] == pytest.approx(100.0, abs=1e-3)
    assert not s0.on_ground and not plant.on_launcher
    assert 0.1 < controls.throttle < 0.8
    assert 0.0 < controls.elevator < 1.0          # nose-up elevator holds 8 deg alpha
    assert abs(controls.aileron) < 0.1 and abs(controls.rudder) < 0.1
    assert math.degrees(s0.alpha_rad) == pytest.approx(8.4, abs=1.0)
    assert abs(s0.beta_rad) < 0.01
    for _ in range(20):
        s = fly(plant, controls, 1.0)
        assert abs(s.alt_m - s0.alt_m) < 5.0
        assert abs(s.airspeed_mps - 22.0) < 1.0
    phi, _, psi = euler(s.q_nb)
    assert abs(phi) < math.radians(5)
    assert abs(math.degrees(psi) - HOME[3]) < 5.0


def test_trim_across_the_speed_range_and_the_minimum_speed():
    plant = JSBSimPlane(home=HOME)
    throttle = []
    elevator = []
    for v in (18.0, 25.0, 30.0):
        c = plant.trim(airspeed_mps=v, height_m=100.0)
        throttle.append(c.throttle)
        elevator.append(c.elevator)
    assert all(0.0 < t < 0.8 for t in throttle)
    assert elevator[0] > elevator[1] > elevator[2] > 0.0   # slower needs more nose-up
    plant.trim(airspeed_mps=V_MIN_LEVEL + 0.2, height_m=100.0)
    with pytest.raises(RuntimeError):
        plant.trim(airspeed_mps=V_MIN_LEVEL - 0.5, height_m=100.0)   # elevator runs out
    assert plant.on_launcher and plant.state().on_ground             # put back at rest


@pytest.mark.parametrize("airframe, speed", [("aerosonde", 22.0), ("c172p", 50.0)])
def test_control_signs_match_plane_controls(airframe, speed):
    plant = JSBSimPlane(airframe, home=HOME)
    trim = plant.trim(airspeed_mps=speed, height_m=300.0)
    base = fly(plant, trim, 0.05)
    expect = {"aileron": 0, "elevator": 1, "rudder": 2}     # p, q, r respond
    for name, axis in expect.items():
        for sign in (1.0, -1.0):
            plant.trim(airspeed_mps=speed, height_m=300.0)
            cmd = replace(trim, **{name: getattr(trim, name) + sign * 0.3})
            s = fly(plant, cmd, 0.05)
            change = s.omega_b[axis] - base.omega_b[axis]
            assert sign * change > 0.005, (name, sign, change)
    # more throttle, more speed
    plant.trim(airspeed_mps=speed, height_m=300.0)
    slow = fly(plant, trim, 3.0)
    plant.trim(airspeed_mps=speed, height_m=300.0)
    fast = fly(plant, replace(trim, throttle=min(1.0, trim.throttle + 0.3)), 3.0)
    assert fast.airspeed_mps > slow.airspeed_mps + 0.5


# ---------------------------------------------------------------- launch and climb

def test_catapult_launch_then_climb_at_full_throttle_and_pitch_up_elevator():
    plant = JSBSimPlane(home=HOME)
    deck = plant.state().alt_m
    climb = PlaneControls(elevator=0.5, throttle=1.0)
    t_release = t_rail = v_rail = None
    lowest = math.inf
    s = plant.state()
    while s.t_us < 15_000_000:
        roll, _, _ = euler(s.q_nb)
        # fixed elevator and throttle; the aileron only holds the wings level
        s = plant.step(replace(climb, aileron=-1.0 * roll - 0.2 * s.omega_b[0]))
        if t_release is None and s.airspeed_mps > 0.5:
            t_release = s.t_us
        if t_rail is None and not plant.on_launcher:
            t_rail, v_rail = s.t_us, s.airspeed_mps
        if t_rail is not None:
            lowest = min(lowest, s.alt_m - HOME[2])
        if s.t_us == 6_000_000:
            s6 = s
    assert t_release / 1e6 == pytest.approx(SPIN_UP_S, abs=0.05)   # after spin-up
    assert (t_rail - t_release) / 1e6 == pytest.approx(0.3, abs=0.1)  # short stroke
    assert v_rail >= 1.3 * V_MIN_LEVEL
    assert v_rail == pytest.approx(21.7, abs=1.0)
    assert lowest > 1.0                               # never sank to the ground
    assert not s6.on_ground
    assert s6.alt_m - deck > 10.0
    assert s6.v_ned[2] < -2.0                         # climbing at 6 s
    assert (s.alt_m - deck) / 15.0 > 2.0              # mean climb rate over 15 s
    assert s.airspeed_mps > V_MIN_LEVEL


def test_launch_method_fires_at_once():
    plant = JSBSimPlane(home=HOME)
    plant.launch()
    s = fly(plant, PlaneControls(throttle=1.0, elevator=0.5), 0.5)
    assert not plant.on_launcher
    assert s.airspeed_mps > 18.0
    assert s.f_b[0] < 5.0                              # catapult has stopped pushing


def test_steady_climb_rate_at_20_mps_full_throttle():
    plant = JSBSimPlane(home=HOME)
    trim = plant.trim(airspeed_mps=20.0, height_m=100.0)
    _, theta0, _ = euler(plant.state().q_nb)
    s = plant.state()
    integral = 0.0
    climbs = []
    for _ in range(40 * 200):
        roll, theta, _ = euler(s.q_nb)
        error = s.airspeed_mps - 20.0                  # airspeed held by pitch
        integral += 0.01 * error * plant.dt_s
        theta_cmd = theta0 + 0.04 * error + integral
        cmd = PlaneControls(aileron=trim.aileron - roll - 0.2 * s.omega_b[0],
                            elevator=trim.elevator + 2.0 * (theta_cmd - theta)
                            - 0.5 * s.omega_b[1],
                            rudder=trim.rudder, throttle=1.0)
        s = plant.step(cmd)
        climbs.append(-s.v_ned[2])
    assert s.airspeed_mps == pytest.approx(20.0, abs=0.3)
    assert np.mean(climbs[-10 * 200:]) > 3.0           # about 4 m/s


# ---------------------------------------------------------------- ground impact

@pytest.mark.parametrize("aileron, elevator, throttle, speed", [
    (0.0, -1.0, 1.0, 30.0),      # vertical dive at full power
    (0.6, -1.0, 1.0, 30.0),      # rolling dive
    (-1.0, -0.5, 0.0, 22.0),     # spiral in, engine off
    (0.0, 0.0, 0.0, 22.0),       # glide in
])
def test_ground_impact_ends_at_rest_not_nan(aileron, elevator, throttle, speed):
    plant = JSBSimPlane(home=HOME)
    plant.trim(airspeed_mps=speed, height_m=30.0)
    s = fly(plant, PlaneControls(aileron=aileron, elevator=elevator, throttle=throttle), 30.0)
    values = np.concatenate([s.v_ned, s.q_nb, s.omega_b, s.f_b,
                             [s.lat_rad, s.lon_rad, s.alt_m, s.airspeed_mps]])
    assert np.all(np.isfinite(values))
    assert s.on_ground
    assert np.linalg.norm(s.v_ned) < 0.1
    assert np.max(np.abs(s.omega_b)) < 0.05
    assert -0.5 < s.alt_m - HOME[2] < 1.0               # on the terrain, not under it


# ---------------------------------------------------------------- geography and wind

def test_flies_east_across_the_180_meridian_at_45_south():
    home = (-45.0, 179.99, 0.0, 90.0)
    plant = JSBSimPlane(home=home)
    trim = plant.trim(airspeed_mps=25.0, height_m=100.0)
    lons, lats, alts = [], [], []
    for _ in range(45 * 10):                           # 45 s: 0.01 deg is 787 m here
        s = plant.step(trim, 20)
        lons.append(s.lon_rad)
        lats.append(s.lat_rad)
        alts.append(s.alt_m)
    lons = np.array(lons)
    assert np.all(lons <= math.pi) and np.all(lons > -math.pi)
    assert lons[0] > 0 and lons[-1] < 0                # crossed from +180 to -180
    steps = np.diff(np.unwrap(lons))
    assert np.all(steps > 0) and np.max(steps) < 1e-5   # eastward, no jump when unwrapped
    assert np.sum(np.abs(np.diff(lons)) > 1.0) == 1     # exactly one wrap
    crossed_m = (np.unwrap(lons)[-1] - math.radians(179.99)) * 6378137 * math.cos(
        math.radians(45))
    assert crossed_m == pytest.approx(25.0 * 45.0, rel=0.05)
    assert np.degrees(np.ptp(lats)) < 1e-3
    assert np.max(np.abs(np.array(alts) - 100.0)) < 5.0


def test_steady_wind_is_the_air_velocity_and_trim_is_relative_to_the_air():
    plant = JSBSimPlane(home=HOME, wind_ned=(0.0, 5.0, 0.0), turbulence="light",
                        rng=np.random.default_rng(3))   # from the west
    # on the launcher the rail holds the airframe: no weathervaning, no rolling
    s0 = plant.state()
    for _ in range(300):
        s = plant.step(PlaneControls(), 1)
    assert s.on_ground
    assert np.allclose(s.q_nb, s0.q_nb, atol=1e-6)
    # released, the air moves
    plant.launch()
    s = plant.step(PlaneControls(throttle=1.0), 1)
    np.testing.assert_allclose(s.wind_ned, [0.0, 5.0, 0.0], atol=2.0)
    plant.set_wind((0.0, 5.0, 0.0), "none")
    plant.trim(airspeed_mps=22.0, height_m=100.0)
    s = plant.state()
    np.testing.assert_allclose(s.wind_ned, [0.0, 5.0, 0.0], atol=1e-9)
    assert s.airspeed_mps == pytest.approx(22.0, abs=1e-3)
    # the vectors: tuples of floats (base.PlantState)
    assert all(type(c) is float for c in s.v_ned + s.q_nb + s.omega_b + s.f_b + s.wind_ned)
    # heading east with the wind behind: ground speed = airspeed + wind
    assert s.v_ned[1] == pytest.approx(27.0, abs=0.05)
    assert np.linalg.norm(np.subtract(s.v_ned, s.wind_ned)) == pytest.approx(s.airspeed_mps, abs=1e-3)
    plant.set_wind((-3.0, 0.0, 0.0), "none")
    s = plant.step(PlaneControls(), 1)
    np.testing.assert_allclose(s.wind_ned, [-3.0, 0.0, 0.0], atol=1e-9)
    with pytest.raises(ValueError):
        plant.set_wind((0.0, 0.0, 0.0), "hurricane")


def test_same_seed_same_turbulent_flight_and_another_seed_differs():
    def run(seed: int) -> np.ndarray:
        plant = JSBSimPlane(home=HOME, turbulence="light", rng=np.random.default_rng(seed))
        trim = plant.trim(airspeed_mps=22.0, height_m=100.0)
        s = plant.step(trim, 2000)
        return np.concatenate([s.v_ned, s.q_nb, s.omega_b, s.f_b, s.wind_ned,
                               [s.lat_rad, s.lon_rad, s.alt_m, s.airspeed_mps]])

    a, b, c = run(7), run(7), run(8)
    assert np.all(np.isfinite(a))
    np.testing.assert_array_equal(a, b)
    assert not np.allclose(a, c)
    # light turbulence really moves the air: the wind is no longer the steady zero
    assert 0.05 < np.linalg.norm(a[13:16]) < 10.0


def test_turbulence_intensity_follows_mil_f_8785c():
    def vertical_gust_std(level: str) -> float:
        plant = JSBSimPlane(home=HOME, turbulence=level, rng=np.random.default_rng(3))
        trim = plant.trim(airspeed_mps=22.0, height_m=100.0)
        gusts = [plant.step(trim, 2).wind_ned[2] for _ in range(60 * 100)]
        return float(np.std(gusts))

    light, severe = vertical_gust_std("light"), vertical_gust_std("severe")
    # sigma_w = 0.1 * W20: 0.77 m/s for light (15 kt), 2.3 m/s for severe (45 kt)
    assert 0.3 < light < 1.5
    assert severe / light == pytest.approx(3.0, rel=0.35)


# ---------------------------------------------------------------- c172p

def test_c172p_rests_on_its_wheels_and_rolls_on_full_throttle():
    plant = JSBSimPlane("c172p", home=HOME)
    s0 = plant.state()
    assert s0.on_ground and plant.on_launcher           # brakes set
    assert s0.f_b[2] == pytest.approx(-G, abs=0.05)
    assert np.linalg.norm(s0.v_ned) < 0.01
    assert np.max(np.abs(s0.omega_b)) < 0.002
    s = fly(plant, PlaneControls(throttle=1.0), 10.0)
    assert not plant.on_launcher                        # brakes released
    assert s.on_ground
    assert s.airspeed_mps > 15.0
    s = fly(plant, PlaneControls(throttle=1.0, elevator=0.3), 8.0)
    assert not s.on_ground
    assert s.alt_m - s0.alt_m > 5.0                     # off the runway and climbing
    assert s.v_ned[2] < -1.0


# ---------------------------------------------------------------- cost
