"""Multirotor control (autopilot/control/multirotor.py, mixer.py): the mixer of eq 3.30,
the PDD design of eqs 3.31-3.36 checked by its closed-loop poles, its discretisation,
the altitude PID of eq 3.37 and the reference-angle generator of eqs 3.38-3.41."""
import itertools
import math

import numpy as np
import pytest
from scipy import signal

from autopilot.control.mixer import K_EFF, QuadPlusMixer
from autopilot.control.multirotor import (G, MULTIROTOR_PARAMS, NO_LEAD, SEED_ALT,
                                          SEED_POS_PITCH, SEED_ROLL_PITCH, SEED_YAW,
                                          AltitudeController, AttitudeController, DiscretePdd,
                                          MultirotorController, ReferenceAngleGenerator,
                                          attitude_error, axis_gains, closed_loop_poles,
                                          place_pdd, place_position)
from autopilot.geo import euler_to_quat
from autopilot.modes.copter import CopterMode
from autopilot.params import ParamStore
from sim_bridge.plants.quadrotor import F450, QuadrotorPlant


def params(**kw):
    p = ParamStore(MULTIROTOR_PARAMS)
    for k, v in kw.items():
        p.set(k, v)
    return p


# ------------------------------------------------------------------------ mixer ---
def moments(thrusts, l=F450.arm_m, km=F450.k_m):
    """The plant's moments (sim_bridge/plants/quadrotor.py) of four rotor thrusts."""
    t1, t2, t3, t4 = thrusts
    return np.array([l * (t2 - t4), l * (t3 - t1), km * (t1 + t3 - t2 - t4)])


@pytest.mark.parametrize("u, axis", [((0.3, 0, 0), 0), ((0, 0.3, 0), 1), ((0, 0, 0.3), 2)])
def test_mixer_inputs_turn_the_airframe_about_their_own_axis(u, axis):
    m = QuadPlusMixer(15.7, 0.78, 0.1)
    t0 = np.array(m.mix_thrusts(14.0, 0.0, 0.0, 0.0))
    t = np.array(m.mix_thrusts(14.0, *u))
    mom = moments(t)
    assert mom[axis] > 0.0                                   # positive input: positive moment
    assert np.allclose(np.delete(mom, axis), 0.0, atol=1e-12)
    assert t.sum() == pytest.approx(t0.sum())                # collective unchanged
    # eq 3.30: moments (2 l u_phi, 2 l u_theta, 4 k_M u_psi)
    gain = (2 * F450.arm_m, 2 * F450.arm_m, 4 * F450.k_m)[axis]
    assert mom[axis] == pytest.approx(gain * 0.3)


def test_mixer_saturation_keeps_attitude_before_height():
    m = QuadPlusMixer(15.7, 0.78, 0.1)
    # near full collective, a roll demand: the roll differential survives, the collective gives
    t = m.mix_thrusts(4 * 15.0, 2.0, 0.0, 0.0)
    assert max(t) <= m.t_hi + 1e-9 and min(t) >= m.t_lo - 1e-9
    assert t[1] - t[3] == pytest.approx(4.0)
    assert m.saturated == (False, False, True) and m.collective < 60.0
    # roll + yaw beyond the span: yaw is cut first, roll kept
    span = m.t_hi - m.t_lo
    t = m.mix_thrusts(4 * 6.0, 0.4 * span, 0.0, 0.4 * span)
    assert t[1] - t[3] == pytest.approx(0.8 * span)
    assert m.saturated[1] is True and not m.saturated[0]
    # idle: never below the minimum spinning thrust
    t = m.mix_thrusts(0.0, 0.5, 0.0, 0.0)
    assert min(t) >= m.t_lo - 1e-9 and t[1] - t[3] == pytest.approx(1.0)


def test_thrust_curve_inverts_and_fits_the_plant_near_hover():
    m = QuadPlusMixer(15.7, 0.78, 0.1)
    for u in (0.0, 0.1, 0.4, 0.7, 1.0):
        assert m.command_of(m.thrust_of(u)) == pytest.approx(u, abs=1e-12)
    hover = m.command_of(F450.mass_kg * 9.80665 / 4)
    assert hover == pytest.approx(F450.hover_command(), abs=0.005)


# ------------------------------------------------------------- PDD design (3.31) ---
def test_design_places_the_requested_poles_and_the_rest_are_stable_and_faster():
    p = params()
    ax = axis_gains(p)
    for axis, (wn, z, p3) in (("roll", (12.0, 0.8, 25.0)), ("yaw", (4.0, 0.9, 15.0))):
        k = place_pdd(ax[axis], ax["tau"], wn, z, p3, 100.0)
        poles = closed_loop_poles(ax[axis], ax["tau"], *k, 100.0)
        want = [complex(-z * wn, wn * math.sqrt(1 - z * z)), complex(-p3, 0.0)]
        for w in want:
            assert np.min(np.abs(poles - w)) < 1e-6
        assert np.all(poles.real < 0.0)
        others = [x for x in poles if np.min(np.abs(np.array(want + [w.conjugate() for w in want]) - x)) > 1e-6]
        assert all(x.real < -p3 for x in others)


def test_seed_roll_pitch_set_is_stable_on_this_airframe_in_any_assignment_and_yaw_is_not():
    ax = axis_gains(params())
    k, tau = ax["roll"], ax["tau"]
    rp = SEED_ROLL_PITCH
    for perm in itertools.permutations((rp["k_p"], rp["k_d"], rp["k_dd"])):
        poles = closed_loop_poles(k, tau, *perm, rp["p_d"], rp["lead"])
        assert np.all(poles.real < 0.0)
    # the listed order (k_P, k_D, k_DD) = (0.99, 1.48, 0.83): dominant pair -1.27 +- 3.63j
    poles = closed_loop_poles(k, tau, rp["k_p"], rp["k_d"], rp["k_dd"], rp["p_d"], rp["lead"])
    assert poles[0].real == pytest.approx(-1.27, abs=0.01) and abs(poles[0].imag) == pytest.approx(3.63, abs=0.01)
    y = SEED_YAW
    for perm in itertools.permutations((y["k_p"], y["k_d"], y["k_dd"])):
        poles = closed_loop_poles(ax["yaw"], tau, *perm, y["p_d"], y["lead"])
        assert np.any(poles.real > 0.0)


def test_the_other_reading_of_the_derivative_filters_is_unstable_with_the_seed_numbers():
    # k_D p_d s / (s + p_d) (k_D the derivative gain) is the same law with k_D, k_DD
    # multiplied by p_d and p_d^2 in our parametrisation: unstable for every assignment
    ax = axis_gains(params())
    rp = SEED_ROLL_PITCH
    pd = rp["p_d"]
    for kp, kd, kdd in itertools.permutations((rp["k_p"], rp["k_d"], rp["k_dd"])):
        poles = closed_loop_poles(ax["roll"], ax["tau"], kp, kd * pd, kdd * pd * pd, pd, rp["lead"])
        assert np.any(poles.real > 0.0)


def test_seed_altitude_gains_assignment_is_the_best_damped():
    # m s^2 (tau s + 1) s + (k_D s^2 + k_P s + k_I)
    m, tau = F450.mass_kg, 0.055

    def damping(kd, kp, ki):
        r = np.roots([m * tau, m, kd, kp, ki])
        return min(-x.real / abs(x) for x in r), np.all(r.real < 0)

    chosen = damping(SEED_ALT["k_d"], SEED_ALT["k_p"], SEED_ALT["k_i"])
    assert chosen[1]
    for perm in itertools.permutations((7.0, 7.5, 6.0)):
        z, stable = damping(*perm)
        assert stable and z <= chosen[0] + 1e-9


def test_position_gains_place_the_poles_of_the_simplified_loop():
    kp, ki, kd = place_position(1.4, 0.9, 0.5)
    poles = np.roots([1.0, G * kd, G * kp, G * ki])
    want = np.roots(np.polymul([1.0, 2 * 0.9 * 1.4, 1.4 ** 2], [1.0, 0.5]))
    np.testing.assert_allclose(np.sort_complex(poles), np.sort_complex(want), atol=1e-9)
    # the seed's pitch set (P, I, D) = (0.72, 0.72, 0.3) is lightly damped on this loop
    # (0.34 with an ideal attitude loop; 0.18 with ours in it, see the module docstring)
    poles = np.roots([1.0, G * SEED_POS_PITCH["k_d"], G * SEED_POS_PITCH["k_p"], G * SEED_POS_PITCH["k_i"]])
    assert min(-x.real / abs(x) for x in poles) < 0.35


def test_discrete_pdd_matches_the_continuous_law():
    """Tustin at 250 Hz: the difference equations follow C(s) = Cbar [k_P e - F(s) omega]."""
    dt = 0.004
    kp, kd, kdd, pd, lead = 4.0, 80.0, 300.0, 100.0, (2.0, 5.0, 20.0)
    pdd = DiscretePdd(kp, kd, kdd, pd, lead, dt)
    t = np.arange(0.0, 0.6, dt)
    omega = np.sin(9.0 * t)                       # a rate signal, error zero
    out = np.array([pdd.update(0.0, w) for w in omega])
    g, z, p = lead
    num = np.polymul([-(kd + kdd), -kd * pd], [g, g * z])
    den = np.polymul([1.0, 2 * pd, pd * pd], [1.0, p])
    _, y, _ = signal.lsim((num, den), omega, t)
    assert np.max(np.abs(out - y)) < 0.02 * np.max(np.abs(y))
    # the proportional path: a step of error gives k_P Cbar(s) step (Tustin's samples
    # are the continuous response half a step later: the trapezoidal rule)
    pdd.reset()
    out = np.array([pdd.update(1.0, 0.0) for _ in t])
    y = kp * g * (z / p + (1.0 - z / p) * np.exp(-p * (t + 0.5 * dt)))
    assert np.max(np.abs(out - y)) < 0.02 * np.max(np.abs(y))


def test_attitude_error_decouples_tilt_and_heading():
    q = euler_to_quat(0.0, 0.0, 0.3)
    ex, ey, ez = attitude_error(q, 0.1, -0.05, 0.3)
    assert (ex, ey, ez) == pytest.approx((0.1, -0.05, 0.0), abs=5e-3)
    # a heading error alone: only yaw, whatever the tilt reference's frame
    ex, ey, ez = attitude_error(q, 0.0, 0.0, 1.3)
    assert (ex, ey) == pytest.approx((0.0, 0.0), abs=1e-12) and ez == pytest.approx(1.0)
    # shortest way round
    assert attitude_error(euler_to_quat(0, 0, 3.0), 0, 0, -3.0)[2] == pytest.approx(2 * math.pi - 6.0)


def test_attitude_step_of_10_deg_overshoots_under_10_percent_and_settles_within_1_s():
    """The inner loop alone on the plant (truth attitude, altitude held): the design set."""
    dt = 0.004
    p = params()
    plant = QuadrotorPlant(dt_s=dt)
    plant.set_airborne(10.0)
    c = MultirotorController(p, dt)
    c.mixer.set_density_ratio(plant.rho / 1.225)
    from autopilot.geo import quat_to_euler
    rolls = []
    for k in range(int(3.0 / dt)):
        st = plant.state()
        r, pi, _ = quat_to_euler(st.q_nb)
        ref = math.radians(10.0) if k * dt >= 1.0 else 0.0
        uz = c.alt.update(10.0, 0.0, 0.0, st.alt_m + plant.af.gear_height_m, -st.v_ned[2],
                          math.cos(r) * math.cos(pi), dt)
        plant.step(c.attitude(st.q_nb, st.omega_b, ref, 0.0, 0.0, uz))
        if k * dt >= 1.0:
            rolls.append(math.degrees(r))
    rolls = np.array(rolls)
    t = np.arange(len(rolls)) * dt
    assert (rolls.max() - 10.0) / 10.0 <= 0.10
    outside = np.flatnonzero(np.abs(rolls - 10.0) > 0.2)     # 2 % band
    assert t[outside[-1]] < 1.0


def test_seed_gain_set_is_available_and_slower():
    p = params(QD_GAIN_SET=1)
    att = AttitudeController(p, 0.004)
    g = att.gains()
    assert g["roll"]["k_p"] == SEED_ROLL_PITCH["k_p"] and g["roll"]["lead"] == SEED_ROLL_PITCH["lead"]
    assert g["yaw"]["lead"] == SEED_YAW["lead"]
    alt = AltitudeController(p)
    assert (alt.k_d, alt.k_p, alt.k_i) == (7.0, 7.5, 6.0)


# --------------------------------------------------------------- altitude (3.37) ---
def test_altitude_law_feeds_the_nominal_thrust_forward_and_compensates_tilt():
    alt = AltitudeController(params())
    u = alt.update(10.0, 0.0, 0.0, 10.0, 0.0, 1.0, 0.004)
    assert u == pytest.approx(1.4 * G)                     # T_n = m g at zero error
    alt.reset()
    c = math.cos(math.radians(20.0))
    assert alt.update(10.0, 0.0, 0.0, 10.0, 0.0, c, 0.004) == pytest.approx(1.4 * G / c)
    alt.reset()
    # height error: P + I; climb-rate error: D (values as eq 3.37's gains)
    u = alt.update(11.0, 0.5, 0.0, 10.0, 0.0, 1.0, 0.004)
    assert u == pytest.approx(1.4 * G + 7.5 * 1.0 + 7.0 * 0.5)
    assert alt.integ == pytest.approx(6.0 * 1.0 * 0.004)


def test_altitude_integrator_holds_while_saturated_or_on_the_ground():
    alt = AltitudeController(params())
    alt.update(11.0, 0.0, 0.0, 10.0, 0.0, 1.0, 0.004, sat_hi=True)
    assert alt.integ == 0.0
    alt.update(11.0, 0.0, 0.0, 10.0, 0.0, 1.0, 0.004, hold_integrator=True)
    assert alt.integ == 0.0


# ------------------------------------------------- reference angles (3.38-3.41) ---
@pytest.mark.parametrize("yaw_deg, roll_sign, pitch_sign", [
    (0.0, 0, -1),      # target ahead (north, facing north): nose down
    (90.0, -1, 0),     # target north, facing east: it is on the left, roll left
    (180.0, 0, 1),     # behind: nose up
    (-90.0, 1, 0),     # on the right: roll right
])
def test_reference_angles_are_rotated_by_the_heading(yaw_deg, roll_sign, pitch_sign):
    g = ReferenceAngleGenerator(params())
    phi, theta = g.update(1.0, 0.0, 0.0, 0.0, 0.0, 0.0, math.radians(yaw_deg), 0.004)
    for val, sign in ((phi, roll_sign), (theta, pitch_sign)):
        if sign == 0:
            assert abs(val) < 1e-12
        else:
            assert math.copysign(1.0, val) == sign


def test_reference_integral_stays_in_the_earth_frame_and_tilt_is_limited():
    g = ReferenceAngleGenerator(params())
    for _ in range(500):                              # a steady north error builds the integral
        g.update(0.2, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.004)
    _, theta0 = g.update(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.004)
    phi90, theta90 = g.update(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, math.pi / 2, 0.004)
    assert theta0 < 0.0 and phi90 == pytest.approx(theta0, rel=1e-3) and abs(theta90) < 1e-9
    phi, theta = g.update(100.0, 100.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.004)
    assert math.hypot(phi, theta) == pytest.approx(math.radians(30.0))
    # acceleration feed-forward: a_x / g of pitch
    g.reset()
    _, theta = g.update(0.0, 0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.004)
    assert theta == pytest.approx(-2.0 / G)


def test_copter_modes_are_numbered_as_arducopter():
    assert {m.name: int(m) for m in CopterMode} == {
        "STABILIZE": 0, "ALT_HOLD": 2, "AUTO": 3, "GUIDED": 4, "LOITER": 5, "RTL": 6, "LAND": 9}


def test_output_predictor_kernel_is_the_strapdown_step():
    """The output predictor (autopilot/vehicle_quad.py, predict_output) against its law
    written out with autopilot.geo: q <- q (x) Exp(omega dt), v <- v + (R f + g) dt,
    p <- p + (v + v') dt / 2, f and omega less the filter's bias estimates; the raw
    sample added to the sums kept for the filter's next update."""
    from autopilot.geo import quat_integrate, quat_to_dcm, quat_to_euler
    from autopilot.vehicle_quad import predict_output
    p, v = np.array([3.0, -2.0, -15.0]), np.array([4.0, 1.0, -0.5])
    q = euler_to_quat(0.2, -0.1, 1.0)
    ba, bg, g = np.array([0.02, -0.01, 0.05]), np.array([0.001, -0.002, 0.003]), 9.79
    f, w, dt = np.array([0.4, -0.3, -9.9]), np.array([0.3, -0.2, 0.1]), 0.004
    sums = np.array([1.0, 2.0, 3.0, 0.1, 0.2, 0.3])               # of earlier samples
    x = np.concatenate((p, v, q, ba, bg, [g], sums, np.zeros(13)))
    y = x[23:]                                                     # its output, a part of x
    p_out, euler = predict_output(x, *f, *w, dt)
    v_out, q_out, w_out = (tuple(y[i:j].tolist()) for i, j in ((0, 3), (3, 7), (7, 10)))
    assert tuple(y[10:].tolist()) == euler                         # the loops' copy (Y_*)
    a = quat_to_dcm(q) @ (f - ba) + np.array([0.0, 0.0, g])
    v1 = v + a * dt
    assert p_out + v_out + q_out == tuple(x[:10].tolist())          # the new p, v, q as x holds them
    assert np.max(np.abs(np.array(w_out) - (w - bg))) < 1e-15
    assert np.max(np.abs(x[3:6] - v1)) < 1e-12
    assert np.max(np.abs(x[0:3] - (p + 0.5 * (v + v1) * dt))) < 1e-12
    assert np.max(np.abs(x[6:10] - quat_integrate(q, w - bg, dt))) < 1e-12
    assert np.all(x[10:17] == np.concatenate((ba, bg, [g])))        # biases untouched
    assert x[17:23].tolist() == (sums + np.concatenate((f, w))).tolist()   # the raw sample summed
    assert euler == quat_to_euler(q_out)                            # the new q's angles


def test_mixer_with_a_weak_rotor_keeps_every_rotor_within_its_share():
    """Fault accommodation (mix_rotors with k_j < 1): each rotor's thrust within
    k_j [T_lo, T_hi], its command that of T_j / k_j, the roll differential kept first."""
    m = QuadPlusMixer(15.7, 0.78, 0.10)
    m.set_effectiveness((1.0, 0.6, 1.0, 1.0))
    eff = m.eff
    t = m.mix_thrusts(4 * 9.0, 1.0, 0.0, 0.2)
    for k, tj in zip(eff, t):
        assert k * m.t_lo - 1e-9 <= tj <= k * m.t_hi + 1e-9
    cmd = m.mix(4 * 9.0, 1.0, 0.0, 0.2)
    assert cmd == tuple(m.command_of(tj / k) for tj, k in zip(t, eff))
    assert t[1] - t[3] == pytest.approx(2.0)                        # roll kept
    assert m.saturated[2]                                           # height gave way
    m.set_effectiveness(None)
    assert m.eff is None and m.mix_thrusts(14.0, 0.0, 0.0, 0.0) == (3.5, 3.5, 3.5, 3.5)


@pytest.mark.parametrize("eff", [None, (1.0, 0.6, 1.0, 0.8)])
def test_controller_attitude_is_the_attitude_loops_then_the_mixer(eff):
    """MultirotorController.attitude (one kernel call, attitude_mix) gives, bit for bit,
    what AttitudeController.update then QuadPlusMixer.mix give, and leaves the same
    filter states and mixer record behind (healthy and weak-rotor mixer)."""
    ctrl = MultirotorController(params(), 0.004)
    att, mixer = AttitudeController(params(), 0.004), QuadPlusMixer(15.7, 0.78, 0.10)
    ctrl.mixer.set_effectiveness(eff)
    mixer.set_effectiveness(eff)
    rng = np.random.default_rng(7)
    for _ in range(200):
        q = euler_to_quat(*rng.uniform(-0.4, 0.4, 3)).tolist()
        w = rng.uniform(-1.0, 1.0, 3).tolist()
        ref = rng.uniform(-0.4, 0.4, 3).tolist()
        u_z = float(rng.uniform(0.0, 60.0))
        got = ctrl.attitude(q, w, *ref, u_z)
        u = att.update(q, w, *ref)
        assert got == mixer.mix(u_z, *u)
        assert ctrl.u == (u_z, *u) and ctrl.att.error == att.error
        assert np.array_equal(ctrl.att.state, att.state)
        assert (ctrl.mixer.saturated, ctrl.mixer.collective, ctrl.mixer.thrusts) == (
            mixer.saturated, mixer.collective, mixer.thrusts)


def test_mixer_density_update_is_the_full_rebuild():
    """A density change rewrites the constants in place (set_density_ratio): the
    kernels' constants equal those of a mixer built at that density, bit for bit, and
    the array is the same object (the attitude kernel's argument)."""
    m = QuadPlusMixer(15.7, 0.78, 0.10)
    k = m.k
    m.set_density_ratio(0.93)
    ref = QuadPlusMixer(15.7, 0.78, 0.10)
    ref.rho_ratio = 0.93
    ref._limits()
    assert m.k is k and m.k.tolist() == ref.k.tolist()
    assert (m.t_lo, m.t_hi) == (ref.t_lo, ref.t_hi) and m.k[0] > 0.0
    m.set_effectiveness((1.0, 0.5, 1.0, 1.0))
    m.set_density_ratio(1.1)
    assert m.k[K_EFF + 1] == 0.5 and m.t_hi == m.thrust_of(1.0)
