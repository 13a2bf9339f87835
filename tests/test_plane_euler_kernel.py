"""quat_to_euler's kernel (autopilot/geo/rotations.py, ``euler_321``) against the 3-2-1
Euler angles written out in Python, bit for bit: the kernel replaced this Python, and
every flight stayed the same."""
import math
import random

import numpy as np

from autopilot.geo import quat_to_euler, wrap_pi


def _euler(q):
    w, x, y, z = q
    roll = math.atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
    pitch = math.asin(max(-1.0, min(1.0, 2.0 * (w * y - z * x))))
    yaw = math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
    return roll, pitch, wrap_pi(yaw)


def test_euler_kernel_is_the_formula_bit_for_bit():
    rnd = random.Random(5)
    qs = [(1.0, 0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0), (0.0, 0.0, 0.0, -1.0),   # yaw +-pi
          (math.sqrt(0.5), 0.0, math.sqrt(0.5), 0.0), (math.sqrt(0.5), 0.0, -math.sqrt(0.5), 0.0)]
    for _ in range(20000):
        q = [rnd.gauss(0.0, 1.0) for _ in range(4)]
        n = math.sqrt(sum(c * c for c in q))
        qs.append(tuple(c / n for c in q))
        # near the vertical: 2 (w y - z x) rounds past +-1
        a = rnd.uniform(-1e-8, 1e-8)
        qs.append((math.sqrt(0.5) + a, a, math.copysign(math.sqrt(0.5), a), 0.0))
    for q in qs:
        want = _euler(q)
        assert quat_to_euler(q) == want
        assert quat_to_euler(np.array(q)) == want
    assert quat_to_euler((0.0, 0.0, 0.0, 1.0))[2] == -math.pi
