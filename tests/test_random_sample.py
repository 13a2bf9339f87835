"""A fixed sample of random missions flown end to end (issue 15): every flight
invariant holds (tools/invariants.py) on short random missions of both vehicles, each in
its own dispersed wind and turbulence (tools.missions_random.fly_sample).

The missions are the generator's own draws held under a short time budget (``BUDGET_S``),
so the sample stays within the suite's time: the same classes (missions starting behind
the launch or inside the climb-out, reversals, short legs, loiters, jumps, speed
changes, homes anywhere), fewer items. Seeds that fail today through the guidance
failures the issue lists are expected failures, each with its reason; they pass (and
are reported as XPASS) once those are fixed. Reproduce one with
``tools.missions_random.sample_command(vehicle, seed, BUDGET_S[vehicle])``.
"""
from __future__ import annotations

import pytest

from tools.missions_random import fly_sample

BUDGET_S = {"plane": 180.0, "quad": 90.0}
PLANE_SEEDS = [*range(0, 20), 34]   # 34: a waypoint in the climb-out (once circled for ever)
QUAD_SEEDS = [*range(0, 10), 44]   # 44: CONDITION_YAW / _DISTANCE, NAV_DELAY

# (vehicle, seed) -> why it fails today (issue 15's failure classes)
KNOWN_FAILURES: dict = {
    # none today. Until aa139dc (fixed-wing joins planned as turns, acceptance in every
    # phase) plane 9, 19 and 34 circled a waypoint inside the turn circle (2.2-20 turns;
    # 34 for ever) and plane 7 slid along the ground towards a waypoint at home on the
    # ground before the take-off
}


def _cases():
    for vehicle, seeds in (("plane", PLANE_SEEDS), ("quad", QUAD_SEEDS)):
        for seed in seeds:
            reason = KNOWN_FAILURES.get((vehicle, seed))
            marks = [pytest.mark.xfail(strict=False, reason=reason)] if reason else []
            yield pytest.param(vehicle, seed, marks=marks, id=f"{vehicle}-{seed}")


@pytest.mark.parametrize("vehicle,seed", list(_cases()))
def test_random_mission_keeps_every_invariant(vehicle, seed):
    s = fly_sample(vehicle, seed, BUDGET_S[vehicle])
    failed = {k: v for k, v in s["invariants"].items() if not v["passed"]}
    assert not failed, failed
    assert s["invariants_passed"] and not s["crashed"]
