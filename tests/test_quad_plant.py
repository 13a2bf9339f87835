"""The quadrotor plant (sim_bridge/plants/quadrotor.py): the seed's model, eqs 3.23-3.26,
on the F450 data. GIVEN a plant state and rotor commands, THEN the physics comes out
as the model says: weight carried at the hover command, free fall, the thrust lag, the
moments' directions, quiet ground contact."""
import math

import numpy as np
import pytest

from autopilot.geo import quat_to_dcm, quat_to_euler
from sim_bridge.plants.quadrotor import F450, QuadrotorPlant, air_data, static_thrust

HOME = (-35.363262, 149.165237, 584.0, 0.0)


def plant(**kw):
    return QuadrotorPlant(home=kw.pop("home", HOME), rng=np.random.default_rng(1), **kw)


def test_airframe_data_match_the_f450_sources():
    assert F450.mass_kg == 1.4 and (F450.ixx, F450.iyy, F450.izz) == (0.019, 0.019, 0.0252)
    assert F450.arm_m == pytest.approx(0.2335, abs=1e-4)
    assert F450.k_m == pytest.approx(0.01965, abs=1e-4)          # C_P D / (2 pi C_T)
    assert F450.thrust_time_constant() == pytest.approx(0.0546, abs=1e-3)
    assert F450.static_thrust(1.0) == pytest.approx(15.72, abs=0.05)
    assert F450.static_thrust(0.0) == 0.0
    u = np.linspace(0.0, 1.0, 21)
    assert np.all(np.diff([F450.static_thrust(x) for x in u]) >= 0.0)   # monotonic


def test_hover_command_holds_the_weight():
    # GIVEN the vehicle in the air with every rotor at the model's hover command
    p = plant()
    p.set_airborne(20.0)
    u = p.af.hover_command(p.rho, p.g)
    assert 4.0 * p.af.static_thrust(u, p.rho) == pytest.approx(p.af.mass_kg * p.g, rel=1e-6)
    # THEN after 5 s it has neither climbed nor sunk, nor tilted
    for _ in range(1250):
        st = p.step((u, u, u, u))
    assert st.alt_m - HOME[2] == pytest.approx(20.0, abs=0.01)
    assert abs(st.v_ned[2]) < 1e-3
    assert np.allclose(st.omega_b, 0.0, atol=1e-9)
    assert st.f_b[2] == pytest.approx(-p.g, abs=1e-3)        # accelerometer: -g, hovering


def test_hover_command_scales_with_air_density():
    # thrust ~ rho: at 584 m (rho 1.157) the hover command is higher than at sea level
    assert plant().af.hover_command(1.157) > plant().af.hover_command(1.225) + 0.005


def test_free_fall_with_motors_off():
    p = plant()
    p.set_airborne(100.0)
    p.thrust = [0.0, 0.0, 0.0, 0.0]
    t = 1.0
    for _ in range(int(t / p.dt_s)):
        st = p.step((0.0, 0.0, 0.0, 0.0))
    # m v' = m g - c_lin v - 1/2 rho CdA v^2 (still air), integrated finely
    af = p.af
    v = h = 0.0
    dt = 1e-5
    for _ in range(int(t / dt)):
        a = p.g - (af.drag_lin * v + 0.5 * p.rho * af.drag_area_m2 * v * v) / af.mass_kg
        h += (v + 0.5 * a * dt) * dt
        v += a * dt
    assert st.v_ned[2] == pytest.approx(v, rel=2e-3)
    assert 100.0 - (st.alt_m - HOME[2]) == pytest.approx(h, rel=5e-3)
    assert v > 0.85 * p.g * t                        # mostly gravity
    # the accelerometer reads the drag only: up along body z, nothing sideways
    drag = af.drag_lin * v + 0.5 * p.rho * af.drag_area_m2 * v * v
    assert st.f_b[2] == pytest.approx(-drag / af.mass_kg, rel=5e-3)
    assert np.linalg.norm(st.f_b[:2]) < 1e-9


def test_rotor_thrust_follows_a_first_order_lag():
    p = plant()
    p.set_airborne(50.0)
    p.thrust = [0.0, 0.0, 0.0, 0.0]
    target = p.static_thrusts((0.6, 0.6, 0.6, 0.6))[0]
    tau = p.tau_s
    n = int(round(tau / p.dt_s))
    for _ in range(n):
        p.step((0.6, 0.6, 0.6, 0.6))
    # after one time constant: 1 - 1/e of the step
    assert p.thrust[0] / target == pytest.approx(1.0 - math.exp(-n * p.dt_s / tau), abs=1e-9)
    assert p.thrust[0] / target == pytest.approx(0.632, abs=0.03)


@pytest.mark.parametrize("channel, axis, sign", [
    (1, 0, +1), (3, 0, -1),     # rotor 2 (left) rolls right, rotor 4 (right) rolls left
    (2, 1, +1), (0, 1, -1),     # rotor 3 (front) pitches up, rotor 1 (aft) pitches down
    (0, 2, +1), (2, 2, +1),     # rotors 1, 3 (counter-clockwise) yaw the nose right
    (1, 2, -1), (3, 2, -1),     # rotors 2, 4 (clockwise) yaw it left
])
def test_each_rotor_turns_the_airframe_the_documented_way(channel, axis, sign):
    p = plant()
    p.set_airborne(50.0)
    u = [p.af.hover_command(p.rho, p.g)] * 4
    u[channel] += 0.05
    for _ in range(10):
        st = p.step(tuple(u))
    assert math.copysign(1.0, st.omega_b[axis]) == sign
    if axis < 2:      # no cross-coupling between roll and pitch (yaw follows the spin)
        assert abs(st.omega_b[1 - axis]) < 1e-3 * abs(st.omega_b[axis])


def test_rests_on_the_ground_then_takes_off_and_lands_without_sinking_or_bouncing():
    p = plant()
    st = p.state()
    ground = HOME[2] + p.af.gear_height_m
    assert st.on_ground and st.alt_m == pytest.approx(ground)
    # idling below the weight: still on the ground, the accelerometer reads -g
    for _ in range(250):
        st = p.step((0.2, 0.2, 0.2, 0.2))
    assert st.on_ground and st.alt_m == pytest.approx(ground)
    assert np.allclose(st.f_b, (0.0, 0.0, -p.g), atol=1e-9) and np.allclose(st.v_ned, 0.0)
    # full power: lifts off
    for _ in range(250):
        st = p.step((0.6, 0.6, 0.6, 0.6))
    assert not st.on_ground and st.alt_m > ground + 1.0
    # a gentle descent at about 0.5 m/s, then it touches down: stops dead at the ground
    alts = []
    hover = p.af.hover_command(p.rho, p.g)
    for _ in range(10000):
        u = hover + 0.05 * (st.v_ned[2] - 0.5)
        st = p.step((u, u, u, u))
        alts.append(st.alt_m)
        if st.on_ground:
            break
    assert st.on_ground and not p.crashed
    for _ in range(250):
        st = p.step((u, u, u, u))
        alts.append(st.alt_m)
    assert min(alts) >= ground - 1e-9                         # never below the ground
    assert st.alt_m == pytest.approx(ground) and np.allclose(st.v_ned, 0.0)
    assert 0.3 < p.touchdown_speed_mps < 0.7


def test_touchdown_impulse_reaches_the_accelerometer_and_a_tilt_levels_through_the_gyro():
    p = plant()
    p.set_airborne(0.3)
    p.v = [0.0, 0.0, 1.0]
    p.q = list(np.array([math.cos(0.05), math.sin(0.05), 0.0, 0.0]))     # 5.7 deg roll
    p.thrust = [0.0] * 4
    st = p.step((0.0, 0.0, 0.0, 0.0))
    while not st.on_ground:
        v_before = p.v[2]
        st = p.step((0.0, 0.0, 0.0, 0.0))
    # integrating the specific force (plus gravity) over the touchdown step gives -v
    f_ned = quat_to_dcm(st.q_nb) @ st.f_b
    assert (f_ned[2] + p.g) * p.dt_s == pytest.approx(-v_before, rel=0.02)
    # then the roll goes to zero at finite rates, never by a jump
    rolls, rates = [], []
    for _ in range(200):
        st = p.step((0.0, 0.0, 0.0, 0.0))
        rolls.append(quat_to_euler(st.q_nb)[0])
        rates.append(st.omega_b[0])
    assert abs(rolls[-1]) < 1e-3
    assert max(abs(np.diff(rolls))) < 0.01
    assert min(rates) < -0.1


def test_crash_is_flagged_on_a_hard_touchdown():
    p = plant()
    p.set_airborne(5.0)
    for _ in range(500):
        st = p.step((0.0, 0.0, 0.0, 0.0))
        if st.on_ground:
            break
    assert p.crashed and p.touchdown_speed_mps > 3.0


def test_state_follows_the_plant_state_contract_across_the_dateline():
    p = plant(home=(-41.0, 179.9999, 10.0, 90.0))
    p.set_airborne(10.0, yaw_rad=math.pi / 2)
    p.p = [0.0, 50.0, -10.0]                      # 50 m east: across the 180 deg meridian
    st = p.state()
    assert -math.pi < st.lon_rad < -math.pi + 1e-4
    assert len(st.q_nb) == 4 and len(st.v_ned) == 3 and len(st.wind_ned) == 3
    assert all(type(c) is float for c in st.q_nb + st.v_ned + st.omega_b + st.f_b + st.wind_ned)
    assert quat_to_euler(st.q_nb)[2] == pytest.approx(math.pi / 2)


def test_wind_and_turbulence_reach_the_air_data_reproducibly():
    a = plant(wind_ned=(0.0, 3.0, 0.0), turbulence="light")
    b = plant(wind_ned=(0.0, 3.0, 0.0), turbulence="light")
    for pl in (a, b):
        pl.set_airborne(10.0)
    u = a.af.hover_command(a.rho, a.g)
    sa = [a.step((u,) * 4) for _ in range(500)]
    sb = [b.step((u,) * 4) for _ in range(500)]
    assert all(np.array_equal(x.wind_ned, y.wind_ned) for x, y in zip(sa, sb))
    w = np.array([s.wind_ned for s in sa])
    assert 1.0 < np.mean(w[:, 1]) < 5.0 and np.std(w[:, 2]) > 0.01
    # the wind pushes the hovering vehicle downwind (east)
    assert sa[-1].v_ned[1] > 0.1


def test_dryden_kernel_is_the_gauss_markov_law_written_out():
    # GIVEN heights inside and outside the model's band, speeds under and over the floor
    # WHEN one step of sim_bridge.wind.dryden_step is taken
    # THEN it is the law of its module docstring computed in Python (to rounding: the
    # kernel doubles the distance where this halves the scale length)
    from sim_bridge.wind import FT_M, dryden_step
    rng = np.random.default_rng(4)
    for h_agl, speed, n in ((-2.0, 1.0, 1), (1.0, 20.0, 2), (80.0, 22.5, 2), (450.0, 3.0, 1)):
        x, nu = rng.standard_normal(3).tolist(), rng.standard_normal(3).tolist()
        axis = (0.6, 0.8)
        h = min(max(h_agl, 3.0), 300.0)
        v = max(speed, 5.0)
        shape = 0.177 + 0.000823 * (h / FT_M)
        sigma_w = 0.77
        sigma_u = sigma_w / shape ** 0.4
        d = v * 0.01 * n
        lengths = (h / shape ** 1.2, 0.5 * h / shape ** 1.2, 0.5 * h)
        sigmas = (sigma_u, sigma_u, sigma_w)
        want = []
        for xk, nk, length, sigma in zip(x, nu, lengths, sigmas):
            a = math.exp(-d / length)
            want.append(a * xk + sigma * math.sqrt(1.0 - a * a) * nk)
        want += [axis[0] * want[0] - axis[1] * want[1], axis[1] * want[0] + axis[0] * want[1]]
        got = dryden_step(*x, h_agl, speed, 0.01, n, sigma_w, *nu, *axis)
        assert got == pytest.approx(tuple(want), rel=1e-13, abs=1e-15)


def test_motor_thrust_fault_scales_the_rotor_thrust_not_its_command():
    # GIVEN the quadrotor's fault injector (thrust-scaled motors) and a plant in hover
    from sim_bridge.bridge import SimBridge
    from sim_bridge.faults import FaultInjector

    class _Link:                      # the HIL end is not used by advance() here
        commands: list = []
        armed = True

        def send_battery(self, _b):
            pass

    p = plant()
    p.set_airborne(20.0)
    inj = FaultInjector(np.random.default_rng(3), dt_s=0.004, motor_channels=(0, 1, 2, 3),
                        thrust_motors=True)
    br = SimBridge(p, None, _Link(), inj, hil_rate_hz=250.0, vehicle="quad")
    u = p.af.hover_command(p.rho, p.g)
    # WHEN motor instance 1 (rotor 2, left) is set to 70 % ("motor wrong", effectiveness)
    assert inj.inject("motor", "wrong", 1, effectiveness=0.7)
    br.advance((u, u, u, u))
    # THEN the command reaches the rotor unchanged and its thrust settles at 70 %
    assert inj.apply_controls((u, u, u, u)) == (u, u, u, u)
    assert p.rotor_scale == (1.0, 0.7, 1.0, 1.0)
    for _ in range(100):                               # 0.4 s, 7 rotor time constants
        br.advance(None)
    t_h = p.af.static_thrust(u, p.rho)
    assert p.thrust[1] == pytest.approx(0.7 * t_h, rel=0.01)
    assert p.thrust[0] == pytest.approx(t_h, rel=1e-3)
    # AND the airframe rolls left (positive roll = right: rotor 2 left lifts less)
    assert quat_to_euler(p.state().q_nb)[0] < -0.05
    # AND "ok" restores the rotor
    assert inj.inject("motor", "ok", 1)
    br.advance(None)
    assert p.rotor_scale == (1.0, 1.0, 1.0, 1.0)


def test_static_thrust_kernel_is_the_airframes_thrust_curve():
    # GIVEN the plant's closed form of T_ss(u) (the kernel flight_step calls)
    p = plant()
    for u in (-0.5, 0.0, 0.01, 0.05, 0.2, 0.41, 0.7, 1.0, 1.5):
        # THEN it is the airframe's steady thrust (motor torque = propeller torque), the
        # command clipped to 0..1
        assert static_thrust(u, *p._ts) == pytest.approx(F450.static_thrust(u, p.rho), rel=1e-9, abs=1e-12)
    assert static_thrust(-0.5, *p._ts) == 0.0
    assert static_thrust(1.5, *p._ts) == static_thrust(1.0, *p._ts)
    assert p.static_thrusts((0.2, 0.4, 0.6, 0.8)) == [static_thrust(u, *p._ts) for u in (0.2, 0.4, 0.6, 0.8)]


def test_air_data_kernel_against_the_rotation_in_numpy():
    # GIVEN a state array with some velocity and attitude, and a wind
    x = np.zeros(23)
    x[3:6] = (4.0, -1.5, 0.7)
    q = np.array((0.9, 0.1, -0.2, 0.3))
    q /= np.linalg.norm(q)
    x[6:10] = q
    wind = np.array((1.0, 2.0, -0.3))
    airspeed, alpha, beta = air_data(x, *wind)
    # THEN: the air velocity in body axes R^T (v - w), alpha = atan2(w_b, u_b), beta = asin(v_b / V)
    va = x[3:6] - wind
    ub, vb, wb = quat_to_dcm(q).T @ va
    assert airspeed == pytest.approx(np.linalg.norm(va), rel=1e-12)
    assert alpha == pytest.approx(math.atan2(wb, ub), abs=1e-12)
    assert beta == pytest.approx(math.asin(vb / np.linalg.norm(va)), abs=1e-12)
    assert tuple(x[16:19]) == tuple(wind)          # the state's wind, stored
    # still air and no motion: no angles
    x[3:6] = 0.0
    assert air_data(x, 0.0, 0.0, 0.0) == (0.0, 0.0, 0.0)


def test_a_state_keeps_its_values_when_the_plant_steps_on():
    # GIVEN a state taken in flight (the plant's own state array is updated in place)
    p = plant()
    p.set_airborne(20.0)
    u = p.af.hover_command(p.rho, p.g)
    st = p.step((u + 0.1, u, u - 0.1, u))
    saved = [list(a) for a in (st.v_ned, st.q_nb, st.omega_b, st.f_b, st.wind_ned)]
    for _ in range(50):
        p.step((u + 0.1, u, u - 0.1, u))
    # THEN the earlier state's vectors are its own
    for a, b in zip((st.v_ned, st.q_nb, st.omega_b, st.f_b, st.wind_ned), saved):
        assert list(a) == b
    # and the state lists read and write the plant's state array
    assert p.q == list(p.state().q_nb) and p.v == list(p.state().v_ned)
    p.v = [1.0, 2.0, 3.0]
    assert p.state().v_ned == (1.0, 2.0, 3.0)
