"""No compiled kernel is loaded in flight (autopilot/jit.py, ``preload``): a kernel's
load from numba's cache takes a few milliseconds, a stalled step. Each flight runs in a
fresh interpreter (in this one other tests have loaded the kernels already) and records
every kernel of autopilot and sim_bridge that numba loads or compiles, with the time and
whether the vehicle was armed: none may be after arming, which also checks that each
``preload`` passes the types the calls in flight pass (another type would be a second
specialisation, loaded in flight). The fault monitor's are loaded when the session is
built."""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

_SCRIPT = r"""
import json, sys
from pathlib import Path
from numba.core import dispatcher
from tools.bench import DEFAULT_SCENARIO, RunConfig, Session
from tools.runner import QUAD_DEFAULT_MISSION

vehicle, until = sys.argv[1], float(sys.argv[2])
if vehicle == "quad":
    cfg = RunConfig(vehicle="quad", airframe="f450", mission=QUAD_DEFAULT_MISSION, nav="ekf",
                    scenario=DEFAULT_SCENARIO, duration_s=1e9, seed=1)
elif vehicle == "c172p":
    cfg = RunConfig(airframe="c172p", mission=Path("missions/c172p_circuit.waypoints"), nav="ekf",
                    scenario=DEFAULT_SCENARIO, duration_s=1e9, seed=1)
else:
    cfg = RunConfig(nav="ekf", scenario=DEFAULT_SCENARIO, duration_s=1e9, seed=1)
s = Session(cfg)
import importlib
built = []                          # the kernels named on the command line loaded by now
for name in sys.argv[3:]:
    mod, fn = name.rsplit(".", 1)
    if getattr(importlib.import_module("autopilot.monitor." + mod), fn).signatures:
        built.append(name)
late = []
orig = dispatcher.Dispatcher._compile_for_args
def record(self, *a, **k):
    if self.py_func.__module__.split(".")[0] in ("autopilot", "sim_bridge"):
        late.append((f"{self.py_func.__module__}.{self.py_func.__name__}", round(s.t_s, 2),
                     s.vehicle.armed))
    return orig(self, *a, **k)
dispatcher.Dispatcher._compile_for_args = record
while s.t_s < until:
    s.step()
print(json.dumps({"built": built, "late": late}))
"""


def _fly(vehicle: str, until_s: float, kernels) -> dict:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    out = subprocess.run([sys.executable, "-c", _SCRIPT, vehicle, str(until_s), *kernels], cwd=ROOT, env=env,
                         capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr[-2000:]
    return json.loads(out.stdout.strip().splitlines()[-1])


@pytest.mark.parametrize("vehicle, until_s, kernels", [
    # the Aerosonde: the electric rotor's kernels (6.8 s), the elevator's stage 2 (9.8 s),
    # the join planner's (21 s), the balances' fit (36.8 s) were loaded in flight before;
    # the monitor's kernels called from Python in flight (the rotor's are compiled into
    # throttle_front)
    ("plane", 40.0, ("throttle.throttle_front", "lateral.lateral_front", "actuator.pitch_front",
                     "stats.stage2_update", "actuator.offset_step", "stats.solve3")),
    # the attitude loops and the mixer (4.6 s, the take-off), the motors' stage 2 (6.6 s)
    ("quad", 10.0, ("stats.stage2_update", "motors.balance_step", "motors.isolation")),
    # the elevator's stage 2 (24.7 s), the balances' fit (51.7 s), the join planner's (53.4 s)
    ("c172p", 55.0, ("throttle.throttle_front", "lateral.lateral_front", "actuator.pitch_front",
                     "stats.stage2_update", "actuator.offset_step", "stats.solve3")),
])
def test_no_kernel_is_loaded_in_flight(vehicle, until_s, kernels):
    r = _fly(vehicle, until_s, kernels)
    in_flight = [(name, t_s) for name, t_s, armed in r["late"] if armed]
    assert in_flight == [], f"kernels loaded in flight: {in_flight}"
    # the monitor's, when the session is built
    assert r["built"] == list(kernels)
    assert not [name for name, _, _ in r["late"] if name.startswith("autopilot.monitor")]
