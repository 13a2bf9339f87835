"""Stop 38: the quadrotor's heading reference slewed in the navigator's kernel call
(guidance_step), the navigator's step and the loops in one call (guide_track), the
output predictor's velocity, attitude and rate read from its array y."""
import math

import numpy as np

from autopilot.control.multirotor import X_N as CTRL_N, MultirotorController
from autopilot.geo import wrap_pi
from autopilot.guidance.multirotor import TRAJ_N, CopterNavigator, Trajectory, guidance_step
from autopilot.params import ParamStore
from autopilot.vehicle_quad import (LOOPS_N, LOOPS_NAV, LOOPS_TRAJ, X_Y, guide_track,
                                    quad_param_declarations)

DT = 0.004


def _heading(yaw_ref, goal, step):
    """The slew as the navigator wrote it in Python before (max(-step, min(step, err)))."""
    err = wrap_pi(goal - yaw_ref)
    return wrap_pi(yaw_ref + max(-step, min(step, err)))


def test_guidance_step_heading_is_the_python_slew():
    """The kernel's heading: the trajectory's step as trajectory_step alone gives it, the
    heading slewed towards the goal as the Python law, bit for bit; NaN: held; ``follow``:
    towards the curve's course after the step (atan2 of its direction), where it is
    horizontal enough."""
    rng = np.random.default_rng(38)
    tr = Trajectory(4.0)
    tr.reset((0.0, 0.0, -10.0))
    pts = [(20.0 * math.sin(0.05 * k), 2.0 * k, -10.0 - 0.1 * k) for k in range(60)]
    tr.curve_to(pts, 5.0, 2.5, 1.5, 2.5, 1.5)
    ref = Trajectory(4.0)
    ref.x[:] = tr.x
    ref._poly, ref.curving = tr._poly, True
    held = slewed = followed = 0
    yaw = 0.3
    for k in range(3000):
        goal = (math.nan, float(rng.uniform(-4.0, 4.0)), 3.1, -3.1)[k % 4]
        follow = k % 5 == 0
        step = float(rng.uniform(0.0, 0.5))
        p = tuple(tr.p)
        arrived, got = guidance_step(tr.x, tr._poly, DT, *p, 8.0, yaw, goal, step, follow)
        ref.update(DT, p, 8.0)
        assert np.array_equal(tr.x, ref.x) and arrived == ref.arrived
        u = tr.x[15:18].tolist()
        if follow and math.hypot(u[0], u[1]) > 0.2:
            goal = math.atan2(u[1], u[0])
            followed += 1
        want = yaw if math.isnan(goal) else _heading(yaw, goal, step)
        held += math.isnan(goal)
        slewed += want != yaw
        assert got == want
        yaw = got
    assert held > 500 and slewed > 1500 and followed > 300


def test_guide_track_is_the_navigator_step_then_track():
    """guide_track: the navigator's step (its step_inputs into guidance_step) and then
    ctrl.track on the reference it left, bit for bit, states and records alike; the
    controller's, the trajectory's arrays and the navigation output parts of its one (as
    the vehicle's)."""
    assert LOOPS_TRAJ == CTRL_N and LOOPS_NAV == CTRL_N + TRAJ_N
    p = ParamStore(quad_param_declarations())
    loops = np.zeros(LOOPS_N)
    a, b = CopterNavigator(p, loops[LOOPS_TRAJ:LOOPS_NAV]), CopterNavigator(p)
    ca, cb = MultirotorController(p, DT, loops[:LOOPS_TRAJ]), MultirotorController(p, DT)
    y_in = loops[LOOPS_NAV + X_Y:]
    for nv in (a, b):
        nv.init((0.0, 0.0, -5.0), 0.2)
        nv.goto((40.0, -30.0, -12.0))
    rng = np.random.default_rng(5)
    pos = (0.0, 0.0, -5.0)
    for k in range(1500):
        q = (np.array((1.0, *rng.uniform(-0.1, 0.1, 3))) / 1.01).tolist()
        y = np.array((*rng.uniform(-2.0, 2.0, 3), *q, *rng.uniform(-0.5, 0.5, 3),
                      *rng.uniform(-0.3, 0.3, 3)))
        hold = k % 7 == 0
        y_in[:] = y
        arrived, yaw_ref, roll_d, pitch_d, u, motors = guide_track(loops, hold,
                                                                   *a.step_inputs(DT, pos))
        b.update(DT, pos, 0.0)
        want = cb.track(y, pos, b.traj.ref, b.yaw_ref, DT, hold, hold)
        assert (arrived, yaw_ref) == (b.traj.arrived, b.yaw_ref)
        assert (roll_d, pitch_d, u, motors) == (cb.roll_d, cb.pitch_d, cb.u, want)
        assert np.array_equal(a.traj.x, b.traj.x) and np.array_equal(ca.x, cb.x)
        a.traj.arrived, a.yaw_ref = arrived, yaw_ref
        pos = tuple(b.traj.p[i] + float(rng.normal(0.0, 0.3)) for i in range(3))
    assert b.yaw_ref != 0.2 and b.traj.p != (0.0, 0.0, -5.0)


def test_quad_vehicle_velocity_is_the_predictors():
    """The vehicle's v_ned is the velocity the output predictor wrote in y (the loops'),
    as floats, every step of a flight."""
    from tools.runner import QUAD_DEFAULT_MISSION, RunConfig, Session
    s = Session(RunConfig(vehicle="quad", airframe="f450", mission=QUAD_DEFAULT_MISSION,
                          nav="ekf", duration_s=60.0, seed=1))
    v = s.vehicle
    moving = 0
    while s.t_s < 25.0:
        s.step()
        vn = v.v_ned
        assert vn == tuple(v.nav.y[0:3].tolist()) and all(type(c) is float for c in vn)
        moving += abs(vn[0]) + abs(vn[1]) > 1.0
    assert v.armed and not v.on_ground and moving > 100


def test_plant_steps_of_a_hil_period_read_out_the_last_only():
    """QuadrotorPlant.step over n steps (the earlier ones plant_advance, without a
    readout) leaves the state and hands on the state that n single steps give, bit for
    bit, in turbulence, resting on the ground and lifting off."""
    from sim_bridge.plants.quadrotor import QuadrotorPlant
    home = (-35.363262, 149.165237, 584.0, 30.0)
    a = QuadrotorPlant(home, turbulence="moderate", rng=np.random.default_rng(2),
                       wind_ned=(3.0, -2.0, 0.0))
    b = QuadrotorPlant(home, turbulence="moderate", rng=np.random.default_rng(2),
                       wind_ned=(3.0, -2.0, 0.0))
    flew = 0
    for k in range(600):
        u = (0.3, 0.3, 0.3, 0.3) if k < 100 else (0.62, 0.6, 0.61, 0.6)
        sa = a.step(u, 2)
        b.step(u)
        sb = b.step(u)
        assert sa == sb and np.array_equal(a._x, b._x) and a.on_ground == b.on_ground
        flew += not sa.on_ground
    assert 300 < flew < 600                   # rested on the ground, then flew
