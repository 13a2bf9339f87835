"""Stop 40's quadrotor speed changes: the motor monitor says when its stage ran (the
vehicle forwards its events, accommodation and failsafe only then), and the formation
quadrotor's guidance, virtual target and peer rows live in one array."""
import random

import numpy as np

from autopilot.control.mixer import QuadPlusMixer
from autopilot.control.multirotor import Y_N, Y_W
from autopilot.formation import load_formation
from autopilot.formation.guidance import G_N, VT_N, VT_R, VT_START
from autopilot.formation.peers import ROW_N, ROW_T
from autopilot.formation.quad import FS_ROWS, FS_VT
from autopilot.monitor.motors import MotorMonitor
from autopilot.params import ParamStore
from autopilot.vehicle_quad import quad_param_declarations
from tools.formation import QuadMember


def test_motor_monitor_update_is_true_exactly_when_its_stage_ran():
    """update() answers True on the steps its stage ran (the only code that changes its
    events, accommodation and failsafe), False on the others, where they stay as they
    were; in flight and on the ground."""
    rng = random.Random(40)
    mixer = QuadPlusMixer(15.7, 0.78, 0.1)
    mon = MotorMonitor(ParamStore(quad_param_declarations()), 0.004, div=2)
    staged = []
    stage = mon._stage
    mon._stage = lambda t_us, omega: (staged.append(t_us), stage(t_us, omega))
    ran = 0
    y = np.zeros(Y_N)                    # the navigation output (its rates, Y_W)
    for k in range(20000):
        t_us = k * 8000
        motors = tuple(rng.uniform(0.4, 0.6) for _ in range(4))
        f_z = rng.gauss(-9.8, 0.5)
        y[Y_W:Y_W + 3] = [rng.gauss(0.0, 0.1) for _ in range(3)]
        before = (len(mon.events), mon.accommodation, mon.failsafe)
        n = len(staged)
        if mon.update(t_us, k % 5000 > 100, motors, f_z, y, mixer.k):
            ran += 1
            assert staged[n:] == [t_us]
        else:
            assert len(staged) == n
            assert (len(mon.events), mon.accommodation, mon.failsafe) == before
    assert ran == len(staged) > 100


def test_formation_quad_arrays_are_views_of_one():
    """FormationQuad.fs holds the guidance's array, the virtual target's and the peer
    rows (the kernel's one argument): each class writes there, the virtual target
    rebuilt at arming too."""
    spec = load_formation("missions/formation_seed_quad.toml")
    member = QuadMember(spec, 4, 1, None)
    v = member.vehicle
    fs, nf = v.fs, len(spec.vehicle(4).follows)
    assert fs.shape == (G_N + VT_N + nf * ROW_N,) and nf > 0
    assert np.shares_memory(v.guidance.g, fs) and v.guidance.g.shape == (FS_VT,)
    assert np.shares_memory(v.vt.x, fs) and v.vt.x.shape == (FS_ROWS - FS_VT,)
    assert np.shares_memory(v.peers.rows, fs) and v.peers.rows.shape == (nf, ROW_N)
    v.peers.rows[nf - 1, ROW_T] = 7.5
    assert fs[-ROW_N + ROW_T] == 7.5
    assert fs[FS_VT + VT_START] == v.start_s
    assert fs[FS_VT + VT_R:FS_VT + VT_R + 3].tolist() == list(v.start_ned)
    while not v.armed:
        member.step()
    assert np.shares_memory(v.vt.x, fs) and fs[FS_VT + VT_START] == v.start_s


def test_motor_monitor_due_every_div_th_step():
    """due(): True on every div-th call from the first (the div-th, 2 div-th, ...)."""
    for div in (1, 2, 3):
        mon = MotorMonitor(ParamStore(quad_param_declarations()), 0.004, div=div)
        assert [mon.due() for _ in range(12)] == [(k + 1) % div == 0 for k in range(12)]
