"""Stop 37: the quadrotor's loops read their reference from the trajectory's array (no
tuples of it made every step), and the vehicle's target record is built when asked."""
import numpy as np

from autopilot.control.multirotor import MultirotorController
from autopilot.guidance.multirotor import Trajectory
from autopilot.params import ParamStore
from autopilot.vehicle_quad import quad_param_declarations

DT = 0.004


def test_trajectory_ref_is_its_p_v_a_in_its_array():
    """``ref`` is a view of the state array holding the reference model's p, v and a
    after every step, a = w^2 (p_raw - p) - 2 w v on the step's start values."""
    tr = Trajectory(4.0)
    tr.reset((0.0, 0.0, -10.0))
    tr.line_to((30.0, 10.0, -15.0), 5.0, 2.5, 1.5, 2.5, 1.5)
    assert np.shares_memory(tr.ref, tr.x)
    w = tr.w
    for k in range(600):
        p0, v0 = tr.p, tr.v
        tr.update(DT, p0, 8.0)
        raw = tr.raw
        want_a = tuple(w * w * (raw[i] - p0[i]) - 2.0 * w * v0[i] for i in range(3))
        assert tr.a == want_a
        assert tr.ref.tolist() == [*tr.p, *tr.v, *tr.a]
    assert tr.a != (0.0, 0.0, 0.0)
    tr.reset((1.0, 2.0, -3.0))
    assert tr.ref.tolist() == [1.0, 2.0, -3.0] + [0.0] * 6


def test_track_depth_offset_is_the_reference_moved_down():
    """``track(..., dz)`` flies the reference with its depth moved by dz (a terrain-frame
    leg), bit for bit what the reference written moved gives; dz = 0 leaves it as it is."""
    p = ParamStore(quad_param_declarations())
    a, b = MultirotorController(p, DT), MultirotorController(p, DT)
    rng = np.random.default_rng(5)
    for k in range(500):
        ref = rng.uniform(-3.0, 3.0, 9)
        dz = 0.0 if k % 3 == 0 else float(rng.uniform(-2.0, 2.0))
        moved = ref.copy()
        moved[2] = ref[2] + dz
        q = (np.array((1.0, *rng.uniform(-0.1, 0.1, 3))) / 1.01).tolist()
        w, pos, v = (tuple(rng.uniform(-1.0, 1.0, 3).tolist()) for _ in range(3))
        y = np.array((*v, *q, *w, 0.01, -0.02, 0.3))
        got = a.track(y, pos, ref, 0.5, DT, False, False, dz)
        want = b.track(y, pos, moved, 0.5, DT, False, False)
        assert got == want and a.u == b.u and np.array_equal(a.x, b.x)


def test_quad_target_is_built_when_asked_and_is_the_steps():
    """In AUTO the vehicle makes no target record on its steps; asked, it gets the
    navigator's target of that step (the reference, the sequencer's item), once."""
    from tools.runner import QUAD_DEFAULT_MISSION, RunConfig, Session
    s = Session(RunConfig(vehicle="quad", airframe="f450", mission=QUAD_DEFAULT_MISSION,
                          nav="ekf", duration_s=60.0, seed=1))
    v = s.vehicle
    while not (v.armed and not v.on_ground) and s.t_s < 30.0:
        s.step()
    assert v.armed and not v.on_ground
    for _ in range(300):
        s.step()
        nv = v.navigator
        tgt = v.target
        assert tgt is v.target                                   # built once
        assert tgt.p_ned == nv.traj.p and tgt.v_ned == nv.traj.v and tgt.a_ned == nv.traj.a
        assert tgt.seq == v._target_of[0] and tgt.yaw_rad == nv.yaw_ref
